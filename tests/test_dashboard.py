"""The dashboard built from a tiny sweep (spheres at 16^3, every registered model, twice, so the
history has two runs) against a baseline in which one model's MSE is made better than it is: opened
in headless Chromium, the page must load without a console error or a broken image, list every
registered model, highlight that model's regression, reference nothing outside its folder (its
libraries are vendored under vendor/), and render to a screenshot (kept in the test's temporary
folder, or copied to $DASHBOARD_SCREENSHOT). Its navigation: a table of contents, a table that sorts
when a header is clicked and filters, images that open full size, a truth/model slider and an error
map per cell, links to each job's command, stats JSON and EXR that exist on disk, trend charts of
error, time and memory with one point per commit, and a notice on a figure made by an older binary
than the table."""
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
# (capture phase sees <img> errors) and, after load, every image that did not decode; then clicks the
# MSE header of the first metrics table twice (a real click: mousedown + mouseup, as tablesorter
# listens), filters it by one model, reads the trend charts; writes it all into the DOM for --dump-dom.
PROBE = """<script>
window.__errors = [];
window.onerror = function (m, src, line) { window.__errors.push('error: ' + m + ' at ' + src + ':' + line); };
window.addEventListener('error', function (e) {
  if (e.target && e.target !== window) window.__errors.push('resource: ' + (e.target.src || e.target.href));
}, true);
function __click(el) {
  ['mousedown', 'mouseup', 'click'].forEach(function (t) {
    el.dispatchEvent(new MouseEvent(t, {bubbles: true, cancelable: true, button: 0, buttons: 1}));
  });
}
function __column(table, metric) {
  var ths = Array.prototype.slice.call(table.querySelectorAll('thead tr:first-child th'));
  var k = ths.findIndex(function (th) { return th.getAttribute('data-metric') === metric; });
  return Array.prototype.map.call(table.querySelectorAll('tbody tr'), function (tr) {
    return tr.children[k].getAttribute('data-text');
  });
}
window.addEventListener('load', function () {
  var imgs = document.images, bad = [];
  for (var i = 0; i < imgs.length; i++) if (!imgs[i].complete || imgs[i].naturalWidth === 0) bad.push(imgs[i].src);
  // jQuery 3 runs ready handlers after load: wait until the page says its tables and charts are set up.
  var tries = 0, wait = setInterval(function () {
    if (window.dashboardReady || ++tries > 40) { clearInterval(wait); __interact(bad, imgs.length); }
  }, 100);
});
function __interact(bad, nimgs) {
  // tablesorter sorts in a timer after the click: each step waits for the previous one.
  var table = document.querySelector('table.metrics'), sort = {}, filt = {};
  var th = table && table.querySelector('thead th[data-metric="mse"]');
  var steps = [
    function () { sort.before = __column(table, 'mse'); __click(th); },
    function () { sort.first = __column(table, 'mse'); sort.first_class = th.className; __click(th); },
    function () {
      sort.second = __column(table, 'mse'); sort.second_class = th.className;
      var model = table.querySelector('tbody tr').getAttribute('data-model');
      jQuery.tablesorter.setFilters(table, ['', model], true);
      filt.model = model;
    },
    function () {
      filt.visible = Array.prototype.filter.call(table.querySelectorAll('tbody tr'), function (tr) {
        return tr.style.display !== 'none' && !tr.classList.contains('filtered');
      }).map(function (tr) { return tr.getAttribute('data-model'); });
      jQuery.tablesorter.setFilters(table, ['', ''], true);  // cleared: the rest of the checks see every row
    }];
  if (!table || !window.jQuery || !jQuery.tablesorter) steps = [];
  var k = 0;
  (function next() {
    if (k < steps.length) {
      try { steps[k++](); } catch (e) { window.__errors.push('probe: ' + e); k = steps.length; }
      setTimeout(next, 250);
      return;
    }
    var charts = (window.__charts || []).map(function (c) {
      return {id: c.canvas.id, labels: c.data.labels,
              datasets: c.data.datasets.map(function (d) { return {label: d.label, data: d.data}; })};
    });
    var pre = document.createElement('pre');
    pre.id = 'probe-report';
    pre.textContent = JSON.stringify({errors: window.__errors, broken: bad, images: nimgs,
                                      svgs: document.querySelectorAll('svg').length, sort: sort, filter: filt,
                                      charts: charts, jquery: !!window.jQuery, chartjs: !!window.Chart});
    document.body.appendChild(pre);
  })();
}
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


def fake_figures(results):
    """Two plots with provenance sidecars (as voxlab_exp/plots.py writes them): a grid made by an older
    binary than the tiny table, and a Pareto plot (with its PDF and SVG) made by the table's binary."""
    from PIL import Image

    with open(os.path.join(results, "tiny", "rows.json")) as f:
        meta = json.load(f)["meta"]
    for sub, stem, sha, date in (("figures", "grid_old_16", "0" * 64, "2000-01-01T00:00:00+00:00"),
                                 ("pareto", "pareto_same", meta["voxlab_sha256"], meta["date"])):
        d = os.path.join(results, sub)
        os.makedirs(d, exist_ok=True)
        Image.new("RGB", (40, 30), (200, 100, 50)).save(os.path.join(d, stem + ".png"))
        for ext in ("pdf", "svg"):
            with open(os.path.join(d, f"{stem}.{ext}"), "w") as f:
                f.write("vector\n")
        with open(os.path.join(d, stem + ".json"), "w") as f:
            json.dump({"experiment": "x", "voxlab_sha256": sha, "date": date, "commit": "0" * 40, "dirty": False}, f)


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
    fake_figures(results)
    p = subprocess.run(dash, capture_output=True, text=True)
    index = os.path.join(out, "index.html")
    report("dashboard builds", p.returncode == 0 and os.path.isfile(index), p.stderr[-1500:])
    if not os.path.isfile(index):
        return
    with open(index) as f:
        page = f.read()
    external = re.findall(r"""(?:src|href)\s*=\s*["']?\s*(?:https?:|//|file:)""", page)
    report("no external or absolute references", not external, str(external[:5]))
    scripts = re.findall(r"""<script\b([^>]*)>""", page)
    script_src = [re.search(r"""src=['"]([^'"]+)['"]""", x).group(1) for x in scripts if "src=" in x]
    report("scripts only from the page's vendor/ folder (Debian's jquery, tablesorter, Chart.js), with licences",
           script_src and all(x.startswith("vendor/") and os.path.isfile(os.path.join(out, x)) for x in script_src)
           and all(os.path.isfile(os.path.join(out, "vendor", f"{pkg}.copyright"))
                   for pkg in ("libjs-jquery", "libjs-jquery-tablesorter", "libjs-chart.js")), str(script_src))
    refs = re.findall(r"""src=['"]([^'"]+)['"]""", page)
    report("every image is inside the dashboard folder",
           refs and all(not os.path.isabs(r) and os.path.isfile(os.path.join(out, r)) for r in refs), str(refs[:5]))
    # In-page anchors aside; "?exp=E" (one experiment alone) is the page itself.
    hrefs = [("index.html" if h.startswith("?") else h) for h in re.findall(r"""href=['"]([^'"]+)['"]""", page)
             if not h.startswith("#")]
    report("every link points to a file inside the dashboard folder",
           hrefs and all(not os.path.isabs(h) and ".." not in h.split("/") and os.path.isfile(os.path.join(out, h))
                         for h in hrefs), str([h for h in hrefs if not os.path.isfile(os.path.join(out, h))][:5]))

    # Per cell: the job's command, stats JSON and EXR, on disk, each what it says.
    rows_html = re.findall(r"<tr class='[^']*' data-model='([^']+)'>(.*?)</tr>", page, re.S)
    ok_rows = [(mm, body) for mm, body in rows_html if "class=cmd" in body]
    good = len(ok_rows) == len(models)
    why = f"{len(ok_rows)} rows with job links for {len(models)} models"
    for mm, body in ok_rows:
        cmd = re.search(r"<a class=cmd href='([^']+)'", body)
        st = re.search(r"<a class=stats href='([^']+)'", body)
        ex = re.search(r"<a class=exr href='([^']+)'", body)
        if not (cmd and st and ex):
            good, why = False, f"{mm}: missing link(s)"
            break
        with open(os.path.join(out, cmd.group(1))) as f:
            c_text = f.read()
        with open(os.path.join(out, ex.group(1)), "rb") as f:
            magic = f.read(4)
        try:
            stats = json.load(open(os.path.join(out, st.group(1))))
        except ValueError:
            stats = {}
        if not ("render" in c_text and f"--model {mm}" in c_text and "seconds" in stats and magic == b"\x76\x2f\x31\x01"):
            good, why = False, f"{mm}: command {c_text[:120]!r}, stats keys {list(stats)[:5]}, EXR magic {magic!r}"
            break
    report("each cell links to its job's command, stats JSON and EXR (on disk)", good, why)
    report("each cell has a truth/model slider and an error map that open full size",
           len(re.findall(r"<div class=flip[^>]*><img class=truth src='[^']+'[^>]*><img class=model src='[^']+'[^>]*>"
                          r"<input type=range", page)) == len(models) and
           len(re.findall(r"<a href='(img/[^']+_error\.png)' target=_blank class=full><img class=err src='\1'", page))
           == len(models), "")
    report("every image of the strips and figures opens full size (a link to the same file)",
           all(re.search(rf"<a href='{re.escape(src)}' target=_blank", page)
               for src in re.findall(r"<img (?:class=plot )?src='([^']+)'", page)), "")
    toc = re.search(r"<nav id=toc>(.*?)</nav>", page, re.S)
    anchors = re.findall(r"href='#([^']+)'", toc.group(1)) if toc else []
    report("a table of contents links every experiment and section",
           "exp-tiny" in anchors and "history" in anchors and all(f"id='{x}'" in page or f"id={x}" in page
                                                                   for x in anchors), str(anchors))
    report("tabs: one experiment alone (?exp=E)", re.search(r"<a class=tab data-exp='tiny' href='\?exp=tiny'>", page)
           is not None and "<section class=part id='sec-tiny'>" in page, "")
    notice = re.search(r"<img class=plot src='img/figures_grid_old_16\.png'.*?</p>", page, re.S)
    same = re.search(r"<img class=plot src='img/pareto_pareto_same\.png'.*?</p>", page, re.S)
    report("a figure made by an older binary than the table carries a notice; one by the same binary none",
           notice is not None and "older-binary" in notice.group(0) and "older voxlab" in notice.group(0) and
           same is not None and "notice" not in same.group(0),
           (notice.group(0)[-400:] if notice else "no old figure") + " | " + (same.group(0)[-300:] if same else "none"))
    report("a figure's PDF and SVG are linked beside it",
           same is not None and "pareto_pareto_same.pdf'>PDF" in same.group(0) and
           "pareto_pareto_same.svg'>SVG" in same.group(0), same.group(0)[-300:] if same else "")

    probe_page = os.path.join(out, "probe.html")
    with open(probe_page, "w") as f:
        f.write(page.replace("<head>", "<head>" + PROBE, 1))
    c = chromium("file://" + probe_page, "--dump-dom")
    m = re.search(r'<pre id="probe-report">(.*?)</pre>', c.stdout, re.S)
    probe = json.loads(m.group(1).replace("&quot;", '"').replace("&lt;", "<").replace("&gt;", ">")
                       .replace("&amp;", "&")) if m else None
    report("page loads in headless Chromium", c.returncode == 0 and probe is not None, c.stderr[-800:])
    if probe:
        report("no script errors, no broken images", not probe["errors"] and not probe["broken"] and
               probe["images"] > 0 and probe["jquery"] and probe["chartjs"], json.dumps(probe)[:800])
        srt = probe["sort"]
        vals = lambda key: [float(v) for v in srt.get(key, []) if v]
        report("clicking the MSE header sorts the table (ascending, then descending)",
               len(vals("first")) == len(models) and vals("first") == sorted(vals("before")) and
               vals("second") == sorted(vals("before"), reverse=True) and vals("first") != vals("second"),
               json.dumps(srt))
        report("the filter row filters by model", probe["filter"].get("visible") == [probe["filter"].get("model")],
               json.dumps(probe["filter"]))
        charts = probe["charts"]
        commits = {len(ch["labels"]) for ch in charts}
        metrics_charted = {ch["id"].rsplit("-", 1)[1] for ch in charts}
        report("trend charts of error, time and memory, one point per commit (two commits)",
               {"mse", "render_ms", "mb"} <= metrics_charted and commits == {2} and
               all(len(set(ch["labels"])) == len(ch["labels"]) for ch in charts) and
               all(len(d["data"]) == 2 and all(v is not None for v in d["data"]) for ch in charts
                   for d in ch["datasets"]) and
               all(sorted(d["label"] for d in ch["datasets"]) == sorted(models) for ch in charts),
               json.dumps(charts)[:800])
    errs = console_errors(c.stderr)
    report("no console errors", not errs, "\n".join(errs[:5]))
    dom = c.stdout
    models_list = re.search(r'<ul class="models" id="models">(.*?)</ul>', dom, re.S)
    listed = re.findall(r'data-model="([^"]+)"', models_list.group(1)) if models_list else []
    report("lists every registered model", sorted(listed) == sorted(models), f"listed {listed}, registered {models}")
    report("every registered model has a metrics row",
           all(re.search(rf'<tr class="[^"]*" data-model="{re.escape(mm)}"', dom) for mm in models), "")
    row = re.search(rf'<tr class="regression[^"]*" data-model="{re.escape(victim)}"[^>]*>(.*?)</tr>', dom, re.S)
    report("the regression is highlighted", row is not None and 'class="regression"' in row.group(1) and
           'class="banner bad"' in dom, (row.group(0)[:300] if row else "no regression row"))
    others = [mm for mm in models if mm != victim]
    report("the other models are not", all(re.search(rf'<tr class="ok[^"]*" data-model="{re.escape(mm)}"', dom)
                                           for mm in others), "")
    report("history table has both runs", dom.count("<td class=\"l\">tiny</td>") >= 2, "")

    # A link that opens one experiment alone with its table sorted (what --screenshot's second picture shows).
    c = chromium("file://" + index + "?exp=tiny&sort=mse:desc", "--dump-dom")
    body = re.search(r'<table class="sortable metrics[^"]*" id="table-tiny".*?<tbody[^>]*>(.*?)</tbody>', c.stdout, re.S)
    order = []
    for tr in re.findall(r"<tr\b.*?</tr>", body.group(1), re.S) if body else []:
        mse_td = re.findall(r"<td\b([^>]*)>", tr)[4]  # scene, model, res, image, MSE
        order.append(float(re.search(r'data-text="([^"]+)"', mse_td).group(1)))
    hidden = re.search(r'<section class="part" id="sec-history" style="display: none;">', c.stdout)
    report("?exp=tiny&sort=mse:desc shows that experiment alone, sorted by MSE (descending)",
           len(order) == len(models) and order == sorted(order, reverse=True) and hidden is not None,
           f"order {order}; history hidden: {hidden is not None}")

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
