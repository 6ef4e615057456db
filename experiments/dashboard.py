#!/usr/bin/python3
"""The results dashboard: one static page that opens from disk (make dashboard).

    /usr/bin/python3 experiments/dashboard.py [--results results] [--baseline results/baseline.json]
        [--history results/history.csv] [--experiments regress,table1] [--out results/dashboard]
        [--voxlab build/voxlab] [--screenshot] [--record-history]

Reads what the other targets wrote (it runs nothing itself; `make dashboard` runs them first):
<results>/<experiment>/rows.json for each experiment named, the baseline, the history, and the
plots under <results>/pareto and <results>/figures. Writes <out>/index.html with every image it shows
copied into <out>/img/, each job file it links to under <out>/jobs/ (hard links where possible) and
its libraries under <out>/vendor/ (copied from Debian's libjs-jquery, libjs-jquery-tablesorter and
libjs-chart.js with their copyright files): relative links only, no server, no external URL, so the
folder can be copied or archived as it is. The page has:

  - a table of contents (sticky at the top): models, each experiment, each figure section, trends;
  - the registered models (`voxlab models` when the binary runs, and every model in the results),
    each with its bytes per voxel, compositing rule and its colour (the same in every figure:
    voxlab_exp/plots.py);
  - per experiment one table (jQuery tablesorter: click a header to sort, a filter row under the
    headers) with scene, model, resolution, image and each metric with its change against the
    baseline (results/baseline.json); cells beyond the tolerances of experiments/regress.json are
    marked regression (red, gating), warning (orange, report-only metrics such as time) or improved
    (green); per cell a truth <-> model slider, the error map, and links to the render job's
    command, stats JSON and EXR; every image opens full size;
  - image strips (truth and each model), and the paper-figure grids, Pareto plots and figures when
    they exist, with their PDF and SVG, and a notice when a figure was made by another (older)
    voxlab binary than the tables (the figure's provenance sidecar <stem>.json against rows.json);
  - trends over commits (results/history.csv), drawn by Chart.js: per experiment and scene error
    (MSE), render time and memory, a line per model, one point per commit; a table of the latest runs.

--record-history (what `make dashboard` passes) first writes the shown experiments' current rows into
the history, for those whose declaration says "history": true: one line per commit and configuration,
a rerun at the same commit replacing its lines. Nothing else writes the history.

The page is written into a temporary folder that replaces <out> when complete. --screenshot also
saves <out>/screenshot.png with headless Chromium (Debian's chromium package) when it is installed.
"""
import argparse
import datetime
import glob
import html
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from voxlab_exp.cli import main_wrapper  # noqa: E402
from voxlab_exp.config import DEFAULT_RESULTS, REPO  # noqa: E402
from voxlab_exp.errors import VoxlabError  # noqa: E402
from voxlab_exp.files import load_json, rel, write_text  # noqa: E402
from voxlab_exp.history import compare_to_baseline, read_history, record_history  # noqa: E402
from voxlab_exp.images import error_map  # noqa: E402
from voxlab_exp.plots import model_colour  # noqa: E402
from voxlab_exp.jobs import models_info  # noqa: E402
from voxlab_exp.provenance import git_info, now_iso  # noqa: E402
from voxlab_exp.report import settings_text, size_text  # noqa: E402
from voxlab_exp.rows import row_key, shadow_method, shadow_skip_off  # noqa: E402
from voxlab_exp.schema import load_declaration  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
METRICS = [("mse", "MSE"), ("ssim", "SSIM"), ("psnr", "PSNR"), ("render_ms", "render ms"), ("bake_s", "bake s"),
           ("mb", "MB")]

CSS = """
body{font:14px/1.45 system-ui,-apple-system,'DejaVu Sans',sans-serif;margin:0 auto;max-width:1500px;padding:0 18px 40px;color:#222}
h1{margin:18px 0 4px}h2{margin-top:34px;border-bottom:1px solid #ccc;padding-bottom:3px}h3{margin:20px 0 6px}
.meta{color:#555;font-size:13px}.meta code{font-size:12px}
table{border-collapse:collapse;margin:6px 0 12px;font-size:13px}
th,td{border:1px solid #d6d6d6;padding:3px 7px;text-align:right;white-space:nowrap}
th{background:#f2f2f2}td.l,th.l{text-align:left}
td.regression,td.failed,td.missing,tr.regression td.status{background:#f8caca}
td.warning{background:#fde3b5}td.improved{background:#cfeecf}td.new{background:#dde8f8}
.delta{color:#555;font-size:11px;display:block}
.banner{padding:10px 14px;border-radius:6px;margin:12px 0;font-weight:600}
.banner.ok{background:#d8f1d8}.banner.bad{background:#f8caca}.banner.none{background:#eee}
.notice{background:#fff3c4;border:1px solid #e0c060;padding:4px 8px;border-radius:4px;font-size:12px;display:inline-block}
.strip{display:flex;flex-wrap:wrap;gap:6px;margin:6px 0 14px}
.strip figure{margin:0;text-align:center;font-size:11px}
.strip img{image-rendering:pixelated;width:160px;height:auto;border:1px solid #ccc}
img.plot{max-width:100%;border:1px solid #ddd;margin:6px 0}
.models li{margin:2px 0}.small{font-size:12px;color:#666}
.swatch{display:inline-block;width:10px;height:10px;border-radius:2px;margin-right:4px;vertical-align:baseline}
nav#toc{position:sticky;top:0;background:#fafafa;border-bottom:1px solid #ccc;padding:6px 0;z-index:5;font-size:13px}
nav#toc a{margin-right:12px;text-decoration:none;color:#0645ad}nav#toc a.current{font-weight:700;color:#000}
.flip{position:relative;display:inline-block;width:96px;line-height:0;vertical-align:middle}
.flip img{width:96px;image-rendering:pixelated;display:block}
.flip img.model{position:absolute;top:0;left:0;clip-path:inset(0 50% 0 0)}
.flip input{width:96px;margin:2px 0 0;display:block}
img.err{width:96px;image-rendering:pixelated;vertical-align:middle}
td.img{padding:2px;text-align:center}td.links a{margin-right:5px}
.trends{display:grid;grid-template-columns:repeat(3,minmax(0,1fr));gap:10px;margin:6px 0 18px}
.trends figure{margin:0}.trends figcaption{font-size:12px;color:#444}
"""

# Vendored from Debian packages at build time (experiments/experiments.mk DEPS): served from the page's
# own vendor/ folder, so the page needs no network. (source, name in vendor/, its package's licence).
VENDOR = [("/usr/share/javascript/jquery/jquery.min.js", "jquery.min.js", "libjs-jquery"),
          ("/usr/share/javascript/jquery-tablesorter/js/jquery.tablesorter.combined.min.js",
           "jquery.tablesorter.combined.min.js", "libjs-jquery-tablesorter"),
          ("/usr/share/javascript/jquery-tablesorter/css/theme.default.css", "theme.default.css",
           "libjs-jquery-tablesorter"),
          ("/usr/share/javascript/chart.js/chart.min.js", "chart.min.js", "libjs-chart.js")]

# The page's own script: only glue (which tables sort, which canvases chart, the flip sliders).
PAGE_JS = """
$(function () {
  $('table.sortable').tablesorter({theme: 'default', widgets: ['filter'],
    widgetOptions: {filter_columnFilters: true, filter_ignoreCase: true, filter_placeholder: {search: 'filter'}}});
  $('.flip input').on('input', function () {
    $(this).siblings('img.model').css('clip-path', 'inset(0 ' + (100 - this.value) + '% 0 0)');
  });
  var data = JSON.parse(document.getElementById('trend-data').textContent);
  window.__charts = [];
  data.forEach(function (c) {
    var el = document.getElementById(c.id);
    if (!el) return;
    window.__charts.push(new Chart(el, {type: 'line', data: {labels: c.labels, datasets: c.datasets},
      options: {animation: false, spanGaps: true, responsive: true,
        plugins: {legend: {labels: {boxWidth: 10, font: {size: 10}}}, title: {display: true, text: c.title}},
        scales: {y: {type: c.log ? 'logarithmic' : 'linear', title: {display: true, text: c.ylabel}},
                 x: {title: {display: true, text: 'commit (oldest first; * = uncommitted changes)'}}}}}));
  });
  // index.html?exp=EXPERIMENT shows that experiment's section alone (a tab: the links in the table of
  // contents' "only" row); &sort=METRIC[:desc] opens its table sorted (what --screenshot's second
  // picture shows).
  var q = /[?&]exp=([^&]+)/.exec(location.search), srt = /[?&]sort=([^&:]+)(?::(desc))?/.exec(location.search);
  if (q) {
    $('section.part').not('#sec-' + q[1]).hide();
    $('nav#toc a.tab[data-exp="' + q[1] + '"]').addClass('current');
    if (srt) {
      var table = $('#table-' + q[1]), col = table.find('thead th[data-metric="' + srt[1] + '"]').index();
      if (col >= 0) table.trigger('sorton', [[[col, srt[2] ? 1 : 0]]]);
    }
  }
  window.dashboardReady = true;  // for tests/test_dashboard.py
});
"""


def esc(x):
    return html.escape(str(x), quote=True)


def num(v, metric):
    if v is None or v == "":
        return "–"
    v = float(v)
    if metric == "mse":
        return f"{v:.3e}"
    if metric == "ssim":
        return f"{v:.4f}"
    if metric in ("psnr", "mb"):
        return f"{v:.2f}"
    if metric == "render_ms":
        return f"{v:.1f}"
    return f"{v:.3g}"


def delta_text(d, metric):
    if d["base"] in (None, "") or d["delta"] is None:
        return ""
    base = float(d["base"])
    rel = f" ({d['delta'] / base:+.1%})" if base else ""
    return f"{d['delta']:+.2e}{rel}" if metric == "mse" else f"{d['delta']:+.4g}{rel}"


def safe_name(s):
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", s)


class Page:
    def __init__(self, out_tmp):
        self.parts, self.root, self.img_dir, self.copied = [], out_tmp, os.path.join(out_tmp, "img"), {}
        self.linked = {}
        os.makedirs(self.img_dir, exist_ok=True)

    def add(self, s):
        self.parts.append(s)

    def image(self, src, name_hint):
        """Copies src into img/ once; returns the relative link."""
        src = os.path.abspath(src)
        if src not in self.copied:
            base = safe_name(name_hint)
            name, k = base, 1
            while name in self.copied.values():
                stem, ext = os.path.splitext(base)
                name, k = f"{stem}_{k}{ext}", k + 1
            shutil.copyfile(src, os.path.join(self.img_dir, name))
            self.copied[src] = name
        return "img/" + self.copied[src]

    def save_image(self, pil_img, name):
        """A PIL image made for the page (an error map) into img/; returns the relative link."""
        name = safe_name(name)
        pil_img.save(os.path.join(self.img_dir, name), format="PNG")
        return "img/" + name

    def job_file(self, src, job_dir_name, name):
        """A job's file into jobs/<job>/ (hard link when the file system allows: EXRs cost no space);
        returns the relative link, or None when the job did not write it."""
        if not os.path.isfile(src):
            return None
        rel_path = f"jobs/{safe_name(job_dir_name)}/{name}"
        if rel_path not in self.linked:
            dst = os.path.join(self.root, rel_path)
            os.makedirs(os.path.dirname(dst), exist_ok=True)
            try:
                os.link(src, dst)
            except OSError:
                shutil.copyfile(src, dst)
            self.linked[rel_path] = src
        return rel_path

    def job_text(self, text, job_dir_name, name):
        rel_path = f"jobs/{safe_name(job_dir_name)}/{name}"
        dst = os.path.join(self.root, rel_path)
        os.makedirs(os.path.dirname(dst), exist_ok=True)
        with open(dst, "w") as f:
            f.write(text)
        return rel_path


def vendor(out_tmp):
    """Copies the page's libraries (and their Debian copyright files) into vendor/; returns the
    packages that are missing (the page then still shows everything, unsorted and without charts)."""
    d = os.path.join(out_tmp, "vendor")
    os.makedirs(d, exist_ok=True)
    missing = []
    for src, name, pkg in VENDOR:
        if not os.path.isfile(src):
            missing.append(pkg)
            continue
        shutil.copyfile(src, os.path.join(d, name))
        lic = f"/usr/share/doc/{pkg}/copyright"
        if os.path.isfile(lic):
            shutil.copyfile(lic, os.path.join(d, f"{pkg}.copyright"))
    return list(dict.fromkeys(missing))


def registered_models(voxlab, metas):
    models = {}
    if voxlab and os.access(voxlab, os.X_OK):
        try:
            for m in models_info(voxlab):
                models[m["name"]] = m
        except VoxlabError:
            pass
    for meta in metas:
        for m in meta.get("models", []):
            models.setdefault(m["name"], m)
    return list(models.values())


def cell_images(page, results_root, exp, r):
    """The cell's truth ↔ model slider (drag: the model image covers the truth up to the handle),
    its error map (mean |model − truth|, own scale), each opening full size."""
    img, ref = os.path.join(results_root, r.get("image") or ""), os.path.join(results_root, r.get("truth_image") or "")
    prev, tprev = os.path.join(results_root, r.get("preview") or ""), \
        os.path.join(results_root, r.get("truth_preview") or "")
    if r.get("status") != "ok" or not all(os.path.isfile(p) for p in (img, ref, prev, tprev)):
        return "<td class=img>–</td><td class=img>–</td>"
    tag = f"{exp}_{r['scene']}_{r['model']}_{r['res']}_{r['width']}x{r['height']}_spp{r['spp']}_{os.path.basename(os.path.dirname(img))}"
    t = page.image(tprev, f"{exp}_{r['scene']}_truth_{r['width']}x{r['height']}_{os.path.basename(os.path.dirname(ref))}.png")
    m = page.image(prev, f"{tag}.png")
    try:
        e = page.save_image(error_map(ref, img), f"{tag}_error.png")
    except Exception as ex:  # an unreadable EXR: the cell says so, the page still builds
        e = None
        err_cell = f"<td class=img><span class=small>{esc(str(ex)[:60])}</span></td>"
    flip = (f"<td class=img><div class=flip title='drag: {esc(r['model'])} (left of the handle) against the truth'>"
            f"<img class=truth src='{t}' alt='truth'><img class=model src='{m}' alt='{esc(r['model'])}'>"
            f"<input type=range min=0 max=100 value=50 aria-label='truth / model'></div>"
            f"<a href='{m}' target=_blank class=full>model</a> <a href='{t}' target=_blank class=full>truth</a></td>")
    if e:
        err_cell = (f"<td class=img><a href='{e}' target=_blank class=full><img class=err src='{e}' "
                    f"alt='error map' title='mean |model − truth|, black 0 to yellow at this image's maximum'></a></td>")
    return flip + err_cell


def cell_links(page, results_root, r):
    """Links to the render job's command, stats JSON and EXR (copied or hard-linked under jobs/)."""
    if not r.get("image"):
        return "<td class='l links'>–</td>"
    job_dir = os.path.dirname(os.path.join(results_root, r["image"]))
    name = os.path.basename(job_dir)
    links = []
    jj = os.path.join(job_dir, "job.json")
    if os.path.isfile(jj):
        try:
            cmd = load_json(jj).get("command") or []
            links.append(f"<a class=cmd href='{page.job_text(shlex.join(map(str, cmd)) + chr(10), name, 'command.txt')}'"
                         f" title='{esc(shlex.join(map(str, cmd)))}'>command</a>")
            page.job_file(jj, name, "job.json")
        except (OSError, ValueError):
            pass
    for fname, label, cls in (("stats.json", "stats", "stats"), ("image.exr", "EXR", "exr")):
        link = page.job_file(os.path.join(job_dir, fname), name, fname)
        if link:
            links.append(f"<a class={cls} href='{link}'>{label}</a>")
    return "<td class='l links'>" + (" ".join(links) or "–") + "</td>"


def metrics_table(page, exp, meta, rows, section, tol, results_root):
    """One sortable, filterable table per experiment: a row per configuration with each metric and its
    change against the baseline, the truth ↔ model slider, the error map and the job's files."""
    results = compare_to_baseline(rows, section, tol) if section else \
        [{"key": row_key(r), "scene": r["scene"], "model": r["model"], "res": r["res"], "row": r,
          "status": "ok" if r["status"] == "ok" else "failed", "error": r.get("error"), "metrics": {}}
         for r in rows if r["kind"] == "model"]
    counts = {}
    for x in results:
        counts[x["status"]] = counts.get(x["status"], 0) + 1
    page.add(f"<table class='sortable metrics' id='table-{esc(exp)}'><thead><tr><th class=l>scene</th>"
             "<th class=l>model</th><th>res</th><th>image</th>" +
             "".join(f"<th data-metric='{m}'>{esc(label)}</th>" for m, label in METRICS) +
             "<th class=l>status</th><th class='sorter-false filter-false'>truth ↔ model</th>"
             "<th class='sorter-false filter-false'>error map</th><th class='l sorter-false'>job</th></tr></thead><tbody>")
    for x in results:
        r = x.get("row") or {}
        cls = x["status"]
        page.add(f"<tr class='{esc(cls)}' data-model='{esc(x['model'])}'><td class=l>{esc(x['scene'])}</td>"
                 f"<td class=l><span class=swatch style='background:{model_colour(x['model'])}'></span>"
                 f"{esc(x['model'])}</td><td data-text='{esc(x['res'])}'>{esc(x['res'])}³</td>"
                 f"<td>{esc(r.get('width', '–'))}×{esc(r.get('height', '–'))}"
                 f"{', ' + esc(r['spp']) + ' spp' if r.get('spp') else ''}</td>")
        for m, _ in METRICS:
            d = x["metrics"].get(m)
            cur = r.get(m) if r else None
            sort_val = f" data-text='{esc(cur)}'" if cur not in (None, "") else ""
            if d and d["base"] is not None:
                page.add(f"<td class='{esc(d['verdict'])}'{sort_val} title='baseline {esc(num(d['base'], m))}'>"
                         f"{esc(num(cur, m))}<span class=delta>{esc(delta_text(d, m))}</span></td>")
            else:
                page.add(f"<td{sort_val}>{esc(num(cur, m))}</td>")
        status = x["status"] + (f": {x['error']}" if x.get("error") else "")
        page.add(f"<td class='l status {esc(cls)}'>{esc(status)}</td>")
        page.add(cell_images(page, results_root, exp, r) if r else "<td class=img>–</td><td class=img>–</td>")
        page.add(cell_links(page, results_root, r) if r else "<td class=l>–</td>")
        page.add("</tr>")
    page.add("</tbody></table>")
    return results, counts


def strips(page, results_root, rows, label):
    """Truth and each model's preview per scene (the regression subset's images), each opening full size."""
    for sc, n in dict.fromkeys((r["scene"], r["res"]) for r in rows if r["kind"] == "model"):
        rs = [r for r in rows if r["scene"] == sc and r["res"] == n and r["kind"] == "model"]
        page.add(f"<h3>{esc(label)} — {esc(sc)}, {esc(n)}³ voxels, {esc(size_text(rs))} images</h3><div class=strip>")
        t = next((r for r in rs if r.get("truth_preview") and
                  os.path.exists(os.path.join(results_root, r["truth_preview"]))), None)
        if t:
            src = page.image(os.path.join(results_root, t["truth_preview"]), f"{label}_{sc}_truth_{t['res']}.png")
            page.add(f"<figure><a href='{src}' target=_blank><img src='{src}' alt='truth'></a>"
                     f"<figcaption>truth {esc(t['truth_spp'])} spp</figcaption></figure>")
        for r in rs:
            if r["status"] == "ok" and os.path.exists(os.path.join(results_root, r["preview"])):
                src = page.image(os.path.join(results_root, r["preview"]), f"{label}_{sc}_{r['model']}_{r['res']}.png")
                page.add(f"<figure data-model='{esc(r['model'])}'><a href='{src}' target=_blank><img src='{src}' "
                         f"alt='{esc(r['model'])}'></a><figcaption>{esc(r['model'])} {esc(r['res'])}³<br>"
                         f"MSE {num(r['mse'], 'mse')}</figcaption></figure>")
            else:
                page.add(f"<figure data-model='{esc(r['model'])}'><figcaption>{esc(r['model'])}: failed<br>"
                         f"<span class=small>{esc(r.get('error', ''))[:120]}</span></figcaption></figure>")
        page.add("</div>")


TREND_METRICS = [("mse", "MSE", True), ("render_ms", "render ms per frame", True), ("mb", "memory MB", False)]


def trend_charts(history, experiment):
    """Error, time and memory over commits for one experiment: per scene a chart per metric, a line per
    model (and configuration when the experiment has several per scene), ONE point per commit (the
    newest line of that commit). Returns (html, chart specs for Chart.js)."""
    rows = [h for h in history if h.get("experiment") == experiment and h.get("status") == "ok"]
    if not rows:
        return "", []
    rows.sort(key=lambda h: (h["date"], h["run_id"]))
    commits = list(dict.fromkeys(h["commit"] for h in rows))
    dirty = {h["commit"] for h in rows if h.get("dirty") in ("1", "True")}
    labels = [c[:7] + ("*" if c in dirty else "") for c in commits]
    multi = len({(h["res"], h.get("spp"), h.get("width"), shadow_method(h), shadow_skip_off(h)) for h in rows}) > 1

    def series(h):
        if not multi:
            return h["model"]
        name = f"{h['model']} {h['res']}³" + ("" if h.get("spp") == "4" else f" {h.get('spp')}spp")
        # Shadows and shadow skip name a series too: history.csv keeps their lines apart (HISTORY_KEY).
        if shadow_method(h) != "march":
            name += f" {shadow_method(h)}"
        if shadow_skip_off(h):
            name += " no skip"
        return name
    scenes = list(dict.fromkeys(h["scene"] for h in rows))
    specs, out = [], [f"<h3 id='trends-{esc(experiment)}'>{esc(experiment)}: trends over commits "
                      f"({len(commits)} commit(s))</h3>"]
    for sc in scenes:
        out.append(f"<div class=trends data-scene='{esc(sc)}'>")
        for metric, ylabel, log in TREND_METRICS:
            cid = safe_name(f"trend-{experiment}-{sc}-{metric}")
            point = {}
            for h in rows:  # the newest line per commit and series wins: one point per commit
                if h["scene"] == sc and h.get(metric) not in (None, ""):
                    point[(series(h), h["commit"])] = (float(h[metric]), h["model"])
            names = list(dict.fromkeys(k[0] for k in point))
            datasets, first_of = [], {}
            for name in names:
                model = next(v[1] for k, v in point.items() if k[0] == name)
                first_of.setdefault(model, name)
                datasets.append({"label": name, "data": [point.get((name, c), (None,))[0] for c in commits],
                                 "borderColor": model_colour(model), "backgroundColor": model_colour(model),
                                 # a model's first series solid, its other configurations dashed
                                 "borderDash": [] if first_of[model] == name else [5, 3],
                                 "pointRadius": 3, "borderWidth": 1.5})
            specs.append({"id": cid, "title": f"{sc}: {ylabel}", "ylabel": ylabel, "log": log, "labels": labels,
                          "datasets": datasets})
            out.append(f"<figure><canvas id='{cid}' class=trend data-metric='{metric}' width=460 height=300></canvas>"
                       f"<figcaption>{esc(sc)}: {esc(ylabel)}, {len(datasets)} series</figcaption></figure>")
        out.append("</div>")
    return "\n".join(out), specs


def mean_mse(values):
    return num(sum(values) / len(values), "mse") if values else "–"


def history_table(page, history, limit=30):
    runs = {}
    for h in history:
        r = runs.setdefault(h["run_id"], {"date": h["date"], "commit": h["commit"], "dirty": h.get("dirty"),
                                          "experiment": h["experiment"], "host": h.get("host", ""), "n": 0,
                                          "failed": 0, "mse": {}})
        r["n"] += 1
        if h.get("status") != "ok":
            r["failed"] += 1
        elif h.get("mse"):
            r["mse"].setdefault(h["model"], []).append(float(h["mse"]))
    models = list(dict.fromkeys(h["model"] for h in history))
    page.add("<table class='sortable history' id=history-table><thead><tr><th class=l>date</th><th class=l>commit</th>"
             "<th class=l>experiment</th><th>configs</th><th>failed</th>" +
             "".join(f"<th>{esc(m)} mean MSE</th>" for m in models) + "<th class=l>host</th></tr></thead><tbody>")
    for rid, r in sorted(runs.items(), key=lambda kv: kv[1]["date"], reverse=True)[:limit]:
        page.add(f"<tr><td class=l>{esc(r['date'])}</td><td class=l><code>{esc(r['commit'][:10])}</code>"
                 f"{' (dirty)' if r['dirty'] in ('1', 'True') else ''}</td><td class=l>{esc(r['experiment'])}</td>"
                 f"<td>{r['n']}</td><td class='{'failed' if r['failed'] else ''}'>{r['failed']}</td>" +
                 "".join(f"<td>{mean_mse(r['mse'].get(m))}</td>" for m in models)
                 + f"<td class=l>{esc(r['host'])}</td></tr>")
    page.add("</tbody></table>")


def binary_notice(fig_png, tables):
    """A notice when the figure was made by another binary than the tables on this page: its
    provenance sidecar (<stem>.json, voxlab_exp/plots.py) against each table's rows.json meta.
    tables: {experiment: meta}. '' when they agree."""
    side = os.path.splitext(fig_png)[0] + ".json"
    if not tables:
        return ""
    if not os.path.isfile(side):
        return ("<span class='notice binary-unknown'>made before plots recorded their binary: which voxlab made it "
                "is unknown (run <code>make figures</code> / <code>make pareto</code> again)</span>")
    try:
        prov = load_json(side)
    except (OSError, ValueError):
        return ""
    fh, fd = prov.get("voxlab_sha256") or "", prov.get("date") or ""
    notes = []
    for exp, meta in tables.items():
        th, td = meta.get("voxlab_sha256") or "", meta.get("date") or ""
        if fh and th and fh != th:
            older = fd < td
            notes.append(f"made by {'an older' if older else 'another'} voxlab ({fh[:12]}, {fd[:16]}) than the "
                         f"{exp} table ({th[:12]}, {td[:16]})")
    if not notes:
        return ""
    return "<span class='notice older-binary'>⚠ " + esc("; ".join(notes)) + \
        " — rerun the figure's target to compare like with like</span>"


def build(a):
    results_root = os.path.abspath(a.results)
    out = os.path.abspath(a.out or os.path.join(results_root, "dashboard"))
    tol = load_declaration(a.tolerances, a.voxlab)["tolerances"]
    baseline = load_json(a.baseline) if a.baseline and os.path.exists(a.baseline) else None
    history_path = a.history or os.path.join(results_root, "history.csv")
    exps = [e.strip() for e in a.experiments.split(",") if e.strip()]
    loaded = {}
    for e in exps:
        p = os.path.join(results_root, e, "rows.json")
        if os.path.exists(p):
            loaded[e] = load_json(p)
    if a.record_history:
        runs = [(d["meta"], d["rows"]) for d in loaded.values() if (d["meta"].get("settings") or {}).get("history")]
        n = record_history(history_path, runs, os.path.join(results_root, "cache"))
        print(f"dashboard: history: {', '.join(m['experiment'] for m, _ in runs) or 'nothing'} recorded; "
              f"{rel(history_path, REPO)} has {n} line(s)", file=sys.stderr)
    history = read_history(history_path)
    parent = os.path.dirname(out)
    os.makedirs(parent, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix=os.path.basename(out) + ".tmp.", dir=parent)
    os.chmod(tmp, 0o755)  # mkdtemp makes it private; the page is for everyone who can read results/
    try:
        page = Page(tmp)
        missing = vendor(tmp)
        if missing:
            print(f"dashboard: {', '.join(missing)} not installed (make deps): the page's tables do not sort or "
                  f"filter and it has no trend charts", file=sys.stderr)
        metas = [d["meta"] for d in loaded.values()]
        models = registered_models(a.voxlab, metas)
        g = git_info()
        page.add("<!DOCTYPE html><html lang=en><head><meta charset=utf-8><title>voxlab dashboard</title>"
                 "<link rel=stylesheet href='vendor/theme.default.css'>"
                 f"<style>{CSS}</style>"
                 "<script src='vendor/jquery.min.js'></script>"
                 "<script src='vendor/jquery.tablesorter.combined.min.js'></script>"
                 "<script src='vendor/chart.min.js'></script></head><body>")
        page.add("<h1>voxlab dashboard</h1>")
        page.add(f"<p class=meta>generated {esc(now_iso())} from <code>{esc(results_root)}</code>; checkout "
                 f"<code>{esc(g['text'])}</code>; baseline: "
                 + (f"<code>{esc(a.baseline)}</code>" if baseline else "none (run <code>make baseline</code>)") + "</p>")
        if missing:
            page.add(f"<p class=notice>not installed when this page was made: {esc(', '.join(missing))} "
                     "(<code>make deps</code>): tables do not sort or filter, no trend charts</p>")
        toc_at = len(page.parts)  # the table of contents goes here once the sections are known
        toc = [("models", "Models")]
        page.add("<h2 id=models-h>Registered models</h2><ul class=models id=models>")
        for m in models:
            page.add(f"<li data-model='{esc(m['name'])}'><span class=swatch style='background:"
                     f"{model_colour(m['name'])}'></span><b>{esc(m['name'])}</b> — "
                     f"{esc(m.get('bytes_per_voxel') or '?')} B/voxel, {esc(m.get('rule') or '?')} compositing: "
                     f"<span class=small>{esc(m.get('description', ''))}</span></li>")
        page.add("</ul>")
        # Status first: is the current build worse than the baseline?
        summaries = {}
        body = []
        for e, d in loaded.items():
            meta, rows = d["meta"], d["rows"]
            section = ((baseline or {}).get("experiments") or {}).get(e)
            start = len(page.parts)  # this experiment's part goes below the status banners
            sub = page
            toc.append((f"exp-{e}", e))
            sub.add(f"<section class=part id='sec-{esc(e)}'><h2 id='exp-{esc(e)}'>{esc(e)}: current metrics"
                    f"{' against the baseline' if section else ' (no baseline section)'}</h2>")
            sub.add("<p class=meta>" + "<br>".join(esc(x) for x in settings_text(meta)) +
                    (f"<br>baseline: commit {esc(section['commit'][:10])}{' (dirty)' if section.get('dirty') else ''}"
                     f", {esc(section['date'])}" if section else "") + "</p>")
            sub.add("<p class=small>Click a header to sort (shift-click: a second key); type in the row under the "
                    "headers to filter (e.g. <code>&lt;0.01</code>, <code>vmesh</code>). Drag a slider: the model "
                    "left of the handle, the truth right of it. Every image opens full size.</p>")
            res, counts = metrics_table(sub, e, meta, rows, section, tol, results_root)
            present = {r["model"] for r in rows}
            absent = [m["name"] for m in models if m["name"] not in present]
            if absent:
                sub.add(f"<p class=small>registered but not in this run (run it again): {esc(', '.join(absent))}</p>")
            strips(sub, results_root, rows, e)
            sub.add("</section>")
            summaries[e] = (counts, bool(section))
            body += page.parts[start:]
            del page.parts[start:]
        if summaries:
            for e, (counts, has_base) in summaries.items():
                bad = sum(counts.get(s, 0) for s in ("regression", "failed", "missing"))
                text = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
                cls = "none" if not has_base else "bad" if bad else "ok"
                verdict = "no baseline to compare with" if not has_base else \
                    f"{bad} regression(s) beyond tolerance" if bad else "no regression beyond tolerance"
                page.add(f"<div class='banner {cls}' id='status-{esc(e)}'>{esc(e)}: {esc(verdict)} ({esc(text)})</div>")
        else:
            page.add("<div class='banner none'>No results yet: run <code>make regress</code> or "
                     "<code>make table1</code>.</div>")
        page.add("<p class=small>Tolerances (experiments/regress.json): " + esc("; ".join(
            f"{m} {t['better']} is better, ±{t.get('abs', 0):g} abs / {t.get('rel', 0):.0%} rel"
            f"{'' if t.get('gate', True) else ' (report only)'}" for m, t in tol.items())) +
            ". Red: regression (fails <code>make regress</code>); orange: beyond tolerance on a report-only metric; "
            "green: improved. The small line under a value is its change against the baseline.</p>")
        page.parts += body
        # Plots and figures that exist; each notes when another binary than the tables' made it.
        tables = {e: d["meta"] for e, d in loaded.items()}
        sections = [("Paper figures: image grids (Brito et al. Figure 11)", "figures", ["figure11_*.png", "grid_*.png"]),
                    ("Error against cost (Pareto)", "pareto", ["pareto_*.png"]),
                    ("Heitz & Neyret colour against view angle", "figures", ["view_angle.png"]),
                    ("Silhouette coverage", "figures", ["coverage.png"]),
                    ("Depth of field", "figures", ["dof_*.png"])]
        for k, (title, sub_dir, patterns) in enumerate(sections):
            files = [f for p in patterns for f in sorted(glob.glob(os.path.join(results_root, sub_dir, p)))]
            toc.append((f"fig-{k}", title.split(":")[0].split(" (")[0]))
            page.add(f"<section class=part id='sec-fig-{k}'><h2 id='fig-{k}'>{esc(title)}</h2>")
            if not files:
                page.add(f"<p class=small>not made yet: run <code>make {'pareto' if sub_dir == 'pareto' else 'figures'}"
                         f"</code></p></section>")
                continue
            for f in files:
                src = page.image(f, f"{sub_dir}_{os.path.basename(f)}")
                vec = []
                for ext in ("pdf", "svg"):
                    v = os.path.splitext(f)[0] + "." + ext
                    if os.path.isfile(v):
                        vec.append(f"<a href='{page.image(v, f'{sub_dir}_{os.path.basename(v)}')}'>{ext.upper()}</a>")
                page.add(f"<p class=figure><a href='{src}' target=_blank><img class=plot src='{src}' "
                         f"alt='{esc(os.path.basename(f))}'></a><br>"
                         f"<span class=small>{esc(os.path.relpath(f, results_root))}, "
                         f"{esc(datetime.datetime.fromtimestamp(os.path.getmtime(f)).isoformat(timespec='minutes'))}"
                         f"{' — ' + ' '.join(vec) if vec else ''}</span> {binary_notice(f, tables)}</p>")
            page.add("</section>")
        toc.append(("history", "Trends and history"))
        page.add("<section class=part id=sec-history><h2 id=history>Trends over commits and history</h2>")
        if not history:
            page.add("<p class=small>no history yet (results/history.csv has no rows: <code>make dashboard</code> "
                     "records one per commit and configuration)</p>")
        specs = []
        for e in dict.fromkeys(h["experiment"] for h in history):
            text, sp = trend_charts(history, e)
            if text:
                page.add(f"<div class=chart id='history-{esc(e)}'>{text}</div>")
                specs += sp
        if history:
            history_table(page, history)
        page.add("</section>")
        page.add("<script type='application/json' id=trend-data>" + json.dumps(specs).replace("</", "<\\/") +
                 "</script>")
        page.add(f"<script>{PAGE_JS}</script>" if not missing else "")
        page.add("</body></html>")
        page.parts[toc_at:toc_at] = [
            "<nav id=toc>" + " ".join(f"<a href='#{esc(i)}'>{esc(t)}</a>" for i, t in toc) +
            ("<br><span class=small>one experiment alone:</span> " + " ".join(
                f"<a class=tab data-exp='{esc(e)}' href='?exp={esc(e)}'>{esc(e)}</a>" for e in loaded) +
             " <a class=tab href='index.html'>all</a>" if loaded else "") + "</nav>"]
        write_text(os.path.join(tmp, "index.html"), "\n".join(page.parts) + "\n")
        # Swap the finished folder in; the old one goes only after the new one is in place.
        old = None
        if os.path.exists(out):
            old = f"{out}.old.{os.getpid()}"
            os.rename(out, old)
        os.rename(tmp, out)
        if old:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out


def chromium_command():
    for c in ("chromium", "chromium-browser", "google-chrome"):
        p = shutil.which(c)
        if p:
            return p
    return None


def headless(url, extra, user_dir, timeout=60):
    """Runs headless Chromium on url with no network features and a throwaway profile."""
    exe = chromium_command()
    if not exe:
        raise VoxlabError("chromium is not installed (apt-get install chromium, or `make deps`)")
    cmd = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
           "--disable-component-update", "--disable-sync", "--no-first-run", "--hide-scrollbars",
           f"--user-data-dir={user_dir}", "--enable-logging=stderr", "--v=0", *extra, url]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)


def screenshot(index, png, size=(1400, 3000), query=""):
    with tempfile.TemporaryDirectory() as ud:
        tmp = f"{png}.tmp.{os.getpid()}.png"
        p = headless("file://" + index + query, [f"--screenshot={tmp}", f"--window-size={size[0]},{size[1]}",
                                                 "--virtual-time-budget=5000"], ud)
        if p.returncode != 0 or not os.path.exists(tmp):
            raise VoxlabError(f"chromium --screenshot failed: {p.stderr[-500:]}")
        os.replace(tmp, png)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--results", default=DEFAULT_RESULTS)
    ap.add_argument("--baseline", default=os.path.join(REPO, "results", "baseline.json"))
    ap.add_argument("--history", help="default <results>/history.csv")
    ap.add_argument("--experiments", default="regress,table1", help="experiments whose rows the page shows")
    ap.add_argument("--tolerances", default=os.path.join(HERE, "regress.json"),
                    help="declaration whose tolerances mark the cells")
    ap.add_argument("--out", help="default <results>/dashboard")
    ap.add_argument("--voxlab", default=os.path.join(REPO, "build", "voxlab"))
    ap.add_argument("--screenshot", action="store_true", help="also save <out>/screenshot.png (headless Chromium)")
    ap.add_argument("--record-history", action="store_true",
                    help="write the shown experiments' rows into the history first (make dashboard)")
    a = ap.parse_args(argv)

    def go():
        out = build(a)
        print(f"dashboard: wrote {rel(out, REPO)}/index.html (open it from disk)", file=sys.stderr)
        if a.screenshot:
            if chromium_command():
                screenshot(os.path.join(out, "index.html"), os.path.join(out, "screenshot.png"))
                shown = [e for e in a.experiments.split(",") if e.strip() and
                         os.path.exists(os.path.join(os.path.abspath(a.results), e.strip(), "rows.json"))]
                if shown:  # the last experiment's table sorted by MSE, best first
                    screenshot(os.path.join(out, "index.html"), os.path.join(out, "screenshot_sorted.png"),
                               size=(1400, 1600), query=f"?exp={shown[-1].strip()}&sort=mse")
                print(f"dashboard: wrote {rel(out, REPO)}/screenshot.png" +
                      (", screenshot_sorted.png" if shown else ""), file=sys.stderr)
            else:
                print("dashboard: chromium is not installed: no screenshot", file=sys.stderr)
        return 0

    return main_wrapper(go, "dashboard")


if __name__ == "__main__":
    sys.exit(main())
