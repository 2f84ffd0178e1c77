"""Command line of the fracture sandbox (DESIGN.md section 7): thin: parse, build, hand over.

    python main.py                      run the default scene headless (out/pot/)
    python main.py run SCENE [options]  run a scene headless: frames, video, stats.json
    python main.py view SCENE           interactive window
    python main.py scenes               list the scenes and their effects
    python main.py check OBJECT|MESH    validate and print particle/tet statistics (Table 1)
    python main.py bench [--quick]      accuracy-vs-cost report in docs/report/
    python main.py sweep SCENE --grid KEY=V1,V2,...   parameter sweep on Dask (docs/sweeps.md)
"""

from __future__ import annotations

import argparse
import json
import sys

from core.errors import SandboxError

DEFAULT_OBJECT = "pot"
DEFAULT_SCENE = "pot"


def _check_threads(args: argparse.Namespace) -> None:
    """--threads within 1..cores, checked before anything imports Taichi (a refusal costs no start-up)."""
    from core.errors import ConfigError
    from core.host_threads import host_cores

    cores = host_cores()
    if not 1 <= args.threads <= cores:
        raise ConfigError("--threads", args.threads, f"an integer from 1 to {cores} (this machine's cores)")


def _init(args: argparse.Namespace) -> None:
    """Start Taichi (main() has checked --threads before anything imported it)."""
    from core.runtime import init_taichi

    info = init_taichi(arch=args.arch, precision=args.precision, threads=args.threads)
    print(f"taichi: arch={info.arch} precision={info.precision} device={info.device}", file=sys.stderr)


def _cmd_run(args: argparse.Namespace) -> int:
    if args.frames is not None and args.frames < 1:
        from core.errors import ConfigError

        raise ConfigError("--frames", args.frames, "an integer >= 1")
    from render.draw_process import DrawingProcess, draws_apart

    # started first thing (its imports and Taichi overlap this process's), told what to draw later
    drawing = DrawingProcess() if draws_apart(args.renderer, not args.draw_here) else None
    try:
        return _run(args, drawing)
    except BaseException:
        if drawing is not None:
            drawing.abandon()  # a second call, after the run's own, does nothing
        raise


def _run(args: argparse.Namespace, drawing) -> int:
    from pathlib import Path

    import anisofrac as af
    from sim.run import RunOptions, start_run

    overrides = list(args.set or [])
    if args.seed is not None:
        overrides.append(f"scene.seed={args.seed}")
    cfg = af.load_config(args.scene, overrides)  # validated before anything is built or written
    exports = tuple(dict.fromkeys(args.export or []))
    if exports and "rigid" not in cfg.scene.effects:
        from core.errors import ConfigError

        raise ConfigError("--export", ",".join(exports), f"a scene with the 'rigid' effect ({cfg.scene.name} has "
                          f"{', '.join(cfg.scene.effects)})")
    _init(args)
    from core.heap import freeze_long_lived

    if args.owns_process:
        freeze_long_lived()  # the imports' objects: no collection walks them again (core/heap.py)
    out = Path(args.out) if args.out else Path("out") / cfg.scene.name
    opts = RunOptions(out=out, frames=args.frames, renderer=args.renderer, video=args.video, width=args.width,
                      height=args.height, overwrite=args.overwrite, meshes=args.meshes, vtu=args.vtu,
                      progress=not args.no_progress, until_settled=not args.all_frames,
                      colors=args.colors, crack_lines=not args.no_crack_lines, export=exports,
                      draw_process=not args.draw_here)
    start = start_run(cfg, opts, drawing)  # the output folder; the drawing process starts its renderer
    try:
        sim = af.Simulation(cfg, warm_events=False)  # the Python API (docs/api.md); event kernels: sim/warm_up.py
    except BaseException:
        start.abandon()
        raise
    if args.owns_process:
        freeze_long_lived()  # and the build's
    with sim:
        stats = sim.run_headless(opts, start)
    t1 = stats["table1"]
    print(f"{cfg.scene.name}: {stats['frames']} frames, {t1['fragments']} fragments, "
          f"{len(stats['events'])} fracture events, {stats['timings']['average_fps']} frames/s -> {out}"
          + (f" ({stats['stopped']})" if stats.get("stopped") else ""))
    return 0


def _cmd_scenes(args: argparse.Namespace) -> int:
    from scenes.loader import load_scene, scene_names

    for name in scene_names():
        cfg = load_scene(name)
        print(f"{name:16s} [{', '.join(cfg.scene.effects)}]")
        print(f"{'':16s} {cfg.scene.description}")
    return 0


def _cmd_view(args: argparse.Namespace) -> int:
    import anisofrac as af

    cfg = af.load_config(args.scene, list(args.set or []))
    _init(args)
    from viewer.app import run_viewer

    return run_viewer(cfg, args)


def _cmd_bench(args: argparse.Namespace) -> int:
    from core.errors import ConfigError

    if args.frames is not None and args.frames < 1:
        raise ConfigError("--frames", args.frames, "an integer >= 1")
    if args.scenes:
        from bench.bench_scenes import main as scenes_main

        return scenes_main((["--only", args.only] if args.only else []) + (["--readme"] if args.readme else [])
                           + (["--frames", str(args.frames)] if args.frames else [])
                           + (["--arch", args.arch] if args.arch else []))
    if args.only or args.readme or args.frames:
        raise ConfigError("bench", "--only/--readme/--frames", "options of `bench --scenes`")
    from bench.report import main as bench_main

    return bench_main((["--quick"] if args.quick else []) + (["--arch", args.arch] if args.arch else []))


def _cmd_sweep(args: argparse.Namespace) -> int:
    from pathlib import Path

    from anisofrac.sweep import SweepSpec, make_security, run_sweep

    spec = SweepSpec(scene=args.scene, grids=list(args.grid or []), frames=args.frames,
                     out=Path(args.out) if args.out else None, fixed=list(args.set or []),
                     scheduler=args.scheduler, workers=args.workers, overwrite=args.overwrite,
                     dataset=args.dataset, progress=not args.no_progress,
                     security=make_security(args.tls_ca, args.tls_cert, args.tls_key),
                     command=" ".join(["main.py"] + sys.argv[1:]) if sys.argv[1:2] == ["sweep"] else "")
    r = run_sweep(spec)
    print(f"sweep: {r.points} points, {r.computed} run now, {r.skipped} already done; "
          f"{r.ok} ok, {r.failed} failed -> {r.out}")
    return 0 if r.failed == 0 else 1


def _cmd_figures(args: argparse.Namespace) -> int:
    from pathlib import Path

    from core.errors import ConfigError
    from sim.figures import FIGURES, make_sheet

    numbers = [f.number for f in FIGURES]
    only = None
    if args.only:
        try:
            only = [int(x) for x in args.only.split(",")]
        except ValueError:
            only = [-1]
        if not set(only) <= set(numbers):
            raise ConfigError("--only", args.only, "figure numbers from " + ", ".join(map(str, numbers)))
    _init(args)
    out = make_sheet(Path(args.out), only, args.frames, progress=not args.no_progress)
    print(f"figures -> {out}")
    return 0


def _cmd_check(args: argparse.Namespace) -> int:
    import contextlib

    # with --json, stdout carries the report only: libraries' banners (Taichi's) go to stderr
    with contextlib.redirect_stdout(sys.stderr if args.json else sys.stdout):
        from geometry.build import build_object

        geo = build_object(
            args.object,
            resolution=args.resolution,
            density=args.density,
            units=args.units,
            repair=args.repair,
            seed=args.seed,
            group_size=args.group_size,
        )
    r = geo.report
    if args.json:
        print(json.dumps(r, indent=2))
        return 0
    print(f"object: {args.object}")
    for line in r.get("repairs", []):
        print(f"  repaired: {line}")
    print("Table 1 (paper) counts")
    print(f"  physical particles   {r['physical_particles']:>10,}")
    print(f"  surface particles    {r['surface_particles']:>10,}")
    print(f"  boundary particles   {r['boundary_particles']:>10,}   (group size n = {r['boundary_group_size']})")
    print(f"  links                {r['links']:>10,}")
    from geometry.tetrahedralize import QUALITY_BOUNDS

    print(f"tet quality ({r.get('mesher', 'tet mesh file')}; bounds: dihedral >= "
          f"{QUALITY_BOUNDS['min_dihedral_deg']:g} deg, radius ratio >= {QUALITY_BOUNDS['worst_radius_ratio']:g}, "
          f"|volume error| <= {QUALITY_BOUNDS['volume_error']:g})")
    for failure in r.get("mesher_failures", []):
        print(f"  not meshed at        {failure}")
    if r.get("mesher_failures"):
        passes = r["mesher_optimisation_passes"] or "default"
        print(f"  meshed at            {r['mesher_size_m']:.4g} m, {passes} optimisation passes "
              f"(resolution {r['resolution_m']:.4g} m)")
    print(f"  tets / vertices      {r['tets']:>10,} / {r['vertices']:,}")
    print(f"  volume               {r['volume_m3']:.6g} m^3   mass {r['mass_kg']:.6g} kg")
    print(f"  tet volume min/max   {r['min_tet_volume_m3']:.3g} / {r['max_tet_volume_m3']:.3g} m^3")
    print(f"  radius ratio worst   {r['worst_radius_ratio']:.3f} (mean {r['mean_radius_ratio']:.3f}; 1 = regular)")
    print(f"  dihedral min/max     {r['min_dihedral_deg']:.1f} / {r['max_dihedral_deg']:.1f} deg")
    if "volume_error" in r:
        print(f"  volume error         {r['volume_error']:+.3%} against the solid ({r['reference_volume_m3']:.6g} m^3)")
    if "slivers_removed" in r:
        print(f"  surface slivers removed {r['slivers_removed']}")
    print(f"  thickness B          {r['thickness_m']:.4g} m")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="main.py", description="Brittle fracture sandbox (Li, Wang & Qin 2015)")
    sub = p.add_subparsers(dest="command")
    c = sub.add_parser("check", help="validate an object or mesh and print particle/tet statistics")
    c.add_argument("object", nargs="?", default=DEFAULT_OBJECT, help="named shape or mesh file (default: pot)")
    c.add_argument("--resolution", type=float, default=None, help="target tet size in m")
    c.add_argument("--units", default=None, help="length unit of a mesh file: m, cm, mm, in, ...")
    c.add_argument("--density", type=float, default=2400.0, help="kg/m^3 (default 2400)")
    c.add_argument("--repair", action="store_true", help="repair fixable mesh problems and report them")
    c.add_argument("--seed", type=int, default=0)
    c.add_argument("--group-size", type=int, default=4, help="surface particles per boundary particle")
    c.add_argument("--json", action="store_true", help="print the report as JSON")
    c.set_defaults(func=_cmd_check)

    def runtime_options(q: argparse.ArgumentParser) -> None:
        q.add_argument("--arch", default="cpu", choices=["cpu", "cuda", "auto"], help="Taichi backend (default cpu)")
        q.add_argument("--precision", default="f32", choices=["f32", "f64"], help="floating point (default f32)")
        q.add_argument("--threads", type=int, default=1,
                       help="CPU threads, 1 to the machine's cores (default 1: bitwise reproducible)")
        q.add_argument("--set", action="append", metavar="KEY.PATH=VALUE",
                       help="override a scene value, validated like the file (repeatable)")

    r = sub.add_parser("run", help="run a scene headless and write frames, video and stats.json")
    r.add_argument("scene", nargs="?", default=DEFAULT_SCENE, help="scene name or .toml file (default: pot)")
    r.add_argument("--frames", type=int, default=None, help="frames to run (default: the scene's)")
    r.add_argument("--out", default=None, help="output folder (default: out/<scene>)")
    r.add_argument("--overwrite", action="store_true", help="replace the files of an existing output folder")
    r.add_argument("--renderer", default="auto", choices=["ggui", "raster", "auto", "none"])
    r.add_argument("--video", default="mp4", choices=["mp4", "gif", "none"])
    r.add_argument("--width", type=int, default=640)
    r.add_argument("--height", type=int, default=480)
    r.add_argument("--seed", type=int, default=None, help="override scene.seed")
    r.add_argument("--meshes", default="none", choices=["none", "obj", "ply"], help="fragment meshes every frame")
    r.add_argument("--vtu", action="store_true", help="write a VTU series of the particles (ParaView)")
    r.add_argument("--export", action="append", choices=["glb", "usd"],
                   help="the whole run as one animated file: animation.glb (glTF 2.0) or animation.usd; repeatable")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    r.add_argument("--colors", default="material", choices=["material", "fragments"],
                   help="faces in their material's look (crack faces shaded), or one colour per fragment")
    r.add_argument("--no-crack-lines", action="store_true",
                   help="do not draw the lines where cracks meet the surface (pieces that stay together)")
    r.add_argument("--all-frames", action="store_true",
                   help="run every frame (default: stop once every piece has rested for 1 s)")
    r.add_argument("--draw-here", action="store_true",
                   help="draw the frames in this process (default: a second process draws them while the next "
                        "frame steps, where there are two cores)")
    runtime_options(r)
    r.set_defaults(func=_cmd_run)

    v = sub.add_parser("view", help="interactive window")
    v.add_argument("scene", nargs="?", default=DEFAULT_SCENE)
    v.add_argument("--width", type=int, default=1280)
    v.add_argument("--height", type=int, default=800)
    v.add_argument("--frames", type=int, default=0, help="stop after N frames (0 = until closed)")
    v.add_argument("--script", default=None, help="scripted actions (tests): strike@F,toggle@F:NAME,shot@F:PATH")
    runtime_options(v)
    v.set_defaults(func=_cmd_view)

    s = sub.add_parser("scenes", help="list the scenes and their effects")
    s.set_defaults(func=_cmd_scenes)

    fg = sub.add_parser("figures", help="render the paper's Figs. 7-12 with our scenes into docs/figures.md")
    fg.add_argument("--out", default="docs/figures.md", help="Markdown file (images go to figures/ beside it)")
    fg.add_argument("--only", default=None, help="comma-separated figure numbers (default: 7 to 12)")
    fg.add_argument("--frames", type=int, default=None, help="frames per scene (default: each scene's)")
    fg.add_argument("--no-progress", action="store_true", help="no progress bars")
    runtime_options(fg)
    fg.set_defaults(func=_cmd_figures)

    w = sub.add_parser("sweep", help="run a scene over a grid of --set values on Dask; writes runs.parquet")
    w.add_argument("scene", help="scene name or .toml file")
    w.add_argument("--grid", action="append", metavar="KEY.PATH=V1,V2,...",
                   help="values of one key path (TOML; commas inside [] {} or quotes stay); repeatable: the product")
    w.add_argument("--set", action="append", metavar="KEY.PATH=VALUE", help="a value every run shares (repeatable)")
    w.add_argument("--frames", type=int, default=None, help="frames per run (default: the scene's test_frames, "
                   "else its frames); every frame runs")
    w.add_argument("--out", default=None, help="output folder (default: out/sweep_<scene>); rerun to resume")
    w.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="a running dask scheduler, e.g. tcp://HOST:8786 (default: a local cluster on 127.0.0.1)")
    w.add_argument("--workers", type=int, default=None, help="local cluster worker processes (default: CPU count)")
    w.add_argument("--overwrite", action="store_true", help="forget the rows of an earlier sweep in --out")
    w.add_argument("--dataset", action="store_true", help="per run: fragments.ply, cracks.json, params.json")
    w.add_argument("--no-progress", action="store_true", help="no progress bar")
    w.add_argument("--tls-ca", default=None, help="CA certificate (PEM) of a TLS scheduler")
    w.add_argument("--tls-cert", default=None, help="client certificate (PEM) for a TLS scheduler")
    w.add_argument("--tls-key", default=None, help="client private key (PEM) for a TLS scheduler")
    w.set_defaults(func=_cmd_sweep)

    b = sub.add_parser("bench", help="the accuracy-vs-cost study (docs/report/), or --scenes: the paper's scenes "
                       "as run by default, beside Table 2")
    b.add_argument("--quick", action="store_true", help="a reduced study (minutes)")
    b.add_argument("--scenes", action="store_true", help="time every paper scene as `main.py run` runs it")
    b.add_argument("--only", default=None, help="with --scenes: comma-separated scenes")
    b.add_argument("--frames", type=int, default=None, help="with --scenes: frames per run")
    b.add_argument("--readme", action="store_true", help="with --scenes: write the table into README.md")
    b.add_argument("--arch", default=None, choices=["cpu", "cuda", "auto"],
                   help="backend: with --scenes cpu (default) or cuda; the study adds CUDA rows by default (auto) "
                   "when a device is present")
    b.set_defaults(func=_cmd_bench)
    return p


def main(argv: list[str] | None = None, owns_process: bool = False) -> int:
    """The command line; `owns_process`: main.py runs as the program, so whole-process settings are its
    to make (core/heap.py), not those of a caller that imported it (a test, a notebook)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        args = parser.parse_args(["run", DEFAULT_SCENE])
    args.owns_process = owns_process
    try:
        if hasattr(args, "threads"):
            _check_threads(args)
        return args.func(args)
    except SandboxError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into a command that stopped reading (head)
        return 0


if __name__ == "__main__":
    sys.exit(main(owns_process=True))
