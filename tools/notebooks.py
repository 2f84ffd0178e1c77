"""Lecture notebooks (docs/notebooks/): execute them with a real Jupyter kernel, or strip outputs.

    python tools/notebooks.py run [NAME ...] [--out out/notebooks]   execute; executed copies go to --out
    python tools/notebooks.py strip [NAME ...]                       clear outputs in place (before a commit)
    python tools/notebooks.py check                                  fail if a stored notebook has outputs

The notebooks are stored without outputs: `run` regenerates them (the test suite runs the same
`execute`), so no output is ever edited by hand. A notebook fails when a cell raises, including the
final cell's asserts of the lesson's known answer.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "docs" / "notebooks"
TIMEOUT_S = 600  # s: per cell


def notebook_paths(names: list[str] | None = None) -> list[Path]:
    """The notebooks by name (with or without .ipynb), or all of them in lesson order."""
    every = sorted(NOTEBOOKS.glob("*.ipynb"))
    if not names:
        return every
    out = []
    for n in names:
        stem = Path(n).stem
        match = [p for p in every if p.stem == stem]
        if not match:
            raise SystemExit(f"notebook {n!r} not found; allowed: {', '.join(p.stem for p in every)}")
        out += match
    return out


def execute(path: Path, timeout: int = TIMEOUT_S):
    """Run every cell of the notebook in a fresh python3 kernel started in docs/notebooks/ (as a
    student opening it there would); returns (executed notebook, wall seconds). Raises
    nbclient.exceptions.CellExecutionError on the first failing cell."""
    import nbformat
    from nbclient import NotebookClient

    nb = nbformat.read(path, as_version=4)
    t0 = time.perf_counter()
    NotebookClient(nb, timeout=timeout, kernel_name="python3",
                   resources={"metadata": {"path": str(path.parent)}}).execute()
    return nb, time.perf_counter() - t0


def has_outputs(nb) -> bool:
    return any(c.cell_type == "code" and (c.get("outputs") or c.get("execution_count") is not None) for c in nb.cells)


def strip(path: Path) -> bool:
    """Clear outputs and execution counts in place; True when the file changed."""
    import nbformat

    nb = nbformat.read(path, as_version=4)
    if not has_outputs(nb):
        return False
    for c in nb.cells:
        if c.cell_type == "code":
            c.outputs = []
            c.execution_count = None
    nbformat.write(nb, path)
    return True


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("command", choices=("run", "strip", "check"))
    ap.add_argument("names", nargs="*")
    ap.add_argument("--out", default=str(ROOT / "out" / "notebooks"), help="folder of the executed copies")
    args = ap.parse_args(argv)
    paths = notebook_paths(args.names)
    if args.command == "strip":
        for p in paths:
            print(f"{p.name}: {'stripped' if strip(p) else 'clean'}")
        return 0
    if args.command == "check":
        import nbformat

        dirty = [p.name for p in paths if has_outputs(nbformat.read(p, as_version=4))]
        print("stored with outputs: " + ", ".join(dirty) if dirty else "all notebooks stored without outputs")
        return 1 if dirty else 0
    import nbformat

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    failed = 0
    for p in paths:
        try:
            nb, seconds = execute(p)
        except Exception as exc:  # noqa: BLE001 - report every notebook, then fail
            print(f"{p.name}: FAILED\n{exc}", file=sys.stderr)
            failed += 1
            continue
        nbformat.write(nb, out / p.name)
        print(f"{p.name}: ran in {seconds:.1f} s -> {out / p.name}")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
