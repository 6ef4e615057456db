#!/usr/bin/python3
"""`make dynamic` (issue 17): which appearance model survives being moved by voxel transformation,
at what accuracy and what cost, against re-baking and against the truth.

For the animated scene scenes/dynamic.py writes (tori spinning and gliding over a plate), every
model and every filter (nearest, split8: records baked once and transformed each frame; rebake: the
posed scene baked whole each frame) renders every frame; each frame is compared with the truth of
that frame (MSE, SSIM: `voxlab compare`), and its milliseconds are split into the frame's voxels
(transform, or re-bake) and the render (--stats). Temporal stability: the mean |difference| between
consecutive frames of each method next to the truth's own (flicker ratio = method / truth; 1 is the
truth's motion, more is flicker). An object-count sweep (1 .. 256 objects) times the voxels of a
frame per filter. Outputs in --out (default results/dynamic/): rows.csv (every frame), sweep.csv,
summary.md (per model and filter; the models whose split8 error exceeds twice their re-baked error
are named), strip.png (truth and each model's split8 over a few frames), strip.gif (every frame),
error.png (per-frame MSE curves), flicker.png (frame-to-frame differences against the truth's),
time.png (sweep curve, every model and filter).

Voxlab is called directly (per-frame sequences do not fit the sweep engine's one-image jobs); runs
are not cached. Defaults are the issue's (128^3, 24 frames, sweep to 256); --quick is a CI-sized
run (32^3, 4 frames, 64x64, sweep 1, 4, 16).
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FILTERS = ["nearest", "split8", "rebake"]


def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit("experiments/dynamic.py: %s failed:\n%s" % (" ".join(cmd), p.stderr))
    return p


def read(path):
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(path)
    px = np.asarray(inp.read_image(oiio.FLOAT), dtype=np.float32)
    inp.close()
    return px[..., :3]


def make_scene(path, objects, frames):
    run([sys.executable, os.path.join(REPO, "scenes", "dynamic.py"), "--objects", str(objects), "--frames", str(frames),
         "-o", path])


def models(voxlab):
    out = run([voxlab, "models"]).stdout.split("\n")
    return [line.split()[0] for line in out if line.strip() and not line.startswith(" ")]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--voxlab", default=os.path.join(REPO, "build", "voxlab"))
    ap.add_argument("--out", default=os.path.join(REPO, "results", "dynamic"))
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--objects", type=int, default=12)
    ap.add_argument("--frames", type=int, default=24, help="frames of the animation (all rendered)")
    ap.add_argument("--size", default="192x192")
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--truth-spp", type=int, default=256)
    ap.add_argument("--models", default="", help="comma-separated (default: every model)")
    ap.add_argument("--sweep", default="1,4,16,64,256", help="object counts of the time curve ('' to skip)")
    ap.add_argument("--sweep-res", type=int, default=0, help="grid of the sweep (default --res)")
    ap.add_argument("--sweep-models", default="", help="comma-separated models of the sweep (default: --models)")
    ap.add_argument("--quick", action="store_true", help="CI size: 32^3, 4 frames, 64x64, sweep 1,4,16")
    ap.add_argument("--threads", type=int, default=0)
    a = ap.parse_args()
    if a.quick:
        a.res, a.frames, a.size, a.truth_spp, a.sweep, a.objects = 32, 4, "64x64", 32, "1,4,16", 6
    os.makedirs(a.out, exist_ok=True)
    work = tempfile.mkdtemp(prefix="dynamic_", dir=a.out)
    thr = ["--threads", str(a.threads)] if a.threads else []
    names = [m for m in (a.models.split(",") if a.models else models(a.voxlab)) if m]
    scene = os.path.join(work, "scene.json")
    make_scene(scene, a.objects, a.frames)
    last = a.frames - 1

    # The truth of every frame.
    run([a.voxlab, "truth", scene, "--frames", "0:%d" % last, "--spp", str(a.truth_spp), "--size", a.size, *thr,
         "-o", os.path.join(work, "truth.exr")])
    truth = [read(os.path.join(work, "truth_%04d.exr" % f)) for f in range(a.frames)]

    rows, fallbacks = [], {}
    for m in names:
        for flt in FILTERS:
            base = os.path.join(work, "%s_%s" % (m, flt))
            p = run([a.voxlab, "render", scene, "--model", m, "--res", str(a.res), "--spp", str(a.spp), "--size", a.size,
                     "--frames", "0:%d" % last, "--filter", flt, *thr, "-o", base + ".exr", "--stats", base + ".json"])
            for f in range(a.frames):
                img = base + "_%04d.exr" % f
                st = json.load(open(base + "_%04d.json" % f))
                if st.get("fallback"):
                    fallbacks[m] = st["fallback"]
                cmp = json.loads(run([a.voxlab, "compare", os.path.join(work, "truth_%04d.exr" % f), img, "--json"]).stdout)
                rows.append({"model": m, "filter": flt, "filter_used": st["filter_used"], "frame": f,
                             "mse": cmp["mse"], "ssim": cmp["ssim"],
                             "voxels_ms": 1e3 * st["frame_voxels_seconds"], "render_ms": 1e3 * st["seconds"],
                             "voxels": st["voxels"]})
            del p
    with open(os.path.join(a.out, "rows.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)

    # Flicker: mean |frame f+1 - frame f| of each method against the truth's.
    t_flicker = np.mean([np.mean(np.abs(truth[f + 1] - truth[f])) for f in range(a.frames - 1)])
    summary = []
    for m in names:
        for flt in FILTERS:
            r = [x for x in rows if x["model"] == m and x["filter"] == flt]
            imgs = [read(os.path.join(work, "%s_%s_%04d.exr" % (m, flt, f))) for f in range(a.frames)]
            pair_diffs = [float(np.mean(np.abs(imgs[f + 1] - imgs[f]))) for f in range(a.frames - 1)]
            fl = np.mean(pair_diffs)
            summary.append({"model": m, "filter": flt, "used": r[0]["filter_used"],
                            "mse": float(np.mean([x["mse"] for x in r])), "ssim": float(np.mean([x["ssim"] for x in r])),
                            "mse_frame0": r[0]["mse"],
                            "voxels_ms": float(np.median([x["voxels_ms"] for x in r[1:] or r])),
                            "render_ms": float(np.median([x["render_ms"] for x in r])),
                            "flicker": float(fl), "flicker_ratio": float(fl / t_flicker) if t_flicker > 0 else 0.0,
                            "pair_diffs": pair_diffs})

    # Object-count sweep: the voxels of a frame per filter (one model with transform, and re-bake).
    sweep = []
    counts = [int(x) for x in a.sweep.split(",") if x.strip()]
    sweep_models = [m for m in (a.sweep_models.split(",") if a.sweep_models else names) if m]
    for n in counts:
        sc = os.path.join(work, "sweep_%d.json" % n)
        make_scene(sc, n, max(a.frames, 3))
        for sweep_model in sweep_models:
            for flt in FILTERS:
                base = os.path.join(work, "sweep_%d_%s_%s" % (n, sweep_model, flt))
                run([a.voxlab, "render", sc, "--model", sweep_model, "--res", str(a.sweep_res or a.res), "--spp", "1",
                     "--size", "32x32", "--frames", "1:2", "--filter", flt, *thr, "-o", base + ".exr",
                     "--stats", base + ".json"])
                ms = [1e3 * json.load(open(base + "_%04d.json" % f))["frame_voxels_seconds"] for f in (1, 2)]
                st = json.load(open(base + "_0001.json"))
                sweep.append({"objects": n, "filter": flt, "model": sweep_model, "voxels_ms": float(np.median(ms)),
                              "prepare_ms": 1e3 * st.get("prepare_bake_seconds", 0.0), "voxels": st["voxels"]})
    if sweep:
        with open(os.path.join(a.out, "sweep.csv"), "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(sweep[0]))
            w.writeheader()
            w.writerows(sweep)

    figures(a, work, names, truth, sweep, summary)
    write_summary(a, names, summary, sweep, fallbacks, t_flicker)
    print(open(os.path.join(a.out, "summary.md")).read())


def figures(a, work, names, truth, sweep, summary):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    frames = sorted(set([0, a.frames // 3, 2 * a.frames // 3, a.frames - 1]))
    rows_ = [("truth", [truth[f] for f in frames])]
    for m in names:
        rows_.append(("%s split8" % m, [read(os.path.join(work, "%s_split8_%04d.exr" % (m, f))) for f in frames]))
    fig, ax = plt.subplots(len(rows_), len(frames), figsize=(2.2 * len(frames), 2.2 * len(rows_)), squeeze=False)
    for i, (label, ims) in enumerate(rows_):
        for j, im in enumerate(ims):
            ax[i][j].imshow(np.clip(im, 0, 1) ** (1 / 2.2))
            ax[i][j].set_xticks([]), ax[i][j].set_yticks([])
            if j == 0:
                ax[i][j].set_ylabel(label, fontsize=8)
            if i == 0:
                ax[i][j].set_title("frame %d" % frames[j], fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "strip.png"), dpi=80)
    plt.close(fig)
    write_gif(a, work, names, truth)
    # Per-frame error of every model and filter (the error curves behind the summary's means).
    rows = list(csv.DictReader(open(os.path.join(a.out, "rows.csv"))))
    fig, ax = plt.subplots(figsize=(6, 4))
    styles = {"nearest": ":", "split8": "-", "rebake": "--"}
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, m in enumerate(names):
        for flt in FILTERS:
            r = [x for x in rows if x["model"] == m and x["filter"] == flt]
            ax.plot([int(x["frame"]) for x in r], [float(x["mse"]) for x in r], styles[flt],
                    color=colours[i % len(colours)], label="%s %s" % (m, flt))
    ax.set_xlabel("frame")
    ax.set_ylabel("MSE against the frame's truth")
    ax.set_yscale("log")
    ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "error.png"), dpi=80)
    plt.close(fig)
    # Temporal stability: mean |frame f+1 - frame f| per consecutive pair, the truth's own beside
    # each model's (a method that flickers sits above the truth's curve; one that lags, below).
    if a.frames > 1:
        fig, ax = plt.subplots(figsize=(6, 4))
        pairs = list(range(a.frames - 1))
        ax.plot(pairs, [np.mean(np.abs(truth[f + 1] - truth[f])) for f in pairs], "k-", lw=2, label="truth")
        for i, m in enumerate(names):
            for flt in FILTERS:  # the per-pair differences the summary's flicker was computed from
                diffs = next(x["pair_diffs"] for x in summary if x["model"] == m and x["filter"] == flt)
                ax.plot(pairs, diffs, styles[flt], color=colours[i % len(colours)], label="%s %s" % (m, flt))
        ax.set_xlabel("frame f (difference to f + 1)")
        ax.set_ylabel("mean |frame-to-frame difference|")
        ax.legend(fontsize=6, ncol=2)
        fig.tight_layout()
        fig.savefig(os.path.join(a.out, "flicker.png"), dpi=80)
        plt.close(fig)
    if sweep:
        fig, ax = plt.subplots(figsize=(6, 4))
        for i, m in enumerate(sorted(set(s["model"] for s in sweep), key=[s["model"] for s in sweep].index)):
            for flt in FILTERS:
                pts = [(s["objects"], s["voxels_ms"]) for s in sweep if s["filter"] == flt and s["model"] == m]
                ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o" + styles[flt], color=colours[i % len(colours)],
                          label="%s %s" % (m, flt))
        ax.set_xlabel("moving objects")
        ax.set_ylabel("ms per frame (the frame's voxels)")
        ax.set_title("%d^3" % (a.sweep_res or a.res), fontsize=9)
        ax.legend(fontsize=6, ncol=2)
        fig.tight_layout()
        fig.savefig(os.path.join(a.out, "time.png"), dpi=80)
        plt.close(fig)


def write_gif(a, work, names, truth):
    """strip.gif: every frame, the truth then each model's split8 side by side (sRGB, 8 bit)."""
    from PIL import Image

    def srgb(im):
        return (np.clip(im, 0, 1) ** (1 / 2.2) * 255 + 0.5).astype(np.uint8)

    pages = []
    for f in range(a.frames):
        row = [truth[f]] + [read(os.path.join(work, "%s_split8_%04d.exr" % (m, f))) for m in names]
        pages.append(Image.fromarray(np.concatenate([srgb(x) for x in row], axis=1)))
    pages[0].save(os.path.join(a.out, "strip.gif"), save_all=True, append_images=pages[1:], duration=120, loop=0)


def write_summary(a, names, summary, sweep, fallbacks, t_flicker):
    L = ["# Moving objects by voxel transformation (issue 17)", "",
         "Scene: scenes/dynamic.py, %d objects, %d frames, %d^3, %s, %d spp (truth %d spp). Errors are means over "
         "the frames against each frame's truth; times are medians per frame (`voxels`: transform or re-bake; "
         "`render`: the image). Flicker: mean |frame-to-frame difference| over the truth's own (%.5f)." %
         (a.objects, a.frames, a.res, a.size, a.spp, a.truth_spp, t_flicker), "",
         "| model | filter | MSE | SSIM | MSE frame 0 | voxels ms | render ms | flicker / truth's |",
         "|---|---|---|---|---|---|---|---|"]
    for s in summary:
        used = s["filter"] if s["used"] == s["filter"] else "%s (re-baked)" % s["filter"]
        L.append("| %s | %s | %.5f | %.4f | %.5f | %.1f | %.1f | %.2f |" % (
            s["model"], used, s["mse"], s["ssim"], s["mse_frame0"], s["voxels_ms"], s["render_ms"], s["flicker_ratio"]))
    L.append("")
    worse = []
    for m in names:
        by = {s["filter"]: s for s in summary if s["model"] == m}
        if m in fallbacks:
            continue
        if by["split8"]["mse"] > 2 * by["rebake"]["mse"]:
            worse.append("%s (split8 MSE %.5f vs re-baked %.5f: %.1fx)" % (
                m, by["split8"]["mse"], by["rebake"]["mse"], by["split8"]["mse"] / by["rebake"]["mse"]))
    L.append("**Models whose split8 error exceeds 2x their re-baked error:** " + (", ".join(worse) if worse else "none") + ".")
    L.append("")
    if fallbacks:
        L.append("**Re-baked every frame (no transform/combine):** " + ", ".join(sorted(fallbacks)) +
                 " (their nearest/split8 rows are re-bakes).")
        L.append("")
    if sweep:
        L += ["## Time per frame against the number of moving objects", "",
              "| model | objects | " + " | ".join("%s ms" % f for f in FILTERS) +
              " | split8 / rebake | one-time bake ms |", "|---|---|---|---|---|---|---|"]
        for m in sorted(set(s["model"] for s in sweep), key=[s["model"] for s in sweep].index):
            for n in sorted(set(s["objects"] for s in sweep)):
                by = {s["filter"]: s for s in sweep if s["objects"] == n and s["model"] == m}
                L.append("| %s | %d | %s | %.3f | %.0f |" % (
                    m, n, " | ".join("%.1f" % by[f]["voxels_ms"] for f in FILTERS),
                    by["split8"]["voxels_ms"] / by["rebake"]["voxels_ms"], by["split8"]["prepare_ms"]))
        L.append("")
    L.append("Figures: strip.png (truth and each model's split8 at a few frames), strip.gif (every frame: truth, "
             "then each model's split8, in the order %s), error.png (MSE per frame, every model and filter), "
             "flicker.png (frame-to-frame difference per frame, the truth's and each method's), time.png (the sweep)." % ", ".join(names))
    with open(os.path.join(a.out, "summary.md"), "w") as f:
        f.write("\n".join(L) + "\n")


if __name__ == "__main__":
    main()
