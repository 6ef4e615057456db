"""Results across runs: results/history.csv (one line per commit and configuration) and the baseline.

Exists because the dashboard's history and the regression check (regress.py, make baseline) both
compare this run's rows with earlier ones; neither is touched by running an experiment.
"""
import csv
import fcntl
import io
import os

from .files import write_text
from .rows import row_key



HISTORY_FIELDS = ["run_id", "date", "commit", "dirty", "experiment", "scene", "model", "res", "width", "height", "spp",
                  "rays", "cache", "shadows", "shadow_skip", "seed", "truth_spp", "status", "mse", "ssim", "psnr",
                  "render_ms", "bake_s", "mb", "bytes_per_voxel", "host", "voxlab_sha256"]


# A job's configuration, as rows.row_key's: shadows, shadow skip, seed and the truth's spp were left
# out, so configurations differing only by them overwrote each other's line (the audit of issue 15's
# stop 45). Lines written before they were columns read them as "".
HISTORY_KEY = ["commit", "experiment", "scene", "model", "res", "width", "height", "spp", "rays", "cache", "shadows",
               "shadow_skip", "seed", "truth_spp"]


def _history_cell(v):
    return "" if v is None else repr(v) if isinstance(v, float) else str(v)


def record_history(path, runs, lock_dir):
    """Writes the rows of each (meta, rows) run into the history: one line per commit and job
    (configuration), the newest run's numbers replacing an older line for the same commit and job
    (and any duplicates an older version of this function appended). Only `make dashboard` calls this
    (dashboard.py --record-history): running an experiment never touches the history. The whole file
    is rewritten under a lock (temp + rename), so concurrent writers neither interleave nor lose lines.
    Returns the number of lines written."""
    os.makedirs(lock_dir, exist_ok=True)
    with open(os.path.join(lock_dir, "history.lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        old = read_history(path)
        header = list(HISTORY_FIELDS) + [k for k in (old[0].keys() if old else []) if k not in HISTORY_FIELDS]
        # A metric `voxlab compare` has gained since the columns above were fixed goes at the end.
        header += [m for meta, _ in runs for m in meta.get("metrics", []) if m not in header]
        header = list(dict.fromkeys(header))
        lines = {}
        for h in old:
            lines[tuple(h.get(k, "") for k in HISTORY_KEY)] = h
        for meta, rows in runs:
            g = meta["git"]
            run_id = f"{meta['date']}-{g['commit'][:8]}-{meta['experiment']}"
            for r in rows:
                h = {k: _history_cell(v) for k, v in r.items() if k in header}
                h.update(run_id=run_id, date=meta["date"], commit=g["commit"], dirty=str(int(g["dirty"])),
                         host=meta["machine"]["host"], voxlab_sha256=meta["voxlab_sha256"][:12])
                key = tuple(h.get(k, "") for k in HISTORY_KEY)
                lines.pop(key, None)  # re-inserted last: the file stays in the order runs happened
                lines[key] = h
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=header, lineterminator="\n", extrasaction="ignore", restval="")
        w.writeheader()
        for h in lines.values():
            w.writerow(h)
        write_text(path, buf.getvalue())
        return len(lines)


def read_history(path):
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


# Besides the image metrics (the run's meta["metrics"]: what `voxlab compare --json` writes).
BASELINE_COLUMNS = ["render_ms", "bake_s", "mb", "bytes_per_voxel"]


def baseline_metrics(meta):
    return list(dict.fromkeys(list(meta.get("metrics") or []) + BASELINE_COLUMNS))


def baseline_section(meta, rows):
    return {"date": meta["date"], "commit": meta["git"]["commit"], "dirty": meta["git"]["dirty"],
            "machine": meta["machine"], "voxlab_sha256": meta["voxlab_sha256"],
            "models": [m["name"] for m in meta["models"]],
            "entries": {row_key(r): {"scene": r["scene"], "model": r["model"], "res": r["res"],
                                     "status": r["status"], **{m: r.get(m) for m in baseline_metrics(meta)}}
                        for r in rows if r["kind"] == "model"}}


def verdict(metric, cur, base, tol):
    """'ok' | 'regression' | 'warning' (beyond tolerance, not gating) | 'improved' | 'n/a'."""
    if cur is None or base is None or cur == "" or base == "":
        return "n/a", None
    cur, base = float(cur), float(base)
    margin = max(tol.get("abs", 0.0), tol.get("rel", 0.0) * abs(base))
    worse = cur - base if tol["better"] == "lower" else base - cur
    if worse > margin:
        return ("regression" if tol.get("gate", True) else "warning"), cur - base
    if -worse > margin and margin > 0:
        return "improved", cur - base
    return "ok", cur - base


def compare_to_baseline(rows, section, tolerances):
    """Each current row against its baseline entry: [{key, scene, model, res, status, metrics}] where
    status is ok / regression / warning / improved / new / failed / missing and metrics maps each
    metric to {cur, base, delta, verdict}. A configuration the baseline has but this run lacks (a
    model removed or renamed) is 'missing' and counts as a regression."""
    entries = dict(section.get("entries", {})) if section else {}
    out = []
    order = {"regression": 4, "failed": 4, "missing": 4, "warning": 2, "improved": 1, "ok": 0, "new": 0}
    for r in rows:
        if r["kind"] != "model":
            continue
        k = row_key(r)
        base = entries.pop(k, None)
        item = {"key": k, "scene": r["scene"], "model": r["model"], "res": r["res"], "metrics": {}, "row": r}
        if r["status"] != "ok":
            # A configuration that fails fails the check, whether the baseline has it or not: a new
            # one that failed was listed as "new", its metrics blank like a missing row's, and the
            # check passed (the audit of issue 15's stop 45).
            item["status"] = "failed"
            item["error"] = r["error"]
        elif base is None:
            item["status"] = "new"
            item["metrics"] = {m: {"cur": r.get(m), "base": None, "delta": None, "verdict": "n/a"}
                               for m in tolerances}
        else:
            status = "ok"
            for m, tol in tolerances.items():
                v, delta = verdict(m, r.get(m), base.get(m), tol)
                item["metrics"][m] = {"cur": r.get(m), "base": base.get(m), "delta": delta, "verdict": v}
                if order.get(v, 0) > order[status]:
                    status = v
            item["status"] = status
        out.append(item)
    for k, base in entries.items():
        out.append({"key": k, "scene": base["scene"], "model": base["model"], "res": base["res"], "metrics": {},
                    "status": "missing", "error": "in the baseline but not in this run (model not registered?)",
                    "row": None})
    return out


def gating(results):
    return [x for x in results if x["status"] in ("regression", "failed", "missing")]
