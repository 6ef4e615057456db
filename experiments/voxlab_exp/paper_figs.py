"""Brito et al. 2023's comparison figures with the three methods in the paper's order, Averages |
[VJK21] | Ours | truth (alpha | vicini | vmesh | truth), drawn from our runs (make figures):

  figure7    the bunny at 128^3 (128^2 px) and 256^3 (256^2 px), from the table1 runs;
  figure10   diffuse and specular shading, light in front of and behind the bunny, red background
             (experiments/fig_paper10.json);
  island2x2  §5's experiment: each model at 256^3 rendered at 256^2 and averaged 2x2 to 128^2,
             against the 128^2 truth, beside each model at 128^3 (the paper: [VJK21] 0.0038 / 0.9085
             against Ours 0.0035 / 0.9294), metrics by `voxlab compare` on the averaged image.
"""
import json
import os
import subprocess

import numpy as np

from .files import write_csv, write_text
from .images import read_exr, srgb8
from .paper import load_paper
from .plots import clean_axes, model_colour, pyplot, save_plot, stamp

PAPER_ORDER = ["Averages", "[VJK21]", "Ours"]


def _tile(ax, results, rel_exr, title, colour="black"):
    path = os.path.join(results, rel_exr) if rel_exr else None
    if path and os.path.exists(path):
        ax.imshow(srgb8(read_exr(path)), interpolation="nearest")
    else:
        ax.set_facecolor("0.85")
        ax.text(0.5, 0.5, "not run", ha="center", va="center", fontsize=7, transform=ax.transAxes)
    ax.set_title(title, fontsize=7, color=colour)


def _method_columns():
    methods = load_paper()["methods"]
    return [(p, methods[p]) for p in PAPER_ORDER]


def _grid(rows_spec, meta, results, out, stem, title):
    """rows_spec: [(row label, {model: row}, truth row)] -> one figure, a row each."""
    plt = pyplot()
    cols = _method_columns()
    fig, axes = plt.subplots(len(rows_spec), len(cols) + 1, figsize=(2.2 * (len(cols) + 1), 2.9 * len(rows_spec)),
                             squeeze=False)
    for k, (label, by_model, truth) in enumerate(rows_spec):
        for i, (p, m) in enumerate(cols):
            r = by_model.get(m)
            ok = r is not None and r.get("status") == "ok"
            sub = f"\nMSE {r['mse']:.4f}  SSIM {r['ssim']:.4f}" if ok else "\nfailed" if r else "\nnot run"
            _tile(axes[k][i], results, r.get("image") if ok else None, f"{p} ({m}){sub}", model_colour(m))
        _tile(axes[k][-1], results, truth.get("truth_image") if truth else None,
              f"truth ({truth.get('truth_spp', '?')} spp)" if truth else "truth")
        axes[k][0].set_ylabel(label, fontsize=8)
        for ax in axes[k]:
            clean_axes(ax)
    fig.suptitle(f"{title}\n{stamp(meta)}", fontsize=9)
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    path = os.path.join(out, f"{stem}.png")
    save_plot(fig, path, dpi=110, meta=meta)
    plt.close(fig)
    return path


def figure7(meta, rows, results, out, scene="bunny"):
    """Figure 7 from the table1 rows: the bunny at each resolution run."""
    model_rows = [r for r in rows if r["kind"] == "model" and r["scene"] == scene]
    spec = []
    for n in sorted(set(r["res"] for r in model_rows)):
        at = {r["model"]: r for r in model_rows if r["res"] == n}
        truth = next((r for r in at.values() if r.get("truth_image")), None)
        w = next(iter(at.values()))
        spec.append((f"{n}³, {w['width']}x{w['height']} px", at, truth))
    if not spec:
        return []
    return [_grid(spec, meta, results, out, "figure7",
                  f"Brito et al. Figure 7 analogue: {scene} (Averages | [VJK21] | Ours | truth)")]


def figure10(meta, rows, results, out):
    """Figure 10 from fig_paper10.json: one row per scene variant (diffuse/specular x front/behind)."""
    model_rows = [r for r in rows if r["kind"] == "model"]
    spec = []
    for sc in dict.fromkeys(r["scene"] for r in model_rows):
        at = {r["model"]: r for r in model_rows if r["scene"] == sc}
        truth = next((r for r in at.values() if r.get("truth_image")), None)
        spec.append((sc.replace("bunny_", "").replace("_", ", "), at, truth))
    if not spec:
        return []
    return [_grid(spec, meta, results, out, "figure10",
                  "Brito et al. Figure 10 analogue: diffuse and specular shading,\nlight in front of and behind "
                  "the bunny, red background (transparency shows red)")]


def _write_exr(path, img):
    import OpenImageIO as oiio

    spec = oiio.ImageSpec(img.shape[1], img.shape[0], 3, oiio.FLOAT)
    buf = oiio.ImageBuf(spec)
    buf.set_pixels(oiio.ROI(0, img.shape[1], 0, img.shape[0]), np.ascontiguousarray(img[..., :3], dtype=np.float32))
    tmp = path + ".tmp.exr"
    if not buf.write(tmp):
        raise OSError(f"cannot write {path}: {buf.geterror()}")
    os.replace(tmp, path)


def box2(img):
    """The 2x2 box average (the paper's "averaged 2x2 pixels into one pixel")."""
    h, w = img.shape[0] // 2 * 2, img.shape[1] // 2 * 2
    x = img[:h, :w, :3]
    return 0.25 * (x[0::2, 0::2] + x[1::2, 0::2] + x[0::2, 1::2] + x[1::2, 1::2])


def island2x2(meta, rows, results, out, voxlab, scene="island"):
    """§5's island experiment for every model that ran at both resolutions (the paper's 256^3 and
    128^3 in make figures: the smallest resolution whose double was run, and that double)."""
    paper = load_paper()
    names = {m: p for p, m in paper["methods"].items()}
    at = {(r["res"], r["model"]): r for r in rows if r["kind"] == "model" and r["scene"] == scene and r["status"] == "ok"}
    ran = sorted({n for n, _ in at})
    coarse = next((n for n in ran if 2 * n in ran), None)
    if coarse is None:
        return [], []
    fine = 2 * coarse
    truth_c = next((r for (n, _), r in at.items() if n == coarse and r.get("truth_image")), None)
    if truth_c is None:
        return [], []
    table = []
    for m in dict.fromkeys(m for _, m in at):
        rf, rc = at.get((fine, m)), at.get((coarse, m))
        if not rf or not rc:
            continue
        down = os.path.join(out, f"island2x2_{m}.exr")
        _write_exr(down, box2(read_exr(os.path.join(results, rf["image"]))))
        res = subprocess.run([voxlab, "compare", down, os.path.join(results, truth_c["truth_image"]), "--json"],
                             capture_output=True, text=True)
        if res.returncode != 0:
            raise RuntimeError(f"voxlab compare on {down}: {res.stderr.strip()}")
        d = json.loads(res.stdout)
        table.append({"model": m, "paper_name": names.get(m, ""), f"mse_{coarse}": rc["mse"], f"ssim_{coarse}": rc["ssim"],
                      f"mse_{fine}_2x2": d["mse"], f"ssim_{fine}_2x2": d["ssim"]})
    fields = ["model", "paper_name", f"mse_{coarse}", f"ssim_{coarse}", f"mse_{fine}_2x2", f"ssim_{fine}_2x2"]
    write_csv(os.path.join(out, "island2x2.csv"), table, fields)
    p = paper["island_2x2"]
    md = [f"# The island 2x2 experiment (Brito et al. §5) — {stamp(meta)}", "",
          f"Each model at {fine}³ rendered at {fine}² and averaged 2x2 to {coarse}², against the {coarse}² truth "
          f"({truth_c.get('truth_spp', '?')} spp), beside the same model at {coarse}³ rendered at {coarse}². Metrics "
          "by `voxlab compare` (MSE, SSIM as scikit-image defines it).", "",
          f"| model | {coarse}³ MSE | {coarse}³ SSIM | {fine}³ → 2x2 MSE | {fine}³ → 2x2 SSIM |", "|---|---:|---:|---:|---:|"]
    for t in table:
        label = f"{t['model']} ({t['paper_name']})" if t["paper_name"] else t["model"]
        md.append(f"| {label} | {t[f'mse_{coarse}']:.4f} | {t[f'ssim_{coarse}']:.4f} | {t[f'mse_{fine}_2x2']:.4f} | "
                  f"{t[f'ssim_{fine}_2x2']:.4f} |")
    vic = next((t for t in table if t["model"] == "vicini"), None)
    ours = next((t for t in table if t["model"] == "vmesh"), None)
    md += ["", f"The paper: [VJK21] 256³ → 2x2: MSE {p['[VJK21] 256 -> 128'][0]}, SSIM {p['[VJK21] 256 -> 128'][1]}; "
               f"Ours 128³: MSE {p['Ours 128'][0]}, SSIM {p['Ours 128'][1]} (Ours better in both)."]
    if vic and ours:
        better_mse = ours[f"mse_{coarse}"] < vic[f"mse_{fine}_2x2"]
        better_ssim = ours[f"ssim_{coarse}"] > vic[f"ssim_{fine}_2x2"]
        md.append(f"Here: vicini {fine}³ → 2x2 MSE {vic[f'mse_{fine}_2x2']:.4f}, SSIM {vic[f'ssim_{fine}_2x2']:.4f}; "
                  f"vmesh {coarse}³ MSE {ours[f'mse_{coarse}']:.4f}, SSIM {ours[f'ssim_{coarse}']:.4f}: the paper's claim "
                  f"(the finer [VJK21] does not beat Ours) {'holds' if better_mse and better_ssim else 'holds in part' if better_mse or better_ssim else 'does not hold'} "
                  f"(MSE {'better' if better_mse else 'worse'}, SSIM {'better' if better_ssim else 'worse'} for vmesh).")
    write_text(os.path.join(out, "island2x2.md"), "\n".join(md) + "\n")

    plt = pyplot()
    fig, axes = plt.subplots(1, 1 + 2 * len(table), figsize=(2.0 * (1 + 2 * len(table)), 2.6), squeeze=False)
    ax = axes[0]
    _tile(ax[0], results, truth_c["truth_image"], f"truth {coarse}²")
    for i, t in enumerate(table):
        m = t["model"]
        _tile(ax[1 + 2 * i], results, at[(coarse, m)]["image"],
              f"{m} {coarse}³\n{t[f'mse_{coarse}']:.4f} / {t[f'ssim_{coarse}']:.3f}", model_colour(m))
        _tile(ax[2 + 2 * i], out, f"island2x2_{m}.exr",
              f"{m} {fine}³ → 2x2\n{t[f'mse_{fine}_2x2']:.4f} / {t[f'ssim_{fine}_2x2']:.3f}", model_colour(m))
    for a in ax:
        clean_axes(a)
    fig.suptitle(f"Island: {coarse}³ against {fine}³ averaged 2x2 (MSE / SSIM) — {stamp(meta)}", fontsize=8)
    fig.tight_layout(rect=(0, 0, 1, 0.9))
    path = os.path.join(out, "island2x2.png")
    save_plot(fig, path, dpi=110, meta=meta)
    plt.close(fig)
    return [path], table
