"""`make shadows` (experiments/shadows.py, issue 18) on a tiny declaration: spheres at 16^3, 32x32,
every model x the four shadow methods, a 16-spp truth, one timed run each.

1. It exits 0 and writes shadows.csv/.md and the crop figure (PNG, PDF, SVG); one row per model and
   method plus the truth's slicemap, every one ok, with the MSE over the truth's shadowed pixels;
   precomputation time and map memory only where a method precomputes, the total MB the model's
   plus the maps'. `voxel` has a row for each
   model the binary renders with it (asked of `voxlab render --dry-run`, not of the experiment's
   own rule), none for the others; its image is march's (read back from the EXRs here), which
   its rows' max_diff_march says too, and a wrong image would show there.
2. The runs' "shadows" dimension leaves march's cache keys as they were: the same declaration
   without it (sweep.py) runs no render job again.
3. A bad method in a declaration is refused (exit 2) naming the field.
4. A scene that declares its own method ("shadows": {"method": "slicemap-model"}) renders its
   march rows with march: no maps built.
"""
import csv
import json
import math
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, read_image, report, voxlab  # noqa: E402

import numpy as np  # noqa: E402

PY = "/usr/bin/python3"
RESULTS = os.path.join(TMP, "results")


METHODS = ("march", "slicemap", "slicemap-model", "voxel")


def declaration(name, shadows=True, methods=METHODS):
    d = {"name": name, "description": "tiny shadows", "seed": 1, "truth_spp": 16, "repeats": 1,
         "scenes": ["spheres"], "runs": [{"models": "all", "res": [16], "size": 32}],
         "figure": {"crop_scene": "spheres", "crop_res": 16, "crop_fraction": 0.5}}
    if shadows:
        d["runs"][0]["shadows"] = list(methods)
    path = os.path.join(TMP, name + ".json")
    with open(path, "w") as f:
        json.dump(d, f)
    return path


def run(*args):
    return subprocess.run([PY, *args], capture_output=True, text=True, cwd=REPO)


models = [line.split()[0] for line in voxlab("models").stdout.splitlines() if line.strip()]
# The models that take `voxel`, as the binary answers (the refusal comes before anything is baked).
takes_voxel = {m for m in models if voxlab("render", os.path.join(REPO, "scenes", "spheres.json"), "--model", m,
                                           "--res", "16", "--size", "32x32", "--shadows", "voxel", "--dry-run",
                                           "-o", os.path.join(TMP, "dry.exr"), check=False).returncode == 0}
report("some model takes voxel and some does not (heitz-neyret marches cones)",
       takes_voxel and takes_voxel != set(models) and "heitz-neyret" not in takes_voxel, str(takes_voxel))
p = run("experiments/shadows.py", "--experiment", declaration("shadows-tiny"), "--results", RESULTS, "--voxlab",
        VOXLAB, "--jobs", "2")
out = os.path.join(RESULTS, "shadows-tiny")
report("shadows.py exits 0", p.returncode == 0, p.stderr[-800:])
rows = []
if os.path.isfile(os.path.join(out, "shadows.csv")):
    with open(os.path.join(out, "shadows.csv"), newline="") as f:
        rows = list(csv.DictReader(f))
want = ({(m, s) for m in models for s in METHODS if s != "voxel"} | {(m, "voxel") for m in takes_voxel} |
        {("truth", "slicemap")})
report("a row per model and method it takes, and the truth's slicemap",
       len(rows) == len(want) and {(r["model"], r["shadows"]) for r in rows} == want,
       str([(r["model"], r["shadows"]) for r in rows]))
report("every row ok, with the MSE over the truth's shadowed pixels",
       rows and all(r["status"] == "ok" and r["mse_shadow"] and math.isfinite(float(r["mse_shadow"])) and
                    int(r["shadow_pixels"]) > 0 for r in rows), str([(r["model"], r["status"], r["error"]) for r in rows]))
pre = [r for r in rows if r["shadows"] != "march"]
report("precomputation time and map memory where a method precomputes, none for march",
       pre and all(float(r["shadow_build_ms"]) > 0 and float(r["shadow_mb"]) > 0 for r in pre) and
       all(float(r["shadow_build_ms"] or 0) == 0 and float(r["shadow_mb"] or 0) == 0 for r in rows
           if r["shadows"] == "march"), str([(r["model"], r["shadows"], r["shadow_build_ms"], r["shadow_mb"])
                                             for r in rows]))
# The sweep's rows charge the precomputed shadows to mb (all the frame reads); the table splits it.
report("total MB = the model's MB + the shadows' MB on every model row, the model's MB the same for every method",
       rows and all(abs(float(r["total_mb"]) - float(r["mb"]) - float(r["shadow_mb"] or 0)) < 1e-9 and
                    len({r2["mb"] for r2 in rows if r2["model"] == r["model"]}) == 1
                    for r in rows if r["model"] != "truth"),
       str([(r["model"], r["shadows"], r["mb"], r["shadow_mb"], r["total_mb"]) for r in rows]))
# voxel's image against march's, read here (testlib's reader, not the experiment's); and the
# experiment's own max_diff_march.
sweep_rows = []
if os.path.isfile(os.path.join(out, "rows.json")):
    with open(os.path.join(out, "rows.json")) as f:
        sweep_rows = json.load(f)["rows"]
image = {(r["model"], r["shadows"]): os.path.join(RESULTS, r["image"]) for r in sweep_rows
         if r.get("kind") == "model" and r.get("status") == "ok"}
diffs = {m: float(np.max(np.abs(read_image(image[(m, "voxel")])[..., :3] - read_image(image[(m, "march")])[..., :3])))
         for m in takes_voxel if (m, "voxel") in image and (m, "march") in image}
report("voxel's image is march's for every model that takes it (read from the EXRs)",
       set(diffs) == takes_voxel and all(d == 0.0 for d in diffs.values()), str(diffs))
vrows = [r for r in rows if r["shadows"] == "voxel"]
report("the voxel rows' max_diff_march is 0, and no other row has one",
       vrows and all(r["max_diff_march"] != "" and float(r["max_diff_march"]) == 0.0 for r in vrows) and
       all(r["max_diff_march"] == "" for r in rows if r["shadows"] != "voxel"),
       str([(r["model"], r["shadows"], r["max_diff_march"]) for r in rows]))
md = open(os.path.join(out, "shadows.md")).read() if os.path.isfile(os.path.join(out, "shadows.md")) else ""
report("the table sets voxel's frame against march's", "voxel / march" in md, md[-600:])
report("the table and the crop figure are written",
       all(os.path.isfile(os.path.join(out, f)) for f in ("shadows.md", "shadows_crops.png", "shadows_crops.pdf",
                                                          "shadows_crops.svg")), str(os.listdir(out)) if
       os.path.isdir(out) else "no output folder")

# 2. march's keys unchanged: the declaration without "shadows" finds its renders cached.
p = run("experiments/sweep.py", declaration("shadows-tiny-plain", shadows=False), "--results", RESULTS,
        "--voxlab", VOXLAB)
report("march's cache keys are those of a declaration without shadows (nothing reruns)",
       p.returncode == 0 and " 0 job(s) ran" in p.stderr, p.stderr[-600:])

# 3. a bad method
p = run("experiments/sweep.py", declaration("shadows-bad", methods=("march", "deep")), "--check")
report("a bad shadow method in a declaration is refused naming the field",
       p.returncode == 2 and "runs[0].shadows[1]" in p.stderr, p.stderr[-300:])

# 4. A scene that declares its own method: a row that says march is rendered with march (the
# experiment passes --shadows always; it used to pass none for march, leaving the scene's method in
# force: alpha's and heitz-neyret's stats then showed slicemap-model's maps under a "march" row).
own = os.path.join(TMP, "own_method.json")
with open(own, "w") as f:
    json.dump({"name": "own-method", "description": "a scene declaring slicemap-model", "seed": 1, "truth_spp": 16,
               "repeats": 1, "scenes": [{"base": "spheres", "name": "sph_sm",
                                          "set": {"shadows": {"method": "slicemap-model", "resolution": 64}}}],
               "runs": [{"models": ["alpha", "heitz-neyret"], "res": [16], "size": 32}]}, f)
p = run("experiments/sweep.py", own, "--results", RESULTS, "--voxlab", VOXLAB)
own_rows = []
if os.path.isfile(os.path.join(RESULTS, "own-method", "rows.csv")):
    with open(os.path.join(RESULTS, "own-method", "rows.csv"), newline="") as f:
        own_rows = [r for r in csv.DictReader(f) if r["kind"] == "model"]
report("a scene's own shadow method does not override the row's march (no maps built)",
       p.returncode == 0 and len(own_rows) == 2 and
       all(r["shadows"] == "march" and float(r["shadow_bytes"] or 0) == 0 for r in own_rows),
       p.stderr[-600:] + str([(r["model"], r["shadows"], r["shadow_bytes"]) for r in own_rows]))
finish()
