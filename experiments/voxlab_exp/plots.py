"""Plots for a paper: one colour per model everywhere, every plot as PNG + PDF + SVG with its fonts
embedded, a provenance sidecar per plot, and labels placed so that they do not overlap.

Exists so that figures.py, pareto.py and the dashboard draw a model in the same colour, write the
same vector formats and record which binary made each plot (the dashboard warns when a figure was
made by another binary than the tables it sits beside).
"""
import hashlib
import os

from .files import save_figure, write_json

# Colour-blind-safe (Okabe & Ito 2008) for the registered models, in registry order; any other model
# gets a colour from the rest of the palette by a hash of its name, so it is the same in every figure
# and on every machine. The truth (triangles) is always black.
MODEL_COLOURS = {
    "binary": "#0072B2",        # blue
    "alpha": "#E69F00",         # orange
    "heitz-neyret": "#009E73",  # green
    "vmesh": "#CC79A7",         # reddish purple
    "vicini": "#D55E00",        # vermillion (Okabe-Ito, as the others)
}
TRUTH_COLOUR = "#000000"
EXTRA_COLOURS = ["#56B4E9", "#F0E442", "#8C564B", "#7F7F7F", "#17BECF", "#BCBD22", "#9467BD"]

# The three formats of every plot: a raster preview for the page, and vector files for a paper.
FORMATS = ("png", "pdf", "svg")


def model_colour(name):
    """The model's colour (hex), the same in every figure, table chart and the dashboard."""
    if name in MODEL_COLOURS:
        return MODEL_COLOURS[name]
    if name == "truth":
        return TRUTH_COLOUR
    h = int(hashlib.sha256(name.encode()).hexdigest(), 16)
    return EXTRA_COLOURS[h % len(EXTRA_COLOURS)]


def pyplot():
    """matplotlib's pyplot on the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def clean_axes(ax):
    """An image tile: no ticks, no frame."""
    ax.set_xticks([])
    ax.set_yticks([])
    for s in ax.spines.values():
        s.set_visible(False)


def stamp(meta):
    """The line every figure carries: the commit (dirty or not), the date and the host."""
    g = meta["git"]
    return f"commit {g['commit'][:10]}{' (dirty)' if g['dirty'] else ''}, {meta['date'][:10]}, {meta['machine']['host']}"


def vector_rc():
    """matplotlib settings for vector files whose fonts are embedded: TrueType (Type 42) fonts in PDF
    (/FontFile2), glyphs as outlines in SVG (no font needed to view it)."""
    import matplotlib

    matplotlib.rcParams["pdf.fonttype"] = 42
    matplotlib.rcParams["ps.fonttype"] = 42
    matplotlib.rcParams["svg.fonttype"] = "path"


def provenance(meta):
    """What the dashboard compares between a plot and a table: the binary, commit and date of the run."""
    if not meta:
        return {}
    g = meta.get("git") or {}
    return {"experiment": meta.get("experiment"), "voxlab_sha256": meta.get("voxlab_sha256"), "date": meta.get("date"),
            "commit": g.get("commit"), "dirty": g.get("dirty")}


def save_plot(fig, png_path, dpi=100, meta=None, formats=FORMATS):
    """Writes fig as <stem>.png (dpi), .pdf and .svg (fonts embedded), and <stem>.json with the run's
    provenance (binary sha256, commit, date) when meta (a rows.json meta) is given. Returns the paths."""
    vector_rc()
    stem = os.path.splitext(png_path)[0]
    paths = []
    for fmt in formats:
        p = f"{stem}.{fmt}"
        save_figure(fig, p, **({"dpi": dpi} if fmt == "png" else {}))
        paths.append(p)
    if meta is not None:
        write_json(f"{stem}.json", provenance(meta))
    return paths


# ---------------------------------------------------------------------------------------------- labels

def _candidates():
    """Candidate offsets (points) around a marker, nearest first; at each distance right-above first
    (where the labels used to go), then around the circle."""
    import math

    out = []
    for radius in (5, 10, 16, 24, 34, 46, 60):
        for k in range(16):
            ang = math.radians(30 - 22.5 * k)
            out.append((round(radius * math.cos(ang), 1), round(radius * math.sin(ang), 1)))
    return out


OFFSETS = _candidates()
LEADER_FROM = 12  # a label farther than this (points) from its marker gets a thin leader line


def _overlap(a, b, pad=1.0):
    return a.x0 < b.x1 + pad and b.x0 < a.x1 + pad and a.y0 < b.y1 + pad and b.y0 < a.y1 + pad


def _text_box(ann, renderer):
    """The label's text alone (a leader line is not part of what must not overlap)."""
    from matplotlib.text import Text

    ann.update_positions(renderer)
    return Text.get_window_extent(ann, renderer)


def _align(ann, off):
    dx, dy = off
    ann.set_ha("left" if dx > 0.5 else "right" if dx < -0.5 else "center")
    ann.set_va("bottom" if dy > 0.5 else "top" if dy < -0.5 else "center")


def place_labels(fig, labels, avoid_points=None):
    """Moves each annotation (matplotlib Annotation made with textcoords='offset points') to the
    nearest candidate offset where it overlaps no label placed before it, no marker in avoid_points
    ((axes, x, y) triples, in data coordinates) and stays inside its axes; a label moved farther than
    LEADER_FROM points gets a thin leader line to its marker. Deterministic: labels are placed in the
    order given, candidates tried nearest first. A label with no free place keeps the candidate with
    the least overlap. Returns the number of labels that still overlap another (0 when all fit)."""
    from matplotlib.transforms import Bbox

    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    placed = {}  # axes -> bboxes of the labels placed so far
    markers = {}
    for ax, x, y in avoid_points or []:
        px, py = ax.transData.transform((x, y))
        markers.setdefault(ax, []).append(Bbox([[px - 3, py - 3], [px + 3, py + 3]]))
    left = 0
    for ann in labels:
        ax = ann.axes
        box_ax = ax.get_window_extent(renderer)
        best, best_cost = None, None
        for off in OFFSETS:
            ann.xyann = off
            _align(ann, off)
            bb = _text_box(ann, renderer)
            cost = sum(_overlap(bb, o) for o in placed.get(ax, [])) * 100 + \
                sum(_overlap(bb, m, 0) for m in markers.get(ax, []))
            if bb.x0 < box_ax.x0 or bb.x1 > box_ax.x1 or bb.y0 < box_ax.y0 or bb.y1 > box_ax.y1:
                cost += 50
            if best_cost is None or cost < best_cost:
                best, best_cost = off, cost
            if cost == 0:
                break
        ann.xyann = best
        _align(ann, best)
        bb = _text_box(ann, renderer)
        if (best[0] ** 2 + best[1] ** 2) ** 0.5 > LEADER_FROM:
            # A leader from the marker to the nearest point of the label's box, in data coordinates
            # (so it stays attached whatever the dpi the figure is saved at).
            mx, my = ax.transData.transform(ann.xy)
            tx, ty = min(max(mx, bb.x0), bb.x1), min(max(my, bb.y0), bb.y1)
            inv = ax.transData.inverted()
            (x0, y0), (x1, y1) = inv.transform((mx, my)), inv.transform((tx, ty))
            ax.plot([x0, x1], [y0, y1], "-", lw=0.5, color=ann.get_color(), alpha=0.6, scalex=False, scaley=False)
        if any(_overlap(bb, o, 0) for o in placed.get(ax, [])):
            left += 1
        placed.setdefault(ax, []).append(bb)
    return left


def label_overlaps(fig, labels):
    """Pairs of labels (same axes) whose text boxes intersect: the tests' check of place_labels."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    boxes = [(a.axes, _text_box(a, renderer), a.get_text()) for a in labels if a.get_visible()]
    return [(t1, t2) for i, (ax1, b1, t1) in enumerate(boxes) for ax2, b2, t2 in boxes[i + 1:]
            if ax1 is ax2 and _overlap(b1, b2, 0)]
