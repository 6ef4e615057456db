"""`make demo` through the experiment engine: experiments/demo.py on a demo-shaped declaration (the
spheres scene at 32^3, 16-spp truth, one timed run) instead of experiments/demo.json's 64^3 and 256 spp.
The table has one row per registered model, its metrics are exactly what `voxlab compare` gives on the
images the engine wrote and are the columns `voxlab compare --list-metrics` names, the strip has one
column per image, table.md records the commit and the settings, a second run does no voxlab work (the
engine's cache), a bad declaration stops with status 2 naming the file and the field, and the shipped
demo.json validates."""
import json
import os
import subprocess
import sys

from PIL import Image

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, read_csv, report, voxlab, voxlab_json  # noqa: E402

SCRIPT = os.path.join(REPO, "experiments", "demo.py")
RES = 32
TRUTH_SPP = 16


def declare(name, **fields):
    d = {"name": name, "scenes": ["spheres"], "truth_spp": TRUTH_SPP, "repeats": 1,
         "runs": [{"models": "all", "res": [RES], "size": "res"}], **fields}
    path = os.path.join(TMP, f"{name}.json")
    os.makedirs(TMP, exist_ok=True)
    with open(path, "w") as f:
        json.dump(d, f)
    return path


def run_demo(decl, results):
    return subprocess.run([sys.executable, SCRIPT, "--experiment", decl, "--results", results, "--voxlab", VOXLAB],
                          capture_output=True, text=True)


def main():
    results = os.path.join(TMP, "results")
    p = run_demo(declare("demo_test"), results)
    report("demo.py exits 0", p.returncode == 0, p.stderr[-2000:])
    if p.returncode != 0:
        return
    out = os.path.join(results, "demo_test")
    models = [line.split()[0] for line in voxlab("models").stdout.splitlines() if line.strip()]
    metrics = [line.strip() for line in voxlab("compare", "--list-metrics").stdout.splitlines() if line.strip()]
    report("compare --list-metrics names mse, psnr, ssim", metrics[:3] == ["mse", "psnr", "ssim"], str(metrics))
    report("engine progress on stderr", "demo_test: [" in p.stderr and "job(s) to run" in p.stderr, p.stderr[-500:])
    rows = read_csv(os.path.join(out, "table.csv"))
    report("one table row per registered model", sorted(r["model"] for r in rows) == sorted(models)
           and all(int(r["res"]) == RES and r["status"] == "ok" for r in rows),
           f"rows {[r['model'] for r in rows]}, models {models}")
    header = list(rows[0].keys()) if rows else []
    report("metric columns are compare's", [h for h in header if h in metrics] == metrics, str(header))
    for r in rows:
        truth, image = os.path.join(out, r["truth_image"]), os.path.join(out, r["image"])
        if not (os.path.isfile(truth) and os.path.isfile(image)):
            report(f"{r['model']}: images exist", False, f"{truth}, {image}")
            continue
        ref = voxlab_json("compare", truth, image, "--json")
        report(f"{r['model']}: metrics equal voxlab compare",
               all(abs(float(r[m]) - ref[m]) <= 1e-9 * max(1, abs(ref[m])) for m in metrics if ref[m] is not None),
               f"csv {[r[m] for m in metrics]}, compare {ref}")
        report(f"{r['model']}: cost columns", float(r["bake_s"]) > 0 and float(r["render_ms"]) > 0
               and int(float(r["voxels"])) > 0 and float(r["mb"]) > 0, str(r))
        for suffix in (".png", "_heat.png"):
            png = os.path.join(out, f"{r['model']}_{RES}{suffix}")
            report(f"{r['model']}: {os.path.basename(png)} is {RES}x{RES}",
                   os.path.isfile(png) and Image.open(png).size == (RES, RES), png)

    strip = os.path.join(out, f"strip_{RES}.png")
    columns = 1 + 2 * len(models)  # truth, each model, each model's error map
    size = Image.open(strip).size if os.path.isfile(strip) else None
    report("strip width = columns x size", size is not None and size[0] == columns * RES and size[1] > RES,
           f"{strip}: {size}, expected width {columns * RES}")

    g = subprocess.run(["git", "-C", REPO, "rev-parse", "HEAD"], capture_output=True, text=True)
    head = g.stdout.strip() if g.returncode == 0 else "unknown (not a git checkout)"
    with open(os.path.join(out, "table.md")) as f:
        md = f.read()
    report("table.md names the commit", f"git commit: {head}" in md, f"{head!r} not in table.md")
    wanted = ["demo_test.json", "MSE", "SSIM", *[f"| {m} | {RES}" for m in models]]
    report("table.md states settings and rows", all(w in md for w in wanted),
           f"missing {[w for w in wanted if w not in md]}")
    leftovers = [n for n in os.listdir(out) if ".tmp." in n]
    report("no temporary files left", not leftovers, str(leftovers))

    p2 = run_demo(declare("demo_test"), results)
    report("second run does no voxlab work", p2.returncode == 0 and "0 job(s) to run" in p2.stderr, p2.stderr[-1000:])

    bad = run_demo(declare("demo_bad", runs=[{"models": "all", "res": [RES, 0]}]), os.path.join(TMP, "bad"))
    report("bad declaration: status 2 naming file and field", bad.returncode == 2 and "demo_bad.json" in bad.stderr
           and "runs[0].res[1]" in bad.stderr and "expected an integer" in bad.stderr
           and "Traceback" not in bad.stderr, bad.stderr[-500:])

    chk = subprocess.run([sys.executable, os.path.join(REPO, "experiments", "sweep.py"), "--check",
                          os.path.join(REPO, "experiments", "demo.json")], capture_output=True, text=True)
    report("experiments/demo.json validates", chk.returncode == 0 and "ok" in chk.stdout, chk.stderr[-500:])


if __name__ == "__main__":
    main()
    finish()
