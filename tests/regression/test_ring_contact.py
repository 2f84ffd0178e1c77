"""A body that lands on a ring of contact breaks where it touches (rigid/records.py `by_body_pair`).

The paper's pot dropped upside down lands on its rim: the floor touches it along a circle whose
impulse-weighted centre lies in the opening, where the pot has no particle. Analysed there, the impact
found no particle within its kernel and the pot never broke, whatever the speed. The pair's point is
now the site of its hardest contact, on the rim.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import tomllib

from scenes.loader import scene_from_dict
from sim.fracture_stage import analysed_rows
from sim.world import World

POT = Path(__file__).resolve().parents[2] / "scenes" / "pot.toml"
RIM_RADIUS = 0.06  # m: the pot's profile at its opening (scenes/pot.toml)
THICKNESS = 0.008  # m: its wall


def test_a_pot_landing_on_its_rim_is_analysed_on_the_rim_and_breaks():
    """Upside down from 0.6 m (3.2 m/s): the first impact is analysed at a particle of the rim (the
    lowest layer, at the rim's radius) with a non-empty neighbourhood in tension, it cracks, and mass
    is conserved exactly through the split."""
    raw = tomllib.loads(POT.read_text())
    raw["objects"][0]["rotation"] = [180.0, 0.0, 0.0]
    w = World(scene_from_dict(raw, "pot"))
    try:
        ps = w.particles
        lowest = float(ps.centroid[ps.alive, 1].min())
        while not w.analyses and w.frame < 40:
            w.step_frame()
        assert w.analyses, "the pot never struck the floor"
        body, result = w.last_analysis
        # `nearest` indexes the analysed rows; `ps` is the store's copy from before the event
        x = ps.centroid[analysed_rows(ps, body)[result.nearest]]  # reference frame: as placed, the opening down
        assert x[1] - lowest < THICKNESS  # the rim's layer, not the base above it
        assert abs(np.hypot(x[0], x[2]) - RIM_RADIUS) < THICKNESS  # on the rim, not in the opening
        assert len(result.particles) > 0 and float(result.tension_per_newton.max()) > 0.0
        assert result.cracks and w.events, "the blow on the rim cracked nothing"
        for _ in range(5):
            w.step_frame()
        ps = w.particles
        assert len(np.unique(ps.body[ps.alive])) >= 2
        balance = w.mass_balance()
        assert abs(balance["error_kg"]) <= 1e-12 * balance["initial_kg"]
    finally:
        w.release()
