"""The accuracy-vs-cost report (DESIGN.md promise 1): `python main.py bench [--quick]`.

    .venv/bin/python main.py bench                # full study, writes docs/report/ (about 20-40 min on 2 cores)
    .venv/bin/python -m bench.report --quick --out /tmp/report   # reduced study (~3 min)

Runs every sweep (`bench/study_*.py`) in its own process, because Taichi's precision and arch are
fixed per process (core.runtime.init_taichi) and each scene is best measured in a fresh runtime:
  1 fracture surfaces   (study_fracture)   resolution x {basic, adaptive subdivision, uniformly fine}
  2 SPH gradient        (study_gradient)   correction order x kernel x neighbour count
  3 cantilever beam     (study_beam)       resolution x gradient order; SPlisHSPlasH where importable
  4 boundary sampling   (study_sampling)   n = 1, 4, 8
  5 precision           (study_precision)  f32 / f64 (one process each) x substeps
  6 paper scenarios     (study_scenes)     one process per scene; on CUDA too when a device exists
  7 crack pattern       (study_pattern)    cobweb, SPH vs exact normals, rod vs beam theory, sweeps, auto N
then writes README.md (machine, versions, the command, tables, plots, readings) and results.json
(the raw numbers) into --out. Returns 0 when every sweep ran, 1 otherwise (the report is written
anyway, naming what failed).
"""

from __future__ import annotations

import argparse
import datetime
import importlib
import json
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

DEFAULT_OUT = ROOT / "docs" / "report"

# (id, module, title, runs: list of extra argument lists, one process each)
STUDIES = [
    ("fracture", "bench.study_fracture", "Fracture surface: basic, subdivision, uniformly fine", [[]]),
    ("gradient", "bench.study_gradient", "SPH gradient: correction, kernels, neighbours", [[]]),
    ("beam", "bench.study_beam", "Elastic cantilever: resolution", [["--precision", "f32"]]),
    ("sampling", "bench.study_sampling", "Boundary sampling size n", [["--precision", "f32"]]),
    ("precision", "bench.study_precision", "Precision and substeps", [["--precision", "f32"], ["--precision", "f64"]]),
    ("scenes", "bench.study_scenes", "Paper scenarios (Tables 1 and 2)", None),  # runs: one per scene
    ("pattern", "bench.study_pattern", "Crack pattern: known answers", [[]]),
]


def _versions() -> dict:
    out = dict(python=platform.python_version(), platform=platform.platform())
    for mod in ("taichi", "numpy", "scipy", "matplotlib"):
        try:
            m = importlib.import_module(mod)
            v = m.__version__
            out[mod] = ".".join(map(str, v)) if isinstance(v, (tuple, list)) else str(v)
        except Exception:  # pragma: no cover - reported, not fatal
            out[mod] = "unavailable"
    return out


def _git() -> str:
    """Commit of the working tree (read-only git commands), with '+ local changes' when dirty."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                              timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "main.py", "bench", "geometry", "rigid", "sim",
                                "sph", "scenes", "render"], cwd=ROOT, capture_output=True, text=True,
                               timeout=10).stdout.strip()
        return (head or "unknown") + (" + local changes" if dirty else "")
    except Exception:
        return "unknown"


def _run_sweep(module: str, extra: list[str], quick: bool, tmp: Path, tag: str) -> tuple[dict | None, str]:
    """Run one sweep process; returns (result, error message)."""
    path = tmp / f"{tag}.json"
    cmd = [sys.executable, "-m", module, "--json", str(path)] + (["--quick"] if quick else []) + extra
    print(f"[bench] {' '.join(cmd[1:])}", flush=True)
    t0 = time.perf_counter()
    lines = []
    with subprocess.Popen(cmd, cwd=ROOT, text=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT) as proc:
        for ln in proc.stdout:  # progress as it comes
            ln = ln.rstrip()
            if ln.strip() and not ln.startswith("[Taichi]"):
                lines.append(ln)
                print(f"    {ln}", flush=True)
    dt = time.perf_counter() - t0
    if proc.returncode != 0 or not path.exists():
        return None, f"exit code {proc.returncode}: " + " / ".join(lines[-3:])
    res = json.loads(path.read_text())
    res["process_s"] = dt
    return res, ""


def _scene_runs(quick: bool, arch: str) -> tuple[list[list[str]], str]:
    """Argument lists of the scene processes (CPU always; CUDA too when a device is there)."""
    from bench.study_scenes import QUICK_SCENES, SCENES
    from core.runtime import cuda_available

    names = list(QUICK_SCENES) if quick else [s[0] for s in SCENES]
    archs = ["cpu"]
    have_cuda = cuda_available()
    if arch in ("cuda", "auto") and have_cuda:
        archs.append("cuda")
    if arch == "cuda" and not have_cuda:
        note = ("**CUDA**: `--arch cuda` was asked for, but no CUDA device is available on this machine: "
                "the scenarios ran on the CPU only.")
    elif have_cuda:
        note = "**CUDA**: a CUDA device is available: every scenario also ran on it (rows with device `cuda`)."
    else:
        note = ("**CUDA**: no CUDA device on this machine, so the scenarios ran on the CPU only; on a GPU machine "
                "the same command adds CUDA rows (device named in the header).")
    runs = [["--only", n, "--arch", a, "--precision", "f32"] for a in archs for n in names]
    return runs, note


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="accuracy-vs-cost report (docs/report/README.md)")
    ap.add_argument("--quick", action="store_true", help="reduced sweeps (~3 min on 2 cores)")
    ap.add_argument("--out", default=str(DEFAULT_OUT), help="output folder (default docs/report/)")
    ap.add_argument("--arch", default="auto", choices=["cpu", "cuda", "auto"],
                    help="scenario table: cpu only, or also cuda (auto: when a device is present)")
    ap.add_argument("--only", default=None, help="comma list of sweep ids to run (debugging): "
                    + ",".join(s[0] for s in STUDIES))
    ap.add_argument("--from-json", default=None, metavar="RESULTS",
                    help="measure nothing: rewrite README.md and the plots from a results.json of an earlier run")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.from_json:
        saved = json.loads(Path(args.from_json).read_text())
        meta = saved.pop("_meta")
        args.quick, args.arch, args.only = meta["quick"], meta["arch"], meta["only"]
        errors = write_report(out, saved, meta["errors"], args, datetime.datetime.fromisoformat(meta["started"]),
                              meta["total_s"], meta["cuda_note"])
        print(f"[bench] report rewritten from {args.from_json} into {out / 'README.md'}", flush=True)
        return 0 if not errors else 1
    wanted = set(args.only.split(",")) if args.only else {s[0] for s in STUDIES}
    t_start = time.perf_counter()
    started = datetime.datetime.now().astimezone()
    results: dict[str, dict] = {}
    errors: dict[str, str] = {}
    cuda_note = ""
    with tempfile.TemporaryDirectory(prefix="anisofrac-bench-") as tmp_name:
        tmp = Path(tmp_name)
        for sid, module, _title, runs in STUDIES:
            if sid not in wanted:
                continue
            if runs is None:
                runs, cuda_note = _scene_runs(args.quick, args.arch)
            parts, errs = [], []
            for k, extra in enumerate(runs):
                res, err = _run_sweep(module, extra, args.quick, tmp, f"{sid}_{k}")
                if res is None:
                    errs.append(f"`{' '.join(extra) or module}`: {err}")
                    continue
                if sid == "scenes":
                    for row in res["rows"]:
                        row["device"] = res["runtime"]["arch"]
                parts.append(res)
            if errs:
                errors[sid] = "; ".join(errs)
            if not parts:
                continue
            mod = importlib.import_module(module)
            results[sid] = mod.merge(parts) if hasattr(mod, "merge") else parts[0]
            results[sid]["process_s"] = sum(p["process_s"] for p in parts)
    total_s = time.perf_counter() - t_start
    errors = write_report(out, results, errors, args, started, total_s, cuda_note)
    print(f"[bench] report written to {out / 'README.md'} in {total_s:.0f} s", flush=True)
    return 0 if not errors and len(results) == len(wanted) else 1


def _command(args) -> str:
    if args.quick:
        return (".venv/bin/python main.py bench --quick   # or, with this output folder: "
                f".venv/bin/python -m bench.report --quick --out {args.out}")
    if Path(args.out).resolve() == DEFAULT_OUT.resolve() and args.arch == "auto" and not args.only:
        return ".venv/bin/python main.py bench"
    extra = f" --arch {args.arch}" if args.arch != "auto" else ""
    extra += f" --only {args.only}" if args.only else ""
    return f".venv/bin/python -m bench.report --out {args.out}{extra}"


def write_report(out: Path, results: dict, measured_errors: dict, args, started, total_s: float,
                 cuda_note: str) -> dict:
    """Write README.md, the plots and results.json; returns the errors (measuring and rendering)."""
    from bench.study_common import machine

    errors = dict(measured_errors)

    mach = machine()
    ver = _versions()
    devices = {}
    for sid, res in results.items():
        for rt in res.get("runtimes", [res.get("runtime", {})]):
            if rt:
                names = devices.setdefault(f"{rt['arch']} ({rt['device']})", [])
                if sid not in names:
                    names.append(sid)
    sections, summary = [], []
    for sid, module, title, _ in STUDIES:
        if sid not in results and sid not in errors:
            continue
        mod = importlib.import_module(module)
        if sid in results:
            try:
                text = mod.render(results[sid], out, cuda_note) if sid == "scenes" else mod.render(results[sid], out)
                sections.append(text)
                if hasattr(mod, "summary"):
                    summary.append(mod.summary(results[sid]))
            except Exception as exc:  # a broken section must not lose the others
                errors[sid] = f"render failed: {type(exc).__name__}: {exc}"
                sections.append(f"## {title}\n\n**Rendering failed**: {errors[sid]}\n")
        if sid in errors and sid not in results:
            sections.append(f"## {title}\n\n**Not measured**: {errors[sid]}\n")
    timing_rows = []
    for sid, _module, title, _ in STUDIES:
        if sid in results:
            r = results[sid]
            timing_rows.append(f"| {title} | {r.get('process_s', r.get('elapsed_s', 0)):,.1f} |")
    versions_line = (f"Python {ver['python']}, Taichi {ver['taichi']}, numpy {ver['numpy']}, scipy {ver['scipy']}, "
                     f"matplotlib {ver['matplotlib']}")
    mode = "a quick run (reduced sweeps)" if args.quick else "the full run"
    head = f"""# Accuracy against cost: what each accuracy option buys and what it costs

Generated by `bench/report.py` ({mode}) on {started.strftime('%Y-%m-%d %H:%M %Z')}. Reproduce with:

```
{_command(args)}
```

Every figure below is what this code measured on the machine named here. The machine was shared with
other work, so timings move between runs (up to 2x for the scene frame rates across two full runs
made the same day); the errors do not.

| | |
|---|---|
| CPU | {mach['cpu']} ({mach['cores']} logical cores visible) |
| Taichi devices | {'; '.join(f'{k}: {", ".join(v)}' for k, v in devices.items())} |
| CUDA | {'available' if any(k.startswith('cuda') for k in devices) else 'no CUDA device on this machine (CPU only)'} |
| versions | {versions_line} |
| platform | {ver['platform']} |
| code | commit {_git()} |
| total run time | {total_s / 60:.1f} min |

Sweep run times (s, wall time of their processes; start-up and Taichi compilation included):

| sweep | s |
|---|---|
{chr(10).join(timing_rows)}

Conventions: errors are absolute values against the known answer named in each section; a column
header ending in `*` may hold 0 where a setting is exact by construction (the section says which);
every plot draws error against time, one point per setting, with the Pareto front (no other setting
is both faster and more accurate) as a black step line and circled points. Raw numbers:
`results.json`.
"""
    if errors:
        head += "\n**Sweeps that failed**: " + "; ".join(f"{k}: {v}" for k, v in errors.items()) + "\n"
    if summary:
        head += "\n## Choosing settings (short reading)\n\n" + "\n".join(f"- {s}" for s in summary) + "\n"
    (out / "README.md").write_text(head + "\n" + "\n\n".join(sections))
    meta = dict(quick=args.quick, arch=args.arch, only=args.only, errors=measured_errors,
                started=started.isoformat(), total_s=total_s, cuda_note=cuda_note)
    (out / "results.json").write_text(json.dumps(dict(results, _meta=meta), indent=1))
    return errors


if __name__ == "__main__":
    raise SystemExit(main())
