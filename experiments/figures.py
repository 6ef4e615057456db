#!/usr/bin/python3
"""The papers' figures regenerated from our own runs (make figures).

    /usr/bin/python3 experiments/figures.py [--only grids,view_angle,coverage,dof] [--results results]
        [--jobs 2] [--voxlab build/voxlab] [--fresh]

Runs (cached) experiments/table1.json and the figure declarations experiments/fig_*.json, then
writes into <results>/figures/:

  grid_<scene>_<N>.png     Brito et al. 2023, Figure 11: truth | each model (sRGB previews) above each
                           model's error map (per-pixel squared error of the linear images, mean of
                           R, G, B, on ONE colour scale per grid, so the colours compare across models);
                           titles carry MSE and SSIM from the table. figure11_<N>.png: every scene.
  view_angle.png           Heitz & Neyret 2012, Figure 9: the heightfield's mean colour (R, G, B)
                           against the view elevation, truth and each model, plus colour swatches.
  coverage.png             Brito et al. 2023, Figure 4: silhouette coverage (from black- and
                           white-background renders) of the truth and each model, and model - truth.
  figure7.png              Brito et al. Figure 7: the bunny at 128^3 and 256^3, Averages | [VJK21] | Ours
                           | truth (alpha | vicini | vmesh); tables/: Tables 1 and 2 and Table 1 beside
                           the paper's, from the same runs (table1.py).
  figure10.png             Brito et al. Figure 10: diffuse / specular, light in front / behind, red
                           background (fig_paper10.json).
  island2x2.png/.md/.csv   Brito et al. §5: each model at 256^3 averaged 2x2 to 128^2 against the
                           same model at 128^3, metrics by voxlab compare, the paper's numbers beside.
  dof_<scene>.png          depth of field: truth, each model at low and high spp, error maps; which
                           models pre-filter (cone marching) is stated; dof_<scene>_cost.png: MSE
                           against render time for the same renders.
  figures.md               what each figure shows, with the run's date, machine, commit, settings.

Every plot is written as .png, .pdf and .svg (fonts embedded) with <stem>.json naming the voxlab
binary, commit and date it was drawn from (voxlab_exp/plots.py); each model has its colour of every
figure; titles state the images' size from the rows.

A figure that needs a model which is not registered (heitz-neyret for view_angle and dof) is drawn
with the models that exist and says so in its title. Failed configurations show as a grey tile
with the reason.
"""
import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from voxlab_exp.cli import add_common_args, main_wrapper  # noqa: E402
from voxlab_exp.config import REPO  # noqa: E402
from voxlab_exp.files import load_json, rel, write_csv, write_text  # noqa: E402
from voxlab_exp.plots import TRUTH_COLOUR, model_colour, save_plot, stamp  # noqa: E402
from voxlab_exp.plots import clean_axes, pyplot  # noqa: E402
from voxlab_exp.images import read_exr, srgb8  # noqa: E402
from voxlab_exp import paper_figs  # noqa: E402
from voxlab_exp.report import settings_text, size_text  # noqa: E402
from voxlab_exp.rows import run_experiment  # noqa: E402
from voxlab_exp.scenes import write_variant  # noqa: E402
from voxlab_exp.scheduler import Sweep  # noqa: E402
from voxlab_exp.schema import load_declaration  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
FIGURES = ["grids", "view_angle", "coverage", "dof", "figure7", "figure10", "island2x2"]


def load_png(results, rel):
    from PIL import Image

    return np.asarray(Image.open(os.path.join(results, rel)).convert("RGB"))


def load_exr(results, rel):
    return read_exr(os.path.join(results, rel))[..., :3]


def sq_error(results, row):
    """Per-pixel squared error against the row's truth, mean over R, G, B (linear values)."""
    return ((load_exr(results, row["image"]) - load_exr(results, row["truth_image"])) ** 2).mean(axis=2)


def failed_tile(ax, text):
    ax.set_facecolor("0.85")
    ax.text(0.5, 0.5, "failed:\n" + "\n".join(text[i:i + 28] for i in range(0, min(len(text), 140), 28)),
            ha="center", va="center", fontsize=6, transform=ax.transAxes, wrap=True)


# ---------------------------------------------------------------------------------------------- grids


def grids(meta, rows, results, out):
    plt = pyplot()
    models = [m for m in dict.fromkeys(r["model"] for r in rows if r["kind"] == "model")]
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    resolutions = list(dict.fromkeys(r["res"] for r in rows))
    cell = {(r["scene"], r["res"], r["model"]): r for r in rows if r["kind"] == "model"}
    written = []

    def draw_row(axes_img, axes_err, sc, n, vmax_out):
        any_r = next((cell[(sc, n, m)] for m in models if (sc, n, m) in cell and cell[(sc, n, m)].get("truth_preview")
                      and os.path.exists(os.path.join(results, cell[(sc, n, m)]["truth_preview"]))), None)
        if any_r:
            axes_img[0].imshow(load_png(results, any_r["truth_preview"]), interpolation="nearest")
            axes_img[0].set_title(f"truth ({any_r['truth_spp']} spp)", fontsize=8)
        else:
            failed_tile(axes_img[0], "no truth")
        errs = {}
        for m in models:
            r = cell.get((sc, n, m))
            if r and r["status"] == "ok":
                errs[m] = sq_error(results, r)
        vmax = max([np.percentile(e, 99.5) for e in errs.values()] + [1e-12])
        vmax_out.append(vmax)
        for i, m in enumerate(models):
            r = cell.get((sc, n, m))
            ai, ae = axes_img[i + 1], axes_err[i + 1] if axes_err is not None else None
            if not r or r["status"] != "ok":
                failed_tile(ai, (r or {}).get("error", "not run"))
                ai.set_title(m, fontsize=8)
                if ae is not None:
                    clean_axes(ae)
                continue
            ai.imshow(load_png(results, r["preview"]), interpolation="nearest")
            ai.set_title(f"{m}\nMSE {r['mse']:.2e}\nSSIM {r['ssim']:.3f}", fontsize=7, color=model_colour(m))
            if ae is not None:
                ae.imshow(errs[m], cmap="magma", vmin=0, vmax=vmax, interpolation="nearest")
                ae.set_title(f"{m} error", fontsize=7, color=model_colour(m))
        return vmax

    for n in resolutions:
        for sc in scenes:
            cols = 1 + len(models)
            tile = max(n, 160) / 100
            fig, axes = plt.subplots(2, cols, figsize=(cols * tile, 2 * tile + 1.3), squeeze=False)
            for ax in axes.flat:
                clean_axes(ax)
            v = []
            draw_row(axes[0], axes[1], sc, n, v)
            axes[1][0].text(0.5, 0.5, f"squared error\n(mean of R, G, B)\nscale 0 – {v[0]:.2g}\n(same for every\n"
                                      f"model; 99.5th pct.)", ha="center", va="center", fontsize=7,
                            transform=axes[1][0].transAxes)
            sm = plt.cm.ScalarMappable(cmap="magma", norm=plt.Normalize(0, v[0]))
            fig.colorbar(sm, ax=list(axes[1]), fraction=0.015, pad=0.01)
            px = size_text([r for r in rows if r["kind"] == "model" and r["scene"] == sc and r["res"] == n])
            fig.suptitle(f"{sc}, {n}³ voxels, {px} pixels — {stamp(meta)}", fontsize=9)
            path = os.path.join(out, f"grid_{sc}_{n}.png")
            save_plot(fig, path, dpi=100, meta=meta)
            plt.close(fig)
            written.append(path)
        # The overview: every scene a row, images then error maps (each row on its own scale).
        cols = 1 + 2 * len(models)
        tile = 1.7
        fig, axes = plt.subplots(len(scenes), cols, figsize=(cols * tile, len(scenes) * (tile + 0.55)), squeeze=False)
        for ax in axes.flat:
            clean_axes(ax)
        for k, sc in enumerate(scenes):
            v = []
            row_axes = axes[k]
            draw_row(row_axes[:1 + len(models)], None, sc, n, v)
            for i, m in enumerate(models):
                r = cell.get((sc, n, m))
                ae = row_axes[1 + len(models) + i]
                if r and r["status"] == "ok":
                    ae.imshow(sq_error(results, r), cmap="magma", vmin=0, vmax=v[0], interpolation="nearest")
                    ae.set_title(f"{m} error", fontsize=7)
            row_axes[0].set_ylabel(sc, fontsize=9)
        px = size_text([r for r in rows if r["kind"] == "model" and r["res"] == n])
        fig.suptitle(f"Figure 11 analogue: {n}³ voxels, {px} pixels; error maps share one scale per row — "
                     f"{stamp(meta)}", fontsize=10)
        fig.tight_layout(rect=(0, 0, 1, 0.97))
        path = os.path.join(out, f"figure11_{n}.png")
        save_plot(fig, path, dpi=100, meta=meta)
        plt.close(fig)
        written.append(path)
    return written


# ---------------------------------------------------------------------------------------------- view angle


def view_angle(sw, decl, meta, rows, results, out):
    """Mean colour over the fully covered pixels against the varied camera parameter."""
    plt = pyplot()
    fig_decl = decl["figure"]
    key = fig_decl.get("vary", "camera.orbit.elevation_deg")
    bg = fig_decl.get("coverage_background", [1, 1, 1])
    scenes = {s["name"]: s for s in decl["scenes"]}
    models = [m["name"] for m in meta["models"]]
    # The coverage masks: each variant's truth again on another background, same samples.
    extra = {}
    for name, s in scenes.items():
        r0 = next((r for r in rows if r["scene"] == name), None)
        if r0 is None:
            continue
        path = write_variant(s["path"], name + "_bg", {"background": bg}, os.path.join(sw.cache_dir, "scenes"))
        extra[name] = (sw.truth(path, name + "_bg", [r0["width"], r0["height"]], decl["truth_spp"], decl["seed"]),
                       sw.truth(s["path"], name, [r0["width"], r0["height"]], decl["truth_spp"], decl["seed"]))
    sw.name = decl["name"] + " (masks)"
    sw.run([j for pair in extra.values() for j in pair])
    series = {"truth": {}}
    for m in models:
        series[m] = {}
    notes = []
    for name, (tw, tb) in extra.items():
        angle = json.loads(next(r for r in rows if r["scene"] == name)["variant"])[key]
        if tw.status not in ("ok", "cached") or tb.status not in ("ok", "cached"):
            notes.append(f"{name}: truth failed: {tw.error or tb.error}")
            continue
        iw, ib = read_exr(tw.path("image.exr"))[..., :3], read_exr(tb.path("image.exr"))[..., :3]
        own_bg = load_json(scenes[name]["path"]).get("background", [0, 0, 0])
        span = np.abs(np.asarray(bg, float) - np.asarray(own_bg, float))
        full = (np.abs(iw - ib) <= 1e-4 * np.maximum(span, 1e-3) + 1e-6).all(axis=2)
        # One pixel in from the mask's edge: a voxel model's silhouette may differ by a pixel there.
        core = full.copy()
        core[1:, :] &= full[:-1, :]
        core[:-1, :] &= full[1:, :]
        core[:, 1:] &= full[:, :-1]
        core[:, :-1] &= full[:, 1:]
        if core.sum() < 16:
            notes.append(f"{name}: fewer than 16 fully covered pixels; skipped")
            continue
        series["truth"][angle] = ib[core].mean(axis=0)
        for r in rows:
            if r["scene"] == name and r["kind"] == "model" and r["status"] == "ok":
                series.setdefault(r["model"], {})[angle] = load_exr(results, r["image"])[core].mean(axis=0)
            elif r["scene"] == name and r["kind"] == "model":
                notes.append(f"{r['model']} at {angle}: {r['error']}")
    missing = fig_decl.get("needs_model")
    title_extra = f" — {missing} is not registered: curves for the models that exist" \
        if missing and missing not in models else ""
    colours = {m: model_colour(m) for m in models}
    fig = plt.figure(figsize=(13, 7.5))
    gs = fig.add_gridspec(2, 3, height_ratios=[3, 1.25])
    chans = ["red", "green", "blue"]
    for c in range(3):
        ax = fig.add_subplot(gs[0, c])
        for name, pts in series.items():
            if not pts:
                continue
            xs = sorted(pts)
            ax.plot(xs, [pts[x][c] for x in xs], "-o" if name != "truth" else "-*", ms=5 if name != "truth" else 9,
                    color=TRUTH_COLOUR if name == "truth" else colours.get(name, model_colour(name)), lw=2 if name == "truth" else 1.2,
                    label=name)
        ax.set_xlabel("view elevation above the surface (degrees)")
        ax.set_ylabel(f"mean {chans[c]} (linear)")
        ax.grid(alpha=0.3)
        if c == 0:
            ax.legend(fontsize=8)
    ax = fig.add_subplot(gs[1, :])
    names = [n for n, pts in series.items() if pts]
    angles = sorted({a for pts in series.values() for a in pts})
    sw_img = np.ones((len(names), len(angles), 3))
    for i, n in enumerate(names):
        for j, a in enumerate(angles):
            if a in series[n]:
                sw_img[i, j] = srgb8(np.asarray(series[n][a])[None, None, :])[0, 0] / 255.0
    ax.imshow(sw_img, aspect="auto", interpolation="nearest")
    ax.set_yticks(range(len(names)), names, fontsize=8)
    ax.set_xticks(range(len(angles)), [f"{a:g}°" for a in angles], fontsize=8)
    ax.set_title("mean colour (sRGB swatches)", fontsize=9)
    r0 = next((r for r in rows if r["kind"] == "model"), None)
    fig.suptitle(f"Heitz & Neyret Figure 9 analogue: heightfield colour against view elevation "
                 f"({r0['res'] if r0 else '?'}³ voxels, {r0['width'] if r0 else '?'}² px, truth "
                 f"{decl['truth_spp']} spp){title_extra}\n{stamp(meta)}", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    path = os.path.join(out, "view_angle.png")
    save_plot(fig, path, dpi=100, meta=meta)
    plt.close(fig)
    data = [{"series": n, "angle": a, "r": float(v[0]), "g": float(v[1]), "b": float(v[2])}
            for n, pts in series.items() for a, v in sorted(pts.items())]
    write_csv(os.path.join(out, "view_angle.csv"), data, ["series", "angle", "r", "g", "b"])
    return [path], notes


# ---------------------------------------------------------------------------------------------- coverage


def coverage(decl, meta, rows, results, out):
    plt = pyplot()
    key = decl["figure"].get("vary", "background")
    models = [m for m in dict.fromkeys(r["model"] for r in rows if r["kind"] == "model")]
    families = list(dict.fromkeys(r["base_scene"] for r in rows))
    by = {}
    for r in rows:
        bgv = tuple(json.loads(r["variant"])[key])
        by[(r["base_scene"], r["model"], sum(bgv) > 1.5)] = r
    cols = 1 + 2 * len(models)
    fig, axes = plt.subplots(len(families), cols, figsize=(cols * 2.0, len(families) * 2.5), squeeze=False)
    summary = []
    for ax in axes.flat:
        clean_axes(ax)
    for k, fam in enumerate(families):
        any_r = next((by.get((fam, m, True)) for m in models if by.get((fam, m, True))), None)
        any_b = next((by.get((fam, m, False)) for m in models if by.get((fam, m, False))), None)
        ok_truth = any_r and any_b and any_r.get("truth_image") and any_b.get("truth_image") and \
            os.path.exists(os.path.join(results, any_r["truth_image"]))
        if not ok_truth:
            failed_tile(axes[k][0], "truth missing")
            continue
        at = 1.0 - (load_exr(results, any_r["truth_image"]) - load_exr(results, any_b["truth_image"])).mean(axis=2)
        at = np.clip(at, 0, 1)
        inside = at > 0.5
        edge = inside ^ np.roll(inside, 1, 0) | inside ^ np.roll(inside, 1, 1)
        band = edge.copy()
        for _ in range(3):  # three pixels either side of the silhouette
            band = band | np.roll(band, 1, 0) | np.roll(band, -1, 0) | np.roll(band, 1, 1) | np.roll(band, -1, 1)
        axes[k][0].imshow(at, cmap="gray", vmin=0, vmax=1, interpolation="nearest")
        axes[k][0].set_title(f"{fam}: truth coverage", fontsize=7)
        axes[k][0].set_ylabel(fam)
        for i, m in enumerate(models):
            rw, rb = by.get((fam, m, True)), by.get((fam, m, False))
            ai, ad = axes[k][1 + i], axes[k][1 + len(models) + i]
            if not rw or not rb or rw["status"] != "ok" or rb["status"] != "ok":
                failed_tile(ai, ((rw or {}).get("error") or (rb or {}).get("error") or "not run"))
                ai.set_title(m, fontsize=7)
                continue
            am = np.clip(1.0 - (load_exr(results, rw["image"]) - load_exr(results, rb["image"])).mean(axis=2), 0, 1)
            d = am - at
            band_err = float(np.abs(d[band]).mean())
            total = float((am.sum() - at.sum()) / max(at.sum(), 1e-9))
            summary.append({"scene": fam, "model": m, "res": rw["res"], "silhouette_abs_error": band_err,
                            "total_coverage_change": total})
            ai.imshow(am, cmap="gray", vmin=0, vmax=1, interpolation="nearest")
            ai.set_title(f"{m}\nedge |Δ| {band_err:.3f}, total {total:+.1%}", fontsize=7)
            ad.imshow(d, cmap="RdBu_r", vmin=-1, vmax=1, interpolation="nearest")
            ad.set_title(f"{m} − truth\n(red: too much)", fontsize=7)
    r0 = next((r for r in rows if r["kind"] == "model"), {})
    fig.suptitle(f"Brito et al. Figure 4 analogue: silhouette coverage at {r0.get('res', '?')}³ voxels, "
                 f"{r0.get('width', '?')}² px, {r0.get('spp', '?')} spp (coverage = 1 − (white-bg − black-bg image)); "
                 f"edge |Δ| = mean |model − truth| within 3 px of the silhouette, total = coverage summed over the "
                 f"image vs truth\n{stamp(meta)}", fontsize=8)
    fig.tight_layout(rect=(0, 0, 1, 0.92))
    path = os.path.join(out, "coverage.png")
    save_plot(fig, path, dpi=100, meta=meta)
    plt.close(fig)
    write_csv(os.path.join(out, "coverage.csv"), summary,
                 ["scene", "model", "res", "silhouette_abs_error", "total_coverage_change"])
    return [path]


# ---------------------------------------------------------------------------------------------- depth of field


def dof(decl, meta, rows, results, out):
    plt = pyplot()
    pre = decl["figure"].get("prefiltered", [])
    registered = [m["name"] for m in meta["models"]]
    models = [m for m in dict.fromkeys(r["model"] for r in rows if r["kind"] == "model")]
    spps = sorted({r["spp"] for r in rows})
    written = []
    for sc in dict.fromkeys(r["scene"] for r in rows):
        cell = {(r["model"], r["spp"]): r for r in rows if r["scene"] == sc}
        cols = 1 + len(models)
        fig, axes = plt.subplots(2 * len(spps), cols, figsize=(cols * 2.4, 2 * len(spps) * 2.55), squeeze=False)
        for ax in axes.flat:
            clean_axes(ax)
        ok = [r for r in cell.values() if r["status"] == "ok"]
        errs = {(r["model"], r["spp"]): sq_error(results, r) for r in ok}
        vmax = max([np.percentile(e, 99.5) for e in errs.values()] + [1e-12])
        tr = next((r for r in cell.values() if r.get("truth_preview") and
                   os.path.exists(os.path.join(results, r["truth_preview"]))), None)
        if tr:
            axes[0][0].imshow(load_png(results, tr["truth_preview"]))
            axes[0][0].set_title(f"truth, {tr['truth_spp']} lens samples", fontsize=7)
        axes[1][0].text(0.5, 0.5, f"error maps:\nsquared error,\none scale 0–{vmax:.2g}", ha="center", va="center",
                        fontsize=7, transform=axes[1][0].transAxes)
        for k, spp in enumerate(spps):
            for i, m in enumerate(models):
                r = cell.get((m, spp))
                ai, ae = axes[2 * k][1 + i], axes[2 * k + 1][1 + i]
                kind = "pre-filtered cone" if m in pre else "lens-sampled"
                if not r or r["status"] != "ok":
                    failed_tile(ai, (r or {}).get("error", "not run"))
                    ai.set_title(f"{m} {spp} spp", fontsize=7)
                    continue
                ai.imshow(load_png(results, r["preview"]))
                ai.set_title(f"{m} ({kind}), {spp} spp\nMSE {r['mse']:.2e}, {r['render_ms']:.0f} ms", fontsize=7)
                ae.imshow(errs[(m, spp)], cmap="magma", vmin=0, vmax=vmax)
        missing = [m for m in pre if m not in registered]
        note = f" — pre-filtered model(s) {', '.join(missing)} not registered: lens-sampled models only" \
            if missing else ""
        fig.suptitle(f"Depth of field with and without pre-filtering: {sc}{note}\n{stamp(meta)}", fontsize=9)
        fig.tight_layout(rect=(0, 0, 1, 0.95))
        path = os.path.join(out, f"dof_{sc}.png")
        save_plot(fig, path, dpi=100, meta=meta)
        plt.close(fig)
        written.append(path)
        fig, ax = plt.subplots(figsize=(6.5, 4.5))
        for i, m in enumerate(models):
            pts = sorted((r for r in ok if r["model"] == m), key=lambda r: r["spp"])
            if pts:
                ax.plot([r["render_ms"] for r in pts], [r["mse"] for r in pts], "-o" if m not in pre else "-s",
                        color=model_colour(m), label=f"{m} ({'pre-filtered' if m in pre else 'lens rays'})")
                for r in pts:
                    ax.annotate(f"{r['spp']} spp", (r["render_ms"], r["mse"]), textcoords="offset points",
                                xytext=(4, 3), fontsize=7)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("render time per frame (ms)")
        ax.set_ylabel("MSE against the DoF truth")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
        ax.set_title(f"{sc}: depth of field, error against time{note}", fontsize=9)
        fig.tight_layout()
        path = os.path.join(out, f"dof_{sc}_cost.png")
        save_plot(fig, path, dpi=100, meta=meta)
        plt.close(fig)
        written.append(path)
    return written


# ---------------------------------------------------------------------------------------------- main


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    add_common_args(ap, experiment=os.path.join(HERE, "table1.json"))
    ap.add_argument("--only", default=",".join(FIGURES), help=f"comma-separated subset of {','.join(FIGURES)}")
    ap.add_argument("--view-angle", default=os.path.join(HERE, "fig_hn_angle.json"))
    ap.add_argument("--coverage", default=os.path.join(HERE, "fig_silhouette.json"))
    ap.add_argument("--dof", default=os.path.join(HERE, "fig_dof.json"))
    ap.add_argument("--figure10", default=os.path.join(HERE, "fig_paper10.json"))
    a = ap.parse_args(argv)
    only = [x.strip() for x in a.only.split(",") if x.strip()]
    bad = [x for x in only if x not in FIGURES]
    if bad:
        ap.error(f"--only: unknown figure(s) {', '.join(bad)} (known: {', '.join(FIGURES)})")

    def go():
        results = os.path.abspath(a.results)
        out = os.path.join(results, "figures")
        os.makedirs(out, exist_ok=True)
        decls = {"grids": a.experiment, "view_angle": a.view_angle, "coverage": a.coverage, "dof": a.dof,
                 "figure7": a.experiment, "figure10": a.figure10, "island2x2": a.experiment}
        loaded = {k: load_declaration(decls[k], a.voxlab) for k in only}  # every declaration checked before any work
        cache = a.cache or os.path.join(results, "cache")
        sw = Sweep(a.voxlab, cache, jobs=a.jobs, fresh=a.fresh, name="figures", executor=a.executor,
                      scheduler=a.scheduler, slurm_args=a.slurm_args, repeats=a.repeats,
                      group_bakes=not a.separate_bakes)
        md = ["# Figures", ""]
        for k in only:
            decl = loaded[k]
            sw.timeout = decl["timeout_s"]
            meta, rows = run_experiment(decl, results=results, cache_dir=cache, sweep=sw)
            notes = []
            if k == "grids":
                paths = grids(meta, rows, results, out)
            elif k == "view_angle":
                paths, notes = view_angle(sw, decl, meta, rows, results, out)
            elif k == "coverage":
                paths = coverage(decl, meta, rows, results, out)
            elif k == "figure7":
                paths = paper_figs.figure7(meta, rows, results, out)
                # Tables 1 and 2 (triangles, MB, bake s, ms per frame, every model) from the same runs.
                import table1

                os.makedirs(os.path.join(out, "tables"), exist_ok=True)
                table1.build(meta, rows, decl, os.path.join(out, "tables"))
                notes = ["tables/table1.md, tables/table2.md and tables/table1_vs_paper.md: Tables 1 and 2 "
                         "from the same runs, beside the paper's Table 1"]
            elif k == "figure10":
                paths = paper_figs.figure10(meta, rows, results, out)
            elif k == "island2x2":
                paths, _ = paper_figs.island2x2(meta, rows, results, out, a.voxlab)
                notes = ["island2x2.md: the table, with the paper's figures and whether its claim holds"]
            else:
                paths = dof(decl, meta, rows, results, out)
            md += [f"## {k}: {', '.join(os.path.basename(p) for p in paths)}", "", decl["description"], ""]
            md += [f"- {x}" for x in settings_text(meta)]
            md += [f"- note: {n}" for n in notes]
            md += [""] + [f"![{os.path.basename(p)}]({os.path.basename(p)})" for p in paths] + [""]
            print(f"figures: {k}: wrote {', '.join(rel(p, REPO) for p in paths)}", file=sys.stderr)
        write_text(os.path.join(out, "figures.md"), "\n".join(md) + "\n")
        return 0

    return main_wrapper(go, "figures")


if __name__ == "__main__":
    sys.exit(main())
