"""The viewer's ImGui panel (GGUI `window.get_gui()`): buttons, sliders, toggles, the paper's Table 1
counts of the World and the Table 2 timings of its last fracture event, the crack preview summary.

`draw_panel` declares the widgets for one frame and returns the commands of the buttons pressed;
slider and checkbox values are written straight into the viewer's `Tuning` and `Toggles`.
"""

from __future__ import annotations

import math

from viewer.overlay import COLOUR_MODES

PANEL_WIDTH_PX = 330  # px: panel width (capped at PANEL_MAX_FRACTION of the window)
PANEL_MAX_FRACTION = 0.4
SLIDER_RANGES = dict(cracks=(1, 12), strength=(0.05, 4.0), axis=(0.25, 4.0), speed=(0.1, 40.0), ball_speed=(0.5, 40.0))
HELP = ("Mouse: left strike, right orbit, middle or",
        "  Shift+right pan, Ctrl+right zoom",
        "Keys: Up/Down or I/O zoom, R view, F fit,",
        "  Space pause, N step, BackSpace reset,",
        "  B ball, M colour, H panel, Esc quit")


def panel_fraction(width: int) -> float:
    """Width of the panel as a fraction of the window (it sits on the right edge)."""
    return min(PANEL_MAX_FRACTION, PANEL_WIDTH_PX / max(width, 1))


def _fmt_ms(v) -> str:
    return "-" if v is None else f"{float(v):.1f} ms"


def _tables(g, v) -> None:
    """Table 1 (counts of the World) and Table 2 (timings of its last fracture event)."""
    w = v.world
    c = w.counts()
    balls = v.balls()
    g.text(f"Table 1: physical {c['physical_particles']:,}  subdivided {c['subdivided_particles']:,}")
    g.text(f"  alive {c['alive_particles']:,}  boundary {c['boundary_particles']:,}  fragments {c['fragments']:,}"
           + (f" (incl. {balls} balls)" if balls else ""))
    if not w.events:
        g.text("Table 2: no fracture event yet")
        return
    e = w.events[-1]
    kind = "strike" if e.get("viewer_strike") else ("scripted" if e.get("scripted") else "impact")
    g.text(f"Table 2: {kind} at frame {e.get('frame')} (event {len(w.events)})")
    g.text(f"  stress analysis {_fmt_ms(e.get('stress_analysis_ms'))}")
    g.text(f"  particle subdivision {_fmt_ms(e.get('particle_subdivision_ms'))}")
    g.text(f"  crack generation {_fmt_ms(e.get('crack_generation_ms'))}")
    g.text(f"  {e.get('cracks', 0)} cracks, {e.get('fragments', 0)} fragments, {e.get('debris', 0)} debris")


def _preview(g, v) -> None:
    """Summary of the crack preview at the cursor."""
    p = v.preview
    if not v.toggles.preview:
        return
    if p is None:
        g.text("Preview: point at a breakable surface")
        return
    an = p.analysis
    fired = int(sum(bool(f) for f in an.fired))
    top = max((float(s[0]) for s in an.principal_stress), default=0.0)
    vth = "none" if not math.isfinite(p.threshold_speed) else f"{p.threshold_speed:.3g} m/s"
    g.text(f"Preview body {p.body} at {p.speed:.3g} m/s: {fired}/{len(an.fired)} fire")
    g.text(f"  tension {top / 1e6:.3g} MPa (strength {an.tensile_strength / 1e6:.3g})")
    g.text(f"  fires above {vth}")
    radii = ",".join(f"{c.r_outer * 1e3:.0f}" for c in p.cracks) or "-"
    g.text(f"  r_outer {radii} mm, r_inner {p.r_inner * 1e3:.1f} mm")


def draw_panel(gui, v) -> list[str]:
    """Declare the panel of viewer `v` (viewer.app.Viewer) for this frame; returns button commands."""
    cmds: list[str] = []
    frac = panel_fraction(v.width)
    w = v.world
    t, tg = v.tuning, v.toggles
    with gui.sub_window("Fracture sandbox", 1.0 - frac, 0.0, frac, 1.0) as g:
        state = "PAUSED" if v.paused else "running"
        g.text(f"{w.cfg.scene.name}: frame {w.frame}, t = {w.time:.3f} s [{state}]")
        g.text(f"viewer {v.fps:.1f} frames/s")
        _tables(g, v)
        _preview(g, v)
        if v.message:
            g.text(v.message)
        g.text("Next impact (strike, ball, preview):")
        lo, hi = SLIDER_RANGES["cracks"]
        t.cracks = int(g.slider_int("cracks", t.cracks, lo, hi))
        lo, hi = SLIDER_RANGES["strength"]
        t.strength_factor = max(lo, float(g.slider_float("strength x", t.strength_factor, lo, hi)))
        g.text("  " + ", ".join(f"{m.name} {m.tensile_strength / 1e6:.3g} MPa" for m in w.cfg.materials))
        lo, hi = SLIDER_RANGES["axis"]
        t.axis_factor = max(lo, float(g.slider_float("kernel axis1 x", t.axis_factor, lo, hi)))
        lo, hi = SLIDER_RANGES["speed"]
        t.strike_speed = max(lo, float(g.slider_float("strike m/s", t.strike_speed, lo, hi)))
        lo, hi = SLIDER_RANGES["ball_speed"]
        t.ball_speed = max(lo, float(g.slider_float("ball m/s", t.ball_speed, lo, hi)))
        k = COLOUR_MODES.index(v.colour_mode)
        k = int(g.slider_int(f"colour {v.colour_mode}###colour", k, 0, len(COLOUR_MODES) - 1))
        v.colour_mode = COLOUR_MODES[k]
        g.text("Show:")
        for name, label in (("surfaces", "surfaces (T)"), ("physical", "physical particles (P)"),
                            ("subdivided", "subdivided particles (U)"), ("boundary", "boundary particles (G)"),
                            ("links", "links (L)"), ("kernels", "kernels near the cursor (K)"),
                            ("cracks", "crack discs (C)"), ("preview", "crack preview at the cursor (V)")):
            setattr(tg, name, bool(g.checkbox(label, getattr(tg, name))))
        for label, cmd in (("Pause / resume (Space)", "pause"), ("Step one frame (N)", "step"),
                           ("Shoot a ball (B)", "ball"), ("Reset scene (BackSpace)", "reset"),
                           ("Reset view (R)", "view")):
            if g.button(label):
                cmds.append(cmd)
        for line in HELP:
            g.text(line)
    return cmds
