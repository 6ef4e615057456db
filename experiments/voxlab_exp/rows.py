"""Rows: a loaded declaration becomes jobs on the scheduler, and their outputs become one row per
configuration, written to <results>/<name>/rows.csv and rows.json.

Exists to define what a row holds (ROW_FIELDS) and how it is computed from the jobs' stats, timings
and `voxlab compare --json` metrics. The metric columns are not listed here: they are the keys
`voxlab compare --json` writes, which voxlab lists with `voxlab compare --list-metrics` (one table in
voxlab's cmd_compare.c), so adding a metric there adds its column to the rows, the history and the
baseline.
"""
import os
import sys
import time

from .config import DEFAULT_RESULTS, REPO
from .files import load_json, rel, write_csv, write_json
from .hashing import canonical
from .provenance import git_info, machine_info, now_iso
from .report import fmt_duration
from .scheduler import TIMING_FIELD, Sweep
from .schema import expand_configs
from .scenes import write_variant

# The columns before and after the metric columns (mse, psnr, ssim, ...: see row_fields).
ROW_FIELDS_HEAD = ["experiment", "scene", "base_scene", "variant", "kind", "model", "res", "width", "height", "spp",
                   "rays", "cache", "shadow_skip", "shadows", "seed", "truth_spp", "status", "error"]
ROW_FIELDS_TAIL = ["render_s", "render_ms", "render_ms_min", "render_ms_spread", "repeats", "bake_s", "bake_s_min",
                   "bake_s_spread", "bake_shared", "truth_s_min", "truth_s_spread", "load", "loaded", "host", "threads",
                   "bytes_per_voxel", "voxels", "model_bytes", "grid_bytes", "table_bytes", "mb", "shadow_build_s",
                   "shadow_bytes", "shadow_queries", "peak_rss_bytes", "cache_hits", "model_evals", "rays_per_pixel",
                   "triangles", "bvh_s", "bvh_bytes", "truth_s", "image", "preview", "truth_image", "truth_preview",
                   "computed", "jobs_cached", "truth_s_cached", "bake_s_cached", "render_ms_cached"]


def row_fields(metrics):
    """rows.csv's columns for a run whose `voxlab compare --json` writes `metrics` (in its order)."""
    return ROW_FIELDS_HEAD + list(metrics) + ROW_FIELDS_TAIL


def shadow_method(r):
    """A row's shadow method (march where the row predates the option or leaves it out)."""
    return r.get("shadows") or "march"


def shadow_skip_off(r):
    """Whether a row's shadow rays were marched without the shadow skip (a row read back from a CSV
    holds the word)."""
    return r.get("shadow_skip", True) in (False, "False", "false", 0, "0")


def row_key(r):
    """What identifies a configuration across runs (baseline, history)."""
    key = "/".join(str(x) for x in (r["scene"], r["model"], f"r{r['res']}", f"{r['width']}x{r['height']}",
                                    f"spp{r['spp']}", f"k{r['rays']}", "cache" if r["cache"] else "nocache",
                                    f"truth{r['truth_spp']}", f"seed{r['seed']}"))
    # The defaults (march shadows, shadow skip on) leave the key as it was before they were options;
    # the others are other configurations (a declaration may run "shadow_skip": [true, false]).
    sh = shadow_method(r)
    key = key if sh == "march" else f"{key}/shadows-{sh}"
    return f"{key}/noskip" if shadow_skip_off(r) else key


def wanted_all(wanted):
    """The jobs `wanted` and everything they depend on, once each."""
    out, seen, todo = [], set(), list(wanted)
    while todo:
        j = todo.pop()
        if j.key not in seen:
            seen.add(j.key)
            out.append(j)
            todo += j.deps
    return out


def _load_summary(jobs):
    loads = [j.record["load_average"] for j in jobs if j.record and "load_average" in j.record]
    return {"mean": sum(loads) / len(loads) if loads else None, "max": max(loads) if loads else None,
            "jobs": len(loads), "unrecorded": len(jobs) - len(loads)}


def timing_columns(job, name, scale):
    """`name` (the median of the job's timed runs, scaled: 1000 for ms), `name`_min and `name`_spread
    (max - min), and render_s beside render_ms; None where the job has no timing."""
    t = job.timing() if job is not None else None
    if t is None:  # an entry from before repeats were recorded: its one time, no spread
        st = {}
        try:
            st = load_json(job.path("stats.json"))
        except (OSError, ValueError, TypeError, AttributeError):
            pass
        v = st.get(TIMING_FIELD.get(getattr(job, "kind", ""), ""))
        t = {"median": v, "min": v, "spread": None, "runs": [v]} if v is not None else None
    med = t["median"] * scale if t else None
    out = {name: med, f"{name}_min": t["min"] * scale if t else None,
           f"{name}_spread": t["spread"] * scale if t and t["spread"] is not None else None}
    if name == "render_ms":
        out["render_s"] = t["median"] if t else None
        out["repeats"] = len(t["runs"]) if t else None
    return out


def cached_columns(**jobs):
    """name_cached per timing column: 1 when the job behind it was reused from the cache, so its time
    was measured in an earlier run (another day's load, maybe another build of the machine's software),
    0 when it was measured in this run; None without a job. Table 2 marks the former where a table
    mixes the two."""
    return {f"{name}_cached": (None if j is None or j.status not in ("ok", "cached") else int(j.status == "cached"))
            for name, j in jobs.items()}


def load_columns(*jobs):
    """The highest 1-minute load average seen while the row's timed jobs ran, and whether any of them
    ran under a load above its machine's cores (its times are then inflated)."""
    recs = [j.record for j in jobs if j is not None and j.record and j.timed]
    loads = [max(r.get("load_average") or 0, r.get("load_after") or 0) for r in recs if "load_average" in r]
    return {"load": max(loads) if loads else None,
            "loaded": int(any(r.get("loaded") for r in recs)) if recs else None}


def model_mb(d):
    """A model's own memory in MB: its records + grid + constant table (heitz-neyret's masks), from
    its render's stats or a row (the same keys); None where they are not known."""
    if d.get("model_bytes") is None or d.get("grid_bytes") is None:
        return None
    return (d["model_bytes"] + d["grid_bytes"] + (d.get("table_bytes") or 0)) / 1e6


def traced_per_pixel(row):
    """The rays or cones a model row's render traced a pixel when that is not its spp (heitz-neyret
    marches one cone a pixel whatever the spp), else None."""
    rpp = row.get("rays_per_pixel")
    return rpp if row.get("kind") == "model" and rpp is not None and abs(rpp - row["spp"]) > 1e-9 else None


def machine_columns(job):
    """Where a timed job ran and with how many threads (its record): a cluster may time two models on
    different machines, whose times do not compare; the tables say so (report.settings_text)."""
    rec = (job.record or {}) if job is not None else {}
    return {"host": rec.get("host"), "threads": rec.get("threads")}


def _timed_machines(jobs):
    """The distinct (host, threads) of the timed jobs behind the rows, as "host (N threads)"."""
    seen = {(j.record.get("host"), j.record.get("threads")) for j in jobs if j.timed and j.record}
    return [f"{h} ({t} threads)" for h, t in sorted(seen, key=str)]


def run_experiment(decl, results=DEFAULT_RESULTS, cache_dir=None, voxlab=None, jobs=2, fresh=False, out_dir=None,
                   sweep=None, executor="local", scheduler=None, slurm_args="", repeats=None, group_bakes=True):
    """Runs a loaded declaration; writes <results>/<name>/rows.csv and rows.json; returns (meta, rows).

    Row paths are relative to `results`. Nothing is appended to results/history.csv here: `make
    dashboard` records the history (dashboard.py --record-history), one row per commit and job."""
    results = os.path.abspath(results)
    cache_dir = os.path.abspath(cache_dir or os.path.join(results, "cache"))
    out_dir = os.path.abspath(out_dir or os.path.join(results, decl["name"]))
    started, date = time.monotonic(), now_iso()
    own = sweep is None
    sw = sweep or Sweep(voxlab or os.path.join(REPO, "build", "voxlab"), cache_dir, jobs=jobs, fresh=fresh,
                        name=decl["name"], timeout=decl["timeout_s"], executor=executor, scheduler=scheduler,
                        slurm_args=slurm_args, repeats=repeats, group_bakes=group_bakes)
    try:
        return _run_experiment(decl, sw, results, cache_dir, out_dir, started, date)
    finally:
        if own:
            sw.close()


def _run_experiment(decl, sw, results, cache_dir, out_dir, started, date):
    sw.name = decl["name"]
    model_names = [m["name"] for m in sw.models]
    seed, truth_spp = decl["seed"], decl["truth_spp"]

    # Scene variants are written into the cache (named by content) before anything hashes them.
    for s in decl["scenes"]:
        if s["path"] is None:
            s["path"] = write_variant(s["base"], s["name"], s["set"], os.path.join(cache_dir, "scenes"))
    scenes = {s["name"]: s for s in decl["scenes"]}

    def scene_size(s):
        try:
            v = load_json(s["path"]).get("size")
            return [int(v[0]), int(v[1])]
        except Exception:
            return [256, 256]  # voxlab's problem; the truth job will report it

    def size_of(size, res, s):
        return [res, res] if size == "res" else scene_size(s) if size == "scene" else size

    plan = []  # (config, truth, bake, render, compare) or (config, None...) for unknown models
    for cfg in expand_configs(decl, model_names, sw.models):
        s = scenes[cfg["scene"]]
        size = size_of(cfg["size"], cfg["res"], s)
        cfg["width"], cfg["height"] = size
        if cfg["model"] not in model_names:
            plan.append((cfg, None, None, None, None))
            continue
        t = sw.truth(s["path"], s["name"], size, truth_spp, seed)
        b = sw.bake(s["path"], s["name"], cfg["model"], cfg["res"], cfg["rays"], seed)
        r = sw.render(b, s["path"], s["name"], size, cfg["spp"], seed, cfg["cache"], cfg["shadow_skip"],
                      cfg.get("shadows", "march"))
        plan.append((cfg, t, b, r, sw.compare(t, r)))
    curve = []
    tc = decl["truth_curve"]
    if tc:
        for sc in tc["scenes"]:
            s = scenes[sc]
            size = scene_size(s) if tc["size"] == "scene" else tc["size"]
            ref = sw.truth(s["path"], s["name"], size, truth_spp, seed)
            for spp in tc["spp"]:
                t = sw.truth(s["path"], s["name"], size, spp, tc["seed"])
                curve.append((s, size, spp, ref, t, sw.compare(ref, t)))
    wanted = [j for p in plan for j in p[1:] if j] + [j for c in curve for j in c[3:]]
    # Timed jobs repeat their voxlab run R times (declared; --repeats overrides); bakes are a one-off
    # precomputation and repeat bake_repeats times.
    for j in wanted + [d for j in wanted for d in j.deps]:
        if j.timed:
            r = sw.repeats_override or (decl["bake_repeats"] if j.kind == "bake" else decl["repeats"])
            j.repeats = max(j.repeats, r) if j.status == "pending" else j.repeats
    counts = sw.run(wanted)

    def stats(job, name="stats.json"):
        try:
            return load_json(job.path(name))
        except (OSError, ValueError):
            return {}

    def first_failure(*jobs):
        for j in jobs:
            if j.status in ("failed", "skipped"):
                return j.error or f"{j.kind} failed"
        return None

    def base_row(s, cfg_like):
        return {"experiment": decl["name"], "scene": s["name"], "base_scene": s.get("base_name") or s["name"],
                "variant": canonical(s["vary"]) if s["vary"] else "", "seed": seed, "truth_spp": truth_spp,
                **cfg_like}

    def metric_columns(ms):
        # Every metric voxlab lists, None where the compare did not write it.
        return {m: ms.get(m) for m in sw.metrics}

    rows = []
    for cfg, t, b, r, c in plan:
        s = scenes[cfg["scene"]]
        row = base_row(s, {"kind": "model", "model": cfg["model"], "res": cfg["res"], "width": cfg["width"],
                           "height": cfg["height"], "spp": cfg["spp"], "rays": cfg["rays"], "cache": cfg["cache"],
                           "shadow_skip": cfg["shadow_skip"], "shadows": cfg.get("shadows", "march")})
        if t is None:
            row.update(status="failed", error=f"model {cfg['model']} is not registered in this voxlab "
                                              f"(voxlab models: {', '.join(model_names)})")
            rows.append(row)
            continue
        err = first_failure(t, b, r, c)
        ts = stats(t) if t.status in ("ok", "cached") else {}
        row.update(triangles=ts.get("triangles"), **timing_columns(t, "truth_s", 1.0),
                   **cached_columns(truth_s=t),
                   truth_image=rel(t.path("image.exr"), results), truth_preview=rel(t.path("image.png"), results))
        if err:
            row.update(status="failed", error=err)
            rows.append(row)
            continue
        rs, ms = stats(r), stats(c, "metrics.json")
        row.update(
            status="ok", error="", **metric_columns(ms),
            **timing_columns(r, "render_ms", 1000.0), **timing_columns(b, "bake_s", 1.0),
            **cached_columns(bake_s=b, render_ms=r), **load_columns(t, b, r), **machine_columns(r),
            # The bake time's kind: the model's share of one sampling pass shared with other models
            # (estimated from its part of the pass), or a bake of its own (a rerun after its code changed).
            bake_shared=int(bool(b.record.get("baked_with"))) if b.record else None,
            bytes_per_voxel=rs.get("bytes_per_voxel"),
            voxels=rs.get("voxels"),
            model_bytes=rs.get("model_bytes"), grid_bytes=rs.get("grid_bytes"), table_bytes=rs.get("table_bytes"),
            # the model's own memory + the precomputed shadows (the slicemap's maps, the `voxel`
            # method's transmittance per voxel and light): all the frame reads. Without the last, a
            # model rendered with precomputed shadows was charged less memory than the same model
            # marching its shadow rays.
            mb=(model_mb(rs) + (rs.get("shadow_bytes") or 0) / 1e6 if model_mb(rs) is not None else None),
            shadow_build_s=rs.get("shadow_build_seconds"), shadow_bytes=rs.get("shadow_bytes"),
            shadow_queries=rs.get("shadow_queries"),
            peak_rss_bytes=rs.get("peak_rss_bytes"), cache_hits=rs.get("cache_hits"),
            model_evals=rs.get("model_evals"), triangles=rs.get("triangles", row["triangles"]),
            # What the render traced per pixel: spp rays, or one cone whatever the spp (heitz-neyret).
            rays_per_pixel=(rs["rays"] / (cfg["width"] * cfg["height"]) if rs.get("rays") is not None else None),
            image=rel(r.path("image.exr"), results), preview=rel(r.path("image.png"), results),
            computed=(r.record or {}).get("date"),
            jobs_cached=sum(j.status == "cached" for j in (b, r, c)))
        rows.append(row)
    base_rss = sw.baseline_memory() if curve else 0
    for s, size, spp, ref, t, c in curve:
        row = base_row(s, {"kind": "truth", "model": "truth", "res": 0, "width": size[0], "height": size[1],
                           "spp": spp, "rays": 0, "cache": True, "shadow_skip": True, "shadows": "march"})
        err = first_failure(ref, t, c)
        if err:
            row.update(status="failed", error=err)
            rows.append(row)
            continue
        ts, ms = stats(t), stats(c, "metrics.json")
        rss = (t.record or {}).get("peak_rss_bytes")
        row.update(status="ok", error="", seed=decl["truth_curve"]["seed"], **metric_columns(ms),
                   **timing_columns(t, "render_ms", 1000.0), **cached_columns(render_ms=t),
                   **load_columns(t), **machine_columns(t), bake_s=0.0,
                   triangles=ts.get("triangles"), peak_rss_bytes=rss,
                   bvh_s=ts.get("bvh_seconds"), bvh_bytes=ts.get("bvh_bytes"),  # the truth's BVH: build, memory
                   # Triangles' memory: the meshes and textures it traces and shades from and its BVH
                   # (voxlab's mesh_bytes and bvh_bytes), as a model is charged its records and grid;
                   # from an older voxlab without mesh_bytes, peak RSS minus a process that loads no
                   # scene (framebuffer and thread stacks included: an overestimate).
                   mb=((ts["mesh_bytes"] + ts.get("bvh_bytes", 0)) / 1e6 if "mesh_bytes" in ts else
                       max(0, rss - base_rss) / 1e6 if rss else None),
                   image=rel(t.path("image.exr"), results), preview=rel(t.path("image.png"), results),
                   truth_image=rel(ref.path("image.exr"), results),
                   truth_preview=rel(ref.path("image.png"), results), computed=(t.record or {}).get("date"),
                   jobs_cached=sum(j.status == "cached" for j in (t, c)))
        rows.append(row)

    cached_dates = sorted(j.record["date"] for j in sw.all.values() if j.status == "cached" and j.record)
    meta = {
        "experiment": decl["name"], "declaration": decl["shown"], "description": decl["description"],
        "settings": decl["raw"], "date": date, "finished": now_iso(),
        "elapsed_s": time.monotonic() - started, "machine": machine_info(), "git": git_info(),
        "voxlab_sha256": sw.voxlab_sha256, "voxlab_build": sw.build, "voxlab_source": sw.source,
        "models": sw.models, "jobs": sw.jobs, "threads": sw.threads,
        "metrics": list(sw.metrics), "counts": counts, "oldest_cached": cached_dates[0] if cached_dates else None,
        "failed_rows": sum(r["status"] != "ok" for r in rows), "results_root": results,
        # Other processes on the machine slow the timed jobs down: say how busy it was when the
        # jobs behind these rows ran (recorded per job, so cached jobs keep their own).
        "load_average": _load_summary([j for j in sw.all.values() if j.kind in ("bake", "render", "truth")]),
        "timed_machines": _timed_machines([j for j in sw.all.values() if j.kind in ("bake", "render", "truth")]),
        "executor": sw.executor_name, "repeats": sw.repeats_override or decl["repeats"],
        "bake_repeats": sw.repeats_override or decl["bake_repeats"],
        "invalidated": [x for x in sw.invalidated if x["kind"]],
        # Timed jobs measured while the machine's load exceeded its cores: their times are inflated.
        "loaded_jobs": sorted(f"{j.kind} {j.label} (load {max(j.record.get('load_average') or 0, j.record.get('load_after') or 0):.1f}"
                              f" on {j.record.get('cores')} cores)" for j in wanted_all(wanted)
                              if j.timed and j.record and j.record.get("loaded")),
    }
    os.makedirs(out_dir, exist_ok=True)
    write_csv(os.path.join(out_dir, "rows.csv"), rows, row_fields(sw.metrics))
    write_json(os.path.join(out_dir, "rows.json"), {"meta": meta, "rows": rows})
    bad = [r for r in rows if r["status"] != "ok"]
    print(f"{decl['name']}: {len(rows)} row(s), {len(bad)} failed; {counts['ran']} job(s) ran, {counts['cached']} "
          f"cached, in {fmt_duration(meta['elapsed_s'])}; wrote {rel(out_dir, REPO)}/rows.csv", file=sys.stderr,
          flush=True)
    for r in bad:
        print(f"{decl['name']}:   failed: {r['scene']} {r['model']} {r['res']}^3: {r['error']}", file=sys.stderr)
    return meta, rows
