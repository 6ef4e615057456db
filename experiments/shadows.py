#!/usr/bin/python3
"""Shadow methods compared for every model (issue 18; make shadows).

    /usr/bin/python3 experiments/shadows.py [--experiment experiments/shadows.json] [--results results]
        [--jobs 2] [--voxlab build/voxlab] [--fresh] [--repeats R]

Runs the declared sweep (its runs list "shadows": march, slicemap, slicemap-model, voxel; cached as
every sweep is; "models": "all" leaves out voxel for a cone model, which has no voxels to
precompute), plus per scene and image size the truth without the shadows effect (which pixels the
truth has in shadow: where its shadows take away more than 5 % of the light) and the truth with its
slicemap instead of shadow rays (`voxlab truth --shadows slicemap`: a comparison of shadow
techniques on the triangles themselves). Writes into <results>/<name>/:

  shadows.csv/.md  per scene, resolution, model and method: MSE and SSIM against the truth, MSE over
                   the truth's shadowed pixels (mse_shadow), frame ms (median of the repeats), the
                   precomputation's ms (shadow_build_ms: apart from the frame), memory (the model's
                   MB + the shadow maps' or the per-voxel transmittances' MB); the truth's slicemap
                   rows beside. The .md's second table sets each precomputing method's frame against
                   march's (same run) and gives the largest pixel difference between voxel's image
                   and march's (0: voxel casts march's shadow rays, only before the frame).
  shadows_crops.png/.pdf/.svg  crops of the figure scene's ground where its shadows are partial
                   (the window with the most partly shadowed truth pixels): truth | march | slicemap |
                   slicemap-model, one row per model (voxel's image is march's).
  rows.csv, rows.json  the sweep's rows.
"""
import argparse
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from voxlab_exp.cli import add_common_args, main_wrapper, sweep_args  # noqa: E402
from voxlab_exp.config import REPO  # noqa: E402
from voxlab_exp.files import load_json, rel, write_csv, write_text  # noqa: E402
from voxlab_exp.images import read_exr, srgb8  # noqa: E402
from voxlab_exp.plots import save_plot  # noqa: E402
from voxlab_exp.report import settings_text  # noqa: E402
from voxlab_exp.rows import model_mb, run_experiment  # noqa: E402
from voxlab_exp.scheduler import Sweep  # noqa: E402
from voxlab_exp.schema import load_declaration  # noqa: E402
from voxlab_exp.scenes import write_variant  # noqa: E402

METHODS = ["march", "slicemap", "slicemap-model", "voxel"]
CROP_METHODS = ["march", "slicemap", "slicemap-model"]  # voxel's image is march's: no column of its own
FIELDS = ["scene", "res", "width", "height", "model", "shadows", "mse", "ssim", "mse_shadow", "shadow_pixels",
          "render_ms", "render_ms_spread", "shadow_build_ms", "mb", "shadow_mb", "total_mb", "max_diff_march",
          "status", "error"]
SHADOWED = 0.05  # a truth pixel is in shadow where its shadows take away more than this fraction


def luminance(img):
    return img[..., :3].mean(axis=2)


def shadow_mask(shadowed, unshadowed):
    """The truth's pixels in shadow: the shadows take away more than SHADOWED of their light."""
    lit = luminance(unshadowed)
    return lit - luminance(shadowed) > SHADOWED * lit


def mse_over(a, b, mask):
    import numpy as np

    if not mask.any():
        return None
    d = (a[..., :3] - b[..., :3]) ** 2
    return float(np.mean(d[mask]))


def crop_window(shadowed, unshadowed, fraction):
    """The square window (fraction of the image's side) with the most partly shadowed truth pixels
    (between 10 % and 90 % of the light kept): where the foliage's shadows are partial."""
    import numpy as np

    lit = luminance(unshadowed)
    ratio = np.where(lit > 1e-6, luminance(shadowed) / np.maximum(lit, 1e-6), 1.0)
    partial = ((ratio > 0.1) & (ratio < 0.9)).astype(np.float64)
    h, w = partial.shape
    side = max(8, int(min(h, w) * fraction))
    ii = np.pad(partial.cumsum(0).cumsum(1), ((1, 0), (1, 0)))
    best, at = -1.0, (0, 0)
    step = max(1, side // 8)
    for y in range(0, h - side + 1, step):
        for x in range(0, w - side + 1, step):
            s = ii[y + side, x + side] - ii[y, x + side] - ii[y + side, x] + ii[y, x]
            if s > best:
                best, at = s, (y, x)
    return at[0], at[1], side


def build(decl, sw, meta, rows, results, out):
    import numpy as np

    seed, truth_spp = decl["seed"], decl["truth_spp"]
    scenes = {s["name"]: s for s in decl["scenes"]}
    models = [r for r in rows if r["kind"] == "model"]
    sizes = sorted({(r["scene"], r["width"], r["height"]) for r in models})
    # The truth without shadows (which pixels are in shadow) and with its slicemap, per scene and size.
    extra, plain, slice_truth, refs = [], {}, {}, {}
    for sc, w, h in sizes:
        s = scenes[sc]
        sdata = load_json(s["path"])
        effects = [e for e in sdata.get("effects", []) if e != "shadows"]
        vpath = write_variant(s["path"], f"{sc}-noshadows", {"effects": effects, "shadows": None},
                              os.path.join(sw.cache_dir, "scenes"))
        plain[(sc, w, h)] = sw.truth(vpath, f"{sc}-noshadows", [w, h], truth_spp, seed)
        refs[(sc, w, h)] = sw.truth(s["path"], s["name"], [w, h], truth_spp, seed)
        st = sw.truth(s["path"], s["name"], [w, h], truth_spp, seed, shadows="slicemap")
        slice_truth[(sc, w, h)] = (st, sw.compare(refs[(sc, w, h)], st))
        extra += [plain[(sc, w, h)], st, slice_truth[(sc, w, h)][1]]
    sw.run(extra)
    images = {}

    def img(path):
        if path not in images:
            images[path] = read_exr(path)
        return images[path]

    table, masks = [], {}
    for key in sizes:
        ref, pl = refs[key], plain[key]
        if ref.status not in ("ok", "cached") or pl.status not in ("ok", "cached"):
            masks[key] = None
            continue
        masks[key] = shadow_mask(img(ref.path("image.exr")), img(pl.path("image.exr")))
    # voxel casts march's shadow rays, only before the frame: its image must be march's, which the
    # largest difference from march's image (any pixel and channel) shows on every voxel row.
    def same_render(r):
        return tuple(r.get(k) for k in ("scene", "res", "width", "height", "model", "spp", "rays", "cache",
                                        "shadow_skip"))
    march_images = {same_render(r): r["image"] for r in models if r["shadows"] == "march" and r["status"] == "ok"}
    for r in models:
        key = (r["scene"], r["width"], r["height"])
        row = {k: r.get(k) for k in FIELDS if k in r}
        if r["shadows"] == "voxel" and r["status"] == "ok" and same_render(r) in march_images:
            a = img(os.path.join(results, r["image"]))[..., :3]
            b = img(os.path.join(results, march_images[same_render(r)]))[..., :3]
            row["max_diff_march"] = float(np.max(np.abs(a - b))) if a.shape == b.shape else math.inf
        row.update(shadow_build_ms=r["shadow_build_s"] * 1e3 if r.get("shadow_build_s") is not None else None,
                   shadow_mb=r["shadow_bytes"] / 1e6 if r.get("shadow_bytes") is not None else None)
        # The rows' mb is everything the frame reads, the shadows included: here the model's part
        # (records, grid, tables) and the maps' apart.
        row["total_mb"] = row.get("mb")
        row["mb"] = model_mb(r)
        m = masks.get(key)
        if r["status"] == "ok" and m is not None:
            row["mse_shadow"] = mse_over(img(os.path.join(results, r["image"])), img(os.path.join(results,
                                                                                              r["truth_image"])), m)
            row["shadow_pixels"] = int(m.sum())
        table.append(row)
    for key in sizes:
        st, cmp_job = slice_truth[key]
        row = {"scene": key[0], "res": 0, "width": key[1], "height": key[2], "model": "truth", "shadows": "slicemap"}
        if st.status not in ("ok", "cached") or cmp_job.status not in ("ok", "cached") or masks[key] is None:
            row.update(status="failed", error=st.error or cmp_job.error or "truth failed")
        else:
            ms, ss = load_json(cmp_job.path("metrics.json")), load_json(st.path("stats.json"))
            t = st.timing() or {}
            row.update(status="ok", error="", mse=ms.get("mse"), ssim=ms.get("ssim"),
                       mse_shadow=mse_over(img(st.path("image.exr")), img(refs[key].path("image.exr")), masks[key]),
                       shadow_pixels=int(masks[key].sum()), render_ms=(t.get("median") or 0) * 1e3,
                       render_ms_spread=(t.get("spread") or 0) * 1e3,
                       shadow_build_ms=ss.get("shadow_build_seconds", 0) * 1e3,
                       shadow_mb=ss.get("shadow_bytes", 0) / 1e6)
        table.append(row)
    write_csv(os.path.join(out, "shadows.csv"), table, FIELDS)

    def f(v, d):
        """v with d decimals, or with -d significant digits in e-notation when d < 0."""
        return "–" if v is None else f"{v:.{-d - 1}e}" if d < 0 else f"{v:.{d}f}"

    lines = [f"# {decl['name']}: shadow methods", "", decl["description"], "", *settings_text(meta), "",
             "| scene | res | model | shadows | MSE | SSIM | MSE in shadow | frame ms | precompute ms | MB (model + maps) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in table:
        if r.get("status") != "ok":
            lines.append(f"| {r['scene']} | {r['res']} | {r['model']} | {r['shadows']} | failed: {r.get('error')} "
                         f"| | | | | |")
            continue
        res = r["res"] or f"{r['width']}x{r['height']} image"  # the truth's rows: no grid
        lines.append(f"| {r['scene']} | {res} | {r['model']} | {r['shadows']} | {f(r['mse'], -3)} | "
                     f"{f(r['ssim'], 4)} | {f(r.get('mse_shadow'), -3)} | {f(r.get('render_ms'), 1)} | "
                     f"{f(r.get('shadow_build_ms'), 1)} | {f(r.get('mb'), 2)} + {f(r.get('shadow_mb'), 2)} |")
    # Per model: the precomputing methods' frame times over march's (same run), voxel's image against
    # march's, and the errors side by side.
    lines += ["", "## Frames over march's (same run), voxel's image against march's, and the error in shadow", "",
              "| scene | res | model | slicemap-model / march | voxel / march | voxel − march (max) | "
              "MSE in shadow: march | slicemap | slicemap-model | voxel |", "|---|---|---|---|---|---|---|---|---|---|"]
    cell = {(r["scene"], r["res"], r["model"], r["shadows"]): r for r in table}

    def frame_ratio(c, method):
        return (c[method].get("render_ms") / c["march"]["render_ms"]
                if c["march"].get("render_ms") and c[method].get("render_ms") else None)

    for sc, res, model in sorted({(r["scene"], r["res"], r["model"]) for r in table if r["model"] != "truth"}):
        c = {m: cell.get((sc, res, model, m), {}) for m in METHODS}
        lines.append(f"| {sc} | {res} | {model} | {f(frame_ratio(c, 'slicemap-model'), 2)} | "
                     f"{f(frame_ratio(c, 'voxel'), 2)} | {f(c['voxel'].get('max_diff_march'), -2)} | " +
                     " | ".join(f(c[m].get("mse_shadow"), -3) for m in METHODS) + " |")
    write_text(os.path.join(out, "shadows.md"), "\n".join(lines) + "\n")

    # The crops: the figure scene's ground where the truth's shadows are partial.
    fig_cfg = decl.get("figure") or {}
    sc = fig_cfg.get("crop_scene", models[0]["scene"] if models else None)
    res = fig_cfg.get("crop_res", max((r["res"] for r in models if r["scene"] == sc), default=None))
    frows = [r for r in models if r["scene"] == sc and r["res"] == res and r["status"] == "ok"]
    if not frows:
        print(f"{decl['name']}: no rows for the crop figure ({sc} at {res}^3)", file=sys.stderr)
        return table
    key = (sc, frows[0]["width"], frows[0]["height"])
    truth_img = img(refs[key].path("image.exr"))
    y, x, side = crop_window(truth_img, img(plain[key].path("image.exr")), fig_cfg.get("crop_fraction", 0.4))
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    model_names = list(dict.fromkeys(r["model"] for r in frows))
    by = {(r["model"], r["shadows"]): r for r in frows}
    fig, axes = plt.subplots(len(model_names), 1 + len(CROP_METHODS), figsize=(8, 2.1 * len(model_names)),
                             squeeze=False)
    for i, m in enumerate(model_names):
        tiles = [("truth", truth_img)] + [(meth, img(os.path.join(results, by[(m, meth)]["image"]))
                                           if (m, meth) in by else None) for meth in CROP_METHODS]
        for j, (title, im) in enumerate(tiles):
            ax = axes[i][j]
            ax.set_xticks([])
            ax.set_yticks([])
            if im is not None:
                ax.imshow(srgb8(im[y:y + side, x:x + side, :3]), interpolation="nearest")
            ms = by.get((m, title), {}).get("mse_shadow") if title != "truth" else None
            ax.set_title(f"{title}" + (f"\nMSE in shadow {ms:.2e}" if ms is not None else ""), fontsize=8)
            if j == 0:
                ax.set_ylabel(m, fontsize=9)
    fig.suptitle(f"{sc} at {res}³, {key[1]}x{key[2]}: crop at ({x}, {y}), {side} px", fontsize=9)
    fig.tight_layout()
    save_plot(fig, os.path.join(out, "shadows_crops.png"), dpi=110, meta=meta)
    plt.close(fig)
    return table


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_common_args(ap, experiment=os.path.join(REPO, "experiments", "shadows.json"))
    a = ap.parse_args()
    decl = load_declaration(a.experiment, a.voxlab)
    kw = sweep_args(a)
    results = os.path.abspath(kw["results"])
    cache_dir = os.path.abspath(kw["cache_dir"] or os.path.join(results, "cache"))
    sw = Sweep(kw["voxlab"], cache_dir, jobs=kw["jobs"], fresh=kw["fresh"], name=decl["name"],
               timeout=decl["timeout_s"], executor=kw["executor"], scheduler=kw["scheduler"],
               slurm_args=kw["slurm_args"], repeats=kw["repeats"], group_bakes=kw["group_bakes"])
    try:
        meta, rows = run_experiment(decl, results=results, cache_dir=cache_dir, sweep=sw)
        out = os.path.join(results, decl["name"])
        table = build(decl, sw, meta, rows, results, out)
    finally:
        sw.close()
    print(f"{decl['name']}: {len(table)} row(s); wrote {rel(out, REPO)}/shadows.md, shadows.csv, shadows_crops.png",
          file=sys.stderr)
    return 0 if all(r.get("status") == "ok" for r in table) else 1


if __name__ == "__main__":
    sys.exit(main_wrapper(main, "shadows.py"))
