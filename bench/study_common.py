"""Shared pieces of the accuracy-vs-cost study (DESIGN.md promise 1; `python main.py bench`).

Every sweep is a module `bench/study_<name>.py` with
  - `run(quick: bool) -> dict`: measures, returns JSON-serialisable results (rows of numbers);
  - `render(result: dict, out: Path) -> str`: writes its PNG plot(s) into `out` and returns the
    Markdown section (table, plot link, short reading);
  - a command line (`python -m bench.study_<name> --json PATH [--quick] [--precision ...]`) that
    starts Taichi (when the sweep needs it) with the requested precision, runs and writes the JSON.
`bench/report.py` runs each sweep's command line in its own process (Taichi's precision is fixed per
process) and assembles docs/report/README.md from the `render` sections.

Conventions of the tables (tests/regression/test_bench_quick.py checks them): numbers are plain
(thousands separated by commas), errors are absolute values, units are in the column headers;
a header ending in `*` marks a column where 0 is a legitimate value because that setting is
exact by construction (the table's note says which); any other number must be finite and > 0.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

PLOT_FLOOR = 1e-17  # errors below this (exact settings, round-off) are drawn at this value on log axes


# ----------------------------------------------------------------------------- timing


def clock() -> float:
    return time.perf_counter()


def median_time(fn, repeat: int, sync: bool = False) -> float:
    """Median wall time (s) of `repeat` calls of fn() after one untimed call (compilation, caches)."""
    ti = None
    if sync:
        import taichi as ti
    fn()
    if ti is not None:
        ti.sync()
    ts = []
    for _ in range(max(1, repeat)):
        t0 = clock()
        fn()
        if ti is not None:
            ti.sync()
        ts.append(clock() - t0)
    return statistics.median(ts)


# ----------------------------------------------------------------------------- Pareto front


def pareto_mask(cost, error) -> np.ndarray:
    """(n,) bool: True for the settings no other setting beats in both cost and error (both <=, one <)."""
    c = np.asarray(cost, dtype=np.float64)
    e = np.asarray(error, dtype=np.float64)
    n = c.size
    keep = np.ones(n, dtype=bool)
    for i in range(n):
        dom = (c <= c[i]) & (e <= e[i]) & ((c < c[i]) | (e < e[i]))
        keep[i] = not dom.any()
    return keep


# ----------------------------------------------------------------------------- Markdown


def fmt(x, kind: str = "g3") -> str:
    """A table cell. kind: 'int' (thousands commas), 'f1'/'f2'/'f3' (fixed), 'e2' (scientific), 'g3'."""
    if x is None:
        return "-"
    if isinstance(x, str):
        return x
    x = float(x)
    if not math.isfinite(x):
        return "nan" if math.isnan(x) else "inf"  # the test rejects these: they must not happen
    if kind == "int":
        return f"{int(round(x)):,}"
    if kind.startswith("f"):
        return f"{x:,.{int(kind[1:])}f}"
    if kind.startswith("e"):
        return f"{x:.{int(kind[1:])}e}"
    digits = int(kind[1:]) if kind.startswith("g") else 3
    if x != 0.0 and (abs(x) < 1e-3 or abs(x) >= 1e6):
        return f"{x:.{digits - 1}e}"
    return f"{x:,.{digits}g}" if abs(x) < 1000 else f"{x:,.0f}"


def md_table(columns: list[str], rows: list[list]) -> str:
    """A Markdown table; rows hold already formatted cells (str)."""
    out = ["| " + " | ".join(columns) + " |", "|" + "|".join("---" for _ in columns) + "|"]
    for r in rows:
        out.append("| " + " | ".join(str(c) for c in r) + " |")
    return "\n".join(out)


# ----------------------------------------------------------------------------- plots


def plot_pareto(path: Path, panels: list[dict], title: str | None = None) -> str:
    """Error against cost, one point per setting, log-log, the Pareto front of each panel marked.

    panel: dict(title, xlabel, ylabel, series=[dict(label, x, y, names=None, marker=None)],
                front_per_series=False): one front over all series of the panel (the same problem solved
                by different settings), or one per series (different problems, e.g. two bodies).
    Returns the file name (relative to the report folder).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(panels)
    fig, axes = plt.subplots(1, n, figsize=(6.2 * n, 4.6), squeeze=False)
    markers = "osD^vP*Xh<>"
    for ax, panel in zip(axes[0], panels):
        xs, ys = [], []
        for k, s in enumerate(panel["series"]):
            x = np.asarray(s["x"], dtype=np.float64)
            y = np.maximum(np.asarray(s["y"], dtype=np.float64), PLOT_FLOOR)
            ax.plot(x, y, s.get("marker") or markers[k % len(markers)], ls=s.get("ls", "-"), lw=0.8,
                    ms=6, alpha=0.85, label=s["label"])
            for xi, yi, name in zip(x, y, s.get("names") or []):
                ax.annotate(name, (xi, yi), textcoords="offset points", xytext=(4, 3), fontsize=7)
            xs.append(x)
            ys.append(y)
        # one front over all series (they solve the same problem), or one per series (different problems)
        groups = list(zip(xs, ys)) if panel.get("front_per_series") else [(np.concatenate(xs), np.concatenate(ys))]
        for g, (x, y) in enumerate(groups):
            front = pareto_mask(x, y)
            order = np.argsort(x[front])
            fx, fy = x[front][order], y[front][order]
            ax.step(fx, fy, where="post", color="k", lw=1.6, alpha=0.5, label="Pareto front" if g == 0 else None)
            ax.plot(fx, fy, "o", mfc="none", mec="k", ms=12, mew=1.4)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(panel["xlabel"])
        ax.set_ylabel(panel["ylabel"])
        ax.set_title(panel.get("title", ""), fontsize=10)
        ax.grid(True, which="both", alpha=0.25)
        ax.legend(fontsize=7, loc="best")
    if title:
        fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path.name


# ----------------------------------------------------------------------------- command line of a sweep


def machine() -> dict:
    """CPU model and core count of this machine (the Taichi device comes from core.runtime)."""
    from core.runtime import _cpu_name

    return dict(cpu=_cpu_name(), cores=os.cpu_count())


def study_main(run, argv=None, taichi: bool = True, default_precision: str = "f32", default_threads: int = 0) -> int:
    """Command line of one sweep: start Taichi (if it needs it), run, write the JSON result."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--json", required=True, help="where to write the result")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--arch", default="cpu", choices=["cpu", "cuda", "auto"])
    ap.add_argument("--precision", default=default_precision, choices=["f32", "f64"])
    ap.add_argument("--threads", type=int, default=default_threads, help="CPU threads (0 = Taichi's default)")
    ap.add_argument("--only", default=None, help="sweep-specific subset (e.g. one scene)")
    args = ap.parse_args(argv)
    info = None
    if taichi:
        from core.runtime import init_taichi

        info = init_taichi(args.arch, args.precision, args.threads)
    t0 = clock()
    kwargs = {"only": args.only} if args.only is not None else {}
    result = run(args.quick, **kwargs)
    result["elapsed_s"] = clock() - t0
    result["runtime"] = (
        dict(arch=info.arch, precision=info.precision, threads=info.threads, device=info.device)
        if info is not None else dict(arch="numpy (host)", precision="f64", threads=1, device=machine()["cpu"])
    )
    Path(args.json).write_text(json.dumps(result, indent=1, default=_json_default))
    return 0


def _json_default(o):
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.floating):
        return float(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.bool_):
        return bool(o)
    raise TypeError(type(o))
