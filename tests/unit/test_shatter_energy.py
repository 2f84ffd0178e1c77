"""What shatters at an impact and how finely (sph/cracks.py step 8, geometry/pulverise.py), against
known answers:

- Hertz's radius comes from the surfaces' own curvature (`surface_radius`): a sphere's radius exactly,
  a plane is flat (inf), a cylinder lies between its radius and twice it (the mean curvature), a
  concave patch counts as flat;
- the mass a blow moves is the body's mass at the contact point (Stronge): a slender box struck
  sideways at its end moves a quarter of its mass;
- the energy held at fracture onset scales as (sigma_t / T_peak)^2; the plugging loss is the energy
  a perfectly inelastic collision of striker and plug loses (momentum conserved);
- the poly6 kernel's share inside a thin slab is its integral over the slab (scipy quadrature);
- a pulverised plug conserves mass and volume, each tet giving four quarter tets inside it;
- each particle's limit is its own size's: the poly6 energy density reaches its own u_limit (~ 1 / edge)
  at a radius that grows with its size (what it then frees, and the energy bound on that:
  tests/unit/test_shatter_faces.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from core.errors import ConfigError
from geometry.build import build_object
from geometry.cutting import Crack
from geometry.particles import KIND_PHYSICAL, KIND_SUBDIVIDED
from geometry.pulverise import centroid_split, pulverise
from geometry.tetmesh import signed_volumes
from sph.algorithm1 import material_weight, onset_energy, plug_energy
from sph.contact import surface_radius

RNG = np.random.default_rng(7)


def cap(radius: float, half_width: float, k: int = 300, concave: bool = False) -> np.ndarray:
    """Points of a sphere of `radius` touching the origin, centre on +z (inward +z), within
    `half_width` of the z axis; `concave`: the centre on -z."""
    d = RNG.normal(size=(k, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    c = np.array([0.0, 0.0, -radius if concave else radius])
    p = c + radius * d
    p = p[(np.hypot(p[:, 0], p[:, 1]) < half_width) & ((p[:, 2] > c[2]) if concave else (p[:, 2] < c[2]))]
    return p


def test_surface_radius_of_a_sphere_a_plane_a_cylinder_and_a_hollow():
    n = np.array([0.0, 0.0, 1.0])
    for R in (0.005, 0.03, 0.2):
        assert surface_radius(cap(R, 0.6 * R), np.zeros(3), n) == pytest.approx(R, rel=1e-9)
        # sphere centres of radius r inside a ball of radius R + r: the ball's radius
        assert surface_radius(cap(R, 0.6 * R), np.zeros(3), n, offset=0.004) == pytest.approx(R + 0.004, rel=1e-9)
    plane = np.c_[RNG.uniform(-0.02, 0.02, (60, 2)), np.zeros(60)]
    assert math.isinf(surface_radius(plane, np.zeros(3), n))
    rho = 0.08
    th, s = RNG.uniform(-0.25, 0.25, 200), RNG.uniform(-0.02, 0.02, 200)
    cyl = np.c_[s, rho * np.sin(th), rho * (1.0 - np.cos(th))]
    assert rho < surface_radius(cyl, np.zeros(3), n) < 2.0 * rho
    assert math.isinf(surface_radius(cap(0.03, 0.02, concave=True), np.zeros(3), n))
    assert math.isinf(surface_radius(cap(0.03, 0.02)[:3], np.zeros(3), n))  # too few points


def test_contact_mass_of_a_slender_box_struck_at_its_end(taichi_runtime):
    """A free box L x w x w struck sideways at the end of its long axis: 1/m_c = 1/m + (L/2)^2 / I,
    I = m (L^2 + w^2) / 12 (a quarter of the mass as w -> 0); struck at its centre, all of it."""
    from scenes.loader import scene_from_dict
    from sim.fracture_stage import _contact_mass
    from sim.world import World

    L, w = 0.3, 0.02
    raw = {
        "scene": {"name": "rod", "effects": ["rigid"], "gravity": [0.0, 0.0, 0.0]},
        "materials": [{"name": "glass", "density": 2500.0, "stiffness": {"model": "isotropic", "E": 7e10, "nu": 0.22},
                       "tensile_strength": 4e7, "toughness": 8.0}],
        "objects": [{"name": "rod", "shape": {"type": "box", "size": [L, w, w]}, "material": "glass",
                     "resolution": 0.01, "position": [0.0, 0.5, 0.0]}],
    }
    world = World(scene_from_dict(raw, "rod"))
    m = world.rigid.body_mass(0)
    st = world.rigid.body_state()
    com = st.x[0]
    I = m * (L * L + w * w) / 12.0
    down = np.array([0.0, -1.0, 0.0])
    end = _contact_mass(world, 0, com + [L / 2, w / 2, 0.0], down, st)
    assert end == pytest.approx(1.0 / (1.0 / m + (L / 2) ** 2 / I), rel=1e-6)
    assert _contact_mass(world, 0, com + [0.0, w / 2, 0.0], down, st) == pytest.approx(m, rel=1e-9)


def test_onset_energy_and_the_plugging_loss():
    assert onset_energy(2.0, 3.0 * 4e7, 4e7) == pytest.approx(2.0 / 9.0, rel=1e-15)
    assert onset_energy(2.0, 0.5 * 4e7, 4e7) == 2.0  # below the strength: all of it
    # Recht & Ipson: striker and plug leave together; the loss is what momentum conservation leaves over
    m_s, rho, R, B, v = 0.88, 2500.0, 0.03, 0.008, 8.0
    m_p = rho * math.pi * R * R * B
    v_after = m_s * v / (m_s + m_p)
    loss = 0.5 * m_s * v * v - 0.5 * (m_s + m_p) * v_after**2
    assert plug_energy(m_s, rho, R, B, v) == pytest.approx(loss, rel=1e-12)
    assert plug_energy(math.inf, rho, R, B, v) == pytest.approx(0.5 * m_p * v * v, rel=1e-15)


def test_the_kernel_share_inside_a_thin_slab(taichi_runtime):
    """sum_j V_j W(d_j) over a pane's particles equals the integral of the normalised poly6 kernel over
    the slab |z| < B/2 (the support's centre on the mid-plane), to the discretisation error."""
    B, h = 0.008, 0.04
    ps = build_object("pane", shape_params=dict(size=[0.2, 0.2, B]), resolution=0.006).particles
    d2 = (ps.centroid**2).sum(1)
    c = 315.0 / (64.0 * math.pi * h**9)
    exact = quad(lambda z: c * math.pi * (h * h - z * z) ** 4 / 4.0, -B / 2, B / 2)[0]  # int over the disc of radius
    assert exact == pytest.approx(315.0 * B / (256.0 * h), rel=0.02)  # thin-slab limit
    assert material_weight(d2, ps.volume, h) == pytest.approx(exact, rel=0.05)
    block = build_object("box", shape_params=dict(size=[0.2, 0.2, 0.2]), resolution=0.01).particles
    assert material_weight((block.centroid**2).sum(1), block.volume, h) == pytest.approx(1.0, rel=0.02)


def test_a_pulverised_plug_keeps_mass_and_volume(taichi_runtime):
    ps = build_object("pane", shape_params=dict(size=[0.1, 0.1, 0.008]), resolution=0.01).particles
    P = np.array([0.0, 0.0, 0.004])
    inner = np.flatnonzero(np.linalg.norm(ps.centroid - P, axis=1) < 0.03)
    crack = Crack(point=P, normal=[1.0, 0.0, 0.0], r_outer=0.05, r_inner=0.03, r_crush=0.015)
    out, debris = pulverise(ps, inner, [crack])
    plug = inner[np.linalg.norm(ps.centroid[inner] - P, axis=1) < 0.015]
    assert plug.size > 0 and len(debris) == len(inner) + 3 * plug.size
    assert not out.alive[plug].any() and out.alive[debris].all()
    kids = debris[out.kind[debris] == KIND_SUBDIVIDED]
    assert len(kids) == 4 * plug.size and np.all(out.kind[np.setdiff1d(debris, kids)] == KIND_PHYSICAL)
    np.testing.assert_allclose(out.volume[kids], np.repeat(ps.volume[plug] / 4.0, 4), rtol=1e-12)
    np.testing.assert_allclose(signed_volumes(out.rest_verts[kids]), out.volume[kids], rtol=1e-9)
    assert out.mass[out.alive].sum() == pytest.approx(ps.mass.sum(), rel=1e-12)
    assert np.all(out.links[kids] == -1) and np.all(out.parent[kids] == np.repeat(plug, 4))
    # every child's corners lie in its parent tet (barycentric coordinates in [0, 1])
    par = ps.rest_verts[out.parent[kids]]
    T = np.transpose(par[:, 1:] - par[:, :1], (0, 2, 1))  # (K,3,3): edge vectors as columns
    rel = np.transpose(out.rest_verts[kids] - par[:, :1], (0, 2, 1))  # (K,3,4): corners as columns
    lam = np.linalg.solve(T, rel)
    assert lam.min() > -1e-9 and lam.sum(1).max() < 1.0 + 1e-9
    assert centroid_split(ps.rest_verts[:2]).shape == (8, 4, 3)
    # no plug, no change
    same, deb = pulverise(ps, inner, [Crack(point=P, normal=[1.0, 0.0, 0.0], r_outer=0.05, r_inner=0.03)])
    assert same is ps and np.array_equal(deb, inner)


def test_a_plug_forms_only_above_the_ballistic_limit(taichi_runtime):
    """A 1 cm steel ball on a 0.3 m plaster pane (gypsum: E 8 GPa, tensile strength 2 MPa,
    K_Ic 0.2 MPa m^0.5 -> G_c 5 J/m^2, rho 1100 kg/m^3; Ashby & Jones, Engineering Materials 2): the
    plug forms exactly where the blow's energy K pays the energy held at onset, the plug's cylindrical
    crack (G_c 2 pi R B) and the plugging loss, and the plugging loss pays for crushing the plug into
    quarter tets. Between the speed that breaks the pane and that limit the pane cracks, no plug."""
    from sph.algorithm1 import u_limit
    from sph.cracks import ImpactSpec, analyse_impact, tet_edge
    from sph.kernel import kernel_isotropic
    from sph.materials import Material, stiffness_isotropic

    B, R, Gc, rho = 0.008, 0.01, 5.0, 1100.0
    ps = build_object("pane", shape_params=dict(size=[0.3, 0.3, B]), resolution=0.01).particles
    plaster = Material("plaster", rho, stiffness_isotropic(8e9, 0.2), tensile_strength=2e6, toughness=Gc)
    ball = dict(m2=7850.0 * 4.0 / 3.0 * math.pi * R**3, R2=R, E2=2.1e11, nu2=0.30)
    seen = set()
    for v in np.geomspace(0.5, 6.0, 14):
        spec = ImpactSpec(point=[0.001, 0.002, 0.5 * B], normal=[0.0, 0.0, -1.0], speed=float(v),
                          m1=float(ps.mass.sum()), R1=math.inf, **ball)
        an = analyse_impact(ps.centroid, ps.volume, kernel_isotropic(0.02), plaster, spec, 4, B)
        if not an.fired.any():
            assert an.r_plug == 0.0
            continue
        T = float(an.tension_per_newton.max()) * an.hertz.force
        onset = float(an.energy_available.sum()) * min(1.0, (2e6 / T) ** 2)
        m_p = rho * math.pi * R * R * B
        plug = 0.5 * ball["m2"] * m_p / (ball["m2"] + m_p) * v * v
        V = float(ps.volume[an.nearest])
        crush = u_limit(Gc, tet_edge(V / 4.0), V / 4.0) * math.pi * R * R * B
        expect = bool(an.kinetic_energy >= onset + Gc * 2.0 * math.pi * R * B + plug and plug >= crush)
        assert (an.r_plug > 0.0) == expect, (v, an.r_plug, an.kinetic_energy, onset, plug, crush)
        assert an.r_inner >= an.r_crush >= an.r_plug
        seen.add(expect)
    assert seen == {False, True}
    with pytest.raises(ConfigError, match="impact.striker_radius"):
        ImpactSpec(point=[0.0, 0.0, 0.0], normal=[0.0, 0.0, -1.0], speed=1.0, m1=1.0, R1=0.1, striker_radius=-0.01)


def test_subdivision_crushes_where_quarter_grains_break_free(taichi_runtime):
    """A glass pane struck by a broad rigid striker (no plug) shatters within r_inner; grains of a
    quarter of a particle's volume need 4^(1/3) the energy density (u_limit ~ 1 / edge), which the
    poly6 profile reaches where (h^2 - r^2)^3 is 4^(1/3) larger: r_crush^2 = h^2 - 4^(1/9) (h^2 - r_inner^2).
    The same cracks then free 3 more grains per particle within r_crush in subdivision mode than in
    basic mode (each crushed into four): the adaptive model resolves the shattered core finer."""
    from geometry.fragments import apply_cracks
    from sph.cracks import ImpactSpec, analyse_impact
    from sph.kernel import kernel_isotropic
    from sph.materials import Material, stiffness_isotropic

    B = 0.008
    ps = build_object("pane", shape_params=dict(size=[0.3, 0.3, B]), resolution=0.01).particles
    glass = Material("glass", 2500.0, stiffness_isotropic(7e10, 0.22), tensile_strength=4e7, toughness=8.0)
    spec = ImpactSpec(point=[0.001, 0.002, 0.5 * B], normal=[0.0, 0.0, -1.0], speed=8.0, m1=float(ps.mass.sum()),
                      R1=math.inf, m2=math.inf, R2=1.0, E2=2.1e11, nu2=0.3)
    an = analyse_impact(ps.centroid, ps.volume, kernel_isotropic(0.02), glass, spec, 4, B)
    h2 = an.support_radius**2
    assert an.fired.any() and an.r_plug == 0.0 and an.r_inner > 0.0
    assert an.r_crush == pytest.approx(math.sqrt(h2 - 4.0 ** (1.0 / 9.0) * (h2 - an.r_inner**2)), rel=1e-9)
    assert all(c.r_crush == an.r_crush for c in an.cracks) and an.r_crush < an.r_inner
    P = an.cracks[0].point
    crushed = int((np.linalg.norm(ps.centroid - P, axis=1) < an.r_crush).sum())
    _, basic = apply_cracks(ps, an.cracks, mode="basic", shatter=True)
    out, fine = apply_cracks(ps, an.cracks, mode="subdivision", shatter=True)
    assert crushed > 0 and len(fine.debris) == len(basic.debris) + 3 * crushed
    assert fine.n_fragments > basic.n_fragments
    assert out.mass[out.alive].sum() == pytest.approx(ps.mass.sum(), rel=1e-12)


def test_push_profile_is_the_fields_own_deflection_shape():
    """The share of the striker's push that the material follows, on the struck face (zeta = -B/2 from
    the mid-plane): the Kirchhoff plate's u_z = w + nu/(2(1 - nu)) zeta^2 lap w with
    w(s) = (3 + nu)/(1 + nu) (L^2 - s) + s ln(s / L^2), s = r^2 + l^2 (Timoshenko, load spread over l),
    relative to its value at the point; on a half-space's surface the Boussinesq
    u_z ~ l^2/R^3 + 2 (1 - nu)/R, R = (r^2 + l^2)^(1/2), relative to (3 - 2 nu)/l."""
    from sph.contact import push_profile

    nu, l, B, L = 0.22, 0.004, 0.008, 0.2
    r = np.linspace(0.0, L, 41)
    face = np.c_[r, np.zeros_like(r), np.zeros_like(r)]

    def u_face(r):
        s = r * r + l * l
        w = (3.0 + nu) / (1.0 + nu) * (L * L - s) + s * np.log(s / (L * L))
        w_s = -(3.0 + nu) / (1.0 + nu) + np.log(s / (L * L)) + 1.0
        lap = 4.0 * w_s + 4.0 * r * r / s
        return w + nu / (2.0 * (1.0 - nu)) * (0.5 * B) ** 2 * lap

    got = push_profile("plate", face, 7e10, nu, l, B, L)
    np.testing.assert_allclose(got, np.clip(u_face(r) / u_face(0.0), 0.0, 1.0), rtol=1e-9, atol=1e-12)
    assert got[0] == pytest.approx(1.0, rel=1e-12) and np.all(np.diff(got) <= 0.0) and got[-1] < 0.01
    R = np.sqrt(r * r + l * l)
    np.testing.assert_allclose(push_profile("halfspace", face, 7e10, nu, l),
                               (l * l / R**3 + 2.0 * (1.0 - nu) / R) / ((3.0 - 2.0 * nu) / l), rtol=1e-9)
    with pytest.raises(ConfigError, match="push_profile.kind"):
        push_profile("beam", face, 7e10, nu, l)


def _glass_pane_analysis(B: float = 0.008):
    from sph.cracks import ImpactSpec, analyse_impact
    from sph.kernel import kernel_isotropic
    from sph.materials import Material, stiffness_isotropic

    ps = build_object("pane", shape_params=dict(size=[0.3, 0.3, B]), resolution=0.01).particles
    glass = Material("glass", 2500.0, stiffness_isotropic(7e10, 0.22), tensile_strength=4e7, toughness=8.0)
    spec = ImpactSpec(point=[0.001, 0.002, 0.5 * B], normal=[0.0, 0.0, -1.0], speed=8.0, m1=float(ps.mass.sum()),
                      R1=math.inf, m2=math.inf, R2=1.0, E2=2.1e11, nu2=0.3)
    return ps, glass, analyse_impact(ps.centroid, ps.volume, kernel_isotropic(0.02), glass, spec, 4, B)


def test_each_particle_is_freed_where_the_energy_density_reaches_its_own_limit(taichi_runtime):
    """The crack's ShatterField gives every particle volume the radius where u(r) = 315/(64 pi h^9)
    (h^2 - r^2)^3 U / w (computed here from the analysis' U, h and the kernel share w) equals that
    particle's u_limit = G_c sqrt3 e^2 / (2 V): the nearest particle's is r_inner, a quarter grain's
    r_crush; smaller particles need a higher density, so their radius is smaller."""
    from sph.algorithm1 import tet_edge, u_limit

    ps, glass, an = _glass_pane_analysis()
    field = an.cracks[0].shatter
    assert field is not None and all(c.shatter == field for c in an.cracks)
    V_near = float(ps.volume[an.nearest])
    assert field.radius(V_near) == pytest.approx(an.r_inner, rel=1e-12)
    assert field.radius(V_near, grains=True) == pytest.approx(an.r_crush, rel=1e-12)
    h = an.support_radius
    w = material_weight(((ps.centroid - an.cracks[0].point) ** 2).sum(1), ps.volume, h)

    def u(r: float) -> float:
        return 315.0 / (64.0 * math.pi * h**9) * (h * h - r * r) ** 3 * an.shatter_energy / w

    radii = []
    for V in V_near * np.array([1.0 / 8.0, 0.5, 1.0, 2.0]):
        r = field.radius(V)
        assert 0.0 < r < h
        assert u(r) == pytest.approx(u_limit(8.0, tet_edge(V), V), rel=1e-9)
        radii.append(r)
    assert np.all(np.diff(radii) > 0.0)
