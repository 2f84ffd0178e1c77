"""Perforation: a striker that shatters a hole wider than itself goes through it (Sect. 6, Fig. 9).

The rigid solver resolves the contact before the fracture that it causes is known, so a ball that
breaks a pane bounces back off it, as if the pane had held (paper Fig. 9: "a ball collapses through
glass window, breaks into a hole"). Once the event has shattered the zone r_inner around the
contact, this step corrects the striker when its whole cross-section (perpendicular to the contact
normal) fits inside that zone: nothing is left in its path to push it back.

- The striker's velocity and spin before the contact are the ones it had at the start of the
  contact's substep (recorded with the impact).
- It loses the energy the fracture consumed: G_c times the new surface, the radial cracks' faces
  outside the hole (B (r_outer - r_inner) per half-disc) plus half the surface of every freed
  particle (each freed face is one side of a crack shared with a neighbour): v = v_pre
  sqrt(1 - E_fracture / K_pre).
- The contact is undone for the struck side too: a free body's new fragments and freed particles
  get back the parent's velocity field from before the contact (v0 + w0 x r); what the striker
  lost to the fracture pushes them on (one velocity change, so momentum is conserved). A held body,
  such as a framed pane, is a wall whose support takes any momentum.
- The striker sweeps the freed particles in its path (inside its cross-section): they move on with
  it, a perfectly inelastic collision (momentum conserved, energy lost).
- Positions move on by each velocity change times the time left in the frame after the contact's
  substep, as if nothing had bounced.

Only a dynamic striker perforates; a collider (the floor) or a striker wider than the hole does not.
"""

from __future__ import annotations

import numpy as np

from core.arrays import cross3


def cross_section(world, striker: int, normal: np.ndarray, state) -> float:
    """m: the striker's half-width perpendicular to `normal`: the largest distance from its COM line
    to a boundary sphere's far side."""
    spheres = world.rigid.body_spheres(striker)
    if spheres.size == 0:
        return float("inf")
    centres = world.rigid.sphere_world(state, spheres) - state.x[striker]
    _, radius, _ = world.rigid.sphere_data()
    perp = centres - np.outer(centres @ normal, normal)
    return float((np.linalg.norm(perp, axis=1) + radius[spheres]).max())


def fracture_energy(world, body: int, thickness: float, record: dict) -> float:
    """J: G_c times the surface the event made (radial cracks outside the hole, freed particles);
    `thickness` (m): the struck body's, for cracks through a wall that is not a plate."""
    material = world.materials[world.body_material[body]]
    analysis = record.get("analysis") or {}
    r_in = float(analysis.get("r_inner", 0.0))
    B = float(analysis.get("plate_thickness") or 0.0) or float(thickness)
    crack_area = 0.0
    for c in analysis.get("cracks", []):
        length = max(float(c["r_outer"]) - r_in, 0.0)
        crack_area += B * length * (1.0 if c.get("side") is not None else 2.0)
    return material.toughness * (crack_area + float(record.get("freed_area_m2", 0.0)))


def perforate(world, body: int, info, impact: dict, record: dict, debris_from: int) -> dict | None:
    """Let the striker of `impact` through the hole the event `record` shattered in `body` (its
    BodyInfo `info`, taken before the event replaced it). `debris_from`: the debris store's count
    before the event (its new entries are this event's).
    Returns what was done (for the event record), or None when the striker does not perforate."""
    other = int(impact["other"])
    analysis = record.get("analysis") or {}
    r_in = float(analysis.get("r_inner", 0.0))
    if other < 0 or r_in <= 0.0 or world.rigid.body_is_static(other) or not record.get("debris"):
        return None
    st = world.rigid.body_state()
    if not st.alive[other]:
        return None
    n = np.asarray(impact["normal"], dtype=np.float64)  # into the struck body
    n = n / np.linalg.norm(n)
    half = cross_section(world, other, n, st)
    v_pre = np.asarray(impact["striker_v"], dtype=np.float64)  # before the substep of the contact
    if half > r_in or float(v_pre @ n) <= 0.0:
        return None
    parts = _struck_parts(world, record, debris_from, st)
    m = world.rigid.body_mass(other)
    E = fracture_energy(world, body, info.thickness, record)
    v_free = v_pre * np.sqrt(max(0.0, 1.0 - E / (0.5 * m * float(v_pre @ v_pre))))
    # a free body's parts as before the contact: the parent's velocity field at that substep (a held
    # body's debris were released with the blow's push, sim.fracture_stage.impact_push)
    v0, w0 = np.asarray(impact["struck_v"], dtype=np.float64), np.asarray(impact["struck_w"], dtype=np.float64)

    def field(x):
        return v0 + cross3(w0, x - parts["com"])

    rel = parts["debris_x"] - st.x[other]
    swept = np.linalg.norm(rel - np.outer(rel @ n, n), axis=1) <= half
    vd = parts["debris_v"].copy() if info.static else field(parts["debris_x"])
    m_sw = parts["debris_m"][swept]
    p_swept = (m_sw[:, None] * vd[swept]).sum(0)  # kg m/s: the swept debris' momentum before the sweep
    v_out = (m * v_free + p_swept) / (m + m_sw.sum())  # an inelastic sweep
    # what the striker lost to the fracture pushes the rest of a free body on (momentum conserved)
    rest = float(parts["body_m"].sum() + parts["debris_m"][~swept].sum())
    dv = m * (v_pre - v_free) / rest if (not info.static and rest > 0.0) else np.zeros(3)
    vd[~swept] += dv
    vd[swept] = v_out
    dp_bodies = m * (v_out - st.v[other])
    t_left = float(impact.get("time_left", 0.0))
    if not info.static:
        for b, m_b in zip(parts["bodies"], parts["body_m"]):
            v_b = field(st.x[b][None])[0] + dv
            dp_bodies += m_b * (v_b - st.v[b])
            world.rigid.set_body_state(b, x=st.x[b] + (v_b - st.v[b]) * t_left, v=v_b, w=w0)
    if len(vd):
        world.debris.set_velocities(parts["debris_index"], vd)
    dp_debris = (parts["debris_m"][:, None] * (vd - parts["debris_v"])).sum(0)
    world.rigid.set_body_state(other, x=st.x[other] + (v_out - st.v[other]) * t_left, v=v_out,
                               w=np.asarray(impact["striker_w"], dtype=np.float64))
    return dict(striker=other, speed_before=float(np.linalg.norm(v_pre)), speed_after=float(np.linalg.norm(v_out)),
                velocity_before=[float(c) for c in v_pre],
                fracture_energy=E, swept_debris=int(swept.sum()), swept_momentum=[float(c) for c in p_swept],
                # kg m/s: what this step changed in the bodies' and the debris' momentum (their sum is
                # zero for a free struck body; for a held one it is the support's impulse)
                bodies_momentum=[float(c) for c in dp_bodies], debris_momentum=[float(c) for c in dp_debris])


def _struck_parts(world, record: dict, debris_from: int, st) -> dict:
    """The event's new dynamic fragments (ids, masses) and its debris entries (store indices, world
    positions, velocities, masses), and their centre of mass (m)."""
    bodies = [b for b in record.get("new_bodies", []) if st.alive[b] and not world.rigid.body_is_static(b)]
    body_m = np.array([world.rigid.body_mass(b) for b in bodies], dtype=np.float64)
    if "debris" in world.stages and world.debris.count > debris_from:
        d = world.debris.state(debris_from)  # the event's entries only
        idx = np.arange(debris_from, world.debris.count)
        dx, dvel = d["x"], d["v"]
        dm = world.store.take_mass(d["particle"])
    else:
        idx, dx, dvel, dm = np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)
    total = body_m.sum() + dm.sum()
    com = ((body_m[:, None] * st.x[bodies]).sum(0) + (dm[:, None] * dx).sum(0)) / total if total > 0 else np.zeros(3)
    return dict(bodies=bodies, body_m=body_m, debris_index=idx, debris_x=dx, debris_v=dvel, debris_m=dm, com=com)


__all__ = ["fracture_energy", "perforate"]
