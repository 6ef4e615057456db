"""experiments/compare_models.py end to end on the spheres scene at 32^3 (16-spp truth): the table has
one row per registered model, its metrics are exactly what `voxlab compare` gives on the images the
script wrote, the strip has one column per image, table.md records the commit and the settings, a
second run reuses the cached truth, and a failing voxlab call makes the script fail loudly."""
import csv
import os
import subprocess
import sys

from PIL import Image

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, report, voxlab, voxlab_json  # noqa: E402

SCRIPT = os.path.join(REPO, "experiments", "compare_models.py")
RES = 32
TRUTH_SPP = 16


def run_script(out, *extra, scene="scenes/spheres.json"):
    return subprocess.run([sys.executable, SCRIPT, "--scene", os.path.join(REPO, scene), "--res", str(RES),
                           "--truth-spp", str(TRUTH_SPP), "--out", out, "--voxlab", VOXLAB, *extra],
                          capture_output=True, text=True)


def main():
    out = os.path.join(TMP, "experiment")
    p = run_script(out)
    report("script exits 0", p.returncode == 0, p.stderr[-2000:])
    if p.returncode != 0:
        return
    models = [line.split()[0] for line in voxlab("models").stdout.splitlines() if line.strip()]
    steps = 1 + 2 * len(models)  # the truth, then a render and a compare per model
    report("progress on stderr", f"[{steps}/{steps}, " in p.stderr, p.stderr[-500:])
    with open(os.path.join(out, "table.csv")) as f:
        rows = list(csv.DictReader(f))
    report("one CSV row per registered model", sorted(r["model"] for r in rows) == sorted(models)
           and all(int(r["resolution"]) == RES for r in rows), f"rows {[r['model'] for r in rows]}, models {models}")

    for r in rows:
        truth = os.path.join(out, r["truth"])
        image = os.path.join(out, r["image"])
        if not (os.path.isfile(truth) and os.path.isfile(image)):
            report(f"{r['model']}: images exist", False, f"{truth}, {image}")
            continue
        ref = voxlab_json("compare", truth, image, "--json")
        mse, ssim = float(r["mse"]), float(r["ssim"])
        report(f"{r['model']}: MSE and SSIM equal voxlab compare",
               abs(mse - ref["mse"]) <= 1e-9 and abs(ssim - ref["ssim"]) <= 1e-9,
               f"csv {mse!r} {ssim!r}, compare {ref['mse']!r} {ref['ssim']!r}")
        report(f"{r['model']}: size and timing columns", ref["width"] == RES and ref["height"] == RES
               and float(r["bake_s"]) > 0 and float(r["render_s"]) > 0 and int(float(r["voxels"])) > 0
               and float(r["mb"]) > 0, str(r))
        for suffix in (".png", "_heat.png"):
            png = os.path.join(out, f"{r['model']}_{RES}{suffix}")
            report(f"{r['model']}: {os.path.basename(png)} is {RES}x{RES}",
                   os.path.isfile(png) and Image.open(png).size == (RES, RES), png)

    strip = os.path.join(out, f"strip_{RES}.png")
    columns = 1 + 2 * len(models)  # truth, each model, each model's heat map
    size = Image.open(strip).size if os.path.isfile(strip) else None
    report("strip width = columns x size", size is not None and size[0] == columns * RES and size[1] > RES,
           f"{strip}: {size}, expected width {columns * RES}")

    g = subprocess.run(["git", "-C", REPO, "rev-parse", "HEAD"], capture_output=True, text=True)
    # Outside a git checkout (an unpacked tarball) the script must say so rather than invent a commit.
    head = g.stdout.strip() if g.returncode == 0 else "unknown (not a git checkout)"
    with open(os.path.join(out, "table.md")) as f:
        md = f.read()
    report("table.md names the commit", f"git commit: {head}" in md, f"{head!r} not in table.md")
    wanted = [f"truth spp {TRUTH_SPP}", f"resolutions {RES}", "model spp 4", "bake rays 150", "nproc",
              "spheres.json", *[f"| {m} | {RES}" for m in models]]
    report("table.md states settings and rows", all(w in md for w in wanted),
           f"missing {[w for w in wanted if w not in md]}")
    leftovers = [n for n in os.listdir(out) if ".tmp." in n]
    report("no temporary files left", not leftovers, str(leftovers))

    truth = os.path.join(out, rows[0]["truth"]) if rows else None
    before = os.stat(truth).st_mtime_ns if truth else None
    p2 = run_script(out)
    report("second run reuses the truth", p2.returncode == 0 and "reusing" in p2.stderr
           and os.stat(truth).st_mtime_ns == before, p2.stderr[-1000:])

    bad = run_script(os.path.join(TMP, "bad"), scene="tests/does_not_exist.json")
    report("missing scene fails", bad.returncode != 0 and "does_not_exist" in bad.stderr, bad.stderr[-500:])
    # A scene the script finds but voxlab rejects: voxlab's own message must reach stderr.
    broken = os.path.join(TMP, "broken.json")
    with open(broken, "w") as f:
        f.write('{"name": "broken", "size": [32, 32]')
    bad = subprocess.run([sys.executable, SCRIPT, "--scene", broken, "--res", str(RES), "--truth-spp", "1",
                          "--out", os.path.join(TMP, "bad2"), "--voxlab", VOXLAB], capture_output=True, text=True)
    report("failing voxlab call prints its stderr, exits non-zero",
           bad.returncode != 0 and "voxlab" in bad.stderr and "broken.json" in bad.stderr, bad.stderr[-500:])


if __name__ == "__main__":
    main()
    finish()
