"""One fracture event on one body, between frames (DESIGN.md section 4).

    crack analysis at the contact point (sph.cracks, Algorithm 1)  -> cracks in the reference frame
    cut: link removal ('basic') or subdivision first (Algorithm 2)   (geometry.fragments.apply_cracks)
    shatter inside r_inner                                            (same call, `shatter`)
    split: connected components -> new rigid bodies keeping the parent's velocity field (rigid.bodies)

Only the touched body is processed, on the particle store in place (geometry.particle_store): the
event takes the body's particles once (`take_body`), the analysis and the cut work on that body-sized
copy with local ids, and `put_body` writes back what changed and appends the children. Timings
follow the paper's Table 2 columns: stress analysis,
particle subdivision, crack generation (link removal, labelling, splitting, new boundary particles).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from core.arrays import cross3
from core.errors import ConfigError
from geometry.particles import ParticleSet, tet_edge
from sim.bodies import BodyInfo
from sim.struck_surface import SurfaceRows, surface_frame, surface_radius_at

# A piece breaks again only when it holds at least this many physical-particle volumes of its object;
# smaller pieces fly and land as they are. Chosen as one kernel's particles when a support was read in
# particle spacings (4/3 pi 2^3 = 34); a support of 2 tet edges a reaches 4/3 pi (2a)^3 = 284 volumes of
# a tet of edge a (a^3 / 6 sqrt 2), so this is about a ninth of a neighbourhood. Left as it is: changing
# it changes every scene's pieces (docs/decisions.md, session 33).
MIN_BREAKABLE_PARTICLES = 32


@dataclass
class TakenBody:
    """A body's particles taken from the store for one event (ParticleStore.take_bodies)."""

    ids: np.ndarray  # (K,) store ids of the rows, ascending
    particles: ParticleSet  # K rows with local ids (links, parents)
    kernel_G: np.ndarray  # (K, 3, 3) 1/m: rest kernel tensors
    extra_rows: np.ndarray  # store rows of the extra links among them


def take_body(world, body: int) -> TakenBody:
    return TakenBody(*world.store.take_bodies([body]))


# What an event imports, one piece each (at most about 60 ms a piece on this machine): scipy's packages in an
# order in which each piece adds only its own modules (scipy 1.17; a module another scipy lacks is skipped),
# then the event's own modules. A run's build imports none of them (geometry/build_cache.py).
LIBRARY_IMPORTS = ("numpy.ma", "numpy.f2py", "numpy.random", "numpy.testing", "scipy._lib._array_api", "scipy.sparse",
                   "scipy.linalg", "scipy.sparse.csgraph", "scipy.special", "scipy.spatial")
EVENT_MODULES = ("sph.cracks", "geometry.fragments", "geometry.crack_merge", "rigid.bodies", "sim.perforation")


def _library_import(module: str) -> None:
    import importlib

    try:
        importlib.import_module(module)
    except ModuleNotFoundError:  # laid out otherwise in this version: the event imports what it needs itself
        pass


def warm_pieces(world) -> list:
    """What the first fracture event would otherwise wait for (issue 16: the first event is as fast as
    the tenth), as pieces of one kernel or a few each: the event's libraries and modules (about 0.3 s of
    imports), and the kernels that only events and debris launch, launched on nothing.
    sim/warm_up.py runs them, at the build or spread over the frames before the first contact."""
    import importlib
    from functools import partial

    from geometry.boundary_groups import warm_up as warm_grouping
    from geometry.components import warm_up as warm_components
    from sph.gradient import kernels_run
    from sph.gradient_kernels import warm_pieces as gradient_pieces

    pieces = [partial(_library_import, m) for m in LIBRARY_IMPORTS]
    pieces += [partial(importlib.import_module, m) for m in EVENT_MODULES]
    if kernels_run():
        pieces += gradient_pieces()  # the analysis' neighbour test and Eq. 7 sums
    pieces.append(warm_grouping)  # the new pieces' boundary spheres (a build reads its own from the cache)
    pieces.append(warm_components)  # the fragments' labels
    pieces += world.store.warm_pieces()
    if "rigid" in world.stages:
        pieces += world.rigid.warm_event_pieces()
    if "debris" in world.stages:
        pieces += world.debris.warm_pieces()
    return pieces


def _to_reference(world, body: int, point: np.ndarray, normal: np.ndarray, state=None):
    from rigid.quat import quat_to_matrix

    st = world.rigid.body_state() if state is None else state
    rot = quat_to_matrix(st.q[body])
    com = world.rigid.body_ref_com(body)
    return rot.T @ (np.asarray(point) - st.x[body]) + com, rot.T @ np.asarray(normal)


def _world_motion(world, body: int, x_ref: np.ndarray, state=None) -> tuple[np.ndarray, np.ndarray]:
    """World positions (K,3) m and velocities v + w x r (K,3) m/s of reference points of a body
    (`state`: the bodies' state if the caller already downloaded it)."""
    from rigid.quat import quat_to_matrix

    st = world.rigid.body_state() if state is None else state
    rot = quat_to_matrix(st.q[body])
    r = (np.asarray(x_ref) - world.rigid.body_ref_com(body)) @ rot.T
    return st.x[body] + r, st.v[body] + cross3(st.w[body], r)


def _local_radius(world, body: int, point_world: np.ndarray, inward: np.ndarray, state, fit: bool = True) -> float:
    """Radius of curvature (m) of a body's surface at the contact from its collision spheres (the
    striker's R2; the struck body's own R1 comes from its faces, `surface_radius_at`): the fit of
    `sph.contact.surface_radius` to the centres of the body's boundary spheres within a patch of
    three sphere radii beyond the nearest (`inward`: world normal into this body), plus their radius;
    a flat or sparsely sampled patch counts as flat (inf). `fit=False`: the nearest sphere's radius
    (where two flat patches meet, the contact is borne by the edge or corner the collision sphere
    stands for). A body split earlier in the same frame has no spheres left: it counts as flat."""
    from sph.contact import surface_radius

    spheres = world.rigid.body_spheres(body)
    if len(spheres) == 0:
        return float("inf")
    centres = world.rigid.sphere_world(state, spheres)
    radius = world.rigid.sphere_data()[1][spheres]
    dist = np.linalg.norm(centres - point_world, axis=1)
    k = int(np.argmin(dist))
    if not fit:
        return float(radius[k])
    patch = dist <= dist[k] + 3.0 * radius[k]
    return surface_radius(centres[patch], centres[k], inward, offset=float(radius[k]))


def _contact_mass(world, body: int, point_world: np.ndarray, normal_world: np.ndarray, st) -> float:
    """kg: the body's mass as seen along `normal_world` at a contact point (Stronge, Impact Mechanics,
    2000, ch. 5): 1 / (1/m + (r x n) . I^-1 (r x n)), r from the COM, I the world inertia; the
    rigid solver's impulse at that point moves this mass. A blow off the COM line also spins the
    body, so less of its kinetic energy goes into the contact."""
    from rigid.quat import quat_to_matrix

    m = world.rigid.body_mass(body)
    rot = quat_to_matrix(st.q[body])
    rn = cross3(np.asarray(point_world, dtype=np.float64) - st.x[body], normal_world)
    inertia_w = rot @ world.rigid.body_inertia(body) @ rot.T
    return 1.0 / (1.0 / m + float(rn @ np.linalg.solve(inertia_w, rn)))


def _striker_contact_mass(world, other: int, point_world: np.ndarray, st) -> float:
    """kg: `_contact_mass` of the body that struck, at its own surface nearest the struck point
    (its boundary sphere nearest the point, along that sphere's normal towards it): at first contact
    both surfaces share that normal. Its pose at the analysis is the one after the contact's
    substep; for a ball this gives its whole mass wherever the contact lies on it."""
    spheres = world.rigid.body_spheres(other)
    if len(spheres) == 0:
        return world.rigid.body_mass(other)
    centres = world.rigid.sphere_world(st, spheres)
    k = int(np.argmin(np.linalg.norm(centres - point_world, axis=1)))
    towards = point_world - centres[k]
    dist = float(np.linalg.norm(towards))
    if dist == 0.0:
        return world.rigid.body_mass(other)
    n = towards / dist
    radius = float(world.rigid.sphere_data()[1][spheres[k]])
    return _contact_mass(world, other, centres[k] + radius * n, -n, st)


def _contact_bodies(world, body: int, other: int, point: np.ndarray, normal: np.ndarray, R1: float) -> dict:
    """Masses, radii and elastic constants of the two bodies at a contact for Hertz (ImpactSpec's m1,
    R1, m2, R2, E2, nu2), at the struck surface's point and inward normal (`point`, `normal`: the
    struck body's reference frame; `R1`: its radius of curvature there, `surface_radius_at`). The
    other body is a body or, for other < 0, the scene's collider (flat)."""
    from rigid.quat import quat_to_matrix
    from sim.perforation import cross_section
    from sph.contact import effective_isotropic

    st = world.rigid.body_state()
    point_w = _world_motion(world, body, np.asarray(point)[None], st)[0][0]
    normal_w = quat_to_matrix(st.q[body]) @ np.asarray(normal)  # into the struck body
    out = dict(m1=_contact_mass(world, body, point_w, normal_w, st), R1=R1)
    if other < 0 or world.rigid.body_is_static(other):
        if other < 0:
            col = world.cfg.colliders[0] if world.cfg.colliders else None
            young, poisson = (col.young, col.poisson) if col else (3.0e10, 0.2)
        else:
            young, poisson = effective_isotropic(world.materials[_body_material(world, other)].stiffness)
        out.update(m2=np.inf, R2=np.inf, E2=young, nu2=poisson)
    else:
        young, poisson = effective_isotropic(world.materials[_body_material(world, other)].stiffness)
        out.update(m2=_striker_contact_mass(world, other, point_w, st), E2=young, nu2=poisson,
                   R2=_local_radius(world, other, point_w, -normal_w, st),
                   striker_radius=cross_section(world, other, normal_w, st))
    if math.isinf(out["R1"]) and math.isinf(out["R2"]):  # flat on flat: an edge or corner bears the blow
        out["R1"] = _local_radius(world, body, point_w, normal_w, st, fit=False)
    return out


def _body_material(world, body: int) -> int:
    """The body's main material (recorded when the body was made, so split bodies keep theirs)."""
    return world.body_material[body]


def analysed_rows(ps: ParticleSet, body: int) -> np.ndarray:
    """The physical particles of a body, including those already replaced by their children.

    The paper analyses stress "on the original model" (Sect. 1, 5): subdivided children track the
    crack geometry, while the stress field is resolved at the physical particles' scale. This also
    keeps the analysis cost bounded by the physical particle count.
    """
    mine = ps.alive & (ps.body == body)
    ids = np.flatnonzero(mine & (ps.kind == 0))
    parents = ps.parent[mine & (ps.kind == 1)]
    if parents.size:
        ids = np.union1d(ids, parents)
    return ids


def held_particles(obj, bounds, x: np.ndarray) -> np.ndarray:
    """(N,) bool: particles of a static object at rest positions x held by the scene (within the
    object's held border of its rest bounding box, along the axes the border does not swallow). A
    static object without a held border is held everywhere."""
    if obj.held_border <= 0:
        return np.ones(len(x), dtype=bool)
    lo, hi = bounds
    axes = (hi - lo) > 2 * obj.held_border
    return ((x - lo < obj.held_border) | (hi - x < obj.held_border))[:, axes].any(1)


def contact_in_reference(world, body: int, other: int, point_w: np.ndarray, normal_w: np.ndarray,
                         state=None) -> dict:
    """The contact as the struck body saw it at that substep, in its reference frame: point, inward
    normal and the striker's centre of mass (None for a collider or a static body). Recorded when
    the contact happens: by the end of the frame both bodies have moved on. `state`: the substep's
    rigid.world.BodyState when the caller has it (one download for all the contacts of a substep)."""
    st = world.rigid.body_state() if state is None else state
    point, normal = _to_reference(world, body, point_w, normal_w, st)
    striker = None
    if other >= 0 and not world.rigid.body_is_static(other):
        striker, _ = _to_reference(world, body, st.x[other], np.zeros(3), st)
    return dict(point=point, normal=normal, striker=striker)


def analyse(world, body: int, impact: dict, taken: TakenBody | None = None):
    """Algorithm 1 at the impact point; returns the ImpactAnalysis (cracks in the reference frame;
    its particle indices are rows of `analysed_rows`)."""
    from geometry.crack_merge import merge_coincident
    from sph.cracks import ImpactSpec, analyse_impact, tet_edge

    taken = take_body(world, body) if taken is None else taken
    ps, G = taken.particles, taken.kernel_G
    ids = analysed_rows(ps, body)
    point_w = np.asarray(impact["point"], dtype=np.float64)
    ref = impact.get("reference") or contact_in_reference(world, body, impact["other"], point_w, impact["normal"])

    def nearest_to(p: np.ndarray) -> int:
        return int(ids[int(np.argmin(np.linalg.norm(ps.centroid[ids] - p, axis=1)))])

    surface = SurfaceRows(ps, body)

    def struck_point(contact: dict):
        """The struck surface's own point and normal, not the collision spheres' (surface_frame)."""
        edge = tet_edge(float(ps.volume[nearest_to(contact["point"])]))
        point, normal = surface_frame(ps, body, contact["point"], contact["normal"], edge, striker=contact["striker"],
                                      surface=surface)
        return point, normal, edge, nearest_to(point)

    point, normal, edge, nearest = struck_point(ref)
    if not within_kernel(G[nearest], ps.centroid[nearest], point):  # the point lies off the body
        if impact.get("site") is not None:  # the contacts' mean (a ring of contact, two feet): their hardest site
            point, normal, edge, nearest = struck_point(impact["site"])
        elif impact.get("key"):  # a caller's point (anisofrac/strikes.py): it would crack nothing, silently
            far = float(np.linalg.norm(point - ps.centroid[nearest]))
            raise ConfigError(f"{impact['key']}.point", point_w.tolist(), f"a point on body {body}'s surface (it lies "
                              f"{far:.3g} m from the body's nearest particle; Simulation.surface_point gives one)")
    material = world.object_material(world.bodies[body].object_index, int(ps.material[nearest]))
    cfg_mat = world.cfg.materials[int(ps.material[nearest])]
    spec = ImpactSpec(point=point, normal=normal, speed=impact["speed"], held=bool(world.rigid.body_is_static(body)),
                      **_contact_bodies(world, body, impact["other"], point, normal,
                                        surface_radius_at(ps, body, point, normal, 2.0 * edge, surface)))
    result = analyse_impact(ps.centroid[ids], ps.volume[ids], G[ids], material, spec,
                            crack_count=cfg_mat.cracks, thickness=world.bodies[body].thickness)
    if len(np.unique(ps.material[ids])) > 1:
        result.cracks = across_materials(world, taken, body, ids, replace(spec, thin=result.thin_axis),
                                         int(ps.material[nearest]), result.cracks, result.field)
    # planes closer than a particle are one crack (geometry/crack_merge.py): the edge of the particle at each point
    at = [nearest_to(c.point) for c in result.cracks]
    result.cracks = merge_coincident(result.cracks, tet_edge(ps.volume[at]), world.bodies[body].history)
    return result


def within_kernel(G: np.ndarray, centre: np.ndarray, point: np.ndarray) -> bool:
    """Whether `point` lies in the support |G (x - centre)| < 1 of a particle's kernel (Eq. 4): Algorithm 1's
    N_p around it (lines 1-6) then holds that particle at least."""
    return float(np.linalg.norm(G @ (point - centre))) < 1.0


def across_materials(world, taken: TakenBody, body: int, ids: np.ndarray, spec, material: int,
                     cracks: list, field: str = "auto") -> list:
    """Sect. 6, Fig. 12: a crack that reaches particles of another material stops there, and the
    nearest crossing point starts a new analysis (Algorithm 1) in the other material's particles,
    with its constants, kernel and crack count, struck by the same impact (same normal and speed):
    the crack goes on in the direction the new material gives, with the fracture energy it had left
    (sph.crossings.carry_on), or not at all where the new material holds; the new analysis takes
    the contact's wall model (a disc struck on its rim stays a beam at an inner crossing). One level:
    cracks of the new analyses are not followed into a third material."""
    from sph.cracks import analyse_impact, material_crossings, stop_at_crossings
    from sph.crossings import carry_on

    ps = taken.particles
    mats = ps.material[ids]
    obj = world.bodies[body].object_index
    out = []
    for crack in cracks:
        crossings = material_crossings(ps.centroid[ids], mats, crack, crack_material=material)
        out.append(stop_at_crossings(crack, crossings))
        if not crossings:
            continue
        first = crossings[0]
        sub = ids[mats == first.material]
        spec_k = replace(spec, point=first.point, reference=None)
        other = world.object_material(obj, first.material)
        more = analyse_impact(ps.centroid[sub], ps.volume[sub], taken.kernel_G[sub], other, spec_k,
                              crack_count=world.cfg.materials[first.material].cracks,
                              thickness=world.bodies[body].thickness, field=field)
        out += carry_on(crack, first, more.cracks, world.materials[material].toughness, other.toughness,
                        f"{crack.source}.crossing.material{first.material}")
    return out


def cut_body(world, body: int, cracks: list, record: dict, taken: TakenBody | None = None, push=None) -> dict:
    """Apply cracks to one body: cut, shatter, split into fragment bodies, on the body's particles
    taken from the store (`taken`, or taken here), written back at the end. `push`: x_ref (K,3) ->
    (K,3) m/s, the velocity the blow gives freed particles on top of the body's (`impact_push`).
    Returns the event record."""
    from geometry.fragments import apply_cracks
    from rigid.bodies import boundary_spheres, split_body
    from sim.bodies import kept_groups, sphere_groups

    taken = take_body(world, body) if taken is None else taken
    info = world.bodies[body]
    obj = world.cfg.objects[info.object_index]
    shatter = world.cfg.has("shatter")
    ps, rep = apply_cracks(taken.particles, cracks, mode=world.mode, shatter=shatter, bodies=[body],
                           history=info.history)
    t_cut = time.perf_counter()
    # children inherit their parent's kernel tensor (they sample the same material, Sect. 5.2)
    G = taken.kernel_G
    if len(ps) > len(G):
        G = np.concatenate([G, G[ps.parent[len(G):]]])
    store_id = world.store.global_ids(taken.ids, len(ps))  # what put_body will give every row
    debris = rep.debris[ps.alive[rep.debris]] if len(rep.debris) else rep.debris
    ids = np.flatnonzero(ps.alive & (ps.body == body))
    ids = ids[~np.isin(ids, debris)]
    # with the 'debris' effect a piece of one particle moves as debris too: a rigid body of one tet
    # would add a boundary sphere and contacts for what is a grain (the pieces count is the same);
    # without it (a teaching scene cutting one tet) such a piece stays a body
    single = np.zeros(len(ids), dtype=bool)
    if len(ids) and world.cfg.has("debris"):
        single = np.bincount(rep.labels[ids])[rep.labels[ids]] == 1
    debris = np.concatenate([debris, ids[single]])
    ids = ids[~single]
    if len(debris):
        _free_particles(world, body, ps, debris, store_id[debris],
                        None if push is None else push(ps.centroid[debris]))
    labels = np.unique(rep.labels[ids], return_inverse=True)[1] if len(ids) else rep.labels[ids]
    new_ids, bp = [], None
    if len(ids):
        held = None
        if info.static:
            held = _held_labels(obj, info.bounds, ps.centroid[ids], labels)
        # the parent's sphere groups that the split leaves whole stay (geometry/boundary.py)
        bp = boundary_spheres(ps, ids, labels, obj.group_size, keep=kept_groups(info.spheres, store_id[ids]))
        new_ids = split_body(world.rigid, body, ps, ids, labels, group_size=obj.group_size, static_labels=held,
                             spheres=bp)
    else:
        world.rigid.remove_bodies([body])
    world.store.put_body(taken.ids, ps, G, taken.extra_rows)
    t_split = time.perf_counter()
    del world.bodies[body]
    history = info.history + list(cracks)
    particle_volume = world.object_particle_volume[info.object_index]
    for label, nb in enumerate(new_ids):
        mine = ps.alive & (ps.body == nb)
        big = float(ps.volume[mine].sum()) >= MIN_BREAKABLE_PARTICLES * particle_volume
        world.body_material[nb] = int(np.bincount(ps.material[mine]).argmax())
        world.bodies[nb] = BodyInfo(info.object_index, info.breakable and big,
                                    bool(world.rigid.body_is_static(nb)), info.thickness, info.resolution, history,
                                    info.bounds, sphere_groups(bp, store_id[ids], label))
    edge = tet_edge(ps.volume[debris])  # regular tet of each freed particle's volume
    record.update(
        cracks=len(cracks), fragments=len(new_ids), debris=int(len(debris)), new_bodies=[int(b) for b in new_ids],
        # half the surface of every freed particle: each freed face is one side of a crack shared with a neighbour
        freed_area_m2=round(0.5 * float((np.sqrt(3.0) * edge**2).sum()), 12),
        subdivided=int(sum(s.children for s in rep.subdivision) + rep.crushed),
        removed_links=int(sum(rep.removed_links)),
        particle_subdivision_ms=round(rep.timings["subdivision_s"] * 1e3, 3),
        crack_generation_ms=round((t_split - t_cut + rep.timings["links_s"] + rep.timings["shatter_s"]
                                   + rep.timings["labels_s"]) * 1e3, 3),
    )
    # the event's stages (sim/stages.py), each under its own name
    cut = "fracture.subdivision" if world.mode == "subdivision" else "fracture.links"
    tm = rep.timings
    world.timers.add(cut, tm["subdivision_s"] + tm["links_s"])
    if shatter:
        world.timers.add("fracture.shatter", tm["shatter_s"])
    world.timers.add("fracture.split", tm["labels_s"] + (t_split - t_cut))
    return record


def _free_particles(world, body: int, ps, idx: np.ndarray, store_idx: np.ndarray,
                    push_ref: np.ndarray | None = None) -> None:
    """Particles `idx` (rows of `ps`; `store_idx` in the store) of `body` leave it as debris: free
    spheres keeping the body's velocity field (v + w x r), plus `push_ref` ((K,3) m/s, reference
    frame) where given, with the `debris` effect; without it they leave the simulation, their mass
    booked."""
    from rigid.quat import quat_to_matrix

    world.debris_pieces += len(idx)
    if world.cfg.has("debris"):
        st = world.rigid.body_state()
        x_w, v_w = _world_motion(world, body, ps.centroid[idx], st)
        if push_ref is not None:
            v_w = v_w + push_ref @ quat_to_matrix(st.q[body]).T
        world.debris.add(x_w, v_w, ps.radius[idx], store_idx)
    else:
        world.debris_mass += float(ps.mass[idx].sum())
        ps.alive[idx] = False
    ps.body[idx] = -1


def _held_labels(obj, obj_bounds, x: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """Per label: True when the fragment (particles at rest positions x) touches the held border of a
    static object (a window frame)."""
    near = held_particles(obj, obj_bounds, x)
    held = np.zeros(int(labels.max()) + 1, dtype=bool)
    held[labels[near]] = True
    return held


def impact_push(world, body: int, result):
    """For a held body (a framed pane), the velocity its freed particles take from the blow: the
    striker's approach speed times the contact field's normal displacement there relative to the
    contact point (`sph.contact.push_profile` of the field Algorithm 1 analysed), along the inward
    normal: the zone under the striker moves with it, the rim of the shattered zone less. The frame
    takes the momentum. A free body's particles keep its velocity field (the rigid contact already
    gave it the blow); None then, or for the beam field. Returns x_ref (K,3) -> (K,3) m/s."""
    from sph.contact import push_profile

    if not world.rigid.body_is_static(body) or result.field not in ("plate", "halfspace") or not result.cracks:
        return None
    P, frame, speed = result.cracks[0].point, result.frame, result.hertz.speed

    def push(x_ref: np.ndarray) -> np.ndarray:
        ratio = push_profile(result.field, (x_ref - P) @ frame.T, result.E1, result.nu1, result.regularisation,
                             result.plate_thickness, result.plate_radius)
        return (speed * ratio)[:, None] * frame[2]

    return push


def fracture_body(world, body: int, impact: dict) -> dict | None:
    """Analyse an impact on `body` and, when it cracks, cut and split it. Returns the event record."""
    t0 = time.perf_counter()
    taken = take_body(world, body)
    result = analyse(world, body, impact, taken)
    t1 = time.perf_counter()
    world.timers.add("fracture.analysis", t1 - t0)
    world.last_analysis = (body, result)  # the viewer colours the analysed particles by it
    world.analyses.append(dict(frame=world.frame, body=body, speed=round(impact["speed"], 6),
                               cracks=len(result.cracks), stress_analysis_ms=round((t1 - t0) * 1e3, 3)))
    if not result.cracks:
        return None
    record = dict(frame=world.frame, body=body, speed=round(float(impact["speed"]), 6),
                  analysis=result.to_dict(), stress_analysis_ms=round((t1 - t0) * 1e3, 3))
    record = cut_body(world, body, result.cracks, record, taken, impact_push(world, body, result))
    record["whole_event_ms"] = round((time.perf_counter() - t0) * 1e3, 3)  # analysis to split, as a user waits
    return record
