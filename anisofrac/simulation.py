"""`Simulation`: one built scene, driven from Python (the public API, docs/api.md).

It wraps the World (sim/world.py), which builds only the stages the scene's effects name, and adds
what a notebook or a script needs: step and run, strike a body, preview the cracks of a strike
(Algorithm 1, Sect. 4.2) without breaking anything, read bodies, pieces, particles, boundary
particles, links and the Table 1 / Table 2 statistics as numpy arrays or plain records, render the
current state to an image array and export it. `main.py run` and the viewer use the same object.

Units are SI throughout (m, kg, s, Pa, J). Positions are in the world frame unless a name says
`_ref` (the reference frame: the scene at t = 0, where rest data live).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from anisofrac import strikes
from core.errors import ConfigError

RENDER_DEFAULT = (640, 480)  # px: default image size of Simulation.render


@dataclass
class Body:
    """One rigid body of the scene (a scene object, a fragment of one, or a shot ball)."""

    id: int  # body id (index of the rigid world)
    object: str  # name of the scene object it came from ('' for a shot ball)
    material: str  # name of its main material
    mass: float  # kg
    position: np.ndarray  # (3,) m: centre of mass, world frame
    velocity: np.ndarray  # (3,) m/s
    angular_velocity: np.ndarray  # (3,) rad/s, world frame
    particles: int  # live particles (physical and subdivided)
    breakable: bool  # a strike or an impact may break it
    static: bool  # held by the scene (a window frame)
    asleep: bool


@dataclass
class Particles:
    """Particles as numpy arrays, one row per particle (the selection `Simulation.particles` made)."""

    id: np.ndarray  # (N,) int: index in the particle store
    x: np.ndarray  # (N, 3) m: world position (NaN for a shattered particle taken out of the simulation)
    x_ref: np.ndarray  # (N, 3) m: rest centroid, reference frame
    verts_ref: np.ndarray  # (N, 4, 3) m: the particle's tet (rest vertices), reference frame
    volume: np.ndarray  # (N,) m^3
    mass: np.ndarray  # (N,) kg
    radius: np.ndarray  # (N,) m: radius of the sphere of the particle's volume
    body: np.ndarray  # (N,) int: rigid body, -1 for a shattered (debris) particle
    material: np.ndarray  # (N,) int: index into the scene's materials
    kind: np.ndarray  # (N,) int: 0 physical (an input tet), 1 subdivided (a child, Sect. 5.2)
    parent: np.ndarray  # (N,) int: parent particle of a subdivided child, -1 for a physical one
    kernel: np.ndarray | None  # (N, 3, 3) 1/m: rest kernel tensor G (Eq. 5), None without kernels

    def __len__(self) -> int:
        return len(self.id)


PARTICLE_KINDS = ("all", "physical", "subdivided")


def _check_int(key: str, value, lo: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lo:
        raise ConfigError(key, value, f"an integer >= {lo}")
    return int(value)


class Simulation:
    """A scene, built and ready to step. Make one with `anisofrac.load(scene, overrides)`.

    `with anisofrac.load("pot") as sim: ...` frees its Taichi fields at the end (or call `close()`)."""

    def __init__(self, config, seed: int | None = None, warm_events: bool = True) -> None:
        """warm_events=False: the kernels only contacts and fracture events launch compile at the first
        frame instead of here (sim/warm_up.py; `main.py run` has them compile while it waits for drawn
        frames)."""
        from core.runtime import ensure_runtime
        from sim.world import World

        ensure_runtime()
        self.config = config  # scenes.config.SceneConfig: the validated scene (read it, do not change it)
        self.world = World(config, seed, warm_events)
        self._views: dict = {}

    # ------------------------------------------------------------------ time
    @property
    def name(self) -> str:
        return self.config.scene.name

    @property
    def frame(self) -> int:
        """Frames stepped so far."""
        return self.world.frame

    @property
    def time(self) -> float:
        """s: simulated time."""
        return self.world.time

    @property
    def dt(self) -> float:
        """s: length of one frame (1 / scene.fps)."""
        return self.world.dt_frame

    def step(self, frames: int = 1) -> None:
        """Advance `frames` frames (each: the rigid substeps, the elastic steps, then the fracture
        events of the impacts it saw)."""
        for _ in range(_check_int("step.frames", frames, 1)):
            self.world.step_frame()

    def run(self, frames: int | None = None, until_settled: bool = True, progress: bool = False) -> int:
        """Step up to `frames` frames (default: the scene's `frames`), stopping early once nothing has
        moved for 1 s when `until_settled`. Returns the frames stepped."""
        from sim.run import SettleClock

        n = self.config.scene.frames if frames is None else _check_int("run.frames", frames, 1)
        clock = SettleClock(self.config.scene.fps)
        bar = None
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=n, desc=self.name, unit="frame")
        done = 0
        try:
            for _ in range(n):
                self.world.step_frame()
                done += 1
                if bar is not None:
                    bar.update(1)
                if until_settled and clock.tick(self.world):
                    break
        finally:
            if bar is not None:
                bar.close()
        return done

    def settled(self) -> bool:
        """True when every body is asleep and the debris at rest."""
        return self.world.settled()

    # ------------------------------------------------------------------ striking
    def body_of(self, name: str) -> int:
        """Body id of the scene object `name` (its heaviest live piece once it broke)."""
        names = [o.name for o in self.config.objects]
        if name not in names:
            raise ConfigError("body_of.name", name, ", ".join(names))
        obj = names.index(name)
        mine = [b for b in self.bodies() if b.object == name]
        if not mine:
            raise ConfigError("body_of.name", name, f"an object with a live body (objects[{obj}] has none)")
        return max(mine, key=lambda b: b.mass).id

    def _body(self, body: int | str, key: str) -> int:
        if isinstance(body, str):
            return self.body_of(body)
        return _check_int(f"{key}.body", body, 0)

    def strike(self, body: int | str, point, velocity) -> dict | None:
        """Strike `body` (id or scene object name) at `point` (m, world; a point on its surface) with a
        rigid anvil moving at `velocity` (m/s, world; into the body): Algorithm 1 analyses the blow, and
        when a group fires the body is cut, its shatter zone freed and its pieces split off, at once.
        Returns the event record (the same as an impact's in stats.json) or None when nothing broke."""
        return strikes.strike(self.world, self._body(body, "strike"), point, velocity)

    def preview(self, body: int | str, point, velocity) -> strikes.Preview:
        """What `strike(body, point, velocity)` would do, without doing it: the analysed particles and
        their groups, each group's stresses and energy, the crack discs (world frame), the shatter
        radius and the speed at which the first group would fire (anisofrac.strikes.Preview)."""
        return strikes.preview(self.world, self._body(body, "preview"), point, velocity)

    def surface_point(self, body: int | str, direction) -> np.ndarray:
        """m: the point of `body`'s surface first met by a ray from far away along `direction` (world)
        through its centre of mass: where to aim a strike that moves along `direction`."""
        from render.pick import ray_cast

        b = self._body(body, "surface_point")
        d = np.asarray(direction, dtype=np.float64).reshape(-1)
        if d.shape != (3,) or not np.all(np.isfinite(d)) or not np.linalg.norm(d) > 0.0:
            raise ConfigError("surface_point.direction", np.asarray(direction).tolist(), "a finite non-zero 3-vector")
        d = d / np.linalg.norm(d)
        verts, faces, label = self.fragment_mesh()
        tris = verts[faces[label[faces[:, 0]] == b]]
        com = self.world.rigid.body_state().x[b].astype(np.float64)
        size = float(np.ptp(verts, axis=0).max()) if len(verts) else 1.0
        hit = ray_cast(com - 2.0 * size * d, d, tris)
        if hit is None:
            raise ConfigError("surface_point.body", body, "a body with a surface on the ray")
        return hit.point

    # ------------------------------------------------------------------ reading
    def bodies(self) -> list[Body]:
        """Every live rigid body (empty for a scene without the `rigid` effect)."""
        w = self.world
        if "rigid" not in w.stages:
            return []
        st = w.rigid.body_state()
        ps = w.particles
        live = ps.alive & (ps.body >= 0)
        count = np.bincount(ps.body[live], minlength=len(st.alive))
        out = []
        for b in np.flatnonzero(st.alive):
            info = w.bodies.get(int(b))
            obj = self.config.objects[info.object_index].name if info and info.object_index >= 0 else ""
            mat = w.body_material.get(int(b), -1)
            mat_name = self.config.materials[mat].name if 0 <= mat < len(self.config.materials) else ""
            out.append(Body(id=int(b), object=obj, material=mat_name, mass=w.rigid.body_mass(int(b)),
                            position=st.x[b].astype(np.float64), velocity=st.v[b].astype(np.float64),
                            angular_velocity=st.w[b].astype(np.float64), particles=int(count[b]),
                            breakable=bool(info is not None and info.breakable), static=bool(w.rigid.body_is_static(b)),
                            asleep=bool(st.asleep[b])))
        return out

    def pieces(self) -> dict:
        """The pieces of the breakable objects as the paper's Table 1 counts them: `debris` (single
        shattered particles), `small` (< 1% of the object's mass), `large`, and `total`."""
        return self.world.pieces()

    def particles(self, kind: str = "all", include_replaced: bool = False) -> Particles:
        """The particles of the scene: `kind` 'all', 'physical' (made from the input tets) or
        'subdivided' (children of adaptive subdivision, Sect. 5.2). A particle replaced by its
        children is left out unless `include_replaced`."""
        if kind not in PARTICLE_KINDS:
            raise ConfigError("particles.kind", kind, ", ".join(PARTICLE_KINDS))
        from sim.export_frames import particle_positions

        ps = self.world.particles
        sel = np.ones(len(ps), dtype=bool) if include_replaced else ps.alive.copy()
        if kind != "all":
            sel &= ps.kind == (0 if kind == "physical" else 1)
        ids = np.flatnonzero(sel)
        G = getattr(self.world, "kernel_G", None)
        return Particles(id=ids, x=particle_positions(self.world, ids), x_ref=ps.centroid[ids].copy(),
                         verts_ref=ps.rest_verts[ids].copy(),
                         volume=ps.volume[ids].copy(), mass=ps.mass[ids].copy(), radius=ps.radius[ids].copy(),
                         body=ps.body[ids].astype(np.int64), material=ps.material[ids].astype(np.int64),
                         kind=ps.kind[ids].astype(np.int64), parent=ps.parent[ids].copy(),
                         kernel=None if G is None else G[ids].copy())

    def boundary_particles(self) -> dict:
        """The collision spheres of the rigid bodies (Sect. 5.3): `x` (S, 3) m world, `radius` (S,) m,
        `body` (S,). Empty without the `rigid` effect."""
        w = self.world
        if "rigid" not in w.stages:
            return dict(x=np.zeros((0, 3)), radius=np.zeros(0), body=np.zeros(0, dtype=np.int64))
        _, radius, body = w.rigid.sphere_data()
        return dict(x=w.rigid.sphere_world(), radius=radius.astype(np.float64), body=body.astype(np.int64))

    def links(self) -> np.ndarray:
        """(L, 2) int: the links between live particles (across shared tet faces, and the extra links
        of adaptive subdivision, Fig. 5), each once with i < j. Fragments are their connected parts."""
        ps = self.world.particles
        i = np.repeat(np.arange(len(ps)), 4)
        j = ps.links.reshape(-1)
        pairs = np.concatenate([np.stack([i, j], 1)[j >= 0], ps.extra_links.reshape(-1, 2)])
        pairs = pairs[ps.alive[pairs[:, 0]] & ps.alive[pairs[:, 1]]]
        return np.unique(np.sort(pairs, axis=1), axis=0).astype(np.int64)

    def debris(self) -> dict:
        """Shattered particles moved by the `debris` effect: `x` (D, 3) m, `v` (D, 3) m/s, `radius`
        (D,) m, `particle` (D,) index in the particle store. Empty without the effect."""
        if "debris" not in self.world.stages:
            return dict(x=np.zeros((0, 3)), v=np.zeros((0, 3)), radius=np.zeros(0), particle=np.zeros(0, np.int64))
        st = self.world.debris.state()
        return dict(x=st["x"], v=st["v"], radius=st["r"], particle=st["particle"].astype(np.int64))

    def events(self) -> list[dict]:
        """One record per fracture event so far (the `events` of stats.json: frame, body, speed, the
        analysis with its groups and cracks, fragments, debris, and Table 2's times in ms)."""
        return list(self.world.events)

    def stats(self) -> dict:
        """stats.json as a run would write it now: `table1` (particle counts, fragments, pieces),
        `events`, `mass` (the balance, kg) and `timings` (Table 2 per event, stage totals)."""
        from sim.run import collect_stats

        return collect_stats(self.world, wall_seconds=0.0, frames_done=self.frame)

    def fragment_mesh(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Closed fragment surfaces at the current poses: vertices (V, 3) m, triangles (F, 3), body of
        each vertex (V,)."""
        if "rigid" not in self.world.stages:
            raise ConfigError("fragment_mesh", self.name, "a scene with the 'rigid' effect")
        from sim.export_frames import fragment_mesh

        return fragment_mesh(self.world)

    # ------------------------------------------------------------------ pictures and files
    def render(self, width: int = RENDER_DEFAULT[0], height: int = RENDER_DEFAULT[1], camera=None,
               renderer: str = "raster", colors: str = "material", crack_lines: bool = True) -> np.ndarray:
        """The current state as an image array (height, width, 3) uint8. `camera`: None for the
        scene's camera (following the bodies when the scene asks), or a dict(eye, target[, fov]) /
        render.camera.Camera for a fixed view. `renderer`: 'raster' (no GPU needed) or 'ggui'.
        `crack_lines`: draw the lines where cracks meet the surface (render/crack_lines.py)."""
        from render.camera import Camera
        from render.session import HeadlessSession

        key = (renderer, int(width), int(height), colors, bool(crack_lines))
        session = self._views.get(key)
        if session is None:
            session = HeadlessSession(self.world, renderer, int(width), int(height), colors=colors,
                                      crack_lines=bool(crack_lines))
            self._views[key] = session
        if camera is None:
            img = session.draw()
        else:
            if isinstance(camera, dict):
                extra = set(camera) - {"eye", "target", "fov"}
                if extra or "eye" not in camera or "target" not in camera:
                    raise ConfigError("render.camera", camera, "dict(eye=[x, y, z], target=[x, y, z], fov=deg)")
                camera = Camera(eye=camera["eye"], target=camera["target"], fov_deg=float(camera.get("fov", 45.0)))
            session.view.refresh()
            img = session.renderer.render(session.view.scene, camera)
        return np.asarray(img)

    def export(self, path: str | Path) -> Path:
        """Write the current state to `path`; the suffix chooses: .obj / .ply (fragment surfaces at
        their poses), .vtu (the particles with body, kind, mass, volume; ParaView), .png (render()).
        Written to a temporary name and renamed."""
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in (".obj", ".ply", ".vtu", ".png"):
            raise ConfigError("export.path", str(path), "a file name ending in .obj, .ply, .vtu or .png")
        if not path.parent.is_dir():
            raise ConfigError("export.path", str(path), "a file in an existing folder")
        if suffix == ".vtu":
            from sim.export_frames import write_particles_vtu

            return write_particles_vtu(self.world, path)
        if suffix == ".png":
            from render.writers import write_png

            return write_png(path, self.render())
        from geometry.export import write_mesh

        verts, faces, _ = self.fragment_mesh()
        return write_mesh(path, verts, faces)

    def run_headless(self, opts, start=None) -> dict:
        """`main.py run`: frames, video and stats.json into opts.out (sim.run.RunOptions); the
        simulation runs on from where it is. `start`: sim.run.start_run's, made before this
        Simulation was built (the drawing process then starts while the World builds)."""
        from sim.run import run

        return run(self.config, opts, world=self.world, start=start)

    def close(self) -> None:
        """Free the Taichi fields of the renderers and of the World."""
        for session in self._views.values():
            session.close()
        self._views.clear()
        self.world.release()

    def __enter__(self) -> Simulation:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        return (f"Simulation({self.name!r}, frame={self.frame}, effects={self.config.scene.effects}, "
                f"particles={int(self.world.particles.alive.sum())})")
