"""The dashboard built from a tiny sweep (spheres at 16^3, every registered model, twice, so the
history has two runs) against a baseline in which one model's MSE is made better than it is: opened
in headless Chromium, the page must load without a console error or a broken image, list every
registered model, highlight that model's regression, show the history chart, reference nothing
outside its folder, and render to a screenshot (kept in the test's temporary folder, or copied to
$DASHBOARD_SCREENSHOT)."""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, report, voxlab  # noqa: E402

EXP = os.path.join(REPO, "experiments")
PY = sys.executable

# Injected first into <head> of a copy of the page: records script errors, failed resource loads
# (capture phase sees <img> errors) and, after load, every image that did not decode; writes them
# into the DOM for --dump-dom.
PROBE = """<script>
window.__errors = [];
window.onerror = function (m, src, line) { window.__errors.push('error: ' + m + ' at ' + src + ':' + line); };
window.addEventListener('error', function (e) {
  if (e.target && e.target !== window) window.__errors.push('resource: ' + (e.target.src || e.target.href));
}, true);
window.addEventListener('load', function () {
  var imgs = document.images, bad = [];
  for (var i = 0; i < imgs.length; i++) if (!imgs[i].complete || imgs[i].naturalWidth === 0) bad.push(imgs[i].src);
  var pre = document.createElement('pre');
  pre.id = 'probe-report';
  pre.textContent = JSON.stringify({errors: window.__errors, broken: bad, images: imgs.length,
                                    svgs: document.querySelectorAll('svg').length});
  document.body.appendChild(pre);
});
</script>"""


def chromium(url, *extra):
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    with tempfile.TemporaryDirectory() as profile:
        return subprocess.run([exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                               "--disable-component-update", "--disable-sync", "--no-first-run",
                               f"--user-data-dir={profile}", "--enable-logging=stderr", "--v=0",
                               "--virtual-time-budget=5000", *extra, url],
                              capture_output=True, text=True, timeout=90)


def console_errors(stderr):
    """Chromium logs the page's console as ':INFO:CONSOLE' lines; errors say Uncaught or failed loads."""
    return [line for line in stderr.splitlines() if "CONSOLE" in line and
            re.search(r"Uncaught|Error|Failed to load|Not allowed", line)]


def dirty_baseline_refused(decl):
    """A baseline must belong to a commit: in a scratch git repository holding a copy of experiments/,
    --write-baseline on a checkout with an uncommitted change fails, names the cause and writes
    nothing; committing the change lets it through."""
    repo = os.path.join(TMP, "scratch-repo")
    shutil.copytree(EXP, os.path.join(repo, "experiments"))
    git = lambda *a: subprocess.run(["git", "-C", repo, *a], capture_output=True, text=True, check=True)
    os.symlink(os.path.join(REPO, "scenes"), os.path.join(repo, "scenes"))  # untracked: not "dirty"
    git("init", "-q")
    git("add", "experiments")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "scratch")
    with open(os.path.join(repo, "experiments", "README.md"), "a") as f:
        f.write("an uncommitted edit\n")
    baseline = os.path.join(TMP, "scratch-baseline.json")
    cmd = [PY, os.path.join(repo, "experiments", "regress.py"), "--experiment", decl, "--results",
           os.path.join(TMP, "scratch-results"), "--baseline", baseline, "--voxlab", VOXLAB, "--write-baseline"]
    p = subprocess.run(cmd, capture_output=True, text=True)
    report("--write-baseline refuses a checkout with uncommitted changes",
           p.returncode != 0 and "uncommitted changes" in p.stderr and not os.path.exists(baseline), p.stderr[-800:])
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qam", "the edit")
    p = subprocess.run(cmd, capture_output=True, text=True)
    report("--write-baseline on the committed checkout writes the baseline",
           p.returncode == 0 and os.path.exists(baseline), p.stderr[-800:])


def main():
    models = [line.split()[0] for line in voxlab("models").stdout.splitlines() if line.strip()]
    results = os.path.join(TMP, "results")
    baseline = os.path.join(TMP, "baseline.json")
    decl = os.path.join(TMP, "tiny.json")
    with open(decl, "w") as f:
        json.dump({"name": "tiny", "truth_spp": 16, "scenes": ["spheres"], "history": True,
                   "runs": [{"models": "all", "res": [16], "size": 32, "spp": [2], "rays": [64]}]}, f)
    common = ["--experiment", decl, "--results", results, "--baseline", baseline, "--voxlab", VOXLAB, "--jobs", "2"]
    # --allow-dirty: this test runs in developers' checkouts too; the refusal is tested below.
    p = subprocess.run([PY, os.path.join(EXP, "regress.py"), *common, "--write-baseline", "--allow-dirty"],
                       capture_output=True, text=True)
    report("tiny sweep and baseline", p.returncode == 0 and os.path.exists(baseline), p.stderr[-1500:])
    if p.returncode != 0:
        return
    dirty_baseline_refused(decl)
    # Pretend the baseline was better: the first model's MSE now counts as a regression.
    with open(baseline) as f:
        doc = json.load(f)
    entries = doc["experiments"]["tiny"]["entries"]
    victim = models[0]
    for e in entries.values():
        if e["model"] == victim:
            e["mse"] = e["mse"] / 2
    with open(baseline, "w") as f:
        json.dump(doc, f)
    p = subprocess.run([PY, os.path.join(EXP, "regress.py"), *common], capture_output=True, text=True)
    report("regress exits 1 on the regression and names it", p.returncode == 1 and victim in p.stderr and
           "regression" in p.stderr, p.stderr[-800:])

    out = os.path.join(results, "dashboard")
    dash = [PY, os.path.join(EXP, "dashboard.py"), "--results", results, "--baseline", baseline,
            "--experiments", "tiny", "--voxlab", VOXLAB, "--out", out, "--record-history"]
    # Two commits in the history: record this run, pretend it was an earlier commit's, record again.
    subprocess.run(dash, capture_output=True, text=True)
    hist = os.path.join(results, "history.csv")
    if os.path.exists(hist):
        with open(hist) as f:
            text = f.read()
        head = subprocess.run(["git", "-C", REPO, "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
        with open(hist, "w") as f:
            f.write(text.replace(head[:8], "0" * 8) if head else text)  # the commit and its run id
    p = subprocess.run(dash, capture_output=True, text=True)
    index = os.path.join(out, "index.html")
    report("dashboard builds", p.returncode == 0 and os.path.isfile(index), p.stderr[-1500:])
    if not os.path.isfile(index):
        return
    with open(index) as f:
        page = f.read()
    external = re.findall(r"""(?:src|href)\s*=\s*["']?\s*(?:https?:|//|file:)""", page)
    report("no external or absolute references", not external and "<script" not in page, str(external[:5]))
    refs = re.findall(r"""src=['"]([^'"]+)['"]""", page)
    report("every image is inside the dashboard folder",
           refs and all(not os.path.isabs(r) and os.path.isfile(os.path.join(out, r)) for r in refs), str(refs[:5]))

    probe_page = os.path.join(out, "probe.html")
    with open(probe_page, "w") as f:
        f.write(page.replace("<head>", "<head>" + PROBE, 1))
    c = chromium("file://" + probe_page, "--dump-dom")
    m = re.search(r'<pre id="probe-report">(.*?)</pre>', c.stdout, re.S)
    probe = json.loads(m.group(1).replace("&quot;", '"').replace("&amp;", "&")) if m else None
    report("page loads in headless Chromium", c.returncode == 0 and probe is not None, c.stderr[-800:])
    if probe:
        report("no script errors, no broken images", not probe["errors"] and not probe["broken"] and
               probe["images"] > 0, json.dumps(probe)[:800])
        report("history chart present (inline SVG)", probe["svgs"] >= 1, json.dumps(probe))
    errs = console_errors(c.stderr)
    report("no console errors", not errs, "\n".join(errs[:5]))
    dom = c.stdout
    models_list = re.search(r'<ul class="models" id="models">(.*?)</ul>', dom, re.S)
    listed = re.findall(r'data-model="([^"]+)"', models_list.group(1)) if models_list else []
    report("lists every registered model", sorted(listed) == sorted(models), f"listed {listed}, registered {models}")
    report("every registered model has a metrics row",
           all(re.search(rf'<tr class="[^"]*" data-model="{re.escape(mm)}"', dom) for mm in models), "")
    row = re.search(rf'<tr class="regression" data-model="{re.escape(victim)}">(.*?)</tr>', dom, re.S)
    report("the regression is highlighted", row is not None and 'class="regression"' in row.group(1) and
           'class="banner bad"' in dom, (row.group(0)[:300] if row else "no regression row"))
    others = [mm for mm in models if mm != victim]
    report("the other models are not", all(re.search(rf'<tr class="ok" data-model="{re.escape(mm)}"', dom)
                                           for mm in others), "")
    report("history table has both runs", dom.count("<td class=\"l\">tiny</td>") >= 2, "")

    shot = os.path.join(TMP, "dashboard.png")
    s = chromium("file://" + index, f"--screenshot={shot}", "--window-size=1280,1800")
    ok = s.returncode == 0 and os.path.isfile(shot)
    if ok:
        from PIL import Image
        import numpy as np

        img = np.asarray(Image.open(shot).convert("L"), dtype=float)
        ok = img.shape == (1800, 1280) and img.std() > 5
    report("screenshot saved", ok, s.stderr[-500:])
    if ok:
        print(f"# screenshot: {shot}")
        if os.environ.get("DASHBOARD_SCREENSHOT"):
            shutil.copy(shot, os.environ["DASHBOARD_SCREENSHOT"])


if __name__ == "__main__":
    if not (shutil.which("chromium") or shutil.which("chromium-browser")):
        report("chromium installed (make deps installs it)", False, "no chromium on PATH")
        finish()
    main()
    finish()
