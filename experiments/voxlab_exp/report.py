"""The settings lines every table and page states (date, machine, commit, binary, load, cache use).

Exists so that table1, pareto, figures, regress, the demo and the dashboard describe a run in the
same words from its rows.json meta.
"""
import math
import os

from .provenance import machine_text



def fmt_duration(s):
    if s is None or not math.isfinite(s):
        return "?"
    s = int(round(s))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


def source_text(src):
    if not src:
        return "copied from build/voxlab before its source commit was recorded"
    g = src.get("git", {})
    return f"copied from {os.path.basename(os.path.dirname(src.get('from', '')))}/voxlab on {src.get('snapshot_date', '?')} " \
           f"with the checkout at {g.get('commit', '?')[:10]}{' + uncommitted changes' if g.get('dirty') else ''}"


def load_text(meta):
    la = meta.get("load_average") or {}
    if not isinstance(la, dict) or not la.get("jobs"):
        return "machine load while the jobs ran: not recorded"
    loaded = meta.get("loaded_jobs") or []
    return (f"machine load (1-minute average) around the timed jobs: mean {la['mean']:.1f}, max "
            f"{la['max']:.1f} on {meta['machine']['nproc']} cores" +
            (f" ({la['unrecorded']} older jobs not recorded)" if la.get("unrecorded") else "") +
            (f"; FLAGGED: {len(loaded)} timed job(s) measured under a load above their machine's cores, their "
             f"times are inflated: {', '.join(loaded[:5])}{', ...' if len(loaded) > 5 else ''}" if loaded else
             "; no timed job ran under a load above its cores"))


def machines_text(meta):
    """Where the timed jobs ran: one machine and thread count, or the warning that several did (the
    rows' host and threads columns say which; their times do not compare)."""
    ms = meta.get("timed_machines") or []
    if len(ms) <= 1:
        return f"{meta['threads']} here" if not ms else f"on {ms[0]}"
    return (f"CAUTION: on {len(ms)} machines or thread counts, {', '.join(ms)}: times from different ones do not "
            f"compare; the rows' host and threads columns say which")


def settings_text(meta):
    """The lines every table and page states: date, machine, commit, binary, job layout, cache use."""
    g, c = meta["git"], meta["counts"]
    rep = meta.get("repeats")
    lines = [
        f"date: {meta['date']}",
        f"machine: {machine_text(meta['machine'])}",
        f"git commit: {g['text']}",
        f"voxlab sha256: {meta['voxlab_sha256'][:16]} ({source_text(meta.get('voxlab_source'))}); models: "
        f"{', '.join(m['name'] for m in meta['models'])}",
        f"declaration: {meta['declaration']}; executor {meta.get('executor', 'local')}, {meta['jobs']} untimed "
        f"job(s) at a time; " + (f"each timed job (truth, bake, render) alone on its machine with all its cores "
                                 f"({machines_text(meta)}), its voxlab run repeated {rep} times (bakes "
                                 f"{meta.get('bake_repeats')}): times are the median, ± the spread (max − min)"
                                 if rep else f"{meta['threads']} voxlab thread(s) each"),
        load_text(meta),
        f"jobs: {c['ran']} ran now, {c['cached']} reused from the cache (same code path sources, scene files and "
        f"options" + (f"; the oldest from {meta['oldest_cached']}: its timings are from that run"
                      if meta["oldest_cached"] else "") + ")" +
        (f"; {len(meta['invalidated'])} cached job(s) invalidated by changed sources and rerun"
         if meta.get("invalidated") else ""),
    ]
    return lines


def size_text(rows):
    """The image sizes of rows as the tables and figures state them ("256x256", or "64x64, 128x128"
    when they differ): from the rows' width and height, never assumed from the voxel resolution (a
    declaration's "size" may be "scene", a number or [W, H])."""
    sizes = list(dict.fromkeys((r.get("width"), r.get("height")) for r in rows if r.get("width")))
    return ", ".join(f"{w}x{h}" for w, h in sizes) if sizes else "?"
