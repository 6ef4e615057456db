"""make crossover (experiments/crossover.py, issue 19): the truth's time at a model's error read off
its spp curve (hand-computed cases: interpolation, the 1-spp floor, extrapolation), crossings found
where a model's time crosses the truth's, and the script on a tiny sweep (two tree counts, two
distances, two models) writing its table, summary and plot with every row consistent with the
experiment's own truth curve; a declaration without a crossover figure refused."""
import csv
import json
import math
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, finish, report  # noqa: E402

sys.path.insert(0, os.path.join(REPO, "experiments"))
import crossover  # noqa: E402

curve = [(1, 10.0, 0.04), (4, 40.0, 0.01), (16, 160.0, 0.0025)]
ms, spp, how = crossover.truth_time_at(curve, 0.02)
report("truth time at equal error: log-log interpolation (MSE 0.02 between 1 and 4 spp: 20 ms, 2 spp)",
       how == "interpolated" and abs(ms - 20.0) < 1e-9 and abs(spp - 2.0) < 1e-9, (ms, spp, how))
ms, spp, how = crossover.truth_time_at(curve, 0.05)
report("a model less accurate than the truth at 1 spp is charged the 1-spp time (floor)",
       how == "floor" and ms == 10.0 and spp == 1, (ms, spp, how))
ms, spp, how = crossover.truth_time_at(curve, 0.001)
report("beyond the curve: MSE ~ 1/spp from its last point (0.001: 40 spp, 400 ms)",
       how == "extrapolated" and abs(ms - 400.0) < 1e-9 and abs(spp - 40.0) < 1e-9, (ms, spp, how))
cr = crossover.crossings([1e3, 1e4, 1e5], [100, 100, 100], [10, 1000, 1000])
report("crossings: a flat model time against a truth time growing 10x to 1000x overtakes at 10^3.5 (%s)" % cr,
       len(cr) == 1 and cr[0][1] == "overtakes" and abs(cr[0][0] - 10 ** 3.5) < 1e-6 * 10 ** 3.5)
report("crossings: none when the model is always slower",
       crossover.crossings([1, 2, 3], [5, 5, 5], [1, 2, 3]) == [])

decl = {
    "name": "crossover_tiny", "seed": 1, "truth_spp": 16, "repeats": 1,
    "scenes": [
        {"base": "trees", "name": "fn", "set": {"size": [32, 32], "objects.0.params.leaves_per_tree": 50},
         "vary": {"objects.0.params.count": [1, 3]}},
        {"base": "trees", "name": "fd", "set": {"size": [32, 32], "objects.0.params.count": 2,
                                                "objects.0.params.leaves_per_tree": 50},
         "vary": {"camera.orbit.distance": [8, 40]}}],
    "runs": [{"models": ["alpha", "binary"], "res": [16], "size": "scene", "spp": [1]}],
    "truth_curve": {"spp": [1, 4], "seed": 2, "size": "scene"},
    "figure": {"type": "crossover", "complexity": ["fn"], "distance": {"family": "fd", "field": "camera.orbit.distance"}},
}
path = os.path.join(TMP, "crossover_tiny.json")
with open(path, "w") as f:
    json.dump(decl, f)
res = os.path.join(TMP, "crossover_results")
p = subprocess.run(["/usr/bin/python3", os.path.join(REPO, "experiments", "crossover.py"), "--experiment", path,
                    "--results", res, "--voxlab", os.path.join(REPO, os.environ.get("BUILD", "build"), "voxlab")],
                   capture_output=True, text=True)
report("crossover.py on a tiny sweep runs", p.returncode == 0, p.stderr[-2000:])
out = os.path.join(res, "crossover_tiny")
if p.returncode == 0:
    pts = list(csv.DictReader(open(os.path.join(out, "crossover.csv"))))
    report("crossover.csv: 2 sweeps x 2 points x 2 models", len(pts) == 8 and
           {(r["sweep"], r["model"]) for r in pts} == {(s, m) for s in ("complexity", "distance") for m in ("alpha", "binary")})
    tri = sorted({int(r["triangles"]) for r in pts if r["sweep"] == "complexity"})
    report("complexity: x is the triangle count, and 3 trees have more than 1 (%s)" % tri,
           len(tri) == 2 and tri[1] > tri[0] and all(r["x"] == r["triangles"] for r in pts if r["sweep"] == "complexity"))
    report("distance: x is the camera distance (8, 40)",
           sorted({float(r["x"]) for r in pts if r["sweep"] == "distance"}) == [8.0, 40.0])
    rows = json.load(open(os.path.join(out, "rows.json")))["rows"]
    ok = True
    for r in pts:
        tr = sorted((x for x in rows if x["scene"] == r["scene"] and x["kind"] == "truth"), key=lambda x: x["spp"])
        t_ms, e = float(r["truth_ms_equal_error"]), float(r["mse"])
        if r["truth_read"] == "floor":
            ok &= t_ms == tr[0]["render_ms"] and e >= tr[0]["mse"]
        elif r["truth_read"] == "interpolated":
            ok &= min(x["render_ms"] for x in tr) <= t_ms <= max(x["render_ms"] for x in tr)
        else:
            ok &= r["truth_read"] == "extrapolated" and e < tr[-1]["mse"] and t_ms > tr[-1]["render_ms"]
        ok &= abs(float(r["speedup"]) - t_ms / float(r["render_ms"])) < 1e-9 * t_ms / float(r["render_ms"])
        ok &= int(r["wins"]) == (float(r["render_ms"]) < t_ms)
    report("every row's truth time at equal error agrees with the experiment's own truth curve", ok)
    md = open(os.path.join(out, "crossover.md")).read()
    report("crossover.md has both sweeps and a verdict per model",
           "## complexity" in md and "## distance" in md and md.count("- **alpha**") == 2 and md.count("- **binary**") == 2)
    report("crossover.png is written", os.path.getsize(os.path.join(out, "crossover.png")) > 5000)
    report("crossover.csv has the truth's BVH build time and memory at every point",
           all(float(r["truth_bvh_s"]) > 0 and float(r["truth_bvh_mb"]) > 0 for r in pts))
    report("crossover.csv names each point's family (crossings are read within one)",
           {(r["sweep"], r["family"]) for r in pts} == {("complexity", "fn"), ("distance", "fd")})
    # --replot: the outputs again from rows.json alone, nothing run (no voxlab given: none needed).
    os.remove(os.path.join(out, "crossover.md"))
    p = subprocess.run(["/usr/bin/python3", os.path.join(REPO, "experiments", "crossover.py"), "--experiment", path,
                        "--results", res, "--replot", "--voxlab", "/nonexistent/voxlab"], capture_output=True, text=True)
    report("--replot rewrites crossover.md from rows.json, identical, running nothing",
           p.returncode == 0 and os.path.exists(os.path.join(out, "crossover.md"))
           and open(os.path.join(out, "crossover.md")).read() == md, p.stderr[-1000:])

bad = dict(decl, figure={})
bpath = os.path.join(TMP, "crossover_bad.json")
with open(bpath, "w") as f:
    json.dump(bad, f)
p = subprocess.run(["/usr/bin/python3", os.path.join(REPO, "experiments", "crossover.py"), "--experiment", bpath,
                    "--results", res], capture_output=True, text=True)
report("a declaration without a crossover figure is refused (exit 2, figure.type named)",
       p.returncode == 2 and "figure.type" in p.stderr, p.stderr)
finish()
