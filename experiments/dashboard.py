#!/usr/bin/python3
"""The results dashboard: one static page that opens from disk (make dashboard).

    /usr/bin/python3 experiments/dashboard.py [--results results] [--baseline results/baseline.json]
        [--history results/history.csv] [--experiments regress,table1] [--out results/dashboard]
        [--voxlab build/voxlab] [--screenshot] [--record-history]

Reads what the other targets wrote (it runs nothing itself; `make dashboard` runs them first):
<results>/<experiment>/rows.json for each experiment named, the baseline, the history, and the
plots under <results>/pareto and <results>/figures. Writes <out>/index.html with every image it shows
copied into <out>/img/ (relative links only: no server, no external URL, no script), so the folder
can be copied or archived as it is. The page has:

  - the registered models (`voxlab models` when the binary runs, and every model in the results),
    each with its bytes per voxel and compositing rule;
  - per experiment, scene and model the current metrics with their change against the baseline
    (results/baseline.json); cells beyond the tolerances of experiments/regress.json are marked
    regression (red, gating), warning (orange, report-only metrics such as time) or improved (green);
  - image strips (truth and each model) for the regression subset, and the paper-figure grids, Pareto
    plots and figures when they exist;
  - the history over commits (results/history.csv): a chart drawn by matplotlib as inline SVG, and a
    table of the latest runs.

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
import io
import os
import re
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
from voxlab_exp.jobs import models_info  # noqa: E402
from voxlab_exp.provenance import git_info, now_iso  # noqa: E402
from voxlab_exp.report import settings_text  # noqa: E402
from voxlab_exp.rows import row_key  # noqa: E402
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
.strip{display:flex;flex-wrap:wrap;gap:6px;margin:6px 0 14px}
.strip figure{margin:0;text-align:center;font-size:11px}
.strip img{image-rendering:pixelated;width:160px;height:auto;border:1px solid #ccc}
img.plot{max-width:100%;border:1px solid #ddd;margin:6px 0}
.models li{margin:2px 0}.small{font-size:12px;color:#666}
.chart svg{max-width:100%;height:auto}
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


class Page:
    def __init__(self, out_tmp):
        self.parts, self.img_dir, self.copied = [], os.path.join(out_tmp, "img"), {}
        os.makedirs(self.img_dir, exist_ok=True)

    def add(self, s):
        self.parts.append(s)

    def image(self, src, name_hint):
        """Copies src into img/ once; returns the relative link."""
        src = os.path.abspath(src)
        if src not in self.copied:
            base = re.sub(r"[^A-Za-z0-9_.-]+", "_", name_hint)
            name, k = base, 1
            while name in self.copied.values():
                stem, ext = os.path.splitext(base)
                name, k = f"{stem}_{k}{ext}", k + 1
            shutil.copyfile(src, os.path.join(self.img_dir, name))
            self.copied[src] = name
        return "img/" + self.copied[src]


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


def metrics_table(page, exp, meta, rows, section, tol):
    """Per scene: a row per configuration with each metric and its change against the baseline."""
    results = compare_to_baseline(rows, section, tol) if section else \
        [{"key": row_key(r), "scene": r["scene"], "model": r["model"], "res": r["res"], "row": r,
          "status": "ok" if r["status"] == "ok" else "failed", "error": r.get("error"), "metrics": {}}
         for r in rows if r["kind"] == "model"]
    counts = {}
    for x in results:
        counts[x["status"]] = counts.get(x["status"], 0) + 1
    for sc in dict.fromkeys(x["scene"] for x in results):
        page.add(f"<h3>{esc(exp)} — {esc(sc)}</h3>")
        page.add("<table><tr><th class=l>model</th><th>res</th><th>image</th>" +
                 "".join(f"<th>{esc(label)}</th>" for _, label in METRICS) + "<th class=l>status</th></tr>")
        for x in (x for x in results if x["scene"] == sc):
            r = x.get("row") or {}
            cls = x["status"]
            page.add(f"<tr class='{esc(cls)}' data-model='{esc(x['model'])}'><td class=l>{esc(x['model'])}</td>"
                     f"<td>{esc(x['res'])}³</td><td>{esc(r.get('width', '–'))}×{esc(r.get('height', '–'))}"
                     f"{', ' + esc(r['spp']) + ' spp' if r.get('spp') else ''}</td>")
            for m, _ in METRICS:
                d = x["metrics"].get(m)
                cur = r.get(m) if r else None
                if d and d["base"] is not None:
                    page.add(f"<td class='{esc(d['verdict'])}' title='baseline {esc(num(d['base'], m))}'>"
                             f"{esc(num(cur, m))}<span class=delta>{esc(delta_text(d, m))}</span></td>")
                else:
                    page.add(f"<td>{esc(num(cur, m))}</td>")
            status = x["status"] + (f": {x['error']}" if x.get("error") else "")
            page.add(f"<td class='l status {esc(cls)}'>{esc(status)}</td></tr>")
        page.add("</table>")
    return results, counts


def strips(page, results_root, rows, label):
    """Truth and each model's preview per scene (the regression subset's images)."""
    for sc, n in dict.fromkeys((r["scene"], r["res"]) for r in rows if r["kind"] == "model"):
        rs = [r for r in rows if r["scene"] == sc and r["res"] == n and r["kind"] == "model"]
        page.add(f"<h3>{esc(label)} — {esc(sc)}, {esc(n)}³ images</h3><div class=strip>")
        t = next((r for r in rs if r.get("truth_preview") and
                  os.path.exists(os.path.join(results_root, r["truth_preview"]))), None)
        if t:
            src = page.image(os.path.join(results_root, t["truth_preview"]), f"{label}_{sc}_truth_{t['res']}.png")
            page.add(f"<figure><img src='{src}' alt='truth'><figcaption>truth {esc(t['truth_spp'])} spp"
                     f"</figcaption></figure>")
        for r in rs:
            if r["status"] == "ok" and os.path.exists(os.path.join(results_root, r["preview"])):
                src = page.image(os.path.join(results_root, r["preview"]), f"{label}_{sc}_{r['model']}_{r['res']}.png")
                page.add(f"<figure data-model='{esc(r['model'])}'><img src='{src}' alt='{esc(r['model'])}'>"
                         f"<figcaption>{esc(r['model'])} {esc(r['res'])}³<br>MSE {num(r['mse'], 'mse')}</figcaption>"
                         f"</figure>")
            else:
                page.add(f"<figure data-model='{esc(r['model'])}'><figcaption>{esc(r['model'])}: failed<br>"
                         f"<span class=small>{esc(r.get('error', ''))[:120]}</span></figcaption></figure>")
        page.add("</div>")


def history_svg(history, experiment):
    """MSE and SSIM over the runs of one experiment, a panel per scene, a line per model: inline SVG."""
    rows = [h for h in history if h.get("experiment") == experiment and h.get("status") == "ok"]
    if not rows:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = list(dict.fromkeys(h["run_id"] for h in sorted(rows, key=lambda h: (h["date"], h["run_id"]))))
    idx = {r: i for i, r in enumerate(runs)}
    tick = {}
    for h in rows:
        tick[h["run_id"]] = h["commit"][:7] + ("*" if h.get("dirty") in ("1", "True") else "")
    scenes = list(dict.fromkeys(h["scene"] for h in rows))
    # A line per model, or per model and configuration when the experiment has several per scene.
    def series(h):
        return h["model"] if not multi else f"{h['model']} {h['res']}³" + ("" if h.get("spp") == "4" else
                                                                          f" {h.get('spp')}spp")
    multi = len({(h["res"], h.get("spp"), h.get("width")) for h in rows}) > 1
    models = list(dict.fromkeys(series(h) for h in rows))
    fig, axes = plt.subplots(2, len(scenes), figsize=(5.2 * len(scenes), 5.6), squeeze=False)
    for j, sc in enumerate(scenes):
        for k, (metric, label) in enumerate([("mse", "MSE"), ("ssim", "SSIM")]):
            ax = axes[k][j]
            for i, m in enumerate(models):
                pts = sorted((idx[h["run_id"]], float(h[metric])) for h in rows
                             if h["scene"] == sc and series(h) == m and h.get(metric) not in (None, ""))
                if pts:
                    ax.plot([p[0] for p in pts], [p[1] for p in pts], "-o" if i < 10 else "--s", ms=3.5, lw=1.2,
                            color=plt.get_cmap("tab10")(i % 10), label=m)
            ax.set_title(f"{sc}: {label}", fontsize=10)
            if metric == "mse":
                ax.set_yscale("log")
            ax.set_xticks(range(len(runs)), [tick[r] for r in runs], rotation=60, fontsize=7)
            ax.grid(alpha=0.3)
            if j == 0 and k == 0:
                ax.legend(fontsize=8)
    fig.suptitle(f"{experiment}: history over runs (commit, * = uncommitted changes)", fontsize=10)
    fig.tight_layout()
    buf = io.StringIO()
    fig.savefig(buf, format="svg")
    plt.close(fig)
    svg = buf.getvalue()
    # Inline: no XML prolog or DOCTYPE, and no <metadata> (its RDF namespace URLs are not needed).
    svg = re.sub(r"<\?xml[^>]*\?>\s*", "", svg)
    svg = re.sub(r"<!DOCTYPE[^>]*>\s*", "", svg)
    svg = re.sub(r"<metadata>.*?</metadata>\s*", "", svg, flags=re.S)
    return svg


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
    page.add("<table><tr><th class=l>date</th><th class=l>commit</th><th class=l>experiment</th><th>configs</th>"
             "<th>failed</th>" + "".join(f"<th>{esc(m)} mean MSE</th>" for m in models) + "<th class=l>host</th></tr>")
    for rid, r in sorted(runs.items(), key=lambda kv: kv[1]["date"], reverse=True)[:limit]:
        page.add(f"<tr><td class=l>{esc(r['date'])}</td><td class=l><code>{esc(r['commit'][:10])}</code>"
                 f"{' (dirty)' if r['dirty'] in ('1', 'True') else ''}</td><td class=l>{esc(r['experiment'])}</td>"
                 f"<td>{r['n']}</td><td class='{'failed' if r['failed'] else ''}'>{r['failed']}</td>" +
                 "".join(f"<td>{mean_mse(r['mse'].get(m))}</td>" for m in models)
                 + f"<td class=l>{esc(r['host'])}</td></tr>")
    page.add("</table>")


def build(a):
    results_root = os.path.abspath(a.results)
    out = os.path.abspath(a.out or os.path.join(results_root, "dashboard"))
    tol = load_declaration(a.tolerances)["tolerances"]
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
        metas = [d["meta"] for d in loaded.values()]
        models = registered_models(a.voxlab, metas)
        g = git_info()
        page.add("<!DOCTYPE html><html lang=en><head><meta charset=utf-8><title>voxlab dashboard</title>"
                 f"<style>{CSS}</style></head><body>")
        page.add("<h1>voxlab dashboard</h1>")
        page.add(f"<p class=meta>generated {esc(now_iso())} from <code>{esc(results_root)}</code>; checkout "
                 f"<code>{esc(g['text'])}</code>; baseline: "
                 + (f"<code>{esc(a.baseline)}</code>" if baseline else "none (run <code>make baseline</code>)") + "</p>")
        page.add("<h2>Registered models</h2><ul class=models id=models>")
        for m in models:
            page.add(f"<li data-model='{esc(m['name'])}'><b>{esc(m['name'])}</b> — "
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
            sub.add(f"<h2 id='exp-{esc(e)}'>{esc(e)}: current metrics"
                    f"{' against the baseline' if section else ' (no baseline section)'}</h2>")
            sub.add("<p class=meta>" + "<br>".join(esc(x) for x in settings_text(meta)) +
                    (f"<br>baseline: commit {esc(section['commit'][:10])}{' (dirty)' if section.get('dirty') else ''}"
                     f", {esc(section['date'])}" if section else "") + "</p>")
            res, counts = metrics_table(sub, e, meta, rows, section, tol)
            present = {r["model"] for r in rows}
            absent = [m["name"] for m in models if m["name"] not in present]
            if absent:
                sub.add(f"<p class=small>registered but not in this run (run it again): {esc(', '.join(absent))}</p>")
            strips(sub, results_root, rows, e)
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
        # Plots and figures that exist.
        sections = [("Paper figures: image grids (Brito et al. Figure 11)", "figures", ["figure11_*.png", "grid_*.png"]),
                    ("Error against cost (Pareto)", "pareto", ["pareto_*.png"]),
                    ("Heitz & Neyret colour against view angle", "figures", ["view_angle.png"]),
                    ("Silhouette coverage", "figures", ["coverage.png"]),
                    ("Depth of field", "figures", ["dof_*.png"])]
        for title, sub_dir, patterns in sections:
            files = [f for p in patterns for f in sorted(glob.glob(os.path.join(results_root, sub_dir, p)))]
            page.add(f"<h2>{esc(title)}</h2>")
            if not files:
                page.add(f"<p class=small>not made yet: run <code>make {'pareto' if sub_dir == 'pareto' else 'figures'}"
                         f"</code></p>")
                continue
            for f in files:
                src = page.image(f, f"{sub_dir}_{os.path.basename(f)}")
                page.add(f"<p><img class=plot src='{src}' alt='{esc(os.path.basename(f))}'><br>"
                         f"<span class=small>{esc(os.path.relpath(f, results_root))}, "
                         f"{esc(datetime.datetime.fromtimestamp(os.path.getmtime(f)).isoformat(timespec='minutes'))}"
                         f"</span></p>")
        page.add("<h2 id=history>History over commits</h2>")
        if not history:
            page.add("<p class=small>no history yet (results/history.csv has no rows: <code>make dashboard</code> "
                     "records one per commit and configuration)</p>")
        for e in dict.fromkeys(h["experiment"] for h in history):
            svg = history_svg(history, e)
            if svg:
                page.add(f"<div class=chart id='history-{esc(e)}'>{svg}</div>")
        if history:
            history_table(page, history)
        page.add("</body></html>")
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


def screenshot(index, png, size=(1400, 3000)):
    with tempfile.TemporaryDirectory() as ud:
        tmp = f"{png}.tmp.{os.getpid()}.png"
        p = headless("file://" + index, [f"--screenshot={tmp}", f"--window-size={size[0]},{size[1]}"], ud)
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
                print(f"dashboard: wrote {rel(out, REPO)}/screenshot.png", file=sys.stderr)
            else:
                print("dashboard: chromium is not installed: no screenshot", file=sys.stderr)
        return 0

    return main_wrapper(go, "dashboard")


if __name__ == "__main__":
    sys.exit(main())
