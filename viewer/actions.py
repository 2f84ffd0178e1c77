"""What the interactive viewer does to a World: shoot a ball, strike a surface point, tune the
material knobs, and preview a strike's crack analysis without applying it (no window needed).

* Shooting (`shoot_ball`): a steel ball of tets (rigid.bodies.ball_tetmesh) becomes particles of the
  World (so it is drawn, collides through its boundary spheres, and sim.fracture_stage finds its
  material when it strikes a breakable body) and a rigid body moving along the camera ray. The
  ball's reference frame is its spawn pose; it is never breakable.
* Striking (`strike`): the Python API's strike (anisofrac/strikes.py) at a picked surface point,
  along its inward normal: Algorithm 1 sees a normal impact of a rigid flat anvil at the given speed.
  The event record is appended to `world.events` as the World does.
* Tuning (`Tuning`): crack count, tensile strength (a factor on each material's scene value) and a
  factor on the first kernel axis; they act on the next analysis (an impact, a strike or a preview).
* Preview (`preview_strike`): the API's preview (the analysis only, nothing applied), turned into
  world-frame crack discs, groups and shatter radius for drawing.

Positions of rest data are in the reference frame; a body maps X to `R(q) (X - ref_com) + x`.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field, replace

import numpy as np

# body frames, strikes and previews are the Python API's (anisofrac/strikes.py): the viewer builds on it
from anisofrac.strikes import Preview, body_frames, breakable, crack_shapes
from core.errors import ConfigError
from geometry.particles import build_particles
from render.pick import Hit

STEEL = dict(model="isotropic", E=2.0e11, nu=0.3, density=7800.0, tensile_strength=1.0e9, toughness=1.0e4,
             restitution=0.3, friction=0.4, name="viewer-ball-steel")  # SI units: the shot ball's material
BALL_RADIUS_FRACTION = 0.15  # -: ball radius as a fraction of the largest breakable object's extent
BALL_RADIUS_RANGE_M = (0.005, 0.05)  # m: clamp of the ball radius
BALL_SHELLS = 2  # -: Fibonacci shells of the ball's tet mesh
BALL_POINTS = 40  # -: points on the outer shell
BALL_KERNEL_SUPPORT = 2.0  # tet edges: isotropic kernel support of ball particles (never analysed)


# ----------------------------------------------------------------------------- tuning
@dataclass
class Tuning:
    """The viewer's sliders. They change the World's materials, read at the next analysis:
    cracks: crack count N (groups of Algorithm 1, `world.cfg.materials[i].cracks`) of every material;
        it starts at the first material's count, and at that value each material keeps its scene count;
    strength_factor: tensile strength = factor x the scene's value, every material
        (`world.materials[i].tensile_strength` and `world.cfg.materials[i].tensile_strength`);
    axis_factor: the first kernel axis is `axis_factor` times longer than the scene's (the kernel
        config's axis_scale multiplied by (axis_factor, 1, 1); first axis = the object's rotated x
        axis for 'isotropic', the first column of `axes` for 'fixed', the major WPCA axis for
        'wpca'); world.kernel_G is recomputed (children inherit their root particle's tensor);
    strike_speed (m/s): speed of a strike and of the preview's hypothetical strike;
    ball_speed (m/s): launch speed of a shot ball."""

    cracks: int = 3
    strength_factor: float = 1.0
    axis_factor: float = 1.0
    strike_speed: float = 5.0
    ball_speed: float = 8.0
    _applied: dict = field(default_factory=dict, repr=False)

    @classmethod
    def from_config(cls, cfg) -> Tuning:
        n = cfg.materials[0].cracks if cfg.materials else 3
        return cls(cracks=3 if n == "auto" else int(n))  # the slider sets N; "auto" starts it at 3

    def key(self) -> tuple:
        """What a preview depends on (recompute when it changes)."""
        return (self.cracks, round(self.strength_factor, 6), round(self.axis_factor, 6), round(self.strike_speed, 6))

    def new_world(self) -> None:
        """Forget what was applied (call when a World is rebuilt: a new World has the scene's kernels)."""
        self._applied = {}

    def apply(self, world, base_cfg) -> None:
        """Write the settings into the World (cheap when nothing changed)."""
        if not 1 <= int(self.cracks) <= 32:
            raise ConfigError("viewer.cracks", self.cracks, "1..32 cracks per event")
        if not (self.strength_factor > 0.0 and self.axis_factor > 0.0):
            raise ConfigError("viewer.strength_factor/axis_factor", (self.strength_factor, self.axis_factor), "> 0")
        first = int(base_cfg.materials[0].cracks) if base_cfg.materials else 0
        for i, m in enumerate(world.cfg.materials):
            # at its starting value (the first material's count) every material keeps its scene count
            m.cracks = int(base_cfg.materials[i].cracks) if int(self.cracks) == first else int(self.cracks)
            s = float(base_cfg.materials[i].tensile_strength) * self.strength_factor
            m.tensile_strength = s
            mat = world.materials[i]  # the World turns it for each object at use (World.object_material)
            mat.tensile_strength = s
            if mat.cleavage is not None:  # its weak planes scale with it
                base = float(base_cfg.materials[i].cleavage["tensile_strength"])
                mat.cleavage = replace(mat.cleavage, tensile_strength=base * self.strength_factor)
        if getattr(world, "kernel_G", None) is None or "rigid" not in world.stages:
            return
        done = self._applied.get(id(world))
        if done is None:
            self._applied = {id(world): 1.0}  # a freshly built World has the scene's kernels
            done = 1.0
        if done != self.axis_factor:
            world.replace_particles(world.particles, kernel_tensors(world, self.axis_factor))
            self._applied[id(world)] = self.axis_factor


def kernel_tensors(world, axis_factor: float) -> np.ndarray:
    """Rest kernel tensors G (N, 3, 3) of every particle with the first kernel axis scaled by
    `axis_factor` (the World's own construction, Eq. 5 / WPCA Sect. 4.1, repeated with
    axis_scale x (axis_factor, 1, 1)); subdivided children take their parent's tensor (Sect. 5.2,
    as sim.fracture_stage.cut_body); particles added later without a parent (shot balls) keep theirs."""
    from sim.world import euler_xyz_deg
    from sph.kernel import kernel_from_axes, kernel_wpca

    ps = world.particles
    G = np.array(world.kernel_G, dtype=np.float64, copy=True)
    mult = np.array([axis_factor, 1.0, 1.0])
    for sp in world._spawn:  # the object copies as built (World._build_objects)
        o = world.cfg.objects[sp["object"]]
        sl = slice(sp["start"], sp["stop"])
        rot = euler_xyz_deg(o.rotation)
        for mid in np.unique(ps.material[sl]):
            kc = world.cfg.materials[int(mid)].kernel
            sel = np.flatnonzero(ps.material[sl] == mid) + sp["start"]
            h = kc.support * o.resolution
            scale = np.asarray(kc.axis_scale, dtype=np.float64) * mult
            if kc.mode == "wpca":
                G[sel] = kernel_wpca(ps.centroid[sel], h, k_r=kc.max_ratio, axis_scale=scale)
            else:
                axes = np.asarray(kc.axes, dtype=np.float64).reshape(3, 3).T if kc.mode == "fixed" else np.eye(3)
                G[sel] = kernel_from_axes(rot @ axes, h * scale)
    n0 = int(world.physical_count)
    for i in np.flatnonzero(ps.parent[n0:] >= 0) + n0:  # a child comes after its parent
        G[i] = G[ps.parent[i]]
    return G


# ----------------------------------------------------------------------------- shooting
def ball_radius(world) -> float:
    """m: radius of a shot ball, scaled to the scene's breakable objects."""
    ext = [float(np.max(np.asarray(b.bounds[1]) - np.asarray(b.bounds[0])))
           for b in world.bodies.values() if b.breakable and len(b.bounds) == 2]
    size = max(ext) if ext else 0.2
    lo, hi = BALL_RADIUS_RANGE_M
    return float(np.clip(BALL_RADIUS_FRACTION * size, lo, hi))


def _ball_material(world) -> int:
    """Index in world.materials of the ball's steel (appended once; not a scene material)."""
    from sph.materials import material_from_dict

    for i, m in enumerate(world.materials):
        if m.name == STEEL["name"]:
            return i
    world.materials.append(material_from_dict(dict(STEEL), key="viewer.ball"))
    return len(world.materials) - 1


def shoot_ball(world, origin, direction, speed: float, radius: float | None = None) -> int:
    """Add a steel ball centred at `origin` (m, world) moving at `speed` (m/s) along `direction`;
    returns its body id. Its particles join world.particles (material: STEEL, not breakable)."""
    from geometry.particles import concat_particles
    from rigid.bodies import add_tet_body, ball_tetmesh
    from sim.bodies import BodyInfo

    if "rigid" not in world.stages:
        raise ConfigError("viewer.shoot", world.cfg.scene.name, "a scene with the 'rigid' effect")
    d = np.asarray(direction, dtype=np.float64).reshape(3)
    if not (np.all(np.isfinite(d)) and np.linalg.norm(d) > 0.0 and math.isfinite(speed) and speed >= 0.0):
        raise ConfigError("viewer.shoot", (d.tolist(), speed), "a finite non-zero direction and speed >= 0 m/s")
    d = d / np.linalg.norm(d)
    r = ball_radius(world) if radius is None else float(radius)
    mat = _ball_material(world)
    mesh = ball_tetmesh(r, shells=BALL_SHELLS, points_outer=BALL_POINTS, center=np.asarray(origin, dtype=np.float64))
    ball = build_particles(mesh, STEEL["density"])
    ball.material[:] = mat
    n_old = len(world.particles)
    ps = concat_particles([world.particles, ball])  # a writable host copy: add_tet_body sets its bodies
    ids = np.arange(n_old, len(ps))
    edge = float(np.cbrt(6.0 * math.sqrt(2.0) * ball.volume.mean()))
    G = np.broadcast_to(np.eye(3) / (BALL_KERNEL_SUPPORT * edge), (len(ids), 3, 3))
    m = world.materials[mat]
    bid = add_tet_body(world.rigid, ps, ids, v=d * speed, restitution=m.restitution, friction=m.friction)
    world.replace_particles(ps, None if world.kernel_G is None else np.concatenate([world.kernel_G, G]))
    c = ps.centroid[ids]
    world.bodies[bid] = BodyInfo(object_index=-1, breakable=False, static=False, thickness=2.0 * r,
                                 resolution=r / BALL_SHELLS, bounds=(c.min(0), c.max(0)))
    world.surface_version += 1
    return bid


def ball_bodies(world) -> list[int]:
    """Live bodies that are shot balls."""
    if "rigid" not in world.stages:
        return []
    alive = world.rigid.body_state().alive
    return [b for b, info in world.bodies.items() if info.object_index == -1 and alive[b]]


# ----------------------------------------------------------------------------- striking
def strike(world, hit: Hit, speed: float) -> dict | None:
    """Apply a strike at the picked surface point `hit` at `speed` m/s along its inward normal (the
    API's anisofrac.strikes.strike). Returns the event record or None (no crack, or not breakable)."""
    from anisofrac.strikes import strike as api_strike

    if not breakable(world, hit.body):
        return None
    if not speed > 0.0:
        raise ConfigError("viewer.strike_speed", speed, "> 0 m/s")
    record = api_strike(world, hit.body, hit.point, -np.asarray(hit.normal, dtype=np.float64) * speed, "viewer")
    if record is not None:
        record["viewer_strike"] = True
    return record


def preview_strike(world, hit: Hit, speed: float) -> Preview | None:
    """The crack analysis of a strike at `hit` and `speed` (anisofrac.strikes.preview); None when the
    hit body is not breakable."""
    from anisofrac.strikes import preview

    if not breakable(world, hit.body):
        return None
    if not speed > 0.0:
        raise ConfigError("viewer.strike_speed", speed, "> 0 m/s")
    return preview(world, hit.body, hit.point, -np.asarray(hit.normal, dtype=np.float64) * speed, "viewer")


def event_cracks(world, record: dict) -> list:
    """World-frame crack shapes of an event record (attached to the fragment nearest each crack point):
    from its analysis (impacts, strikes) or from the scene's scripted cracks of that frame."""
    from geometry.cutting import Crack

    if "analysis" in record:
        cr = [Crack(point=np.asarray(c["point"]), normal=np.asarray(c["normal"]), r_outer=c["r_outer"],
                    side=None if c["side"] is None else np.asarray(c["side"]), r_inner=c["r_inner"])
              for c in record["analysis"].get("cracks", [])]
    elif record.get("scripted"):
        cr = [Crack(point=np.asarray(c.point, float), normal=np.asarray(c.normal, float), r_outer=c.radius,
                    side=np.asarray(c.side, float) if c.side else None, r_inner=c.r_inner)
              for c in world.cfg.cracks if c.frame == record.get("frame")]
    else:
        return []
    if not cr or "rigid" not in world.stages:
        return []
    ps = world.particles
    live = np.flatnonzero(ps.alive & (ps.body >= 0))
    if not len(live):
        return []
    frames = body_frames(world)
    out = []
    for c in cr:
        near = live[int(np.argmin(np.linalg.norm(ps.centroid[live] - np.asarray(c.point), axis=1)))]
        out += crack_shapes(frames, int(ps.body[near]), [c])
    return out


def copy_config(cfg):
    """A private deep copy of a scene config (the World and the sliders may change it)."""
    return copy.deepcopy(cfg)
