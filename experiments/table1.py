#!/usr/bin/python3
"""Brito et al. 2023's Tables 1 and 2 from our own runs (make table1).

    /usr/bin/python3 experiments/table1.py [--experiment experiments/table1.json] [--results results]
        [--jobs 2] [--voxlab build/voxlab] [--fresh]

Runs the declared sweep (cached: see voxlab_exp/scheduler.py) and writes into <results>/<name>/:

  table1.csv/.md/.tex  accuracy: a column pair (MSE, SSIM) per scene, one block per resolution, a row
                       per model; the best value of each column is marked (bold in Markdown and LaTeX,
                       best_mse / best_ssim = 1 in the CSV, which is one line per cell).
  table2.csv/.md/.tex  cost: per scene and resolution the triangles, non-empty voxels and the ground
                       truth's render time, and per model MB (records + sparse grid, 10^6 bytes),
                       bake seconds and render ms per frame; bytes per voxel in the model's header.
  table1_vs_paper.csv/.md  the paper's printed Table 1 (experiments/paper/brito2023.json) beside ours:
                       both sets of numbers, the three methods' ranks, and which of the paper's claims
                       hold on our scenes. Models carry the paper's names: alpha (Averages), vicini
                       ([VJK21]), vmesh (Ours).
  rows.csv, rows.json  every configuration's numbers as the sweep wrote them.

A configuration that failed (model missing, crashed, timed out) shows as "failed" with a footnote
carrying voxlab's message. The Markdown and LaTeX state the date, machine, commit, binary hash and
settings, and how many jobs were reused from the cache.
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from voxlab_exp.cli import add_common_args, main_wrapper, sweep_args  # noqa: E402
from voxlab_exp.config import REPO  # noqa: E402
from voxlab_exp.errors import DeclarationError, VoxlabError  # noqa: E402
from voxlab_exp.files import rel, write_csv, write_text  # noqa: E402
from voxlab_exp.paper import compare as paper_compare, display_name, load_paper, markdown as paper_markdown  # noqa: E402
from voxlab_exp.report import settings_text, size_text  # noqa: E402
from voxlab_exp.rows import run_experiment, traced_per_pixel  # noqa: E402
from voxlab_exp.schema import load_declaration  # noqa: E402

T1_FIELDS = ["scene", "res", "model", "mse", "ssim", "psnr", "best_mse", "best_ssim", "status", "error"]
T2_FIELDS = ["scene", "res", "triangles", "voxels", "truth_s", "truth_s_spread", "model", "bytes_per_voxel", "mb",
             "bake_s", "bake_s_spread", "render_ms", "render_ms_min", "render_ms_spread", "repeats", "load", "loaded",
             "peak_rss_mb", "status", "error", "truth_s_cached", "bake_s_cached", "render_ms_cached"]


def traced_per_pixel_note(rows):
    """"; M traced N cone(s) per pixel whatever the spp" for each model that traced something else than
    spp rays a pixel (heitz-neyret marches one cone a pixel: its protocol), from its renders' stats."""
    odd = {}
    for r in rows:
        rpp = traced_per_pixel(r) if r.get("status") == "ok" else None
        if rpp is not None:
            odd.setdefault(r["model"], set()).add(round(rpp, 6))
    return "".join(f"; {m} traced {', '.join(f'{v:g}' for v in sorted(vs))} ray(s) or cone(s) a pixel, whatever the spp"
                   for m, vs in sorted(odd.items()))


def fmt_mse(v):
    return f"{v:.3e}" if v is not None else "–"


def fmt_ssim(v):
    return f"{v:.4f}" if v is not None else "–"


def fmt_num(v, digits):
    return f"{v:.{digits}f}" if v is not None else "–"


def fmt_spread(v, spread, digits, pm="±"):
    """The median with its spread (max - min over the timed repeats) when there is one."""
    if v is None:
        return "–"
    return f"{v:.{digits}f}" + (f" {pm} {spread:.{digits}f}" if spread else "")


def tex_escape(s):
    return str(s).replace("\\", r"\textbackslash{}").replace("_", r"\_").replace("&", r"\&").replace("%", r"\%") \
        .replace("#", r"\#").replace("^", r"\^{}").replace("³", r"$^3$").replace("–", "--").replace("−", "-")


# The settings a run may give several values of, which Table 1 cannot show: it has one cell per
# scene, resolution and model.
ONE_VALUE = ("spp", "rays", "cache", "shadow_skip", "shadows")


def check_one_cell_each(decl):
    """Refuses a declaration that gives one (scene, resolution, model) more than one setting: Table 1
    showed one of them (the last row) and dropped the others without a word, under a settings line
    that listed every value (the audit of issue 15's stop 45). A sweep is sweep.py's or pareto.py's."""
    cells = {}  # (scene, res) -> [(model, or "*" for every model, run index, settings)]
    for i, r in enumerate(decl["runs"]):
        for k in ONE_VALUE:
            if len(r[k]) > 1:
                raise DeclarationError(f"{decl['shown']}: runs[{i}].{k}: table1 takes one value (Table 1 has one "
                                       f"cell per scene, resolution and model), got {r[k]}: sweep.py or pareto.py "
                                       f"run sweeps")
        settings = tuple(r[k][0] for k in ONE_VALUE)
        for sc, n in ((sc, n) for sc in r["scenes"] for n in r["res"]):
            for m in (["*"] if r["models"] == "all" else r["models"]):
                for m2, j, other in cells.setdefault((sc, n), []):
                    if (m == m2 or "*" in (m, m2)) and other != settings:
                        raise DeclarationError(
                            f"{decl['shown']}: runs[{i}]: {sc} at {n}^3 ({'every model' if m == '*' else m}) "
                            f"is also in runs[{j}] with other settings (table1 takes one cell per scene, "
                            f"resolution and model)")
                cells[(sc, n)].append((m, i, settings))


def setting_values(rows, key, show):
    """A setting as the rows ran it: "4" when every model ran one value, else per model
    ("binary 1, alpha 4"), so that the line never states what one run said for another's rows."""
    per_model = {}
    for r in rows:
        per_model.setdefault(r["model"], []).append(show(r.get(key)))
    values = list(dict.fromkeys(v for vs in per_model.values() for v in vs))
    if len(values) <= 1:
        return values[0] if values else "?"
    return ", ".join(f"{m} {'/'.join(dict.fromkeys(vs))}" for m, vs in per_model.items())


def build(meta, rows, decl, out):
    rows = [r for r in rows if r["kind"] == "model"]
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    resolutions = list(dict.fromkeys(r["res"] for r in rows))
    models = list(dict.fromkeys(r["model"] for r in rows))
    cell = {}
    for r in rows:  # one cell each (check_one_cell_each refuses the declarations that would give more)
        k = (r["scene"], r["res"], r["model"])
        if k in cell:
            raise VoxlabError(f"table1: two rows for {r['model']} on {r['scene']} at {r['res']}^3 (settings "
                              f"{', '.join(f'{s} {cell[k].get(s)}/{r.get(s)}' for s in ONE_VALUE)}): Table 1 has "
                              f"one cell each")
        cell[k] = r
    notes = []  # failure footnotes, numbered in order of appearance
    paper = load_paper()

    def failure_mark(r):
        msg = f"{r['model']} on {r['scene']} at {r['res']}³: {r['error']}"
        if msg not in notes:
            notes.append(msg)
        return f"failed[{notes.index(msg) + 1}]"

    # Best per column: the lowest MSE and the highest SSIM among the models that ran.
    best = {}
    for sc in scenes:
        for n in resolutions:
            ok = [cell[(sc, n, m)] for m in models if (sc, n, m) in cell and cell[(sc, n, m)]["status"] == "ok"]
            if ok:
                best[(sc, n, "mse")] = min(r["mse"] for r in ok)
                best[(sc, n, "ssim")] = max(r["ssim"] for r in ok)

    def is_best(r, k):
        return r["status"] == "ok" and r[k] == best.get((r["scene"], r["res"], k))

    t1 = [{"scene": r["scene"], "res": r["res"], "model": r["model"], "mse": r.get("mse"), "ssim": r.get("ssim"),
           "psnr": r.get("psnr"), "best_mse": int(is_best(r, "mse")), "best_ssim": int(is_best(r, "ssim")),
           "status": r["status"], "error": r.get("error", "")} for r in rows]
    write_csv(os.path.join(out, "table1.csv"), t1, T1_FIELDS)

    head = settings_text(meta)
    # From the rows, not from a run of the declaration: runs may give different models other settings.
    setting_line = (f"settings: truth {decl['truth_spp']} spp (seed {decl['seed']}); models rendered at "
                    f"{setting_values(rows, 'spp', str)} spp with {setting_values(rows, 'rays', str)} bake rays per "
                    f"voxel, shading cache {setting_values(rows, 'cache', lambda v: 'on' if v else 'off')}, "
                    f"shadows {setting_values(rows, 'shadows', lambda v: v or 'march')} (shadow skip "
                    f"{setting_values(rows, 'shadow_skip', lambda v: 'on' if v in (None, True) else 'off')}); "
                    "image size "
                    + "; ".join(f"{size_text([r for r in rows if r['res'] == n])} at {n}³" for n in resolutions)
                    + traced_per_pixel_note(rows))

    # --- Table 1, Markdown and LaTeX: one block per resolution, a column pair per scene.
    md = [f"# Table 1: accuracy against the ground truth ({meta['experiment']})", ""]
    md += [f"- {x}" for x in head + [setting_line]]
    md += ["", "MSE (lower is better) and SSIM (higher is better) on the linear images, computed by "
               "`voxlab compare`; **bold** = best in its column.", ""]
    tex = ["% Generated by experiments/table1.py; do not edit.", "% " + "\n% ".join(head + [setting_line]),
           r"\begin{table}[t]", r"\centering", r"\small",
           r"\caption{Accuracy against the Embree ground truth (" + str(decl["truth_spp"]) +
           r" spp): MSE $\downarrow$ and SSIM $\uparrow$; best per column in bold. " +
           tex_escape(f"Commit {meta['git']['commit'][:10]}{' (dirty)' if meta['git']['dirty'] else ''}, "
                      f"{meta['date'][:10]}.") + "}",
           r"\label{tab:accuracy}"]
    for n in resolutions:
        # The images' size as the rows give it (a declaration's "size" may be "scene", N or [W, H]).
        md.append(f"## {n}³ voxels, {size_text([r for r in rows if r['res'] == n])} images")
        md.append("")
        md.append("| model | " + " | ".join(f"{sc} MSE | {sc} SSIM" for sc in scenes) + " |")
        md.append("|---|" + "---:|---:|" * len(scenes))
        tex.append(r"\begin{tabular}{l" + "rr" * len(scenes) + "}")
        tex.append(r"\toprule")
        tex.append(f"{n}$^3$, {size_text([r for r in rows if r['res'] == n])} & " + " & ".join(r"\multicolumn{2}{c}{" + tex_escape(sc) + "}" for sc in scenes)
                   + r" \\")
        tex.append("model & " + " & ".join("MSE & SSIM" for _ in scenes) + r" \\")
        tex.append(r"\midrule")
        for m in models:
            mc, tc = [], []
            for sc in scenes:
                r = cell.get((sc, n, m))
                if r is None:
                    mc += ["–", "–"]
                    tc += ["--", "--"]
                elif r["status"] != "ok":
                    f = failure_mark(r)
                    mc += [f, ""]
                    tc += [r"\multicolumn{2}{c}{failed$^{" + f.split("[")[1].rstrip("]") + "}$}"]
                else:
                    a, b = fmt_mse(r["mse"]), fmt_ssim(r["ssim"])
                    mc += [f"**{a}**" if is_best(r, "mse") else a, f"**{b}**" if is_best(r, "ssim") else b]
                    tc += [r"\textbf{" + a + "}" if is_best(r, "mse") else a,
                           r"\textbf{" + b + "}" if is_best(r, "ssim") else b]
            md.append(f"| {display_name(m, paper)} | " + " | ".join(mc) + " |")
            tex.append(tex_escape(display_name(m, paper)) + " & " + " & ".join(tc) + r" \\")
        md.append("")
        tex += [r"\bottomrule", r"\end{tabular}", r"\par\medskip"]
    tex.append(r"\end{table}")

    # --- Table 2: cost.
    t2 = []
    for r in rows:
        t2.append({"scene": r["scene"], "res": r["res"], "triangles": r.get("triangles"), "voxels": r.get("voxels"),
                   "truth_s": r.get("truth_s"), "truth_s_spread": r.get("truth_s_spread"), "model": r["model"],
                   "bytes_per_voxel": r.get("bytes_per_voxel"), "mb": r.get("mb"), "bake_s": r.get("bake_s"),
                   "bake_s_spread": r.get("bake_s_spread"), "render_ms": r.get("render_ms"),
                   "render_ms_min": r.get("render_ms_min"), "render_ms_spread": r.get("render_ms_spread"),
                   "repeats": r.get("repeats"), "load": r.get("load"), "loaded": r.get("loaded"),
                   "peak_rss_mb": r["peak_rss_bytes"] / 1e6 if r.get("peak_rss_bytes") else None,
                   "status": r["status"], "error": r.get("error", ""), "truth_s_cached": r.get("truth_s_cached"),
                   "bake_s_cached": r.get("bake_s_cached"), "render_ms_cached": r.get("render_ms_cached")})
    write_csv(os.path.join(out, "table2.csv"), t2, T2_FIELDS)
    bpv = {}
    for m in meta["models"]:
        bpv[m["name"]] = m["bytes_per_voxel"]
    md2 = [f"# Table 2: what the models cost ({meta['experiment']})", ""]
    md2 += [f"- {x}" for x in head + [setting_line]]
    md2 += ["", "Triangles of the scene; voxels = non-empty voxels at that resolution; truth s = the "
                f"ground truth's render time ({decl['truth_spp']} spp, same image size, same threads); per model: "
                "MB = per-voxel records + sparse grid + the model's constant tables (heitz-neyret's coverage masks) "
                "(10^6 bytes), with the render process's peak resident "
                "memory in parentheses (shading cache, grid build and image included), bake s = sampling rays + building the "
                "records, render ms = one frame (the voxel render alone, bake excluded). Times are the median of the "
                "timed repeats ± their spread (max − min); * = measured under a load above the machine's cores.", ""]
    md2.append("| scene | res | triangles | voxels | truth s | " +
               " | ".join(f"{display_name(m, paper)} MB | bake s | render ms" for m in models) + " |")
    md2.append("|---|---:|---:|---:|---:|" + "---:|---:|---:|" * len(models))
    tex2 = ["% Generated by experiments/table1.py; do not edit.", "% " + "\n% ".join(head + [setting_line]),
            r"\begin{table}[t]", r"\centering", r"\small",
            r"\caption{Cost of each model: memory (MB, records + sparse grid), bake time (s) and render time "
            r"(ms per frame, " + str(meta["threads"]) + r" thread(s)); the ground truth's render time at " +
            str(decl["truth_spp"]) + r" spp for comparison. " +
            tex_escape(f"Commit {meta['git']['commit'][:10]}, {meta['date'][:10]}.") + "}",
            r"\label{tab:cost}",
            r"\resizebox{\linewidth}{!}{%",
            r"\begin{tabular}{lrrrr" + "rrr" * len(models) + "}", r"\toprule",
            " & & & & & " + " & ".join(r"\multicolumn{3}{c}{" + tex_escape(m) +
                                       (f" ({bpv[m]} B/voxel)" if bpv.get(m) else "") + "}" for m in models)
            + r" \\",
            "scene & res & triangles & voxels & truth s & " + " & ".join("MB & bake s & ms" for _ in models) + r" \\",
            r"\midrule"]
    kinds = {r.get("bake_shared") for r in rows if r.get("kind") == "model" and r.get("status") == "ok"}
    mixed_bakes = {0, 1} <= kinds
    # ‡ a time measured in an earlier run (its job reused from the cache) where the table mixes such
    # times with times measured in this run: the two were taken under different loads.
    ok_models = [r for r in rows if r.get("kind") == "model" and r.get("status") == "ok"]
    mixed_runs = {0, 1} <= {r.get(f"{c}_cached") for r in ok_models for c in ("truth_s", "bake_s", "render_ms")}

    def earlier(r, col):
        return "‡" if mixed_runs and r is not None and r.get(f"{col}_cached") == 1 else ""
    for sc in scenes:
        for n in resolutions:
            any_r = next((cell[(sc, n, m)] for m in models if (sc, n, m) in cell and
                          cell[(sc, n, m)].get("triangles") is not None), None)
            tri = any_r["triangles"] if any_r else None
            vox = next((cell[(sc, n, m)]["voxels"] for m in models if (sc, n, m) in cell and
                        cell[(sc, n, m)].get("voxels") is not None), None)
            truth_s = any_r.get("truth_s") if any_r else None
            truth_spread = any_r.get("truth_s_spread") if any_r else None
            mc, tc = [], []
            for m in models:
                r = cell.get((sc, n, m))
                if r is None:
                    mc += ["–"] * 3
                    tc += ["--"] * 3
                elif r["status"] != "ok":
                    f = failure_mark(r)
                    mc += [f, "", ""]
                    tc += [r"\multicolumn{3}{c}{failed$^{" + f.split("[")[1].rstrip("]") + "}$}"]
                else:
                    star = "*" if r.get("loaded") else ""
                    rss = f" ({r['peak_rss_bytes'] / 1e6:.0f})" if r.get("peak_rss_bytes") else ""
                    # † a bake of its own where the table mixes them with shared passes
                    own = "†" if mixed_bakes and r.get("bake_shared") == 0 else ""
                    bake_e, render_e = earlier(r, "bake_s"), earlier(r, "render_ms")
                    mc += [fmt_num(r["mb"], 2) + rss,
                           fmt_spread(r["bake_s"], r.get("bake_s_spread"), 2) + own + bake_e + star,
                           fmt_spread(r["render_ms"], r.get("render_ms_spread"), 1) + render_e + star]
                    tc += [fmt_num(r["mb"], 2), fmt_spread(r["bake_s"], r.get("bake_s_spread"), 2, r"$\pm$") +
                           (r"$^\dagger$" if own else "") + (r"$^\ddagger$" if bake_e else "") + star,
                           fmt_spread(r["render_ms"], r.get("render_ms_spread"), 1, r"$\pm$") +
                           (r"$^\ddagger$" if render_e else "") + star]
            cells = [f"{tri:,}" if tri is not None else "–", f"{vox:,}" if vox is not None else "–",
                     fmt_spread(truth_s, truth_spread, 3) + earlier(any_r, "truth_s")]
            md2.append(f"| {sc} | {n}³ | " + " | ".join(cells + mc) + " |")
            tex_cells = [c.replace(",", "{,}").replace("±", r"$\pm$").replace("‡", r"$^\ddagger$") for c in cells]
            tex2.append(f"{tex_escape(sc)} & {n}$^3$ & " + " & ".join(tex_cells + tc) + r" \\")
    md2.append("")
    md2.append("Bytes per voxel: " + ", ".join(f"{m} {bpv.get(m, '?')}" for m in models) + ".")
    if mixed_bakes:
        md2.append("† bake s of a bake of its own (rerun after its model's code changed); the others are each "
                   "model's share of one sampling pass shared with the other models, estimated from its part of "
                   "the pass (the two measure within about 15 % of each other).")
    if mixed_runs:
        md2.append(f"‡ measured in an earlier run, its job reused from the cache (the oldest from "
                   f"{meta['oldest_cached']}; rows.csv's computed column dates each row), beside times measured "
                   f"in this run: the two were taken under different loads.")
    tex2 += [r"\bottomrule", r"\end{tabular}}"]
    if mixed_runs:
        tex2.append(r"\par\footnotesize $^\ddagger$ measured in an earlier run (reused from the cache), beside "
                    r"times measured in this run.")
    if mixed_bakes:
        tex2.append(r"\par\footnotesize $^\dagger$ a bake of its own; the other bake times are each model's share "
                    r"of one sampling pass shared with the other models.")
    tex2.append(r"\end{table}")

    if notes:
        foot = ["", "Failures:", ""] + [f"[{i + 1}] {t}" for i, t in enumerate(notes)]
        md += foot
        md2 += foot
        tex += ["% Failures:"] + [f"%  [{i + 1}] {t}" for i, t in enumerate(notes)]
        tex2 += ["% Failures:"] + [f"%  [{i + 1}] {t}" for i, t in enumerate(notes)]
    # --- Beside the paper's printed Table 1.
    vs_rows, claims = paper_compare(cell, paper)
    write_csv(os.path.join(out, "table1_vs_paper.csv"), vs_rows,
              ["scene", "res", "method", "model", "paper_mse", "mse", "paper_ssim", "ssim", "paper_rank_mse",
               "rank_mse", "paper_rank_ssim", "rank_ssim"])
    write_text(os.path.join(out, "table1_vs_paper.md"), "\n".join(paper_markdown(vs_rows, claims)) + "\n")
    write_text(os.path.join(out, "table1.md"), "\n".join(md) + "\n")
    write_text(os.path.join(out, "table1.tex"), "\n".join(tex) + "\n")
    write_text(os.path.join(out, "table2.md"), "\n".join(md2) + "\n")
    write_text(os.path.join(out, "table2.tex"), "\n".join(tex2) + "\n")
    return len(notes)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    add_common_args(ap, experiment=os.path.join(REPO, "experiments", "table1.json"))
    a = ap.parse_args(argv)

    def go():
        decl = load_declaration(a.experiment, a.voxlab)
        check_one_cell_each(decl)
        meta, rows = run_experiment(decl, **sweep_args(a))
        out = os.path.join(os.path.abspath(a.results), decl["name"])
        build(meta, rows, decl, out)
        print(f"table1: wrote {rel(out, REPO)}/table1.{{csv,md,tex}}, table1_vs_paper.{{csv,md}} and "
              f"table2.{{csv,md,tex}}",
              file=sys.stderr)
        return 0

    return main_wrapper(go, "table1")


if __name__ == "__main__":
    sys.exit(main())
