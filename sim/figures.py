"""The figure sheet: our versions of the paper's Figs. 7 to 12 (issue 15, "A figure sheet").

`python main.py figures` runs each figure's scenes headless with the default look and camera and
keeps three frames per scene: *before* (the frame before the first fracture event), *during*
(DURING_FRAMES after it) and *after* (the last frame: the scene's frame count, or earlier once every
piece has rested for SETTLED_S, as `main.py run` does). Each figure becomes one PNG in
docs/figures/ (one row per scene, the three frames side by side, labelled) and a section of
docs/figures.md with the paper's caption, our piece counts beside the paper's Table 1 and the
command that reproduces each row. What still differs from the paper, found by looking at the
sheet beside the paper's figures, is written under each figure (FIGURES[...].differs).
Files are written to temporary names and renamed.
"""

from __future__ import annotations

import io
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.output import atomic_write_bytes, atomic_write_text
from sim.run import SETTLED_S, SettleClock

DURING_FRAMES = 6  # frames after the first fracture event shown as "during"
PANEL_PX = (480, 360)  # px: one frame of the sheet (width, height)
LABEL_PX = 22  # px: height of the label strip above each frame


@dataclass(frozen=True)
class Row:
    scene: str
    label: str  # what the row shows in the paper's terms
    table1: str = ""  # the paper's Table 1 row, "" when the paper gives no count
    paper_fragments: int | None = None


@dataclass(frozen=True)
class Figure:
    number: int
    caption: str  # the paper's caption, verbatim
    rows: tuple
    differs: str  # what still differs from the paper's figure (written after looking at both)


FIGURES = (
    Figure(7, "Falling pot simulation with basic fracture surface generation (left) and adaptively "
              "subdivided particle method (right)",
           (Row("pot_basic", "basic link removal (paper: left)", "Pot1", 6),
            Row("pot", "adaptive subdivision (paper: right)", "Pot2", 14)),
           "Both pots break along a Y of three cracks into three large pieces as they land, and those break "
           "again when they land in turn (the cracks of a landing shard run through it: docs/decisions.md, "
           "\"Crack arrest\"): four large pieces each, plus single particles. Basic removal gives jagged "
           "cracks along tet faces and subdivision straight ones, as in the paper; at this landing the "
           "adaptive pot gives 8 pieces on the AMD EPYC of session 43 (5 on sessions 41-42's, 8 on the machine "
           "before it, 28 on the one before that: Taichi compiles for the host CPU) and the basic one 11 (the "
           "paper: 14 adaptive, 6 basic). The first landing is the same in both (its shatter zone, 2.7 mm, "
           "holds no particle to crush finer); the "
           "pieces' own landings decide the rest and are chaotic: at the third rotation angle of 6, 8, 12 "
           "and 14 degrees the adaptive pot gave 3, 34, 8 and 17 pieces and the basic one 19, 26, 12 and 8 "
           "(on an earlier machine). "
           "The adaptive pot's single particles are children cut off between the cracks of its pieces' "
           "landings; the basic pot's landings free whole particles."),
    Figure(8, "The same scene of falling pot for anisotropic material with different kernel. The "
              "interaction along the surface is adjusted to 1/5 (left) and 3 (right) times",
           (Row("pot_aniso_low", "kernel x1/5 along the surface (paper: left)"),
            Row("pot_aniso_high", "kernel x3 along the surface (paper: right)")),
           "The kernel changes where the cracks run: x1/5 along the surface, the wall opens along long "
           "cracks into three large pieces and 36 grains crushed where a piece lands on an edge; x3, the Y "
           "of the first landing parts the pot into four large pieces, two small ones and one grain. The "
           "paper shows both pots broken, with different crack directions, and gives no counts for Fig. 8."),
    Figure(9, "A ball collapses through glass window, breaks into a hole and crack propagates without "
              "destroying the global structure. Fracture surface normal is the same while different "
              "ball sizes lead to different radii. The radii of balls are 3 and 5",
           (Row("glass_r3", "ball radius 3 cm", "Glass1", 436),
            Row("glass_r5", "ball radius 5 cm", "Glass2", 598)),
           "The hole and the cobweb of six radial cracks around it (drawn as lines: the sectors stay in the"
           " frame) match the paper's pattern, the pane stays held, and the crushed core bursts through "
           "with the ball; the 5 cm ball makes the larger hole. The camera follows the flying grains, so "
           "the last frame shows the pane small."),
    Figure(10, "Pots are dropped and fractured into 117 fragments. The top two are sideview display and "
               "the bottom two are zoom-ins from above",
           (Row("pots", "13 pots dropped (side view)", "Pots", 587),),
           "A heap of shards of many sizes, as in the paper, the shards breaking again as they land on "
           "each other (82 large pieces); of our 440 pieces on this machine (457 before session 44 analysed a "
           "blow whose contacts' mean lies off the body at its hardest site, 491 on sessions 41-42's machine; 587 "
           "in the paper) 333 are grains and particles shattered where shards strike each other and 25 are small "
           "(under 1% of a pot). No zoom-in from above: the sheet keeps one camera per scene."),
    Figure(11, "The pet model impacted by a falling ball. 20k original particles and 30k subdivided "
               "particles are created during the simulation",
           (Row("pet", "figurine struck by a steel ball", "Pet", 47),),
           "Our figurine is a procedural stand-in for the paper's pet mesh (no mesh file ships with the "
           "paper). The ball splits it where it lands and the parts break again on the floor (30 pieces "
           "against the paper's 47) and scatter; the camera backs off to keep them in view, so the last "
           "frame shows them small."),
    Figure(12, "An ornament of Tai Chi diagram with two kinds of materials, the two parts show "
               "different propagation directions during one collision",
           (Row("taichi", "white marble and black slate halves", "Tai Chi", 87),),
           "Black and white halves as in the paper. The disc lands on the edge of its rim: the marble "
           "corner that lands is crushed (Hertz pressure about 1 GPa against marble's 100-200 MPa in "
           "compression; 55 grains) and cracks run from it through the disc's thickness, one cutting a "
           "chord off the bottom; where they reach the slate they go on in the slate's own directions "
           "with the energy they had left, so the two materials crack in different directions in one blow "
           "(the lines drawn on the slate). Here the disc then falls flat and its slate's edge parts along "
           "those cracks: five large pieces (the disc, the chord and three of the slate's), one small and 55 "
           "grains, 61 in all against the paper's 87. The count "
           "swings with the landing angle and the tet size (2-72 pieces over 76-84 degrees, the disc in up "
           "to seven large pieces; 4-80 over 7.6-13 mm, docs/decisions.md, \"An edge or a corner has no "
           "normal\")."),
)


def _label(img: np.ndarray, text: str) -> np.ndarray:
    from PIL import Image, ImageDraw

    im = Image.new("RGB", (img.shape[1], img.shape[0] + LABEL_PX), (24, 26, 31))
    im.paste(Image.fromarray(img), (0, LABEL_PX))
    ImageDraw.Draw(im).text((6, 4), text, fill=(235, 235, 235))
    return np.asarray(im)


def run_row(row: Row, frames: int | None = None, progress: bool = True) -> dict:
    """Run one scene; returns its before/during/after frames, counts and the frame numbers."""
    from tqdm import tqdm

    from render.session import HeadlessSession
    from scenes.loader import load_scene
    from sim.world import World

    cfg = load_scene(row.scene)
    n = frames or cfg.scene.frames
    world = World(cfg)
    session = HeadlessSession(world, "raster", *PANEL_PX)
    settle = SettleClock(cfg.scene.fps)
    shots: dict[str, tuple[int, np.ndarray]] = {}
    previous = None
    try:
        for f in tqdm(range(n), desc=f"figures: {row.scene}", unit="frame", disable=not progress, file=sys.stderr):
            had_events = bool(world.events)
            world.step_frame()
            img = session.draw()
            if world.events and not had_events:
                shots["before"] = previous if previous is not None else (f, img)
            if "before" in shots and "during" not in shots and f >= world.events[0]["frame"] + DURING_FRAMES:
                shots["during"] = (f, img)
            previous = (f, img)
            if settle.tick(world):
                break
        shots["after"] = previous
        shots.setdefault("before", shots["after"])
        shots.setdefault("during", shots["after"])
        pieces = world.pieces()
    finally:
        session.close()
        world.release()
    return dict(shots=shots, pieces=pieces, events=len(world.events))


def figure_image(fig: Figure, results: list[dict]) -> bytes:
    """One PNG: a row per scene, before / during / after."""
    from PIL import Image

    rows = []
    for row, res in zip(fig.rows, results):
        panels = [_label(res["shots"][k][1], f"{row.scene}: {k} (frame {res['shots'][k][0]})")
                  for k in ("before", "during", "after")]
        rows.append(np.concatenate(panels, axis=1))
    buf = io.BytesIO()
    Image.fromarray(np.concatenate(rows, axis=0)).save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def figure_markdown(fig: Figure, results: list[dict], image: str) -> str:
    lines = [f"## Fig. {fig.number}", "", f"> {fig.caption} (Li, Wang and Qin 2015)", "",
             f"![Fig. {fig.number}: our version]({image})", "",
             "| scene | shows | pieces (debris / small / large) | total | paper Table 1 | command |",
             "|---|---|---|---|---|---|"]
    for row, res in zip(fig.rows, results):
        p = res["pieces"]
        paper = f"{row.paper_fragments} ({row.table1})" if row.paper_fragments else "not given"
        lines.append(f"| {row.scene} | {row.label} | {p['debris']} / {p['small']} / {p['large']} | {p['total']} "
                     f"| {paper} | `python main.py run {row.scene}` |")
    lines += ["", f"**What still differs.** {fig.differs}", ""]
    return "\n".join(lines)


def make_sheet(out_md: Path, only: list[int] | None = None, frames: int | None = None, progress: bool = True,
               figures: tuple = FIGURES) -> Path:
    """Render the figures (all, or the numbers in `only`) into out_md and the images beside it."""
    figs = [f for f in figures if only is None or f.number in only]
    img_dir = out_md.parent / "figures"
    img_dir.mkdir(parents=True, exist_ok=True)
    sections = ["# The paper's figures, our scenes", "",
                "Generated by `python main.py figures` (sim/figures.py): each row is one scene run headless "
                "with its defaults; frames before the first fracture event, "
                f"{DURING_FRAMES} frames after it, and at the end (the scene's frame count, or once every piece "
                f"has rested for {SETTLED_S:g} s). Debris particles of the shatter zone are drawn as small spheres.",
                ""]
    for fig in figs:
        results = [run_row(row, frames, progress) for row in fig.rows]
        name = f"fig{fig.number}.png"
        atomic_write_bytes(img_dir / name, figure_image(fig, results))
        sections.append(figure_markdown(fig, results, f"figures/{name}"))
    atomic_write_text(out_md, "\n".join(sections))
    return out_md
