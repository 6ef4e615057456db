#!/usr/bin/python3
"""Every registered appearance model against the Embree ground truth, at several voxel resolutions.

    /usr/bin/python3 experiments/compare_models.py [--scene bunny] [--res 64 128] [--truth-spp 1024]
        [--spp 4] [--rays 150] [--jobs 2] [--out results/<scene>] [--voxlab build/voxlab]

(build first with `make`; there is no make target for this script.)

For each resolution N the image is N x N pixels, as in Brito et al. 2023, so a voxel covers about
a pixel. The script renders the ground truth (`voxlab truth`, --truth-spp samples per pixel) and
every model listed by `voxlab models` (`voxlab render --res N`, which bakes with --rays samples per
voxel and renders with --spp), compares each model image with the truth (`voxlab compare --json
--heatmap`) and writes into the output directory (default results/<scene>/):

  table.csv, table.md    model, resolution, MSE, SSIM, bake s, render s, bytes/voxel, voxels, MB.
                         MSE and SSIM are computed on the linear EXR images. MB is the memory of the
                         voxel representation: the model's records plus the sparse grid (10^6 bytes).
                         table.md also records the machine, the git commit, the date and the settings.
  truth_<scene>_<W>x<H>_spp<S>_seed1_<hash>.{exr,png,json}
                         the ground truth, its sRGB preview and its --stats. The name holds every
                         input the image depends on (<hash>: the scene file's contents), so a later
                         run with the same inputs reuses it instead of rendering 1024 spp again.
                         Delete it to force a new one (e.g. after changing the truth renderer or a
                         mesh the scene references).
  <model>_<N>.{exr,png}, <model>_<N>_heat.png, <model>_<N>_stats.json
                         each model's image, preview, error heat map and --stats.
  strip_<N>.png          truth | each model | each model's heat map, N pixels per column, with labels
                         in a band above. Each heat map is scaled to its own largest error (that is
                         how `voxlab compare --heatmap` draws them): compare the MSE column, not the
                         colours, across models.

Independent renders run --jobs at a time; each voxlab gets nproc / jobs threads so concurrent jobs do
not fight over cores and the timings stay meaningful (with 2 jobs on 2 cores the bake and render
times are single-threaded, like the paper's). Progress goes to stderr. A failing voxlab call prints
its command and stderr and the script exits with status 1. Every file is written under a temporary
name and renamed when complete.
"""
import argparse
import concurrent.futures as cf
import csv
import datetime
import hashlib
import io
import json
import os
import platform
import sys
import threading
import time

# The pieces every experiment script shares live in voxlab_runner.py (this directory is sys.path[0]
# when the script runs).
from voxlab_runner import (REPO, SEED, VoxlabError, exr_to_png, git_commit, list_models, make_strip,
                           resolve_scene, run_voxlab, write_text)


def log(msg):
    print(f"compare_models: {msg}", file=sys.stderr, flush=True)


class Progress:
    def __init__(self, total):
        self.total, self.done, self.start = total, 0, time.monotonic()
        self.lock = threading.Lock()

    def step(self, what):
        with self.lock:
            self.done += 1
            log(f"[{self.done}/{self.total}, {time.monotonic() - self.start:.1f} s] {what}")


def fmt_bytes_mb(b):
    return b / 1e6


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", default="bunny", help="scene name (scenes/NAME.json) or scene file (default bunny)")
    ap.add_argument("--res", type=int, nargs="+", default=[64, 128], help="voxel resolutions = image sizes (default 64 128)")
    ap.add_argument("--truth-spp", type=int, default=1024, help="ground-truth samples per pixel (default 1024)")
    ap.add_argument("--spp", type=int, default=4, help="model render rays per pixel (default 4)")
    ap.add_argument("--rays", type=int, default=150, help="bake rays per voxel (default 150)")
    ap.add_argument("--jobs", type=int, default=2, help="renders run at once (default 2)")
    ap.add_argument("--out", help="output directory (default results/<scene>)")
    ap.add_argument("--voxlab", default=os.path.join(REPO, "build", "voxlab"), help="voxlab binary (default build/voxlab)")
    a = ap.parse_args(argv)
    if a.jobs < 1 or a.truth_spp < 1 or a.spp < 1 or a.rays < 1 or any(r < 1 for r in a.res):
        ap.error("--jobs, --truth-spp, --spp, --rays and --res must be positive")
    try:
        return run(a)
    except VoxlabError as e:
        log(f"error: {e}")
        return 1


def run(a):
    t_start = time.monotonic()
    voxlab = os.path.abspath(a.voxlab)
    if not os.access(voxlab, os.X_OK):
        raise VoxlabError(f"--voxlab {voxlab}: not an executable (run `make` first)")
    scene_path = resolve_scene(a.scene)
    scene = os.path.splitext(os.path.basename(scene_path))[0]
    out = os.path.abspath(a.out or os.path.join(REPO, "results", scene))
    os.makedirs(out, exist_ok=True)
    with open(scene_path, "rb") as f:
        scene_hash = hashlib.sha256(f.read()).hexdigest()[:10]
    models = list_models(voxlab)
    if not models:
        raise VoxlabError("`voxlab models` listed no model")
    resolutions = list(dict.fromkeys(a.res))  # unique, in the order given
    ncpu = os.cpu_count() or 1
    threads = max(1, ncpu // a.jobs)

    def truth_paths(n):
        stem = os.path.join(out, f"truth_{scene}_{n}x{n}_spp{a.truth_spp}_seed{SEED}_{scene_hash}")
        return stem + ".exr", stem + ".png", stem + ".json"

    def model_paths(m, n):
        stem = os.path.join(out, f"{m}_{n}")
        return stem + ".exr", stem + ".png", stem + "_heat.png", stem + "_stats.json"

    # The truth is reused only when its image and stats are both there (the stats come last).
    truth_todo = [n for n in resolutions if not all(os.path.exists(p) for p in truth_paths(n)[::2])]
    for n in resolutions:
        if n not in truth_todo:
            log(f"reusing {os.path.basename(truth_paths(n)[0])}")
    # Renders and compares count as steps; biggest first so the pool drains evenly.
    total = len(truth_todo) + 2 * len(models) * len(resolutions)
    prog = Progress(total)

    def do_truth(n):
        exr, png, stats = truth_paths(n)
        run_voxlab(voxlab, ["truth", scene_path, "--spp", a.truth_spp, "--size", f"{n}x{n}", "--seed", SEED,
                            "--threads", threads, "-o", exr, "--stats", stats])
        exr_to_png(exr, png)
        prog.step(f"truth {n}x{n}, {a.truth_spp} spp")

    def do_model(m, n):
        exr, png, _, stats = model_paths(m, n)
        run_voxlab(voxlab, ["render", scene_path, "--model", m, "--res", n, "--rays", a.rays, "--spp", a.spp,
                            "--size", f"{n}x{n}", "--seed", SEED, "--threads", threads, "-o", exr, "--stats", stats])
        exr_to_png(exr, png)
        prog.step(f"render {m} {n}^3")

    def do_compare(m, n):
        exr, _, heat, stats = model_paths(m, n)
        metrics = json.loads(run_voxlab(voxlab, ["compare", truth_paths(n)[0], exr, "--json", "--heatmap", heat]))
        with open(stats) as f:
            st = json.load(f)
        prog.step(f"compare {m} {n}^3: MSE {metrics['mse']:.4g}, SSIM {metrics['ssim']:.4f}")
        return {
            "model": m,
            "resolution": n,
            "mse": metrics["mse"],
            "ssim": metrics["ssim"],
            "psnr": metrics["psnr"],
            "bake_s": st["bake_seconds"],
            "render_s": st["seconds"],
            "bytes_per_voxel": st["bytes_per_voxel"],
            "voxels": st["voxels"],
            "mb": fmt_bytes_mb(st["model_bytes"] + st["grid_bytes"]),
            "image": os.path.relpath(exr, out),
            "truth": os.path.relpath(truth_paths(n)[0], out),
        }

    rows = {}
    pool = cf.ThreadPoolExecutor(max_workers=a.jobs)
    try:
        truth_f = {n: pool.submit(do_truth, n) for n in sorted(truth_todo, reverse=True)}
        model_f = {(m, n): pool.submit(do_model, m, n) for n in sorted(resolutions, reverse=True) for m in models}
        cmp_f = {}
        # A compare needs its truth and its model image; each starts as soon as both are there.
        pending = set(model_f.values()) | set(truth_f.values())
        while pending:
            done, pending = cf.wait(pending, return_when=cf.FIRST_COMPLETED)
            for f in done:
                f.result()  # raises the first failure
            for (m, n), f in model_f.items():
                tf = truth_f.get(n)
                if (m, n) not in cmp_f and f.done() and (tf is None or tf.done()):
                    cmp_f[(m, n)] = pool.submit(do_compare, m, n)
        for key, f in cmp_f.items():
            rows[key] = f.result()
    finally:
        # On failure, drop what has not started; running voxlab calls finish (their outputs are atomic).
        pool.shutdown(wait=True, cancel_futures=True)

    truth_stats = {}
    for n in resolutions:
        with open(truth_paths(n)[2]) as f:
            truth_stats[n] = json.load(f)
        if not os.path.exists(truth_paths(n)[1]):  # a cached truth from a run that died before its preview
            exr_to_png(truth_paths(n)[0], truth_paths(n)[1])

    table = [rows[(m, n)] for n in resolutions for m in models]
    write_csv(os.path.join(out, "table.csv"), table)

    from PIL import Image

    for n in resolutions:
        tiles = [("truth", f"{a.truth_spp} spp", Image.open(truth_paths(n)[1]))]
        tiles += [(m, f"MSE {rows[(m, n)]['mse']:.1e}", Image.open(model_paths(m, n)[1])) for m in models]
        tiles += [(f"{m} error", f"SSIM {rows[(m, n)]['ssim']:.3f}", Image.open(model_paths(m, n)[2])) for m in models]
        make_strip(tiles, n, os.path.join(out, f"strip_{n}.png"))

    elapsed = time.monotonic() - t_start
    settings = {
        "scene": os.path.relpath(scene_path, REPO) if scene_path.startswith(REPO + os.sep) else scene_path,
        "resolutions": resolutions,
        "truth_spp": a.truth_spp,
        "spp": a.spp,
        "rays": a.rays,
        "seed": SEED,
        "jobs": a.jobs,
        "threads": threads,
        "models": models,
    }
    write_text(os.path.join(out, "table.md"), markdown(table, settings, truth_stats, scene_hash, elapsed))
    log(f"wrote {out}/table.csv, table.md, strip_*.png in {elapsed:.1f} s")
    return 0


CSV_FIELDS = ["model", "resolution", "mse", "ssim", "psnr", "bake_s", "render_s", "bytes_per_voxel", "voxels", "mb",
              "image", "truth"]


def write_csv(path, table):
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=CSV_FIELDS, lineterminator="\n")
    w.writeheader()
    for r in table:
        # repr keeps every digit of MSE and SSIM (they round-trip to the doubles voxlab printed).
        w.writerow({k: repr(v) if isinstance(v, float) else v for k, v in r.items()})
    write_text(path, buf.getvalue())


def markdown(table, s, truth_stats, scene_hash, elapsed):
    u = platform.uname()
    lines = [
        f"# Appearance models vs ground truth: {s['scene']}",
        "",
        f"- date: {datetime.datetime.now().astimezone().isoformat(timespec='seconds')}",
        f"- machine: {u.system} {u.release} {u.machine} ({u.node}), nproc {os.cpu_count()}",
        f"- git commit: {git_commit()}",
        f"- settings: scene {s['scene']} (sha256 {scene_hash}), resolutions {' '.join(map(str, s['resolutions']))} "
        f"(image N x N for voxel resolution N^3), truth spp {s['truth_spp']}, model spp {s['spp']}, "
        f"bake rays {s['rays']} per voxel, seed {s['seed']}, jobs {s['jobs']} with {s['threads']} thread(s) each",
        f"- models: {', '.join(s['models'])}",
        "- truth render: " + ", ".join(f"{n}x{n} {st['seconds']:.2f} s" for n, st in truth_stats.items())
        + " (cached truth images keep the time of the run that rendered them)",
        f"- experiment wall time: {elapsed:.1f} s",
        "",
        "MSE and SSIM on the linear images (SSIM as scikit-image, Gaussian σ 1.5); bake s = sampling + model "
        "bake; render s = the voxel render alone; MB = model records + sparse grid, 10^6 bytes.",
        "",
        "| model | resolution | MSE | SSIM | bake s | render s | bytes/voxel | voxels | MB |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in table:
        lines.append(f"| {r['model']} | {r['resolution']}³ | {r['mse']:.4e} | {r['ssim']:.4f} | {r['bake_s']:.3f} | "
                     f"{r['render_s']:.3f} | {r['bytes_per_voxel']:.0f} | {r['voxels']:.0f} | {r['mb']:.2f} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
