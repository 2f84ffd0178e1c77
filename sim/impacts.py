"""A frame's fracture events (DESIGN.md section 4): at every substep the hardest impact on each
breakable body is kept (`collect_impacts`), and after the frame's stages each kept impact is analysed
and cut (`fracture_impacts`: sim/fracture_stage.py, one event a body, with the perforation it makes,
sim/perforation.py). Both read and write the World they are given; the World calls them from its
frame loop (sim/world.py).
"""

from __future__ import annotations


def collect_impacts(world, impacts: dict[int, dict]) -> None:
    """Keep in `impacts`, per breakable body, the hardest impact of this frame above the scene's speed
    threshold: the contact's point and normal (into the struck body), speed, impulse, the time left in
    the frame, both bodies' velocities at the substep's start (sim/perforation.py), and the contact in
    the struck body's reference frame (`reference`) with its hardest site's (`site`: where the contacts'
    mean lies off the body, rigid/records.py `by_body_pair`)."""
    from sim.fracture_stage import contact_in_reference

    threshold = world.cfg.scene.impact_threshold
    if world.rigid.fastest_closing() <= threshold:
        return  # no contact closes fast enough: nothing to download
    pairs = world.rigid.contact_events().by_body_pair(site_above=threshold)  # sites of the impacts kept
    state = None  # the bodies' poses, downloaded once and only when an impact is kept
    start = world._substep_start
    for k in range(len(pairs["impulse"])):
        speed = -float(pairs["speed"][k])  # closing speed, m/s
        if speed <= threshold:
            continue
        a, b = int(pairs["body_a"][k]), int(pairs["body_b"][k])
        # the normal points from B to A: into A it is +n, into B it is -n
        for struck, other, sign in ((a, b, 1.0), (b, a, -1.0)):
            info = world.bodies.get(struck)
            if info is None or not info.breakable:
                continue
            best = impacts.get(struck)
            if best is None or speed > best["speed"]:
                point, normal = pairs["point"][k].copy(), sign * pairs["normal"][k]
                state = world.rigid.body_state() if state is None else state
                impacts[struck] = dict(
                    other=other, speed=speed, point=point, normal=normal, impulse=float(pairs["impulse"][k]),
                    time_left=world._time_left,
                    striker_v=start.v[other].copy() if other >= 0 else None,
                    striker_w=start.w[other].copy() if other >= 0 else None,
                    struck_v=start.v[struck].copy(), struck_w=start.w[struck].copy(),
                    reference=contact_in_reference(world, struck, other, point, normal, state),
                    site=contact_in_reference(world, struck, other, pairs["site_point"][k].copy(),
                                              sign * pairs["site_normal"][k], state),
                )


def fracture_impacts(world, impacts: dict[int, dict]) -> None:
    """Analyse and cut each body of `impacts` (ascending ids) that is still whole and alive; the events
    that cracked go to `world.events`."""
    from sim.fracture_stage import fracture_body
    from sim.perforation import perforate

    world.warm_events()  # left for the frames before a contact: all have run (sim/warm_up.py)
    for body in sorted(impacts):
        if body not in world.bodies or not world.rigid.body_state().alive[body]:
            continue
        info = world.bodies[body]
        debris_from = world.debris.count if "debris" in world.stages else 0
        record = fracture_body(world, body, impacts[body])
        if record is not None:
            record["perforation"] = perforate(world, body, info, impacts[body], record, debris_from)
            world.events.append(record)
            world.surface_version += 1
