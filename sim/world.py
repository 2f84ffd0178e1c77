"""The World: builds only the stages a scene names (sim/stages.py) and runs the frame loop of DESIGN.md section 4.

It composes the packages and holds no physics itself:
- geometry (Sect. 5.1, 5.3): objects -> tets -> physical particles and links -> boundary particles;
- rigid: bodies on boundary particles, impulse contacts, contact events;
- sph (Sect. 3, 4): the `elastic` effect, and the crack analysis of Algorithm 1 at impacts;
- geometry (Sect. 5.2): cutting, adaptive subdivision, shattering, fragments.

Only the effects listed in `scene.effects` are built: a disabled effect imports no module of its
own, allocates no field and launches no kernel (`World.stages` and `World.allocations` show it).
All positions of rest data are in the reference frame (the scene at t = 0); a body maps a reference
point X to the world as `R(q) (X - body_ref_com) + body_x` (rigid/world.py).
"""

from __future__ import annotations

import math
import sys
import time

import numpy as np

from core.errors import ConfigError
from geometry.build import build_object, make_shape
from geometry.particles import ParticleSet, concat_particles, transform_particles
from scenes.config import SceneConfig
from scenes.loader import resolve_mesh_path
from sim.bodies import BodyInfo
from sim.guards import check_neighbourhoods, check_scene, check_state, check_time_step
from sim.impacts import collect_impacts, fracture_impacts
from sim.stages import FRAME, SUBSTEP, build_stages, fracture_mode
from sim.timers import StageTimers
from sph.materials import oriented

SMALL_PIECE = 0.01  # 1: pieces lighter than this fraction of their object's mass count as small


def euler_xyz_deg(angles) -> np.ndarray:
    """Rotation matrix of intrinsic X, then Y, then Z rotations (degrees)."""
    ax, ay, az = np.radians(np.asarray(angles, dtype=np.float64))
    cx, sx, cy, sy, cz, sz = math.cos(ax), math.sin(ax), math.cos(ay), math.sin(ay), math.cos(az), math.sin(az)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


class World:
    """A scene, built: particles, bodies and the stages its effects name."""

    def __init__(self, cfg: SceneConfig, seed: int | None = None, warm_events: bool = True) -> None:
        check_scene(cfg)
        if cfg.has("elastic") and cfg.has("rigid"):
            raise ConfigError(
                "scene.effects", cfg.scene.effects,
                "'elastic' without 'rigid': deformable and rigid bodies in one scene are not supported yet",
                cfg.source,
            )
        self.cfg = cfg
        self.seed = cfg.scene.seed if seed is None else seed
        self.mode = fracture_mode(cfg) if cfg.has("fracture") else None
        self.plan = build_stages(cfg.scene.effects, self.mode)  # sim.stages.Stage, in frame order
        self.stages = [st.name for st in self.plan]
        self.timers = StageTimers()
        self.allocations: dict[str, object] = {}  # Taichi-backed stores by name (for tests and release)
        self.frame = 0
        self.time = 0.0  # s
        self._time_left = 0.0  # s: time from the current substep to the end of the frame (impact records)
        self._substep_start = None  # rigid.records.BodyState at the start of the current substep
        self.dt_frame = 1.0 / cfg.scene.fps
        self.events: list[dict] = []  # one record per fracture event (stats.json)
        self.analyses: list[dict] = []  # one record per crack analysis, cracked or not
        self.last_analysis = None  # (body, sph.cracks.ImpactAnalysis) of the latest analysis
        self.debris_mass = 0.0  # kg: shattered particles taken out of the simulation (no 'debris')
        self.debris_pieces = 0  # shattered particles, moved by the 'debris' effect or taken out
        self.surface_version = 0  # increases whenever fragment surfaces change
        self.store = None  # geometry.particle_store.ParticleStore, made at the end of the build
        self._input: list = [None, None]  # the host particles and kernel tensors while building
        t0 = time.perf_counter()
        self._build_materials()
        self._build_objects()
        if cfg.has("fracture") or cfg.has("elastic"):
            self._build_kernels()
        if cfg.has("rigid"):
            self._build_rigid()
        if cfg.has("debris"):
            self._build_debris()
        if cfg.has("elastic"):
            self._build_elastic()
        from geometry.particle_store import ParticleStore

        self.initial_mass = float(self.particles.mass[self.particles.alive].sum())
        self.store = ParticleStore(*self._input)
        self._input = None
        from sim.warm_up import WarmUp

        # the kernels only contacts and events launch, and when they compile
        self.warm_up = WarmUp(self) if cfg.has("fracture") or cfg.has("rigid") else None
        if warm_events:
            self.warm_events()
        self.build_seconds = time.perf_counter() - t0
        check_time_step(self)

    def warm_events(self) -> None:
        """Compile what the first contact and fracture event would wait for, all that is left of it
        (sim/warm_up.py)."""
        if self.warm_up is not None:
            self.warm_up.run_all()

    @property
    def particles(self) -> ParticleSet:
        """The tet particles: while the World builds, the host set it builds; then a read-only copy of
        `store` (geometry.particle_store), downloaded when the store changed. An output: events and
        frames work on the store."""
        return self._input[0] if self.store is None else self.store.host()[0]

    @property
    def kernel_G(self) -> np.ndarray | None:
        """(N, 3, 3) 1/m: rest kernel tensors (Eq. 5), read-only like `particles`; None in a scene
        with neither the fracture nor the elastic effect."""
        if self.store is None:
            return self._input[1]
        return self.store.host()[1] if self.store.has_kernels else None

    def replace_particles(self, particles: ParticleSet, kernel_G: np.ndarray | None) -> None:
        """Input after the build (the viewer's shot ball, its kernel slider): the store takes these."""
        self.store.reset(particles, kernel_G)

    # ------------------------------------------------------------------ building
    def _build_materials(self) -> None:
        self.materials = [m.elastic for m in self.cfg.materials]  # validated when the scene was loaded
        self.material_index = {m.name: i for i, m in enumerate(self.cfg.materials)}

    def object_material(self, obj: int, mid: int):
        """Material mid in object obj, its axes turned with the object; at use, so the viewer's edits reach it."""
        return oriented(self.materials[mid], euler_xyz_deg(self.cfg.objects[obj].rotation))

    def _object_geometry(self, i: int):
        o = self.cfg.objects[i]
        mats = [self.material_index[o.material]]
        for region, name in sorted(o.region_materials.items()):
            if not region.isdigit():
                raise ConfigError(f"objects[{i}].region_materials.{region}", region, "a region number", self.cfg.source)
            while len(mats) <= int(region):
                mats.append(mats[0])
            mats[int(region)] = self.material_index[name]
        density = np.array([self.cfg.materials[k].density for k in mats])
        try:
            if o.mesh:
                mesh_file = resolve_mesh_path(o.mesh, self.cfg.source)
                geo = build_object(mesh_file, resolution=o.resolution, density=density, units=o.units,
                                   repair=o.repair, seed=self.seed, group_size=o.group_size, boundary=False)
                if geo.report.get("mesher_failures"):  # Netgen needed another try (geometry/tetrahedralize.py)
                    passes = geo.report["mesher_optimisation_passes"] or "default"
                    print(f"note: objects[{i}].mesh {o.mesh}: meshed at {geo.report['mesher_size_m']:.4g} m with "
                          f"{passes} optimisation passes ({'; '.join(geo.report['mesher_failures'])})", file=sys.stderr)
            else:
                params = dict(o.shape)
                kind = params.pop("type", None)
                if kind is None:
                    raise ConfigError(f"objects[{i}].shape.type", None, "a shape type", self.cfg.source)
                make_shape(kind, params, key_path=f"objects[{i}].shape")  # validates early with the key path
                geo = build_object(kind, resolution=o.resolution, density=density, seed=self.seed,
                                   group_size=o.group_size, shape_params=params, boundary=False)
        except ConfigError as exc:
            if not exc.key_path.startswith("objects"):
                exc.key_path = f"objects[{i}].{exc.key_path}"
                exc.args = (f"{self.cfg.source}: {exc.key_path} = {exc.value!r} is invalid; allowed: {exc.allowed}",)
            raise
        ps = geo.particles
        ps.material = np.asarray(mats, dtype=np.int32)[geo.mesh.tet_region]
        return geo, ps

    def _build_objects(self) -> None:
        parts: list[ParticleSet] = []
        self.object_bodies: list[list[int]] = []  # per scene object: particle-set slices of each copy
        self._spawn: list[dict] = []  # per copy: object index, particle range, velocity, ...
        start = 0
        for i, o in enumerate(self.cfg.objects):
            geo, ps = self._object_geometry(i)
            rot = euler_xyz_deg(o.rotation)
            for c in range(o.count):
                offset = np.asarray(o.position) + c * np.asarray(o.spacing)
                moved = transform_particles(ps, rot, offset)
                parts.append(moved)
                self._spawn.append(dict(object=i, start=start, stop=start + len(moved), thickness=geo.thickness))
                start += len(moved)
        self._input[0] = concat_particles(parts)
        self.particles.body[:] = -1
        for k, sp in enumerate(self._spawn):
            self.particles.body[sp["start"]:sp["stop"]] = k
        self.physical_count = len(self.particles)
        self.rest_open_faces = self.particles.links < 0  # (P, 4) bool: the surface at rest (render/session.py)
        # per scene object: one copy's mass (kg) and whether it can break (pieces by size class)
        self.object_mass: dict[int, float] = {}  # kg
        self.object_particle_volume: dict[int, float] = {}  # m^3: mean physical particle volume
        for sp in self._spawn:
            sl = slice(sp["start"], sp["stop"])
            self.object_mass.setdefault(sp["object"], float(self.particles.mass[sl].sum()))
            self.object_particle_volume.setdefault(sp["object"], float(self.particles.volume[sl].mean()))
        self.object_breakable = [bool(o.breakable) for o in self.cfg.objects]

    def _build_kernels(self) -> None:
        """Rest kernel tensor G0 of every particle (Eq. 5; WPCA when the material asks, Sect. 4.1)."""
        from sph.kernel import kernel_from_axes, kernel_wpca

        ps = self.particles
        G = np.zeros((len(ps), 3, 3))
        for sp in self._spawn:
            o = self.cfg.objects[sp["object"]]
            sl = slice(sp["start"], sp["stop"])
            for mid in np.unique(ps.material[sl]):
                kc = self.cfg.materials[mid].kernel
                sel = np.flatnonzero(ps.material[sl] == mid) + sp["start"]
                h = kc.support * o.resolution  # m: support radius
                if kc.mode == "wpca":
                    G[sel] = kernel_wpca(ps.centroid[sel], h, k_r=kc.max_ratio, axis_scale=kc.axis_scale, cache=True)
                else:
                    axes = np.asarray(kc.axes, dtype=np.float64).reshape(3, 3).T if kc.mode == "fixed" else np.eye(3)
                    rot = euler_xyz_deg(o.rotation)
                    G[sel] = kernel_from_axes(rot @ axes, h * np.asarray(kc.axis_scale))
        self._input[1] = G  # (N, 3, 3) 1/m: rest kernel tensors in the reference frame

    def _build_rigid(self) -> None:
        from geometry.chip_corners import CHIP_CORNERS
        from rigid.bodies import add_tet_body, boundary_spheres
        from rigid.world import RigidConfig, RigidWorld
        from sim.bodies import sphere_groups

        sc = self.cfg.scene
        n = len(self.particles)
        # Headroom for fracture, so the store never grows in a run (that recompiles every rigid kernel: 2 s).
        # Measured at the paper scenes' ends: spheres 0.22-0.77 x the physical particles, bodies ever made
        # up to 179 for Pots' 84k (ids are not reused); a chip's corners add CHIP_CORNERS - 1 per body at most.
        bodies = sc.body_capacity or max(64, 4 * len(self._spawn) + n // 16)
        spheres = sc.sphere_capacity or max(64, n) + (CHIP_CORNERS - 1) * bodies
        self.rigid = RigidWorld(
            capacity_bodies=bodies,
            capacity_spheres=spheres,
            capacity_contacts=sc.contact_capacity or 4 * spheres,  # pieces resting on each other touch at many spheres
            capacity_colliders=max(1, len(self.cfg.colliders)),
            config=RigidConfig(gravity=tuple(sc.gravity)),
            on_grow=self._rigid_grows,
        )
        self.allocations["rigid"] = self.rigid
        for col in self.cfg.colliders:
            if col.type == "plane":
                self.rigid.add_plane(col.point, col.normal, restitution=col.restitution, friction=col.friction)
            else:
                self.rigid.add_box_collider(col.center, 0.5 * np.asarray(col.size), restitution=col.restitution,
                                            friction=col.friction)
        self.bodies: dict[int, BodyInfo] = {}
        self.body_material: dict[int, int] = {}  # main material of every body ever made (split ones too)
        ps = self.particles
        for sp in self._spawn:
            o = self.cfg.objects[sp["object"]]
            ids = np.arange(sp["start"], sp["stop"])
            mat = self.materials[int(ps.material[ids[0]])]
            bp = boundary_spheres(ps, ids, np.zeros(len(ids), np.int64), o.group_size, cache=True)
            bid = add_tet_body(self.rigid, ps, ids, v=o.velocity, w=o.angular_velocity, static=o.static,
                               restitution=mat.restitution, friction=mat.friction, spheres=(bp.position, bp.radius))
            c = ps.centroid[ids]
            sp["body"] = bid  # (the store's rows are the build's: `ids` are the groups' store ids below)
            self.bodies[bid] = BodyInfo(sp["object"], o.breakable, o.static, sp["thickness"], o.resolution,
                                        bounds=(c.min(0), c.max(0)), spheres=sphere_groups(bp, ids, 0))
            self.body_material[bid] = int(np.bincount(ps.material[ids]).argmax())

    def _rigid_grows(self, kind: str, needed: int, capacity: int) -> None:
        """The rigid store is about to grow (its kernels compile again): say which option avoids it."""
        option = {"bodies": "scene.body_capacity", "spheres": "scene.sphere_capacity",
                  "contacts": "scene.contact_capacity"}.get(kind)
        hint = f"; set {option} >= {2 * needed} in the scene (or --set) to avoid the pause" if option else ""
        print(f"note: frame {self.frame}: {needed} rigid {kind} exceed the store's {capacity}; it grows and its "
              f"kernels compile again{hint}", file=sys.stderr)

    def _build_debris(self) -> None:
        """Free debris spheres (rigid/debris.py) that meet the scene's colliders."""
        from rigid.debris import DebrisStore

        cols = []
        for c in self.cfg.colliders:
            if c.type == "plane":
                cols.append(dict(type="plane", x=c.point, normal=c.normal, restitution=c.restitution,
                                 friction=c.friction))
            else:
                cols.append(dict(type="box", x=c.center, half=0.5 * np.asarray(c.size), restitution=c.restitution,
                                 friction=c.friction))
        self.debris = DebrisStore(len(self.particles), self.cfg.scene.gravity, cols)
        self.allocations["debris"] = self.debris

    def _build_elastic(self) -> None:
        from sph.elastic import ElasticEffect

        ps = self.particles
        fixed = np.zeros(len(ps), dtype=bool)
        obj = np.zeros(len(ps), dtype=np.int64)  # each particle's object, whose materials turn with it
        for sp in self._spawn:
            obj[sp["start"]:sp["stop"]] = sp["object"]
            box = self.cfg.objects[sp["object"]].fixed_box
            if box:
                lo, hi = np.asarray(box[:3]), np.asarray(box[3:])
                c = ps.centroid[sp["start"]:sp["stop"]]
                fixed[sp["start"]:sp["stop"]] = np.all((c >= lo) & (c <= hi), axis=1)
        nm = len(self.materials)  # elastic material id: object x materials + material
        mats = [self.object_material(k // nm, k % nm) for k in range(len(self.cfg.objects) * nm)]
        self.elastic = ElasticEffect(
            ps.centroid, ps.volume, self.kernel_G, mats, material_id=obj * nm + ps.material, fixed=fixed,
            gravity=tuple(self.cfg.scene.gravity), damping=self.cfg.scene.elastic_damping,
        )
        self.allocations["elastic"] = self.elastic
        check_neighbourhoods(self.elastic)
        self.elastic_fixed = fixed
        self.elastic_steps_per_frame = max(1, int(math.ceil(self.dt_frame / self.elastic.dt)))
        self.elastic.dt = self.dt_frame / self.elastic_steps_per_frame

    # ------------------------------------------------------------------ stepping
    def step_frame(self) -> None:
        """Advance one frame: substeps of the enabled stages, then fracture events."""
        if self.warm_up is not None:
            self.warm_up.before_frame()
        check_state(self, when="start")
        sc = self.cfg.scene
        impacts: dict[int, dict] = {}
        if self.cfg.cracks and "rigid" in self.stages:
            self._scripted_cracks()
        substep = [st for st in self.plan if st.phase == SUBSTEP]
        if substep:
            dt = self.dt_frame / sc.substeps
            free = self.warm_up is not None and self.warm_up.free_frame(dt)  # rigid/free_flight.py
            track = "fracture.events" in self.stages and not free
            for k in range(sc.substeps):
                # a fast body splits the substep (rigid.step.travel_splits): impacts are read from every part
                parts = self._travel_splits(dt)
                for part in range(parts):
                    self._time_left = (sc.substeps - k - part / parts) * dt  # s: this part's and the later ones
                    if track:  # the strikers' velocities before this part's contacts (sim/perforation.py)
                        self._substep_start = self.rigid.body_state()
                    for st in substep:
                        with self.timers.stage(st.name):
                            self._run_stage(st.name, dt / parts, impacts, free)
        for st in self.plan:
            if st.phase == FRAME:
                with self.timers.stage(st.name):
                    self._run_stage(st.name, self.dt_frame, impacts)
        if impacts:
            fracture_impacts(self, impacts)
        check_state(self)
        self.frame += 1
        self.time += self.dt_frame
        return self.timers.end_frame()

    def _travel_splits(self, dt: float) -> int:
        if "rigid" not in self.stages:
            return 1
        from rigid.step import travel_splits

        return travel_splits(self.rigid, dt)

    def _run_stage(self, name: str, dt: float, impacts: dict[int, dict], free: bool = False) -> None:
        """One substep or frame stage (sim/stages.py); fracture events run their own stages. `free`: no
        contact can be made in this frame (rigid/free_flight.py)."""
        if name == "rigid":
            self.rigid.step(dt, split=False, free=free)  # step_frame split the substep (travel_splits)
        elif name == "debris":
            self.debris.step(dt)
        elif name == "fracture.events":
            collect_impacts(self, impacts)
        elif name == "elastic":
            self.elastic.step(self.elastic_steps_per_frame)
        else:
            raise AssertionError(f"no runner for stage {name!r}")

    def _scripted_cracks(self) -> None:
        """Cracks a scene applies at a given frame, without an impact analysis (teaching scenes)."""
        from geometry.cutting import Crack
        from sim.fracture_stage import cut_body

        names = [o.name for o in self.cfg.objects]
        by_body: dict[int, list] = {}  # every crack a body gets this frame, cut in one event
        for c in self.cfg.cracks:
            if c.frame != self.frame:
                continue
            obj = names.index(c.object)
            body = next(sp["body"] for sp in self._spawn if sp["object"] == obj)
            if body in self.bodies:
                by_body.setdefault(body, []).append(
                    Crack(point=c.point, normal=c.normal, r_outer=c.radius, side=c.side or None, r_inner=c.r_inner))
        for body, cracks in by_body.items():
            record = dict(frame=self.frame, body=body, speed=0.0, scripted=True, stress_analysis_ms=0.0)
            self.events.append(cut_body(self, body, cracks, record))
            self.surface_version += 1

    # ------------------------------------------------------------------ reporting
    def pieces(self) -> dict:
        """Pieces of the breakable objects, counted as the paper's Table 1 counts fragments: every
        connected piece, including the single particles a shatter zone freed ("small fragments are
        ignored in animation", Sect. 6.2), whether the `debris` effect moves them or not. Bodies
        that cannot break (a steel ball, a floor block) are not pieces. Size classes: `debris` (one
        particle), `small` (under SMALL_PIECE of its object's mass), `large`."""
        if "rigid" not in self.stages:
            return dict(debris=0, small=0, large=len(self._spawn), total=len(self._spawn))
        alive = self.rigid.body_state().alive
        if self.mode is None:  # nothing can break: the pieces are the moving bodies
            n = int(sum(1 for b, info in self.bodies.items() if alive[b] and not info.static))
            return dict(debris=0, small=0, large=n, total=n)
        count, mass = self.store.body_totals(len(alive))  # particles and kg per body (a kernel)
        counts = dict(debris=self.debris_pieces, small=0, large=0)
        for b, info in self.bodies.items():
            if not alive[b] or not self.object_breakable[info.object_index]:
                continue
            if count[b] == 1:
                counts["debris"] += 1
            elif mass[b] < SMALL_PIECE * self.object_mass[info.object_index]:
                counts["small"] += 1
            else:
                counts["large"] += 1
        counts["total"] = counts["debris"] + counts["small"] + counts["large"]
        return counts

    def settled(self) -> bool:
        """Nothing moves any more: every dynamic body asleep and the debris slower than the rigid
        world's sleep speed (a run may stop writing frames then, sim/run.py)."""
        if "rigid" not in self.stages or self.rigid.awake_bodies():
            return False
        if "debris" in self.stages:
            return self.debris.max_speed() < self.rigid.config.sleep_linear_speed_mps
        return True

    def fragment_count(self) -> int:
        return self.pieces()["total"]

    def counts(self) -> dict:
        """The paper's Table 1 columns, and the pieces by size class."""
        ps = self.particles
        return dict(
            physical_particles=int(self.physical_count),
            subdivided_particles=int((ps.kind == 1).sum()),
            alive_particles=int(ps.alive.sum()),
            boundary_particles=int(self.rigid.n_spheres) if "rigid" in self.stages else 0,
            fragments=self.fragment_count(),
            pieces=self.pieces(),
        )

    def mass_balance(self) -> dict:
        ps = self.particles
        alive = float(ps.mass[ps.alive].sum())
        return dict(initial_kg=self.initial_mass, alive_kg=alive, debris_removed_kg=self.debris_mass,
                    error_kg=alive + self.debris_mass - self.initial_mass)

    def release(self) -> None:
        """Free every Taichi store this world allocated."""
        for store in self.allocations.values():
            store.release()
        self.allocations.clear()
        if self.store is not None:
            self.store.release()
