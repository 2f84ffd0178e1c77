"""One fracture event on one body, between frames (DESIGN.md section 4).

    crack analysis at the contact point (sph.cracks, Algorithm 1)  -> cracks in the reference frame
    cut: link removal ('basic') or subdivision first (Algorithm 2)   (geometry.fragments.apply_cracks)
    shatter inside r_inner                                            (same call, `shatter`)
    split: connected components -> new rigid bodies keeping the parent's velocity field (rigid.bodies)

Only the touched body is processed. Timings follow the paper's Table 2 columns: stress analysis,
particle subdivision, crack generation (link removal, labelling, splitting, new boundary particles).
"""

from __future__ import annotations

import time

import numpy as np

from sim.world import BodyInfo, World

MIN_BREAKABLE_PARTICLES = 8  # fragments with fewer particles do not break again


def _to_reference(world: World, body: int, point: np.ndarray, normal: np.ndarray):
    from rigid.quat import quat_to_matrix

    st = world.rigid.body_state()
    rot = quat_to_matrix(st.q[body])
    com = world.rigid.body_ref_com(body)
    return rot.T @ (np.asarray(point) - st.x[body]) + com, rot.T @ np.asarray(normal)


def _local_radius(world: World, body: int, point_world: np.ndarray) -> float:
    """Radius (m) of the body's boundary sphere nearest the contact: the curvature the collision saw.
    A body split earlier in the same frame has no spheres left: it counts as flat (inf)."""
    spheres = world.rigid.body_spheres(body)
    if len(spheres) == 0:
        return float("inf")
    centres = world.rigid.sphere_world()[spheres]
    _, radius, _ = world.rigid.sphere_data()
    k = int(np.argmin(np.linalg.norm(centres - point_world, axis=1)))
    return float(radius[spheres[k]])


def _other_body(world: World, other: int, point_world: np.ndarray) -> dict:
    """Mass, radius and elastic constants of what struck the body (a body, or a static collider)."""
    from sph.contact import effective_isotropic

    if other < 0 or world.rigid.body_is_static(other):
        if other < 0:
            col = world.cfg.colliders[0] if world.cfg.colliders else None
            young, poisson = (col.young, col.poisson) if col else (3.0e10, 0.2)
        else:
            young, poisson = effective_isotropic(world.materials[_body_material(world, other)].stiffness)
        return dict(m2=np.inf, R2=np.inf, E2=young, nu2=poisson)
    young, poisson = effective_isotropic(world.materials[_body_material(world, other)].stiffness)
    return dict(m2=world.rigid.body_mass(other), R2=_local_radius(world, other, point_world), E2=young, nu2=poisson)


def _body_material(world: World, body: int) -> int:
    """The body's main material (recorded when the body was made, so split bodies keep theirs)."""
    return world.body_material[body]


def analysed_particles(world: World, body: int) -> np.ndarray:
    """The physical particles of a body, including those already replaced by their children.

    The paper analyses stress "on the original model" (Sect. 1, 5): subdivided children track the
    crack geometry, while the stress field is resolved at the physical particles' scale. This also
    keeps the analysis cost bounded by the physical particle count.
    """
    ps = world.particles
    mine = ps.alive & (ps.body == body)
    ids = np.flatnonzero(mine & (ps.kind == 0))
    parents = ps.parent[mine & (ps.kind == 1)]
    if parents.size:
        ids = np.union1d(ids, parents)
    return ids


def analyse(world: World, body: int, impact: dict):
    """Algorithm 1 at the impact point; returns the ImpactAnalysis (cracks in the reference frame)."""
    from sph.cracks import ImpactSpec, analyse_impact

    ps = world.particles
    ids = analysed_particles(world, body)
    point, normal = _to_reference(world, body, impact["point"], impact["normal"])
    nearest = ids[int(np.argmin(np.linalg.norm(ps.centroid[ids] - point, axis=1)))]
    # The collision spheres cover the surface particles, so their contact point lies up to a few mm
    # outside the tets: move it along the inward normal onto the nearest particle's surface
    # (one particle radius from its centroid), where Algorithm 1 expects the analysed point.
    gap = float(np.dot(normal, ps.centroid[nearest] - point)) - float(ps.radius[nearest])
    if gap > 0.0:
        point = point + gap * normal
    material = world.materials[int(ps.material[nearest])]
    cfg_mat = world.cfg.materials[int(ps.material[nearest])]
    spec = ImpactSpec(
        point=point, normal=normal, speed=impact["speed"], m1=world.rigid.body_mass(body),
        R1=_local_radius(world, body, impact["point"]), **_other_body(world, impact["other"], impact["point"]),
    )
    result = analyse_impact(ps.centroid[ids], ps.volume[ids], world.kernel_G[ids], material, spec,
                            crack_count=cfg_mat.cracks, thickness=world.bodies[body].thickness)
    return result


def cut_body(world: World, body: int, cracks: list, record: dict) -> dict:
    """Apply cracks to one body: cut, shatter, split into fragment bodies. Returns the event record."""
    from geometry.fragments import apply_cracks
    from rigid.bodies import split_body

    info = world.bodies[body]
    obj = world.cfg.objects[info.object_index]
    shatter = world.cfg.has("shatter")
    t0 = time.perf_counter()
    ps, rep = apply_cracks(world.particles, cracks, mode=world.mode, shatter=shatter, bodies=[body],
                           history=info.history)
    t_cut = time.perf_counter()
    # children inherit their parent's kernel tensor (they sample the same material, Sect. 5.2)
    n_old = len(world.kernel_G)
    if len(ps) > n_old:
        parent = ps.parent[n_old:]
        world.kernel_G = np.concatenate([world.kernel_G, world.kernel_G[parent]])
    debris = rep.debris
    if len(debris) and not world.cfg.has("debris"):
        # without the 'debris' effect shattered particles leave the simulation; their mass is booked
        world.debris_mass += float(ps.mass[debris][ps.alive[debris]].sum())
        ps.alive[debris] = False
        ps.body[debris] = -1
    world.particles = ps
    ids = np.flatnonzero(ps.alive & (ps.body == body))
    labels = rep.labels[ids]
    new_ids = []
    if len(ids):
        held = None
        if info.static:
            held = _held_labels(world, obj, info.bounds, ids, labels)
        new_ids = split_body(world.rigid, body, ps, ids, labels, group_size=obj.group_size, static_labels=held)
    else:
        world.rigid.remove_bodies([body])
    t_split = time.perf_counter()
    del world.bodies[body]
    history = info.history + list(cracks)
    for nb in new_ids:
        count = int((ps.body == nb).sum())
        world.body_material[nb] = int(np.bincount(ps.material[ps.body == nb]).argmax())
        world.bodies[nb] = BodyInfo(info.object_index, info.breakable and count >= MIN_BREAKABLE_PARTICLES,
                                    bool(world.rigid.body_is_static(nb)), info.thickness, info.resolution, history,
                                    info.bounds)
    record.update(
        cracks=len(cracks), fragments=len(new_ids), debris=int(len(debris)),
        subdivided=int(sum(s.children for s in rep.subdivision)) if rep.subdivision else 0,
        removed_links=int(sum(rep.removed_links)),
        particle_subdivision_ms=round(rep.timings["subdivision_s"] * 1e3, 3),
        crack_generation_ms=round((t_split - t_cut + rep.timings["links_s"] + rep.timings["labels_s"]) * 1e3, 3),
    )
    world.timers.total["fracture.cut"] += t_cut - t0
    world.timers.total["fracture.split"] += t_split - t_cut
    return record


def _held_labels(world: World, obj, obj_bounds, ids: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """Per label: True when the fragment touches the held border of a static object (a window frame)."""
    n = int(labels.max()) + 1
    if obj.held_border <= 0:
        return np.ones(n, dtype=bool)
    x = world.particles.centroid[ids]
    lo, hi = obj_bounds
    span = hi - lo
    axes = span > 2 * obj.held_border
    near = ((x - lo < obj.held_border) | (hi - x < obj.held_border))[:, axes].any(1)
    held = np.zeros(n, dtype=bool)
    held[labels[near]] = True
    return held


def fracture_body(world: World, body: int, impact: dict) -> dict | None:
    """Analyse an impact on `body` and, when it cracks, cut and split it. Returns the event record."""
    t0 = time.perf_counter()
    result = analyse(world, body, impact)
    t1 = time.perf_counter()
    world.last_analysis = (body, result)  # the viewer colours the analysed particles by it
    world.analyses.append(dict(frame=world.frame, body=body, speed=round(impact["speed"], 6),
                               cracks=len(result.cracks), stress_analysis_ms=round((t1 - t0) * 1e3, 3)))
    if not result.cracks:
        return None
    record = dict(frame=world.frame, body=body, speed=round(float(impact["speed"]), 6),
                  analysis=result.to_dict(), stress_analysis_ms=round((t1 - t0) * 1e3, 3))
    return cut_body(world, body, result.cracks, record)
