#!/usr/bin/python3
"""The fast regression check CI runs (make regress), and the baseline it checks against.

    /usr/bin/python3 experiments/regress.py [--experiment experiments/regress.json]
        [--baseline results/baseline.json] [--write-baseline] [--results results] [--jobs 2]
        [--voxlab build/voxlab] [--fresh]

Runs the declared subset (spheres and bunny at 64^3, every registered model; cached by inputs, so
after a rebuild it runs again and otherwise it costs nothing), then compares every configuration with
its entry in the baseline's section for this experiment, metric by metric, with the declaration's
tolerances (experiments/regress.json; a declaration without its own uses those):

  regression  worse than the baseline by more than max(abs, rel x |baseline|) on a gating metric
              (MSE, SSIM): exit status 1.
  failed      the configuration worked in the baseline and fails now: exit status 1.
  missing     the baseline has it, this run does not (a model was removed or renamed): exit 1.
  warning     beyond tolerance on a report-only metric (times, memory): reported, exit 0.
  improved    better by more than the tolerance: reported (update the baseline to keep it).
  new         not in the baseline (a model added since): reported.

Writes <results>/<name>/report.md and report.json. --write-baseline stores this run as the
baseline section for the experiment (other sections are kept) instead of comparing: do that, and
commit results/baseline.json, when a change of the numbers is intended.
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from voxlab_exp.cli import add_common_args, main_wrapper, sweep_args  # noqa: E402
from voxlab_exp.config import REPO  # noqa: E402
from voxlab_exp.errors import DeclarationError, VoxlabError  # noqa: E402
from voxlab_exp.files import load_json, write_json, write_text  # noqa: E402
from voxlab_exp.history import baseline_section, compare_to_baseline, gating  # noqa: E402
from voxlab_exp.provenance import git_info  # noqa: E402
from voxlab_exp.report import settings_text  # noqa: E402
from voxlab_exp.rows import run_experiment  # noqa: E402
from voxlab_exp.schema import load_declaration  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_TOLERANCES = os.path.join(HERE, "regress.json")


def tolerances_for(decl, voxlab):
    """The declaration's tolerances, else those of experiments/regress.json."""
    if decl["tolerances"]:
        return decl["tolerances"]
    return load_declaration(DEFAULT_TOLERANCES, voxlab)["tolerances"]


def fmt(v):
    if v is None or v == "":
        return "–"
    v = float(v)
    return f"{v:.4g}" if abs(v) >= 1e-3 or v == 0 else f"{v:.3e}"


def tol_text(m, t):
    parts = ([f"{t['abs']:g} absolute"] if t.get("abs") else []) + ([f"{t['rel']:.0%} relative"] if t.get("rel") else [])
    return (f"{m} ({t['better']} is better): {' or '.join(parts) or 'exact'}"
            f"{'' if t.get('gate', True) else ', report only'}")


def report(meta, results, section, tol):
    lines = [f"# Regression check: {meta['experiment']}", ""]
    lines += [f"- {x}" for x in settings_text(meta)]
    if section:
        lines.append(f"- baseline: commit {section['commit'][:10]}{' (dirty)' if section.get('dirty') else ''}, "
                     f"{section['date']}, host {section['machine'].get('host', '?')}")
    lines.append("- tolerances: " + "; ".join(tol_text(m, t) for m, t in tol.items()))
    lines += ["", "| status | scene | model | res | " + " | ".join(tol) + " |",
              "|---|---|---|---:|" + "---:|" * len(tol)]
    for x in results:
        cells = []
        for m in tol:
            d = x["metrics"].get(m)
            if not d:
                cells.append("–")
                continue
            mark = {"regression": " ❌", "warning": " ⚠", "improved": " ✓"}.get(d["verdict"], "")
            cells.append(f"{fmt(d['cur'])} (base {fmt(d['base'])}){mark}" if d["base"] is not None else fmt(d["cur"]))
        lines.append(f"| {x['status']} | {x['scene']} | {x['model']} | {x['res']} | " + " | ".join(cells) + " |")
        if x.get("error"):
            lines.append(f"|  |  | ↳ {x['error']} |  |" + " |" * len(tol))
    return "\n".join(lines) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    add_common_args(ap, experiment=DEFAULT_TOLERANCES)
    ap.add_argument("--baseline", default=os.path.join(REPO, "results", "baseline.json"))
    ap.add_argument("--write-baseline", action="store_true", help="store this run as the baseline; do not compare")
    ap.add_argument("--allow-dirty", action="store_true",
                    help="let --write-baseline store a run of a checkout with uncommitted changes (its numbers "
                         "then belong to no commit: a fresh clone cannot reproduce them)")
    a = ap.parse_args(argv)

    def go():
        if a.write_baseline and not a.allow_dirty:
            g = git_info()
            if g["dirty"]:
                # A baseline from uncommitted sources shows a false regression on every fresh clone.
                raise VoxlabError("--write-baseline: the checkout has uncommitted changes outside results/ "
                                     f"({g['text']}); commit them first, so that the baseline belongs to a commit "
                                     "a fresh clone can rebuild (or pass --allow-dirty)")
        decl = load_declaration(a.experiment, a.voxlab)
        tol = tolerances_for(decl, a.voxlab)
        baseline = None
        if os.path.exists(a.baseline):
            try:
                baseline = load_json(a.baseline)
            except ValueError as e:
                raise DeclarationError(f"{a.baseline}: not valid JSON: {e}")
        elif not a.write_baseline:
            raise VoxlabError(f"no baseline {a.baseline}: run `make baseline` (or this script with "
                                 f"--write-baseline) on a known-good commit and commit the file")
        meta, rows = run_experiment(decl, **sweep_args(a))
        out = os.path.join(os.path.abspath(a.results), decl["name"])
        if a.write_baseline:
            bad = [r for r in rows if r["status"] != "ok"]
            if bad:
                print(f"regress: warning: {len(bad)} configuration(s) failed and enter the baseline as failed",
                      file=sys.stderr)
            doc = baseline or {}
            doc.setdefault("comment", "Reference numbers for `make regress` and the dashboard: one section per "
                                      "experiment, written by experiments/regress.py --write-baseline from a real "
                                      "run. Tolerances: experiments/regress.json.")
            doc.setdefault("experiments", {})[decl["name"]] = baseline_section(meta, rows)
            os.makedirs(os.path.dirname(os.path.abspath(a.baseline)), exist_ok=True)
            write_json(a.baseline, doc)
            print(f"regress: wrote the {decl['name']} section of {a.baseline} ({len(rows)} configurations)",
                  file=sys.stderr)
            return 0
        section = (baseline.get("experiments") or {}).get(decl["name"])
        if section is None:
            raise VoxlabError(f"{a.baseline} has no section \"{decl['name']}\": run this script with "
                                 f"--write-baseline once")
        results = compare_to_baseline(rows, section, tol)
        text = report(meta, results, section, tol)
        write_text(os.path.join(out, "report.md"), text)
        write_json(os.path.join(out, "report.json"),
                      {"meta": meta, "results": [{k: v for k, v in x.items() if k != "row"} for x in results]})
        sys.stdout.write(text)
        bad = gating(results)
        counts = {}
        for x in results:
            counts[x["status"]] = counts.get(x["status"], 0) + 1
        summary = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
        if bad:
            print(f"regress: FAILED: {summary}", file=sys.stderr)
            for x in bad:
                worst = [f"{m} {fmt(d['base'])} -> {fmt(d['cur'])}" for m, d in x["metrics"].items()
                         if d["verdict"] == "regression"]
                print(f"regress:   {x['status']}: {x['scene']} {x['model']} {x['res']}^3: "
                      f"{'; '.join(worst) or x.get('error', '')}", file=sys.stderr)
            return 1
        print(f"regress: ok ({summary})", file=sys.stderr)
        return 0

    return main_wrapper(go, "regress")


if __name__ == "__main__":
    sys.exit(main())
