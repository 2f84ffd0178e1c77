"""Parameter sweeps on Dask (`main.py sweep`, docs/sweeps.md): the Cartesian product of `--grid` values.

Each grid point is one task: one headless run of the scene with the point's `--set` overrides for a
fixed number of frames (every frame, no early stop when settled), on CPU, f32, one Taichi thread, in
a Dask worker process. Every point is validated through the scene loader before any task starts.
Results go to OUT/runs.parquet (anisofrac.sweep_results), rewritten atomically after each finished
task; rows are keyed by a hash of the scene file, the overrides, the frames and the code version, so
rerunning the same command runs only what is missing. With no scheduler address an embedded
`LocalCluster` on the loopback interface runs the tasks; with one, the same code runs on that cluster.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
import subprocess
import sys
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path

from anisofrac.api import toml_literal
from anisofrac.sweep_results import parse_value, parse_value_table
from core.errors import ConfigError

REPO = Path(__file__).resolve().parents[1]
CONNECT_TIMEOUT_S = 30.0  # s: how long to wait for a remote scheduler to answer


# ---------------------------------------------------------------------------------------- the grid
def split_values(text: str) -> list[str]:
    """Split a grid's value list on the commas outside brackets, braces and quotes:
    `[0,0,-4],[0,0,-8]` -> `['[0,0,-4]', '[0,0,-8]']`."""
    parts, depth, quote, start = [], 0, "", 0
    for i, ch in enumerate(text):
        if quote:
            if ch == quote and text[i - 1] != "\\":
                quote = ""
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return [p.strip() for p in parts]


def parse_grid(specs: list[str]) -> dict[str, list[str]]:
    """`["KEY=V1,V2", ...]` -> {key: [canonical TOML value, ...]} in the order given."""
    if not specs:
        raise ConfigError("--grid", None, "at least one KEY.PATH=V1,V2,... to sweep")
    grid: dict[str, list[str]] = {}
    for spec in specs:
        key, sep, text = spec.partition("=")
        key = key.strip()
        if not sep or not key or any(c.isspace() for c in key):
            raise ConfigError("--grid", spec, "KEY.PATH=V1,V2,... (values in TOML syntax)")
        if key in grid:
            raise ConfigError(f"--grid {key}", spec, "each key path in one --grid only")
        values = split_values(text)
        if any(not v for v in values):
            raise ConfigError(f"--grid {key}", text, "comma-separated values, none empty")
        canon = [toml_literal(parse_value(v)) for v in values]
        if len(set(canon)) != len(canon):
            raise ConfigError(f"--grid {key}", text, "distinct values")
        grid[key] = canon
    return grid


def grid_points(grid: dict[str, list[str]]) -> list[dict[str, str]]:
    """The Cartesian product: one {key: TOML value} per point, the last key varying fastest."""
    keys = list(grid)
    return [dict(zip(keys, combo)) for combo in itertools.product(*(grid[k] for k in keys))]


# ---------------------------------------------------------------------------------------- the points
def code_version() -> str:
    """`git rev-parse HEAD` of the checkout, else the package version from pyproject.toml."""
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], cwd=REPO, capture_output=True, text=True, timeout=10)
        if out.returncode == 0 and out.stdout.strip():
            return out.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        pass
    try:
        return "v" + str(parse_value_table((REPO / "pyproject.toml").read_text())["project"]["version"])
    except (OSError, KeyError, ValueError):
        return "unknown"


def run_key(scene_text: str, overrides: list[str], frames: int, version: str) -> str:
    """The row key: sha256 of the scene file's content, the sorted overrides, the frames and the code version."""
    blob = json.dumps(dict(scene=scene_text, overrides=sorted(overrides), frames=frames, code=version), sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


@dataclass
class SweepSpec:
    scene: str
    grids: list[str]
    frames: int | None = None  # None: each point's scene.test_frames, else its scene.frames
    out: Path | None = None  # None: out/sweep_<scene>
    fixed: list[str] = field(default_factory=list)  # --set overrides every point shares
    scheduler: str | None = None  # None: an embedded LocalCluster on 127.0.0.1
    workers: int | None = None  # LocalCluster processes (None: os.cpu_count())
    overwrite: bool = False  # discard the rows of an earlier sweep in OUT
    dataset: bool = False  # OUT/dataset/<key>/: fragments.ply, cracks.json, params.json
    progress: bool = True
    security: object = None  # distributed.security.Security for a TLS scheduler
    command: str = ""  # the command line, for summary.md


def plan_points(spec: SweepSpec) -> tuple[dict, list[dict]]:
    """Validate every point through the scene loader (nothing runs when one fails) and return the grid
    and one task per point: scene text and source, overrides, frames, params and key."""
    from scenes.loader import load_scene, scene_path

    if spec.frames is not None and (isinstance(spec.frames, bool) or spec.frames < 1):
        raise ConfigError("--frames", spec.frames, "an integer >= 1")
    if spec.workers is not None and spec.workers < 1:
        raise ConfigError("--workers", spec.workers, "an integer >= 1")
    grid = parse_grid(spec.grids)
    for fixed in spec.fixed:
        if fixed.partition("=")[0].strip() in grid:
            raise ConfigError("--set", fixed, "a key path that no --grid sweeps")
    path = scene_path(spec.scene)
    scene_text = path.read_text()
    version = code_version()
    tasks = []
    for point in grid_points(grid):
        overrides = list(spec.fixed) + [f"{k}={v}" for k, v in point.items()]
        cfg = load_scene(str(path), overrides)  # raises the loader's ConfigError naming the key path
        frames = spec.frames or cfg.scene.test_frames or cfg.scene.frames
        tasks.append(dict(scene_text=scene_text, source=str(path), scene=cfg.scene.name, overrides=overrides,
                          frames=frames, params=point, key=run_key(scene_text, overrides, frames, version),
                          code_version=version, dataset=spec.dataset))
    return grid, tasks


# ---------------------------------------------------------------------------------------- one task
def run_point(task: dict) -> dict:
    """One grid point, in the worker process: build the scene with its overrides, run every frame,
    return the results row (a failure is a row with status 'failed' and the error)."""
    from anisofrac.sweep_results import base_row, dataset_files, run_metrics

    row = base_row(task)
    t0 = time.perf_counter()
    try:
        from distributed import get_worker

        row["worker"] = str(get_worker().name)
    except (ImportError, ValueError):
        row["worker"] = f"pid {os.getpid()}"
    try:
        from anisofrac.api import init
        from anisofrac.simulation import Simulation
        from scenes.loader import scene_from_dict

        init("cpu", "f32", 1)
        cfg = scene_from_dict(parse_value_table(task["scene_text"]), task["source"], task["overrides"])
        with Simulation(cfg) as sim:
            row["build_s"] = time.perf_counter() - t0
            sim.run(task["frames"], until_settled=False)
            stats = sim.stats()
            row.update(run_metrics(stats))
            if task["dataset"]:
                row["_dataset"] = dataset_files(sim, stats, task)
        row["status"] = "ok"
    except Exception as exc:  # noqa: BLE001 - a failed run is a row, not the end of the sweep
        row["status"] = "failed"
        row["error"] = f"{type(exc).__name__}: {exc}"
    row["wall_s"] = time.perf_counter() - t0
    return row


# ---------------------------------------------------------------------------------------- Dask
def make_security(ca: str | None, cert: str | None, key: str | None):
    """`--tls-ca/--tls-cert/--tls-key` -> distributed Security (all three or none)."""
    given = [x for x in (ca, cert, key) if x]
    if not given:
        return None
    if len(given) != 3:
        raise ConfigError("--tls-ca/--tls-cert/--tls-key", given, "all three files together")
    for name, p in (("--tls-ca", ca), ("--tls-cert", cert), ("--tls-key", key)):
        if not Path(p).is_file():
            raise ConfigError(name, p, "an existing PEM file")
    from distributed.security import Security

    return Security(tls_ca_file=ca, tls_client_cert=cert, tls_client_key=key, require_encryption=True)


def open_client(spec: SweepSpec):
    """A Dask client: on the scheduler at spec.scheduler, or on an embedded loopback LocalCluster.
    Returns (client, cluster or None)."""
    from distributed import Client, LocalCluster

    if spec.scheduler:
        try:
            return Client(spec.scheduler, timeout=CONNECT_TIMEOUT_S, security=spec.security), None
        except (OSError, TimeoutError, ValueError) as exc:
            raise ConfigError("--scheduler", spec.scheduler,
                              f"the address of a running dask scheduler, e.g. tcp://HOST:8786 ({exc})") from None
    n = spec.workers or os.cpu_count() or 1
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address=None)
    try:
        return Client(cluster), cluster
    except BaseException:
        cluster.close()
        raise


@dataclass
class SweepResult:
    out: Path
    points: int  # grid points of this sweep
    computed: int  # tasks run now
    skipped: int  # points already in runs.parquet with status ok
    ok: int  # rows of this sweep with status ok
    failed: int
    files: list[Path]


def run_sweep(spec: SweepSpec, on_row=None) -> SweepResult:
    """Validate, run what runs.parquet lacks on Dask, write rows as they finish, then plots and summary.
    `on_row(row)` is called on the client after each finished task (row written)."""
    from anisofrac import sweep_results as res

    grid, tasks = plan_points(spec)
    out = res.prepare_out(spec.out or Path("out") / f"sweep_{tasks[0]['scene']}", spec.overwrite)
    rows = res.Rows(out / res.RUNS_FILE, fresh=spec.overwrite)
    todo = [t for t in tasks if not rows.is_ok(t["key"])]
    if todo:
        _compute(spec, todo, rows, out, on_row)
    keys = {t["key"] for t in tasks}
    mine = [r for r in rows.rows if r["key"] in keys]
    files = [rows.path] + res.write_plots(out, grid, mine) + [res.write_summary(out, spec, grid, mine, len(todo))]
    ok = sum(r["status"] == "ok" for r in mine)
    return SweepResult(out=out, points=len(tasks), computed=len(todo), skipped=len(tasks) - len(todo), ok=ok,
                       failed=len(mine) - ok, files=files)


def _compute(spec: SweepSpec, todo: list[dict], rows, out: Path, on_row) -> None:
    """Submit the tasks, collect each as it finishes (a lost or crashed task is a failed row)."""
    from distributed import as_completed
    from tqdm import tqdm

    from anisofrac import sweep_results as res

    client, cluster = open_client(spec)
    bar = tqdm(total=len(todo), desc=f"sweep {todo[0]['scene']}", unit="run", disable=not spec.progress,
               file=sys.stderr)
    failed = 0
    try:
        futures = {client.submit(run_point, t, pure=False, key=f"sweep-{t['key'][:16]}-{uuid.uuid4().hex[:8]}"): t
                   for t in todo}
        for fut in as_completed(futures):
            task = futures[fut]
            try:
                row = fut.result()
            except Exception as exc:  # noqa: BLE001 - e.g. KilledWorker: the worker died on this task repeatedly
                row = res.base_row(task)
                row.update(status="failed", error=f"{type(exc).__name__}: {exc}")
            if row.get("_dataset") is not None:
                res.write_dataset(out, row["key"], row.pop("_dataset"))
            row.pop("_dataset", None)
            rows.add(row)
            rows.save()
            failed += row["status"] != "ok"
            bar.set_postfix(done=bar.n + 1 - failed, failed=failed, remaining=len(todo) - bar.n - 1, refresh=False)
            bar.update(1)
            if on_row is not None:
                on_row(row)
    finally:
        bar.close()
        client.close()
        if cluster is not None:
            cluster.close()
