"""What a sweep leaves in its output folder (docs/sweeps.md): rows, Parquet, dataset files, plots, summary.

`run_metrics` turns a run's stats.json into one row (fragments by size class, fracture events,
crack discs' radii in m, Table 2 times summed in ms, the state hash); `Rows` holds runs.parquet and
rewrites it atomically (temporary name + os.replace) after each finished task; `write_plots` draws
fragments against each numeric swept key (matplotlib Agg) and `write_summary` writes summary.md.
"""

from __future__ import annotations

import datetime
import json
import math
import os
import sys
import tempfile
from pathlib import Path

from core.errors import ConfigError
from core.output import atomic_write_bytes, atomic_write_text, temporary_beside

RUNS_FILE = "runs.parquet"

# fixed columns and their Arrow types; the parameters add `param.<key>` (TOML text) and
# `param_value.<key>` (float64, null where the value is not a number)
COLUMNS = {
    "key": "string", "scene": "string", "frames": "int64", "code_version": "string", "overrides": "string",
    "status": "string", "error": "string", "worker": "string", "finished_utc": "string",
    "fragments_total": "int64", "fragments_debris": "int64", "fragments_small": "int64", "fragments_large": "int64",
    "fracture_events": "int64", "cracks": "int64",
    "r_outer_mean_m": "float64", "r_outer_max_m": "float64", "r_inner_max_m": "float64",
    "stress_analysis_ms": "float64", "particle_subdivision_ms": "float64", "crack_generation_ms": "float64",
    "build_s": "float64", "wall_s": "float64", "state_hash": "string",
}


def parse_value(text: str):
    """A value as `--set` reads it: TOML syntax, a bare word is a string (scenes.loader)."""
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - Python 3.10
        import tomli as tomllib
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def parse_value_table(text: str) -> dict:
    """A scene file's text as a dict (TOML)."""
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - Python 3.10
        import tomli as tomllib
    return tomllib.loads(text)


def _number(text: str) -> float | None:
    """The TOML value `text` as a float when it is a number (not a bool), else None."""
    v = parse_value(text)
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else None


def base_row(task: dict) -> dict:
    """A row with the task's identity and parameters, every result column empty."""
    row = {name: None for name in COLUMNS}
    row.update(key=task["key"], scene=task["scene"], frames=task["frames"], code_version=task["code_version"],
               overrides=json.dumps(task["overrides"]), status="failed", error="")
    for k, v in task["params"].items():
        row[f"param.{k}"] = v
        if _number(v) is not None:
            row[f"param_value.{k}"] = _number(v)
    row["finished_utc"] = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    return row


def run_metrics(stats: dict) -> dict:
    """The results columns of one run's stats (Simulation.stats())."""
    t1 = stats["table1"]
    pieces = t1.get("pieces") or {}
    events = stats["events"]
    analyses = [e["analysis"] for e in events if e.get("analysis")]
    r_outer = [float(c["r_outer"]) for a in analyses for c in a.get("cracks", [])]
    r_inner = [float(a["r_inner"]) for a in analyses if a.get("r_inner") is not None]
    table2 = stats["timings"]["table2_events"]

    def total(name: str) -> float:
        return float(sum(e.get(name, 0.0) for e in table2))

    return dict(
        fragments_total=int(t1.get("fragments", pieces.get("total", 0))),
        fragments_debris=int(pieces.get("debris", 0)), fragments_small=int(pieces.get("small", 0)),
        fragments_large=int(pieces.get("large", 0)),
        fracture_events=len(events), cracks=int(sum(int(e.get("cracks", 0)) for e in events)),
        r_outer_mean_m=sum(r_outer) / len(r_outer) if r_outer else None,
        r_outer_max_m=max(r_outer) if r_outer else None, r_inner_max_m=max(r_inner) if r_inner else None,
        stress_analysis_ms=total("stress_analysis_ms"), particle_subdivision_ms=total("particle_subdivision_ms"),
        crack_generation_ms=total("crack_generation_ms"), state_hash=stats["state_hash"],
    )


# ---------------------------------------------------------------------------------------- dataset
def dataset_files(sim, stats: dict, task: dict) -> dict:
    """In the worker: the dataset files of one run as {name: bytes} (the client writes them)."""
    events = []
    for e in stats["events"]:
        a = e.get("analysis") or {}
        cracks = [dict(point=c["point"], normal=c["normal"], r_outer=c["r_outer"], r_inner=c.get("r_inner"),
                       side=c.get("side")) for c in a.get("cracks", [])]
        if e.get("scripted"):  # the scene's scripted discs (reference frame; no impact analysis)
            cracks = [dict(point=list(c.point), normal=list(c.normal), r_outer=c.radius, r_inner=None,
                           side=list(c.side) or None, frame_of_reference="reference")
                      for c in sim.config.cracks if c.frame == e["frame"]]
        events.append(dict(frame=e["frame"], body=e["body"], speed=e["speed"], scripted=bool(e.get("scripted")),
                           impact_point=cracks[0]["point"] if a.get("cracks") else None, r_inner=a.get("r_inner"),
                           fragments=e.get("fragments"), debris=e.get("debris"), cracks=cracks))
    params = dict(scene=task["scene"], scene_file=task["source"], frames=task["frames"], key=task["key"],
                  code_version=task["code_version"], overrides=task["overrides"], params=task["params"],
                  state_hash=stats["state_hash"])
    files = {"cracks.json": (json.dumps(dict(events=events), indent=2) + "\n").encode(),
             "params.json": (json.dumps(params, indent=2) + "\n").encode()}
    if "rigid" in sim.world.stages:
        with tempfile.TemporaryDirectory(prefix="sweep_") as tmp:
            files["fragments.ply"] = Path(sim.export(Path(tmp) / "fragments.ply")).read_bytes()
    return files


DATASET_SCHEMA = Path(__file__).resolve().parents[1] / "docs" / "schemas" / "sweep_dataset.schema.json"


def write_dataset(out: Path, key: str, files: dict) -> Path:
    """OUT/dataset/<key>/ with the run's files, and OUT/dataset/schema.json (the layout's JSON Schema)."""
    folder = out / "dataset" / key
    folder.mkdir(parents=True, exist_ok=True)
    if not (out / "dataset" / "schema.json").exists():
        atomic_write_bytes(out / "dataset" / "schema.json", DATASET_SCHEMA.read_bytes())
    for name, data in files.items():
        atomic_write_bytes(folder / name, data)
    return folder


# ---------------------------------------------------------------------------------------- runs.parquet
def prepare_out(path: Path, overwrite: bool) -> Path:
    """The sweep folder: new, empty, or holding an earlier sweep (resumed; `overwrite` starts again).
    A folder with other files is refused unless `overwrite`."""
    from core.output import prepare_output_dir

    path = Path(path)
    ours = path.is_dir() and (path / RUNS_FILE).exists()
    return prepare_output_dir(path, overwrite or ours)


class Rows:
    """The rows of runs.parquet by key; `save()` rewrites the file atomically."""

    def __init__(self, path: Path, fresh: bool = False) -> None:
        self.path = Path(path)
        self.by_key: dict[str, dict] = {}
        if self.path.exists() and not fresh:
            import pyarrow.parquet as pq

            try:
                rows = pq.read_table(self.path).to_pylist()
            except Exception as exc:  # noqa: BLE001 - any unreadable file: say what to do
                allowed = f"a runs.parquet written by main.py sweep ({exc}); pass --overwrite to start again"
                raise ConfigError("--out", str(self.path), allowed) from None
            self.by_key = {r["key"]: r for r in rows}

    @property
    def rows(self) -> list[dict]:
        return list(self.by_key.values())

    def is_ok(self, key: str) -> bool:
        r = self.by_key.get(key)
        return r is not None and r.get("status") == "ok"

    def add(self, row: dict) -> None:
        self.by_key[row["key"]] = row

    def table(self):
        import pyarrow as pa

        rows = self.rows
        names = list(COLUMNS) + sorted({n for r in rows for n in r if n.startswith("param")})
        fields = [pa.field(n, pa.float64() if n.startswith("param_value.") else getattr(pa, COLUMNS.get(n, "string"))())
                  for n in names]
        return pa.table({f.name: pa.array([r.get(f.name) for r in rows], type=f.type) for f in fields},
                        schema=pa.schema(fields))

    def save(self) -> None:
        import pyarrow.parquet as pq

        tmp = temporary_beside(self.path)
        try:
            pq.write_table(self.table(), tmp)
            os.replace(tmp, self.path)
        except BaseException:
            if os.path.exists(tmp):
                os.unlink(tmp)
            raise


# ---------------------------------------------------------------------------------------- plots, summary
def write_plots(out: Path, grid: dict[str, list[str]], rows: list[dict]) -> list[Path]:
    """OUT/fragments_vs_<key>.png for each swept key whose values are all numbers: fragments against
    the key, one line per combination of the other keys."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r["status"] == "ok"]
    files = []
    for key, values in grid.items():
        if not ok or any(_number(v) is None for v in values):
            continue
        others = [k for k in grid if k != key]
        lines: dict[tuple, list] = {}
        for r in ok:
            lines.setdefault(tuple(r.get(f"param.{k}") for k in others), []).append(
                (_number(r[f"param.{key}"]), r["fragments_total"]))
        fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=100)
        for combo, pts in sorted(lines.items()):
            pts.sort()
            label = ", ".join(f"{k}={v}" for k, v in zip(others, combo)) or None
            ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=label)
        ax.set_xlabel(key)
        ax.set_ylabel("fragments")
        ax.set_title(f"{ok[0]['scene']}: fragments vs {key}")
        ax.grid(True, alpha=0.3)
        if others:
            ax.legend(fontsize=7)
        fig.tight_layout()
        buf = io.BytesIO()
        fig.savefig(buf, format="png")
        plt.close(fig)
        path = out / f"fragments_vs_{key}.png"
        atomic_write_bytes(path, buf.getvalue())
        files.append(path)
    return files


def _cell(v) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return ""
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v).replace("|", "\\|")


def write_summary(out: Path, spec, grid: dict[str, list[str]], rows: list[dict], computed: int,
                  max_rows: int = 200) -> Path:
    """OUT/summary.md: the command, the grid, rows ok/failed and a table of the runs."""
    ok = sum(r["status"] == "ok" for r in rows)
    lines = [f"# Sweep of {rows[0]['scene'] if rows else spec.scene}", "",
             f"Command: `{spec.command or 'main.py sweep ' + spec.scene}`", "", "Grid:", ""]
    lines += [f"- `{k}`: {', '.join(f'`{v}`' for v in vals)}" for k, vals in grid.items()]
    if spec.fixed:
        lines += ["", "Fixed: " + ", ".join(f"`{f}`" for f in spec.fixed)]
    lines += ["", f"Rows: {len(rows)} ({ok} ok, {len(rows) - ok} failed); computed now: {computed}, "
              f"frames per run: {rows[0]['frames'] if rows else '-'}", ""]
    cols = ["status", "fragments_total", "fragments_debris", "fragments_small", "fragments_large",
            "fracture_events", "cracks", "r_outer_max_m", "wall_s", "state_hash", "error"]
    head = [f"`{k}`" for k in grid] + cols
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    order = sorted(rows, key=lambda r: [str(r.get(f"param.{k}")) for k in grid])
    for r in order[:max_rows]:
        cells = [r.get(f"param.{k}") for k in grid] + [
            (r[c] or "")[:12] if c == "state_hash" else r.get(c) for c in cols]
        lines.append("| " + " | ".join(_cell(c) for c in cells) + " |")
    if len(rows) > max_rows:
        lines.append(f"\n({len(rows) - max_rows} more rows in {RUNS_FILE})")
    path = out / "summary.md"
    atomic_write_text(path, "\n".join(lines) + "\n")
    return path
