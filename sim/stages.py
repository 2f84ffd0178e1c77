"""A frame as a list of stages (DESIGN.md section 4), built once from the scene's effects.

    per substep (scene.substeps times):  rigid -> debris -> fracture.events
    per frame:                            elastic
    per fracture event (sim/fracture_stage.py):
                                          fracture.analysis -> fracture.subdivision | fracture.links
                                          -> fracture.shatter -> fracture.split

Every stage has a name (its key in stats.json's `stage_totals_ms` and `per_frame_ms`), the effect
that switches it on and where it runs. `build_stages` keeps the catalogue's order and asserts it, so
reading `World.stages` is reading one frame top to bottom. A stage whose effect is off is not in the
list: its module is never imported, so it allocates no field and compiles or launches no kernel
(tests/regression/test_effects_on_demand.py proves it per effect). Rendering is not a World stage:
the run driver or the viewer draws after the frame (render/session.py).
"""

from __future__ import annotations

from dataclasses import dataclass

from core.errors import ConfigError

SUBSTEP, FRAME, EVENT = "substep", "frame", "event"


@dataclass(frozen=True)
class Stage:
    name: str  # timer key in stats.json
    effect: str  # the scene effect that builds it
    phase: str  # SUBSTEP: every rigid substep; FRAME: once a frame; EVENT: in each fracture event
    what: str  # one line: what it does and where


CATALOGUE = (
    Stage("rigid", "rigid", SUBSTEP, "impulse-based rigid bodies on boundary particles (rigid/step.py)"),
    Stage("debris", "debris", SUBSTEP, "shattered particles fall and meet the colliders (rigid/debris.py)"),
    Stage("fracture.events", "fracture", SUBSTEP, "the hardest impact per breakable body above the threshold"),
    Stage("elastic", "elastic", FRAME, "corotated SPH elasticity, Sect. 3-4.1 (sph/elastic.py)"),
    Stage("fracture.analysis", "fracture", EVENT, "Algorithm 1 at the impact, Sect. 4.2 (sph/cracks.py)"),
    Stage("fracture.subdivision", "subdivision", EVENT, "cut tets subdivided, Algorithm 2 (geometry/subdivision.py)"),
    Stage("fracture.links", "fracture", EVENT, "links across a crack removed: the basic scheme (geometry/cutting.py)"),
    Stage("fracture.shatter", "shatter", EVENT, "particles inside r_inner freed (geometry/cutting.py)"),
    Stage("fracture.split", "fracture", EVENT, "connected pieces become bodies (rigid/bodies.py)"),
)
ORDER = [s.name for s in CATALOGUE]


def build_stages(effects: list[str], fracture_mode: str | None) -> list[Stage]:
    """The stages of a scene with these effects (and 'basic' or 'subdivision' fracture), in frame order."""
    on = set(effects)
    stages = []
    for s in CATALOGUE:
        if s.effect not in on:
            continue
        if s.name == "fracture.subdivision" and fracture_mode != "subdivision":
            continue
        if s.name == "fracture.links" and fracture_mode == "subdivision":
            continue
        stages.append(s)
    names = [s.name for s in stages]
    assert names == sorted(names, key=ORDER.index), names  # the fixed order of one frame
    return stages


def fracture_mode(cfg) -> str:
    """The scene's fracture mode, 'auto' resolved: subdivision where the effect is on, else basic."""
    mode = cfg.scene.fracture_mode
    if mode == "auto":
        return "subdivision" if cfg.has("subdivision") else "basic"
    if mode == "subdivision" and not cfg.has("subdivision"):
        raise ConfigError("scene.fracture_mode", mode, "'basic' unless 'subdivision' is in scene.effects", cfg.source)
    return mode


def stage_list(cfg) -> list[str]:
    """The names of the stages a scene (scenes.config.SceneConfig) builds, in frame order."""
    return [st.name for st in build_stages(cfg.scene.effects, fracture_mode(cfg) if cfg.has("fracture") else None)]
