#!/usr/bin/python3
"""Every registered appearance model against the ground truth on one scene (make demo).

    /usr/bin/python3 experiments/demo.py [--experiment experiments/demo.json] [--results results]
        [--jobs 2] [--voxlab build/voxlab] [--force] [--repeats R] [--executor local|dask|slurm]

The demo is a declaration (experiments/demo.json: the built-in spheres scene, a 256-spp truth, every
model at 64^3 on a 64 x 64 image) run by the same engine as table1 and pareto (voxlab_exp: cached
jobs, timed jobs alone on the machine, progress on stderr, failures recorded in the rows). From its
rows it writes into <results>/<name>/ (results/demo/):

  rows.csv, rows.json    every configuration as the sweep wrote it
  table.csv, table.md    per model and resolution: the metrics `voxlab compare --json` writes (MSE,
                         PSNR, SSIM on the linear EXR images), bake s, render ms, bytes/voxel, voxels
                         and MB (model records + sparse grid, 10^6 bytes); table.md states the date,
                         machine, commit, binary and settings
  truth_<N>.png, <model>_<N>.png, <model>_<N>_heat.png
                         previews of the truth and each model's image (the EXRs stay in the cache:
                         table.csv's image and truth columns) and each model's error map
  strip_<N>.png          truth | each model | each model's error map, N pixels per column, labels in a
                         band above. Each error map is scaled to its own largest error: compare the
                         MSE column, not the colours, across models.

A second run with unchanged sources does no voxlab work. Exit status 0 (failed configurations are rows
marked failed, shown in the table), 1 when the sweep could not run, 2 for a bad declaration.
"""
import argparse
import os
import shutil
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from voxlab_exp.cli import add_common_args, main_wrapper, sweep_args  # noqa: E402
from voxlab_exp.config import REPO  # noqa: E402
from voxlab_exp.files import atomic_write, rel, save_png, write_csv, write_text  # noqa: E402
from voxlab_exp.images import error_map, make_strip  # noqa: E402
from voxlab_exp.report import settings_text  # noqa: E402
from voxlab_exp.rows import run_experiment  # noqa: E402
from voxlab_exp.schema import load_declaration  # noqa: E402

# Besides the metrics (the run's meta["metrics"], in the order `voxlab compare --json` writes them).
COST_COLUMNS = [("bake_s", "bake s", "{:.3f}"), ("render_ms", "render ms", "{:.2f}"),
                ("bytes_per_voxel", "bytes/voxel", "{:.0f}"), ("voxels", "voxels", "{:.0f}"), ("mb", "MB", "{:.3f}")]
METRIC_FORMAT = {"mse": "{:.4e}", "ssim": "{:.4f}", "psnr": "{:.2f}"}  # any other metric: {:.4g}


def table_frame(meta, rows, results, out):
    """The model rows as a pandas frame: model, res, the metrics, the cost columns, the images."""
    import pandas as pd

    metrics = list(meta.get("metrics") or [])
    frame = pd.DataFrame([r for r in rows if r["kind"] == "model"])
    frame = frame.reindex(columns=["model", "res", "status", "error", *metrics, *(c for c, _, _ in COST_COLUMNS),
                                   "image", "truth_image", "preview", "truth_preview"]).astype(object)
    frame = frame.where(frame.notna(), None)
    for col in ("image", "truth_image"):  # rows are relative to the results root; the table to its folder
        frame[col] = [os.path.relpath(os.path.join(results, p), out) if p else None for p in frame[col]]
    return frame, metrics


def markdown(frame, metrics, meta):
    def cell(v, fmt):
        return "–" if v is None else fmt.format(v)

    head = ["model", "resolution", *(m.upper() for m in metrics),
            *(label for _, label, _ in COST_COLUMNS)]
    lines = [f"# Appearance models vs ground truth: {meta['experiment']}", ""]
    lines += [f"- {s}" for s in settings_text(meta)]
    lines += [f"- settings: {meta['description']}", "",
              "Metrics are `voxlab compare --json`'s on the linear images (SSIM as scikit-image, Gaussian σ 1.5); "
              "bake s = sampling + model bake; render ms = one frame of the voxel render (median of the timed "
              "runs); MB = model records + sparse grid, 10^6 bytes.", "",
              "| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 1)]
    notes = []
    for _, r in frame.iterrows():
        if r["status"] != "ok":
            notes.append(r["error"])
            vals = [f"failed[{len(notes)}]"] * (len(head) - 2)
        else:
            vals = [cell(r[m], METRIC_FORMAT.get(m, "{:.4g}")) for m in metrics]
            vals += [cell(r[c], fmt) for c, _, fmt in COST_COLUMNS]
        lines.append(f"| {r['model']} | {r['res']}³ | " + " | ".join(vals) + " |")
    lines += [""] + [f"[{i}] {n}" for i, n in enumerate(notes, 1)]
    return "\n".join(lines).rstrip("\n") + "\n"


def copy_png(src, dst):
    atomic_write(dst, lambda tmp: shutil.copyfile(src, tmp))


def build(meta, rows, results, out):
    from PIL import Image

    frame, metrics = table_frame(meta, rows, results, out)
    write_csv(os.path.join(out, "table.csv"), frame.to_dict("records"),
              ["model", "res", "status", *metrics, *(c for c, _, _ in COST_COLUMNS), "image", "truth_image", "error"])
    write_text(os.path.join(out, "table.md"), markdown(frame, metrics, meta))
    strips = []
    for res, group in frame.groupby("res", sort=False):
        ok = group[group["status"] == "ok"]
        if ok.empty:
            continue
        truth_png = os.path.join(out, f"truth_{res}.png")
        copy_png(os.path.join(results, ok.iloc[0]["truth_preview"]), truth_png)
        tiles = [("truth", f"{meta['settings'].get('truth_spp', 1024)} spp", Image.open(truth_png))]
        heats = []
        for _, r in ok.iterrows():
            png, heat = os.path.join(out, f"{r['model']}_{res}.png"), os.path.join(out, f"{r['model']}_{res}_heat.png")
            copy_png(os.path.join(results, r["preview"]), png)
            save_png(error_map(os.path.join(out, r["truth_image"]), os.path.join(out, r["image"])), heat)
            tiles.append((r["model"], f"MSE {r['mse']:.1e}" if r.get("mse") is not None else "", Image.open(png)))
            heats.append((f"{r['model']} error", f"SSIM {r['ssim']:.3f}" if r.get("ssim") is not None else "",
                          Image.open(heat)))
        size = tiles[0][2].size[0]
        make_strip(tiles + heats, size, os.path.join(out, f"strip_{res}.png"))
        strips.append(f"strip_{res}.png")
    return strips


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    add_common_args(ap, experiment=os.path.join(REPO, "experiments", "demo.json"))
    a = ap.parse_args(argv)

    def go():
        decl = load_declaration(a.experiment, a.voxlab)
        meta, rows = run_experiment(decl, **sweep_args(a))
        results = os.path.abspath(a.results)
        out = os.path.join(results, decl["name"])
        strips = build(meta, rows, results, out)
        print(f"demo: wrote {rel(out, REPO)}/table.{{csv,md}}, {', '.join(strips) or 'no strip (every model failed)'}",
              file=sys.stderr)
        return 0

    return main_wrapper(go, "demo")


if __name__ == "__main__":
    sys.exit(main())
