#!/usr/bin/python3
"""Where voxels pay: the crossover of each voxel model with the triangles (make crossover, issue 19).

    /usr/bin/python3 experiments/crossover.py [--experiment experiments/crossover.json] [--results results]
        [--jobs 2] [--voxlab build/voxlab] [--fresh]

Runs the declared sweep (cached, the engine of every experiment) over scene variants that grow in
triangles (the declaration's figure.complexity: variant families) and in viewing distance
(figure.distance: one family and the scene field it varies). At every point each model renders at
its settings, and the triangle truth renders its spp curve (truth_curve, a seed other than the
reference's). Error is held equal: the truth's time at a model's error is read off the truth's
curve at that point (log-log interpolation of time against MSE between the curve's spp; a model
less accurate than the truth at 1 spp is charged the 1-spp time, the cheapest truth image there
is, marked "floor"; one more accurate than the curve's last point extrapolates MSE ~ 1/spp, marked
"extrapolated"). Writes into <results>/<name>/:

  crossover.csv   one line per point and model: the sweep, its x (triangles or the varied field),
                  the model's MSE, render ms, bake s and MB (records + grid), the truth's ms at that
                  MSE (and how it was read), the truth's 1-spp ms and MB, speed-up = truth ms at
                  equal error / model ms (> 1: the model wins at that point).
  crossover.md    per sweep and model: where the model overtakes the triangles (the x at which its
                  time crosses below the truth's at equal error, interpolated in log x), or that it
                  does not within the sweep and by how much it misses at best.
  crossover.png   time at equal error and memory against triangles and against distance, each model
                  in its colour (solid: the model; dashed: the truth at the model's error; black:
                  the truth's memory), crossings marked.
"""
import argparse
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from voxlab_exp.cli import add_common_args, main_wrapper, sweep_args  # noqa: E402
from voxlab_exp.config import REPO  # noqa: E402
from voxlab_exp.errors import DeclarationError  # noqa: E402
from voxlab_exp.files import rel, write_csv, write_text  # noqa: E402
from voxlab_exp.plots import TRUTH_COLOUR, model_colour, save_plot  # noqa: E402
from voxlab_exp.report import settings_text  # noqa: E402
from voxlab_exp.rows import run_experiment  # noqa: E402
from voxlab_exp.schema import load_declaration  # noqa: E402

CSV_FIELDS = ["sweep", "family", "scene", "x", "triangles", "model", "mse", "ssim", "render_ms", "bake_s", "mb",
              "truth_ms_equal_error", "truth_read", "truth_spp_equal_error", "truth_ms_1spp", "truth_mse_1spp",
              "truth_mb", "truth_bvh_s", "truth_bvh_mb", "speedup", "wins"]


def truth_time_at(curve, mse):
    """The truth's render ms (and spp) at error `mse`, from its curve [(spp, ms, mse), ...]: log-log
    interpolation between the two curve points around it; 'floor' (the 1-spp point's time) when the
    truth's least accurate point is already at least as accurate; 'extrapolated' beyond its most
    accurate point (MSE ~ 1/spp, time ~ spp from the last point). Returns (ms, spp, how)."""
    pts = sorted((p for p in curve if p[1] > 0 and p[2] > 0), key=lambda p: p[0])
    if not pts or not mse or mse <= 0:
        return None, None, "none"
    if mse >= pts[0][2]:
        return pts[0][1], pts[0][0], "floor"
    for (s0, t0, e0), (s1, t1, e1) in zip(pts, pts[1:]):
        if e1 <= mse <= e0 and e0 > e1:
            f = (math.log(e0) - math.log(mse)) / (math.log(e0) - math.log(e1))
            return (math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0))),
                    math.exp(math.log(s0) + f * (math.log(s1) - math.log(s0))), "interpolated")
    s, t, e = pts[-1]
    if mse < e:
        k = e / mse
        return t * k, s * k, "extrapolated"
    # The curve is not monotone (noise at high spp): the cheapest point at least as accurate.
    ok = [p for p in pts if p[2] <= mse]
    return ok[0][1], ok[0][0], "interpolated"


def crossings(xs, model_ms, truth_ms):
    """The x values (log-interpolated) where the model's time crosses the truth's: a list of
    (x, 'overtakes' | 'falls behind') in order of x."""
    out = []
    pts = [(x, m, t) for x, m, t in zip(xs, model_ms, truth_ms) if x and m and t and x > 0 and m > 0 and t > 0]
    pts.sort()
    for (x0, m0, t0), (x1, m1, t1) in zip(pts, pts[1:]):
        d0, d1 = math.log(m0 / t0), math.log(m1 / t1)
        if (d0 > 0) != (d1 > 0) and d0 != d1:
            f = d0 / (d0 - d1)
            x = math.exp(math.log(x0) + f * (math.log(x1) - math.log(x0)))
            out.append((x, "overtakes" if d1 < 0 else "falls behind"))
    return out


def sweeps_of(decl):
    """[(sweep name, [scene names], x kind)] from the declaration's figure. A sweep may join several
    families (complexity: the procedural forest, then the instanced one); family_of names each
    scene's, and crossings are read within a family, never across two scenes' curves."""
    fig = decl["figure"]
    if fig.get("type") != "crossover":
        raise DeclarationError(f"{decl['shown']}: figure.type: expected \"crossover\"")
    fams = {}
    for s in decl["scenes"]:
        fams.setdefault(s.get("base_name") or s["name"], []).append(s)
    out = []
    comp = [n for f in fig.get("complexity", []) for n in [s["name"] for s in fams.get(f, [])]]
    for f in fig.get("complexity", []):
        if f not in fams:
            raise DeclarationError(f"{decl['shown']}: figure.complexity: no scene family {f}")
    if comp:
        out.append(("complexity", comp, "triangles"))
    dist = fig.get("distance")
    if dist:
        if dist.get("family") not in fams:
            raise DeclarationError(f"{decl['shown']}: figure.distance.family: no scene family {dist.get('family')}")
        out.append(("distance", [s["name"] for s in fams[dist["family"]]], dist["field"]))
    return out


def family_of(decl):
    """Scene name -> its family (the declaration's scene entry name)."""
    return {s["name"]: s.get("base_name") or s["name"] for s in decl["scenes"]}


def build_points(decl, rows):
    scenes = {s["name"]: s for s in decl["scenes"]}
    fam = family_of(decl)
    pts = []
    for sweep, names, xkind in sweeps_of(decl):
        for sc in names:
            rs = [r for r in rows if r["scene"] == sc and r.get("status") == "ok"]
            curve = [(r["spp"], r["render_ms"], r["mse"]) for r in rs
                     if r["kind"] == "truth" and r.get("render_ms") and r.get("mse") is not None]
            tri = next((r["triangles"] for r in rs if r.get("triangles")), None)
            settings = {**scenes[sc]["set"], **scenes[sc]["vary"]}  # dotted field -> value
            x = tri if xkind == "triangles" else settings.get(xkind)
            one = min((r for r in rs if r["kind"] == "truth"), key=lambda r: r["spp"], default=None)
            for r in rs:
                if r["kind"] != "model":
                    continue
                ms, spp, how = truth_time_at(curve, r.get("mse"))
                pts.append({"sweep": sweep, "family": fam[sc], "scene": sc, "x": x, "triangles": tri, "model": r["model"],
                            "mse": r.get("mse"), "ssim": r.get("ssim"), "render_ms": r.get("render_ms"),
                            "bake_s": r.get("bake_s"), "mb": r.get("mb"), "truth_ms_equal_error": ms,
                            "truth_read": how, "truth_spp_equal_error": spp,
                            "truth_ms_1spp": one["render_ms"] if one else None,
                            "truth_mse_1spp": one["mse"] if one else None, "truth_mb": one["mb"] if one else None,
                            "truth_bvh_s": one.get("bvh_s") if one else None,
                            "truth_bvh_mb": one["bvh_bytes"] / 1e6 if one and one.get("bvh_bytes") else None,
                            "speedup": ms / r["render_ms"] if ms and r.get("render_ms") else None,
                            "wins": int(bool(ms and r.get("render_ms") and r["render_ms"] < ms))})
    return pts


def summary(decl, meta, pts):
    md = [f"# Where voxels pay ({meta['experiment']})", ""]
    md += [f"- {x}" for x in settings_text(meta)]
    md += ["", "Error held equal: the truth's time is read off its spp curve at each model's MSE (\"floor\": the "
               "model is less accurate than the truth at 1 spp, which is then the truth's cheapest image). "
               "Speed-up = truth ms at equal error / model render ms (bake excluded; it is a one-off, "
               "in crossover.csv).", ""]
    for sweep, _names, xkind in sweeps_of(decl):
        sp = [p for p in pts if p["sweep"] == sweep]
        md += [f"## {sweep} (x = {xkind})", "",
               "| model | x | MSE | render ms | truth ms at equal error | read | speed-up | model MB | truth MB |",
               "|---|---|---|---|---|---|---|---|---|"]
        for p in sorted(sp, key=lambda p: (p["model"], p["x"] or 0)):
            md.append("| %s | %s | %.4g | %.3g | %s | %s | %s | %s | %s |" % (
                p["model"], "%.4g" % p["x"] if p["x"] is not None else "?", p["mse"] or 0, p["render_ms"] or 0,
                "%.3g" % p["truth_ms_equal_error"] if p["truth_ms_equal_error"] else "?", p["truth_read"],
                "%.2f" % p["speedup"] if p["speedup"] else "?", "%.3g" % p["mb"] if p["mb"] else "?",
                "%.3g" % p["truth_mb"] if p["truth_mb"] else "?"))
        md.append("")
        families = list(dict.fromkeys(p["family"] for p in sp))
        for m in dict.fromkeys(p["model"] for p in sp):
            for f in families:
                mp = sorted((p for p in sp if p["model"] == m and p["family"] == f and p["x"]), key=lambda p: p["x"])
                cr = crossings([p["x"] for p in mp], [p["render_ms"] for p in mp],
                               [p["truth_ms_equal_error"] for p in mp])
                wins = [p["x"] for p in mp if p["wins"]]
                if cr:
                    text = "; ".join(f"{how} the triangles at {xkind} ≈ {x:.3g}" for x, how in cr)
                elif wins and len(wins) == len(mp):
                    text = "faster than the triangles at equal error over the whole sweep"
                else:
                    best = max((p["speedup"] for p in mp if p["speedup"]), default=None)
                    text = ("does not overtake the triangles within the sweep" +
                            (f" (at best {best:.2f}x the truth's speed at equal error)" if best else ""))
                label = f"**{m}**" + (f" ({f}, {xkind} {mp[0]['x']:.3g} to {mp[-1]['x']:.3g})"
                                      if len(families) > 1 and mp else "")
                md.append(f"- {label}: {text}.")
        md.append("")
    return md


def plot(decl, meta, pts, out_stem):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sweeps = sweeps_of(decl)
    fig, axes = plt.subplots(2, len(sweeps), figsize=(6.5 * len(sweeps), 9), squeeze=False)
    for col, (sweep, _names, xkind) in enumerate(sweeps):
        sp = [p for p in pts if p["sweep"] == sweep and p["x"]]
        at, am = axes[0][col], axes[1][col]
        families = list(dict.fromkeys(p["family"] for p in sp))
        marks = "os^vD"
        for m in dict.fromkeys(p["model"] for p in sp):
            c = model_colour(m)
            for fi, f in enumerate(families):
                mp = sorted((p for p in sp if p["model"] == m and p["family"] == f), key=lambda p: p["x"])
                xs = [p["x"] for p in mp]
                name = m if len(families) == 1 else f"{m} ({f})"
                at.plot(xs, [p["render_ms"] for p in mp], "-" + marks[fi % len(marks)], color=c, ms=4, label=name)
                at.plot(xs, [p["truth_ms_equal_error"] for p in mp], "--", color=c, lw=1,
                        label=f"truth at {name}'s error")
                for x, how in crossings(xs, [p["render_ms"] for p in mp], [p["truth_ms_equal_error"] for p in mp]):
                    at.axvline(x, color=c, ls=":", lw=1)
                    at.text(x, 0.02, f"{name} {how}", transform=at.get_xaxis_transform(), color=c, fontsize=6,
                            rotation=90, va="bottom", ha="right")
                am.plot(xs, [p["mb"] for p in mp], "-" + marks[fi % len(marks)], color=c, ms=4,
                        label=f"{name} (records + grid)")
        for fi, f in enumerate(families):
            tp = sorted({p["x"]: p for p in sp if p["family"] == f}.values(), key=lambda p: p["x"])
            am.plot([p["x"] for p in tp], [p["truth_mb"] for p in tp], "-*", color=TRUTH_COLOUR, alpha=1 - 0.3 * fi,
                    label="truth (mesh + BVH)" + ("" if len(families) == 1 else f" ({f})"))
        for ax, ylabel in ((at, "render ms per frame at equal error"), (am, "memory (MB)")):
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel(xkind)
            ax.set_ylabel(ylabel)
            ax.grid(True, which="both", alpha=0.25)
            ax.legend(fontsize=6)
        at.set_title(f"{sweep}: time at equal error", fontsize=10)
        am.set_title(f"{sweep}: memory", fontsize=10)
    g = meta["git"]
    fig.suptitle(f"Where voxels pay: every model against the triangles at equal error "
                 f"(commit {g['commit'][:10]}{' dirty' if g['dirty'] else ''}, {meta['threads']} thread(s))",
                 fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    save_plot(fig, out_stem + ".png", dpi=100, meta=meta)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    add_common_args(ap, experiment=os.path.join(REPO, "experiments", "crossover.json"))
    ap.add_argument("--replot", action="store_true",
                    help="rewrite crossover.csv/.md/.png from the last run's rows.json, running nothing")
    a = ap.parse_args(argv)

    def go():
        # A replot runs nothing: its declaration was checked against voxlab when it ran.
        decl = load_declaration(a.experiment, None if a.replot else a.voxlab)
        sweeps_of(decl)  # a bad figure block fails before anything runs
        if not decl["truth_curve"]:
            raise DeclarationError(f"{decl['shown']}: truth_curve: required (the truth's time at equal error)")
        out = os.path.join(os.path.abspath(a.results), decl["name"])
        if a.replot:
            try:
                with open(os.path.join(out, "rows.json")) as f:
                    saved = json.load(f)
            except (OSError, ValueError) as err:
                raise DeclarationError(f"--replot: no readable {rel(out, REPO)}/rows.json ({err}): run without it first")
            meta, rows = saved["meta"], saved["rows"]
        else:
            meta, rows = run_experiment(decl, **sweep_args(a))
        pts = build_points(decl, rows)
        write_csv(os.path.join(out, "crossover.csv"), pts, CSV_FIELDS)
        write_text(os.path.join(out, "crossover.md"), "\n".join(summary(decl, meta, pts)) + "\n")
        plot(decl, meta, pts, os.path.join(out, "crossover"))
        print(f"crossover: wrote {rel(out, REPO)}/crossover.csv, crossover.md, crossover.png", file=sys.stderr)
        return 0

    return main_wrapper(go, "crossover")


if __name__ == "__main__":
    sys.exit(main())
