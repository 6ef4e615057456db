"""Brito et al. 2023's printed Table 1 (experiments/paper/brito2023.json) beside our numbers.

Their scenes are not ours, so values are not expected to match: what can be compared is how the
three methods rank on each scene and resolution, and whether the paper's claims hold on our scenes.
"""
import json
import os

from .config import REPO

PAPER_FILE = os.path.join(REPO, "experiments", "paper", "brito2023.json")


def load_paper(path=PAPER_FILE):
    with open(path) as f:
        return json.load(f)


def display_name(model, paper=None):
    """'vicini ([VJK21])': the model with the paper's name for it, when the paper has one."""
    paper = paper or load_paper()
    names = {m: p for p, m in paper["methods"].items()}
    return f"{model} ({names[model]})" if model in names else model


def ranking(values, higher_better):
    """Method names ordered best first."""
    return [k for k, _ in sorted(values.items(), key=lambda kv: -kv[1] if higher_better else kv[1])]


def compare(cell, paper=None):
    """cell[(scene, res, model)] -> row with mse/ssim and status. Returns (rows, claims): one row per
    scene, resolution and paper method with both sets of numbers and ranks; claims as
    {"claim", "paper", "ours", "holds"} with per-case detail."""
    paper = paper or load_paper()
    methods = paper["methods"]
    rows, cases = [], []
    for res, table in paper["table1"].items():
        for scene in table["Averages"]:
            ours = {}
            for p, m in methods.items():
                r = cell.get((scene, int(res), m))
                if r and r.get("status") == "ok":
                    ours[p] = (r["mse"], r["ssim"])
            if len(ours) != len(methods):
                continue
            theirs = {p: tuple(table[p][scene]) for p in methods}
            rank = {}
            for which, data in (("paper", theirs), ("ours", ours)):
                rank[(which, "mse")] = ranking({p: v[0] for p, v in data.items()}, False)
                rank[(which, "ssim")] = ranking({p: v[1] for p, v in data.items()}, True)
            for p, m in methods.items():
                rows.append({"scene": scene, "res": int(res), "method": p, "model": m,
                             "paper_mse": theirs[p][0], "mse": ours[p][0],
                             "paper_ssim": theirs[p][1], "ssim": ours[p][1],
                             "paper_rank_mse": rank[("paper", "mse")].index(p) + 1,
                             "rank_mse": rank[("ours", "mse")].index(p) + 1,
                             "paper_rank_ssim": rank[("paper", "ssim")].index(p) + 1,
                             "rank_ssim": rank[("ours", "ssim")].index(p) + 1})
            cases.append((scene, int(res), theirs, ours))
    claims = []

    def claim(text, test, where=None):
        sel = [c for c in cases if where is None or where(c)]
        detail = [{"scene": s, "res": n, "paper": bool(test(t)), "ours": bool(test(o))} for s, n, t, o in sel]
        claims.append({"claim": text, "cases": detail,
                       "paper": sum(d["paper"] for d in detail), "ours": sum(d["ours"] for d in detail),
                       "of": len(detail)})

    claim("Ours beats [VJK21] in MSE", lambda v: v["Ours"][0] < v["[VJK21]"][0])
    claim("Ours beats [VJK21] in SSIM", lambda v: v["Ours"][1] > v["[VJK21]"][1])
    claim("Ours beats [VJK21] in both, except on Trees (scenes other than trees)",
          lambda v: v["Ours"][0] < v["[VJK21]"][0] and v["Ours"][1] > v["[VJK21]"][1],
          where=lambda c: c[0] != "trees")
    claim("[VJK21] beats Ours on Trees (both metrics)",
          lambda v: v["[VJK21]"][0] < v["Ours"][0] and v["[VJK21]"][1] > v["Ours"][1], where=lambda c: c[0] == "trees")
    claim("[VJK21] beats Averages in MSE", lambda v: v["[VJK21]"][0] < v["Averages"][0])
    claim("Averages has the worst MSE", lambda v: v["Averages"][0] > max(v["Ours"][0], v["[VJK21]"][0]))
    return rows, claims


def markdown(rows, claims):
    md = ["# Table 1 beside the paper's (Brito et al. 2023)", "",
          "The paper's scenes are not ours (ours are built to the same kinds), so the values differ; the "
          "ranks (1 = best of the three) and the paper's claims are what compare.", "",
          "| scene | res | method | model | paper MSE | our MSE | paper SSIM | our SSIM | paper rank MSE/SSIM | "
          "our rank MSE/SSIM |", "|---|---:|---|---|---:|---:|---:|---:|:---:|:---:|"]
    for r in rows:
        md.append(f"| {r['scene']} | {r['res']}³ | {r['method']} | {r['model']} | {r['paper_mse']:.4f} | "
                  f"{r['mse']:.4f} | {r['paper_ssim']:.4f} | {r['ssim']:.4f} | "
                  f"{r['paper_rank_mse']}/{r['paper_rank_ssim']} | {r['rank_mse']}/{r['rank_ssim']} |")
    md += ["", "## The paper's claims on our scenes", "", "| claim | paper: holds in | ours: holds in | where ours differs |",
           "|---|---:|---:|---|"]
    for c in claims:
        diff = ", ".join(f"{d['scene']} {d['res']}³ ({'holds' if d['ours'] else 'fails'})"
                         for d in c["cases"] if d["ours"] != d["paper"]) or "–"
        md.append(f"| {c['claim']} | {c['paper']}/{c['of']} | {c['ours']}/{c['of']} | {diff} |")
    if not claims or not any(c["of"] for c in claims):
        md += ["", "No scene of the paper's was run with all three methods: nothing to compare."]
    return md
