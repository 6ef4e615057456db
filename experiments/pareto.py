#!/usr/bin/python3
"""What accuracy costs in time and memory (make pareto).

    /usr/bin/python3 experiments/pareto.py [--experiment experiments/pareto.json] [--results results]
        [--jobs 2] [--voxlab build/voxlab] [--fresh]

Runs the declared sweep (cached) and writes into <results>/<name>/:

  pareto.csv              one line per point: scene, series (a model, or "truth" for the triangle
                          ground truth at low spp), its parameters, render ms, memory MB, MSE, 1 - SSIM,
                          and on_front_<x>_<y> = 1 for the points on the Pareto front of that plot.
  pareto_<scene>.png/.pdf/.svg  four panels: MSE and 1 - SSIM against render time and against memory, log
                          scales, every model over its parameters, the truth's spp curve in black,
                          the Pareto front (lower left: nothing else is both cheaper and better) as a
                          dashed step line with ringed points; labels placed so that none overlaps
                          another (voxlab_exp/plots.py), each model in its colour of every figure;
                          PDF and SVG with fonts embedded, pareto_<scene>.json: the binary that made it.
  pareto.md               per scene the fronts in words, and which model points the brute-force truth
                          curve dominates (a truth render that is both faster and more accurate:
                          such a model setting is not worth using on this scene).
  rows.csv, rows.json     the sweep's rows.

Render time is one frame's render with the bake excluded (the bake is a one-off precomputation: see
Table 2), at the voxlab thread count the sweep states. Memory is what the frame reads: the model's
records + sparse grid + its constant tables + the precomputed shadows of a method that has them;
for the truth it is voxlab's mesh_bytes when its stats give them, else the truth process's peak RSS
minus that of a voxlab process that loads no scene (mesh, BVH and framebuffer: an overestimate).
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from voxlab_exp.cli import add_common_args, main_wrapper, sweep_args  # noqa: E402
from voxlab_exp.config import REPO  # noqa: E402
from voxlab_exp.files import rel, write_csv, write_text  # noqa: E402
from voxlab_exp.plots import TRUTH_COLOUR, model_colour, place_labels, save_plot  # noqa: E402
from voxlab_exp.report import settings_text  # noqa: E402
from voxlab_exp.rows import run_experiment, shadow_method, shadow_skip_off, traced_per_pixel  # noqa: E402
from voxlab_exp.schema import load_declaration  # noqa: E402

AXES = [("render_ms", "mse"), ("render_ms", "one_minus_ssim"), ("mb", "mse"), ("mb", "one_minus_ssim")]
LABEL = {"render_ms": "render time per frame (ms)", "mb": "memory (MB)", "mse": "MSE",
         "one_minus_ssim": "1 − SSIM"}
CSV_FIELDS = ["scene", "series", "model", "res", "spp", "rays", "cache", "shadows", "shadow_skip", "width", "height",
              "render_ms", "render_ms_min",
              "render_ms_spread", "repeats", "loaded", "bake_s",
              "mb", "mse", "ssim", "one_minus_ssim", "psnr", "label", "status", "error"] + \
             [f"on_front_{x}_{y}" for x, y in AXES] + ["dominated_by_truth"]


def default_shadows(r):
    """Whether a row's shadows are the default ones (march with the shadow skip): a declaration may
    sweep the method or the skip, and those points are other settings, neither on the resolution
    line nor under its label."""
    return shadow_method(r) == "march" and not shadow_skip_off(r)


def shadows_words(r):
    """The label's words for a row's non-default shadows (none for the default)."""
    words = []
    if shadow_method(r) != "march":
        words.append(f"{shadow_method(r)} shadows")
    if shadow_skip_off(r):
        words.append("no shadow skip")
    return words


def point_label(r):
    if r["kind"] == "truth":
        return f"truth {r['spp']} spp"
    parts = [f"{r['res']}³"]
    if r["spp"] != 4:
        parts.append(f"{r['spp']} spp")
    rpp = traced_per_pixel(r)
    if rpp is not None:
        parts.append(f"{rpp:g} per pixel traced")  # one cone a pixel, whatever the spp
    if r["rays"] != 150:
        parts.append(f"{r['rays']} rays")
    if not r["cache"]:
        parts.append("no cache")
    parts += shadows_words(r)
    return f"{r['model']} " + ", ".join(parts)


def pareto_front(points, x, y):
    """Indices of the points no other point beats on both x and y (ties: the first one kept)."""
    order = sorted(range(len(points)), key=lambda i: (points[i][x], points[i][y]))
    front, best = [], float("inf")
    for i in order:
        if points[i][y] < best:
            front.append(i)
            best = points[i][y]
    return front


def truth_time_violations(truth):
    """Pairs of truth points whose render time falls as spp rises beyond what the timing noise
    explains: the higher spp's slowest repeat (min + spread) is faster than the lower spp's fastest
    (its min). Physics says the time grows with the samples; [] when it does (within the spread)."""
    pts = sorted((p for p in truth if p.get("render_ms_min") is not None), key=lambda p: p["spp"])
    bad = []
    for a in pts:
        for b in pts:
            if b["spp"] > a["spp"] and b["render_ms_min"] + (b["render_ms_spread"] or 0) < a["render_ms_min"]:
                bad.append((a, b))
    return bad


def dominated_by_truth(p, truth):
    return any(t["render_ms"] <= p["render_ms"] and t["mse"] <= p["mse"] and t["one_minus_ssim"] <= p["one_minus_ssim"]
               for t in truth)


def time_bars(ax, pts, x, y, colour):
    """Horizontal bars over the range of a point's timed repeats (min to max) around its median."""
    if x != "render_ms":
        return
    pts = [p for p in pts if p.get("render_ms_min") is not None and p.get("render_ms_spread") is not None]
    if pts:
        lo = [max(0.0, p["render_ms"] - p["render_ms_min"]) for p in pts]
        hi = [max(0.0, p["render_ms_min"] + p["render_ms_spread"] - p["render_ms"]) for p in pts]
        ax.errorbar([p[x] for p in pts], [p[y] for p in pts], xerr=[lo, hi], fmt="none", ecolor=colour, elinewidth=1,
                    capsize=2.5, alpha=0.8)


def plot_scene(scene, pts, models, out_stem, meta, decl):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colours = {m: model_colour(m) for m in models}
    fig, axes = plt.subplots(2, 2, figsize=(12, 9.5))
    labels, markers = [], []  # every annotation, placed at the end so that none overlaps another
    for ax, (x, y) in zip(axes.flat, AXES):
        usable = [p for p in pts if p[x] and p[y] and p[x] > 0 and p[y] > 0]
        markers += [(ax, p[x], p[y]) for p in usable]
        for m in models:
            mp = [p for p in usable if p["series"] == m]
            # The resolution sweep (default spp, rays, cache) as a connected line, the other
            # parameters as separate markers, so each model's curve reads at a glance.
            line = sorted((p for p in mp if p["spp"] == 4 and p["rays"] == 150 and p["cache"] and default_shadows(p)),
                          key=lambda p: p["res"])
            if line:
                ax.plot([p[x] for p in line], [p[y] for p in line], "-o", color=colours[m], ms=5, lw=1.3, label=m)
                time_bars(ax, line, x, y, colours[m])
                for p in line:
                    labels.append(ax.annotate(f"{p['res']}", (p[x], p[y]), textcoords="offset points",
                                              xytext=(4, 3), fontsize=7, color=colours[m]))
            for p in mp:
                if p in line:
                    continue
                marker = "s" if p["spp"] != 4 else "^" if p["rays"] != 150 else "D"
                face = "none" if not p["cache"] else colours[m]
                ax.plot(p[x], p[y], marker, color=colours[m], mfc=face, ms=6)
                time_bars(ax, [p], x, y, colours[m])
                short = " ".join(t for t in (f"{p['spp']}spp" if p["spp"] != 4 else "",
                                             f"{p['rays']}rays" if p["rays"] != 150 else "",
                                             "nocache" if not p["cache"] else "", *shadows_words(p)) if t)
                labels.append(ax.annotate(short, (p[x], p[y]), textcoords="offset points", xytext=(4, -8),
                                          fontsize=6, color=colours[m]))
        tr = sorted((p for p in usable if p["series"] == "truth"), key=lambda p: p["spp"])
        if tr:
            ax.plot([p[x] for p in tr], [p[y] for p in tr], "-*", color=TRUTH_COLOUR, ms=8, lw=1.5,
                    label=f"truth (triangles), {tr[0]['spp']}–{tr[-1]['spp']} spp")
            time_bars(ax, tr, x, y, TRUTH_COLOUR)
            for p in tr:
                labels.append(ax.annotate(f"{p['spp']} spp", (p[x], p[y]), textcoords="offset points", xytext=(4, 4),
                                          fontsize=7))
        front = [usable[i] for i in pareto_front(usable, x, y)]
        if front:
            fx, fy = [front[0][x]], [front[0][y]]
            for p in front[1:]:
                fx += [p[x], p[x]]
                fy += [fy[-1], p[y]]
            ax.plot(fx, fy, "--", color="0.45", lw=1, label="Pareto front")
            ax.scatter([p[x] for p in front], [p[y] for p in front], s=140, facecolors="none", edgecolors="0.3",
                       linewidths=1.2)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(LABEL[x])
        ax.set_ylabel(LABEL[y])
        ax.grid(True, which="both", alpha=0.25)
    h, lab = axes.flat[0].get_legend_handles_labels()
    from matplotlib.lines import Line2D

    h += [Line2D([], [], marker="s", ls="", color="0.4", label="other render spp"),
          Line2D([], [], marker="D", ls="", color="0.4", mfc="none", label="shading cache off"),
          Line2D([], [], marker="^", ls="", color="0.4", label="other bake rays per voxel")]
    fig.legend(handles=h, loc="lower center", ncol=4, fontsize=8, frameon=False)
    g = meta["git"]
    fig.suptitle(f"{scene}: error against cost (numbers by the lines: voxel resolution at 4 spp; other points at "
                 f"128³ unless labelled; render time excludes the bake)\n{decl['truth_spp']}-spp reference, {pts[0]['width']}x{pts[0]['height']} images, "
                 f"{meta['threads']} thread(s); commit {g['commit'][:10]}{' (dirty)' if g['dirty'] else ''}, "
                 f"{meta['date'][:10]}", fontsize=10)
    fig.tight_layout(rect=(0, 0.06, 1, 0.95))
    place_labels(fig, labels, markers)  # after the layout: the offsets are measured on the final axes
    save_plot(fig, out_stem + ".png", dpi=110, meta=meta)
    plt.close(fig)
    return fig, labels


def build(meta, rows, decl, out):
    models = [m["name"] for m in meta["models"]]
    models += [m for m in dict.fromkeys(r["model"] for r in rows if r["kind"] == "model") if m not in models]
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    csv_rows, md = [], [f"# Error against cost ({meta['experiment']})", ""]
    md += [f"- {x}" for x in settings_text(meta)]
    md += ["", "Time = render ms per frame (bake excluded; the median of the timed repeats, bars from the fastest "
               "to the slowest); memory = records + sparse grid + the model's tables + precomputed shadows "
               "(truth: see pareto.py). "
               "A point is on a front when no other point is both cheaper and more accurate.", ""]
    for sc in scenes:
        pts = []
        for r in rows:
            if r["scene"] != sc:
                continue
            p = {"scene": sc, "series": "truth" if r["kind"] == "truth" else r["model"], "model": r["model"],
                 "res": r["res"], "spp": r["spp"], "rays": r["rays"], "cache": r["cache"],
                 "shadows": shadow_method(r), "shadow_skip": r.get("shadow_skip", True), "width": r["width"],
                 "height": r["height"], "render_ms": r.get("render_ms"), "render_ms_min": r.get("render_ms_min"),
                 "render_ms_spread": r.get("render_ms_spread"), "repeats": r.get("repeats"), "loaded": r.get("loaded"),
                 "bake_s": r.get("bake_s"), "mb": r.get("mb"),
                 "mse": r.get("mse"), "ssim": r.get("ssim"),
                 "one_minus_ssim": 1.0 - r["ssim"] if r.get("ssim") is not None else None, "psnr": r.get("psnr"),
                 "label": point_label(r), "status": r["status"], "error": r.get("error", ""), "kind": r["kind"]}
            pts.append(p)
        ok = [p for p in pts if p["status"] == "ok" and p["render_ms"] and p["mse"] is not None]
        truth = [p for p in ok if p["series"] == "truth"]
        md.append(f"## {sc}")
        md.append("")
        for x, y in AXES:
            usable = [p for p in ok if p[x] and p[y] and p[x] > 0 and p[y] > 0]
            front = [usable[i] for i in pareto_front(usable, x, y)]
            for p in pts:
                p[f"on_front_{x}_{y}"] = int(any(p is q for q in front))
            md.append(f"- front, {LABEL[y]} against {LABEL[x]}: " +
                      " → ".join(f"{p['label']} ({p[x]:.3g}, {p[y]:.3g})" for p in front))
        for p in ok:
            p["dominated_by_truth"] = int(p["series"] != "truth" and dominated_by_truth(p, truth))
        beaten = [p["label"] for p in ok if p.get("dominated_by_truth")]
        worth = [p["label"] for p in ok if p["series"] != "truth" and not p.get("dominated_by_truth")]
        md.append(f"- beaten by the brute-force truth (a truth render that is faster, lower MSE and higher SSIM): "
                  f"{', '.join(beaten) if beaten else 'none'}")
        md.append(f"- not beaten by any truth render: {', '.join(worth) if worth else 'none'}")
        if len(truth) > 1:
            bad = truth_time_violations(truth)
            md.append("- truth render time against spp: " + (
                "monotone within the spread (" + ", ".join(f"{p['spp']} spp {p['render_ms']:.3g} ms ± "
                                                           f"{p['render_ms_spread'] or 0:.2g}" for p in
                                                           sorted(truth, key=lambda p: p["spp"])) + ")"
                if not bad else "NOT monotone beyond the spread: " + "; ".join(
                    f"{b['spp']} spp ({b['render_ms_min']:.3g}–{b['render_ms_min'] + (b['render_ms_spread'] or 0):.3g}"
                    f" ms) faster than {a['spp']} spp ({a['render_ms_min']:.3g} ms at best)" for a, b in bad)))
        failed = [p for p in pts if p["status"] != "ok"]
        if failed:
            md.append("- failed: " + "; ".join(f"{p['label']}: {p['error']}" for p in failed))
        md.append("")
        if ok:
            plot_scene(sc, ok, models, os.path.join(out, f"pareto_{sc}"), meta, decl)
        csv_rows += pts
    write_csv(os.path.join(out, "pareto.csv"), csv_rows, CSV_FIELDS)
    write_text(os.path.join(out, "pareto.md"), "\n".join(md) + "\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    add_common_args(ap, experiment=os.path.join(REPO, "experiments", "pareto.json"))
    a = ap.parse_args(argv)

    def go():
        decl = load_declaration(a.experiment, a.voxlab)
        meta, rows = run_experiment(decl, **sweep_args(a))
        out = os.path.join(os.path.abspath(a.results), decl["name"])
        build(meta, rows, decl, out)
        print(f"pareto: wrote {rel(out, REPO)}/pareto.csv, pareto.md, pareto_<scene>.png/.pdf/.svg", file=sys.stderr)
        return 0

    return main_wrapper(go, "pareto")


if __name__ == "__main__":
    sys.exit(main())
