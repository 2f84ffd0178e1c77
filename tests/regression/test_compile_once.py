"""No compile stall after start-up (issue 16, item 2): in a fresh process, once the World is built
and its first frame has run, a fracture event with shattering, debris and a perforating ball
compiles no Taichi kernel: the kernels only events and debris launch were compiled and loaded at
build (sim.fracture_stage.warm_pieces), or, for a World built with warm_events=False (`main.py
run`), before its first frame or, under a drawing process, in its waits before the first contact
could come (sim/warm_up.py). And a second World of the same scene, after the first was
released, compiles nothing at all: released stores go back to core/field_pool.py instead of being
destroyed (Taichi 1.7.4's SNodeTree.destroy clears every compiled kernel of the program)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

SPY = """
import json, sys
sys.path.insert(0, {root!r})
from core.runtime import init_taichi
init_taichi("cpu", "f64", threads=1)
import taichi.lang.kernel_impl as kernel_impl
from scenes.loader import load_scene
from sim.world import World

compiled = []
materialize = kernel_impl.Kernel.materialize

def spy(self, key=None, args=None, arg_features=None):
    if key is None or key not in self.compiled_kernels:
        compiled.append((phase, self.func.__qualname__))
    return materialize(self, key, args, arg_features)

kernel_impl.Kernel.materialize = spy
"""

PROBE = SPY + """
phase = "build"
w = World(load_scene("glass_r3"))
phase = "first frame"
w.step_frame()
phase = "later"
for _ in range(5):
    w.step_frame()
print(json.dumps(dict(compiled=compiled, events=len(w.events), debris=w.debris.count,
                      perforation=bool(w.events and w.events[0].get("perforation")))))
"""


def test_a_fracture_event_compiles_no_kernel_after_the_first_frame():
    info = _probe(PROBE)
    assert info["events"] >= 1 and info["debris"] > 0 and info["perforation"]  # the paths this covers ran
    phases = {phase for phase, _ in info["compiled"]}
    assert "build" in phases  # the spy sees compiles
    late = [name for phase, name in info["compiled"] if phase == "later"]
    assert late == [], late


GROWN = SPY + """
import geometry.particle_store as particle_store
particle_store.HEADROOM = 1  # no room for one child: the event grows the store
phase = "build"
w = World(load_scene("glass_r3"))
capacity = w.store.capacity
phase = "first frame"
w.step_frame()
phase = "later"
for _ in range(5):
    w.step_frame()
print(json.dumps(dict(compiled=compiled, events=len(w.events), capacity=capacity, grown=w.store.capacity)))
"""


def test_a_store_that_outgrows_its_capacity_compiles_no_kernel():
    """A run whose particles outgrow the store's capacity (Pots' grains do, at frame 40) copies it
    into a bigger one. On the CPU the store's copies (an event's gather and write-back, the growth)
    are numpy on views of its ndarrays (geometry/store_host.py): none of its kernels compiles at all."""
    import geometry.store_kernels as store_kernels

    info = _probe(GROWN)
    assert info["events"] >= 1 and info["grown"] > info["capacity"]  # the store did grow
    late = [name for phase, name in info["compiled"] if phase == "later"]
    assert late == [], late
    store = {name for name in vars(store_kernels) if name.startswith("k_")}
    assert len(store) == 9 and not store & {name for _, name in info["compiled"]}


SECOND_WORLD = SPY + """
from anisofrac.simulation import Simulation

def one_world():
    sim = Simulation(load_scene("glass_r3"))
    sim.step(6)
    sim.render(160, 120)
    events, debris = len(sim.world.events), sim.world.debris.count
    sim.close()
    return events, debris

phase = "first world"
first = one_world()
phase = "second world"
second = one_world()
print(json.dumps(dict(compiled=compiled, first=first, second=second)))
"""


def test_a_second_world_after_a_released_one_compiles_no_kernel():
    info = _probe(SECOND_WORLD)
    assert info["first"] == info["second"] and info["first"][0] >= 1 and info["first"][1] > 0  # event, debris
    assert any(phase == "first world" for phase, _ in info["compiled"])  # the spy sees compiles
    again = [name for phase, name in info["compiled"] if phase == "second world"]
    assert again == [], again


STRIKE = SPY + """
import anisofrac

phase = "build"
sim = anisofrac.load("pot", ["scene.gravity=[0.0,0.0,0.0]"])
phase = "strike"
point = sim.surface_point(0, (0.0, -1.0, 0.0))
record = sim.strike(0, point, (0.0, -3.2, 0.0))
print(json.dumps(dict(compiled=compiled, fragments=record["fragments"] if record else 0)))
"""


def test_the_api_s_first_strike_compiles_no_kernel():
    """The Python API builds with every event kernel warm: its first `surface_point` and `strike` (the
    anvil blow that bench/bench_event_scale.py times) compile nothing, the bodies' state download
    included (a run's frames launch it before any event; the API's first read of it did not)."""
    info = _probe(STRIKE)
    assert info["fragments"] >= 2  # the event ran and split the pot
    assert any(phase == "build" for phase, _ in info["compiled"])  # the spy sees compiles
    late = [name for phase, name in info["compiled"] if phase == "strike"]
    assert late == [], late


DRAWN = SPY + """
from render.session import HeadlessSession

phase = "build"
w = World(load_scene("glass_r3"))
session = HeadlessSession(w, "raster", 160, 120)
phase = "first frame"
w.step_frame()
session.draw()
phase = "later"
for _ in range(5):
    w.step_frame()
    session.draw()
print(json.dumps(dict(compiled=compiled, events=len(w.events), debris=w.debris.count,
                      drawn_particles=session.view.scene.n_particles, pose_capacity=session.view.scene.cap["pose"],
                      body_capacity=w.rigid.capacity["bodies"])))
"""


def test_drawn_frames_compile_no_kernel_after_the_first():
    """Drawn with the rasteriser, the frames of an event (surface blocks written, debris drawn as
    particles for the first time) compile nothing after the first frame either; and the pose buffer
    holds every body the rigid store can (Pots' grew past 64 and 128 bodies, recompiling the transform)."""
    info = _probe(DRAWN)
    assert info["events"] >= 1 and info["debris"] > 0 and info["drawn_particles"] > 0
    assert info["pose_capacity"] >= info["body_capacity"]
    late = [name for phase, name in info["compiled"] if phase == "later"]
    assert late == [], late


DEFERRED = SPY + """
phase = "build"
w = World(load_scene("glass_r3"), warm_events=False)
phase = "first frame"
w.step_frame()
phase = "later"
for _ in range(5):
    w.step_frame()
print(json.dumps(dict(compiled=compiled, events=len(w.events))))
"""


def test_event_kernels_left_out_of_the_build_compile_before_the_first_frame():
    """`main.py run` builds with warm_events=False, so that the drawing process gets its scene sooner;
    the event kernels then compile at the first frame (or when the run says), never at an event."""
    info = _probe(DEFERRED)
    assert info["events"] >= 1
    when = {name: phase for phase, name in reversed(info["compiled"])}  # each kernel's first compile
    assert when["k_fit_moments"] == "first frame"  # an event-only kernel (the analysis' quadratic fit)
    late = [name for phase, name in info["compiled"] if phase == "later"]
    assert late == [], late


SPREAD = SPY + """
phase = "build"
imminent = World(load_scene("glass_r3"), warm_events=False)
imminent.warm_up.idle = True
imminent.warm_up.before_frame()  # the ball is launched at the pane: all before the first frame
left_imminent = len(imminent.warm_up.pieces)
w = World(load_scene("pot"), warm_events=False)
w.warm_up.idle = True  # as under a drawing process: one piece in each wait for a frame
import sim.warm_up
sim.warm_up.START_WARM_S = 0.0  # no budget before the first frame: the spread alone (a start's budget: unit tests)
pieces = len(w.warm_up.pieces)
left, first_event = [], None
event_imports = None
for f in range(40):
    phase = f"frame {{f}}"
    known = set(sys.modules)
    w.step_frame()
    left.append(len(w.warm_up.pieces))
    if w.events:
        first_event = f
        event_imports = sorted(set(sys.modules) - known)
        break
    w.warm_up.run_one()  # the idle time after the frame is drawn
print(json.dumps(dict(compiled=compiled, left_imminent=left_imminent, pieces=pieces, left=left,
                      first_event=first_event, event_imports=event_imports)))
"""


def test_event_kernels_compile_in_the_idle_frames_before_the_first_contact():
    """Under a drawing process (`main.py run`), the event kernels compile while the simulation waits
    for frames to be drawn (here with no budget before the first frame, START_WARM_S = 0: none there),
    all before the first contact could come (sim/warm_up.py): the event's frame compiles and imports
    nothing. Where a contact is imminent (glass_r3's ball), all compile before the first frame."""
    info = _probe(SPREAD)
    assert info["left_imminent"] == 0
    assert info["left"][0] == info["pieces"] > 0  # the first frame ran none
    assert info["first_event"] is not None
    assert info["left"][info["first_event"] - 1] == 0  # all had run before the frame of the first event
    event = [name for phase, name in info["compiled"] if phase == f"frame {info['first_event']}"]
    assert event == [], event
    assert info["event_imports"] == []  # nor imports anything (sim.fracture_stage.EVENT_MODULES)


PILE = SPY + """
phase = "build"
from tests.regression.test_free_flight_frames import SPREAD
w = World(load_scene("rigid_pile", SPREAD), warm_events=False)  # 13 frames before a contact can come
w.warm_up.idle = True  # as under a drawing process with no budget before the first frame: none there
import sim.warm_up
sim.warm_up.START_WARM_S = 0.0
phase = "first frame"
w.step_frame()
free = w.rigid.free_flight.frames
phase = "warm-up"
w.warm_events()
phase = "later"
while w.rigid.n_contacts == 0:
    w.step_frame()
print(json.dumps(dict(compiled=compiled, free=free, free_after=w.rigid.free_flight.frames)))
"""


def test_the_full_rigid_step_compiles_in_the_warm_up_not_at_the_first_contact():
    """A frame before any contact can come steps the bodies alone (rigid/free_flight.py) and compiles
    only that; the full step's kernels compile as warm-up pieces, the frames after them run the full
    step, and the first contact compiles nothing."""
    info = _probe(PILE)
    assert info["free"] == info["free_after"] == 1
    first = {name for phase, name in info["compiled"] if phase == "first frame"}
    full = {"k_broad_phase", "k_count", "k_contacts", "k_substep", "k_after_substeps", "k_bookkeeping"}
    assert "k_free_substep" in first and not first & full
    assert full <= {name for phase, name in info["compiled"] if phase == "warm-up"}
    late = [name for phase, name in info["compiled"] if phase == "later"]
    assert late == [], late


def _probe(code: str) -> dict:
    out = subprocess.run([sys.executable, "-c", code.format(root=str(ROOT))], capture_output=True, text=True,
                         timeout=600, cwd=ROOT)
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])
