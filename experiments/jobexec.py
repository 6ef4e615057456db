"""Runs one sweep job into the cache: the code every executor (local threads, a Dask worker, a SLURM
array task) calls, so that the same job spec gives the same cache entry wherever it runs.

    execute(spec) -> record (also written as <spec["dir"]>/job.json)

A spec is a plain dict (JSON- and pickle-friendly; voxlab_exp.scheduler.Sweep.spec builds it): the job's key,
identity, kind, label, cache directory, the voxlab command with "{tmp}" standing for the temporary
output folder and "{threads}" for the thread count, the outputs to keep, the timeout and, for a timed
job, the number of repeats. Only the standard library is imported here: Dask ships this module to its
workers by value, and a SLURM task runs it with the system Python.

A timed job gets every core of the machine it runs on (the scheduler never runs anything beside it)
and runs its voxlab command R times; the first run's outputs are kept (renders are deterministic), the
timing field of every run's --stats (seconds, or bake_seconds for a bake) is recorded with its min,
median and spread (max - min), and so is the machine's 1-minute load average before and after: a
measurement taken under a load above the core count is flagged ("loaded").

A bake spec may instead carry "group": the specs of several bake jobs of the same scene, resolution,
rays and seed, run as one `voxlab bake --model a,b,...` (one pass of the sampler for all of them;
each model's .vox is byte for byte its own bake's). Its command writes "{model}"'s files, which voxlab
names per model; each member gets its own cache entry, as its own run would have written it, with
its own timing field (a model's bake_seconds from the shared pass: the samples' part plus its own),
and execute returns the members' records in order."""
import json
import os
import platform
import re
import shutil
import signal
import statistics
import subprocess
import tempfile
import threading
import time
import datetime

GNU_TIME = "/usr/bin/time"  # Debian's `time` package (experiments.mk adds it to DEPS)
# The files a group's command (see the top of this file) writes into its folder for each model; voxlab
# replaces {model} with the model's name.
GROUP_VOX, GROUP_STATS = "{model}.vox", "{model}.json"
_running = set()  # process groups of running children, killed if the script is interrupted
_running_lock = threading.Lock()


class JobFailed(Exception):
    """A job that ran and failed: args = (message, command, voxlab's stderr)."""


def kill_running():
    with _running_lock:
        for pid in list(_running):
            try:
                os.killpg(pid, signal.SIGKILL)
            except OSError:
                pass


def run_measured(cmd, timeout=None):
    """Runs cmd; returns (stdout, stderr, exit status, wall seconds, peak RSS bytes or None).

    The peak RSS comes from GNU time, not from our own wait4: a child forked from this Python process
    inherits its high-water mark (numpy, matplotlib, OpenImageIO: 150 MB) before it execs voxlab,
    and ru_maxrss keeps that. GNU time forks voxlab from a small process. Output goes through
    temporary files, not pipes, so a chatty child never blocks on a full pipe. Each child gets its
    own process group so that a timeout (status -SIGKILL) or an interrupted script can kill
    voxlab and not just the time wrapper."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err, \
            tempfile.NamedTemporaryFile(mode="r", suffix=".rss") as rss_file:
        timed = os.access(GNU_TIME, os.X_OK)
        full = [GNU_TIME, "-f", "%M", "-o", rss_file.name, *cmd] if timed else list(cmd)
        t0 = time.monotonic()
        p = subprocess.Popen(full, stdout=out, stderr=err, stdin=subprocess.DEVNULL, start_new_session=True)
        with _running_lock:
            _running.add(p.pid)
        killed = []

        def kill():
            killed.append(True)
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except OSError:
                pass

        timer = threading.Timer(timeout, kill) if timeout else None
        if timer:
            timer.start()
        try:
            rc = p.wait()
        finally:
            if timer:
                timer.cancel()
            with _running_lock:
                _running.discard(p.pid)
        wall = time.monotonic() - t0
        lines = rss_file.read().split("\n") if timed else []
        rss = None
        for line in lines:
            if line.strip().isdigit():
                rss = int(line) * 1024  # kilobytes
            m = re.match(r"Command terminated by signal (\d+)", line)
            if m:
                rc = -int(m[1])  # GNU time reports the child's signal as 128 + N; say it like Popen
        if killed:
            rc = -signal.SIGKILL
        out.seek(0)
        err.seek(0)
        return out.read().decode(errors="replace"), err.read().decode(errors="replace"), rc, wall, rss


def _write_json(path, obj):
    tmp = f"{path}.tmp.{os.getpid()}.{threading.get_ident()}"
    with open(tmp, "w") as f:
        f.write(json.dumps(obj, indent=1, allow_nan=False, default=str) + "\n")
    os.replace(tmp, path)


def complete(spec):
    """The job's record if its cache entry is complete (same key, every output present, at least as
    many timing repeats as asked), else None."""
    try:
        with open(os.path.join(spec["dir"], "job.json")) as f:
            rec = json.load(f)
    except (OSError, ValueError):
        return None
    if rec.get("key") != spec["key"] or not all(os.path.isfile(os.path.join(spec["dir"], o))
                                                for o in rec.get("outputs", [])):
        return None
    if spec.get("repeats", 1) > len((rec.get("timing") or {}).get("runs", [None])):
        return None  # fewer repeats than asked: re-time it
    return rec


def _fill(cmd, tmp, threads):
    return [str(a).replace("{tmp}", tmp).replace("{threads}", str(threads)) for a in cmd]


def read_exr(path):
    # Imported here: a compare job (and a bake) needs neither numpy nor OpenImageIO.
    import numpy as np
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise OSError(f"cannot read {path}: {oiio.geterror()}")
    px = np.asarray(inp.read_image(oiio.FLOAT), dtype=np.float64)
    inp.close()
    return px


def srgb8(linear):
    """Linear RGB -> 8-bit sRGB, the same curve and rounding as voxlab's PNG writer
    (image_linear_to_srgb8), so previews match `voxlab ... -o x.png`."""
    import numpy as np

    x = np.nan_to_num(linear[..., :3], nan=0.0)
    x = np.clip(x, 0.0, 1.0)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    return np.floor(s * 255.0 + 0.5).astype(np.uint8)


def exr_to_png(exr, png):
    from PIL import Image

    tmp = f"{png}.tmp.{os.getpid()}.{threading.get_ident()}"
    Image.fromarray(srgb8(read_exr(exr)), "RGB").save(tmp, format="PNG")
    os.replace(tmp, png)


def _fail_message(kind, rc, wall, timeout, err):
    why = (f"killed by {signal.Signals(-rc).name}" if rc < 0 and -rc in signal.valid_signals()
           else f"exit status {rc}")
    if rc == -signal.SIGKILL and timeout and wall >= timeout * 0.99:
        why = f"timed out after {timeout:.0f} s"
    msg = err.strip().splitlines()
    return f"voxlab {kind} {why}: " + (msg[-1] if msg else "(no message)")


def _run_repeats(spec, tmp, threads, repeats, stats_files):
    """Runs spec's command `repeats` times (the first into tmp, the others into scratch folders);
    returns (stdout of the first, walls, peak RSS, {stats file: [timing field per run]})."""
    runs = {f: [] for f in stats_files}
    walls, rss_max, out = [], None, ""
    for i in range(repeats):
        where = tmp if i == 0 else os.path.join(tmp, f".repeat{i}")
        os.makedirs(where, exist_ok=True)
        cmd = _fill(spec["cmd"], where, threads)
        out_i, err, rc, wall, rss = run_measured(cmd, spec.get("timeout"))
        if rc != 0:
            raise JobFailed(_fail_message(spec["kind"], rc, wall, spec.get("timeout"), err), " ".join(cmd),
                            err.strip())
        if i == 0:
            out = out_i
        walls.append(wall)
        rss_max = rss if rss_max is None else max(rss_max, rss or 0)
        if spec.get("timing_field"):
            for name in stats_files:
                with open(os.path.join(where, name)) as f:
                    runs[name].append(float(json.load(f)[spec["timing_field"]]))
        if i:
            shutil.rmtree(where, ignore_errors=True)
    return out, walls, rss_max, runs


def _record(spec, run_spec, threads, walls, rss_max, runs, timing, started_at, load_before, load_after):
    """job.json of spec, run by run_spec's command (the same spec, or the group it was run in)."""
    cores = os.cpu_count() or 1
    rec = {"key": spec["key"], "identity": spec["identity"], "kind": spec["kind"], "label": spec["label"],
           "inputs": spec["inputs"], "code_files": spec.get("code_files", {}),
           "command": [os.path.basename(run_spec["cmd"][0]), *_fill(run_spec["cmd"][1:], "<out>", threads)],
           "outputs": list(spec["outputs"]), "wall_seconds": walls[0], "peak_rss_bytes": rss_max, "threads": threads,
           "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"), "host": platform.node(),
           "voxlab_sha256": spec.get("voxlab_sha256"), "executor": spec.get("executor", "local"),
           "timed": timing, "started_at": started_at, "finished_at": time.time(), "cores": cores,
           "load_average": load_before, "load_after": load_after,
           # The 1-minute average includes our own job (at most `threads` runnable): above the
           # core count, something else was competing for the cores while we measured.
           "loaded": max(load_before, load_after) > cores}
    if runs:
        rec["timing"] = {"field": run_spec["timing_field"], "runs": runs, "min": min(runs),
                         "median": statistics.median(runs), "spread": max(runs) - min(runs)}
    return rec


def _tmp_for(job_dir):
    return f"{job_dir}.tmp.{platform.node()}.{os.getpid()}.{threading.get_ident()}"


def _install(spec, tmp, rec):
    """Writes job.json into tmp (last: an entry without it is incomplete) and renames tmp into place."""
    job_dir = spec["dir"]
    _write_json(os.path.join(tmp, "job.json"), rec)
    if os.path.exists(job_dir):  # --force, or an incomplete entry: replace it
        trash = f"{job_dir}.old.{platform.node()}.{os.getpid()}.{threading.get_ident()}"
        os.rename(job_dir, trash)
        shutil.rmtree(trash, ignore_errors=True)
    try:
        os.rename(tmp, job_dir)
    except OSError:
        if complete(spec) is None:  # nobody else completed it either
            raise
        shutil.rmtree(tmp, ignore_errors=True)


def execute(spec):
    """Runs the job into a temporary directory and renames it into place when everything is written
    (job.json last), so a killed run never leaves an entry that looks complete. Returns the record
    (a group's: the list of its members' records); raises JobFailed when voxlab fails."""
    if spec.get("group"):
        return _execute_group(spec)
    job_dir = spec["dir"]
    os.makedirs(os.path.dirname(job_dir), exist_ok=True)
    tmp = _tmp_for(job_dir)
    shutil.rmtree(tmp, ignore_errors=True)
    os.makedirs(tmp)
    timed = spec.get("timed", False)
    # A timed job has the machine to itself: every core. Images do not depend on the thread count.
    threads = (os.cpu_count() or 1) if timed else spec.get("threads", 1)
    repeats = spec.get("repeats", 1) if timed else 1
    try:
        started_at = time.time()  # wall clock: tests check that no job ran beside a timed one
        load_before = os.getloadavg()[0]
        out, walls, rss_max, runs = _run_repeats(spec, tmp, threads, repeats, ["stats.json"])
        load_after = os.getloadavg()[0]
        if spec["kind"] in ("truth", "render"):
            exr_to_png(os.path.join(tmp, "image.exr"), os.path.join(tmp, "image.png"))
        elif spec["kind"] == "compare":
            _write_json(os.path.join(tmp, "metrics.json"), json.loads(out))
        rec = _record(spec, spec, threads, walls, rss_max, runs["stats.json"], timed, started_at, load_before,
                      load_after)
        _install(spec, tmp, rec)
        return rec
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def _execute_group(spec):
    """A group of bakes (see the top of this file): one run of the shared command per repeat, then
    each member's .vox and stats moved into its own entry. Every member fails together."""
    members = spec["group"]
    os.makedirs(os.path.dirname(members[0]["dir"]), exist_ok=True)
    tmp = _tmp_for(members[0]["dir"] + ".group")
    shutil.rmtree(tmp, ignore_errors=True)
    os.makedirs(tmp)
    threads = os.cpu_count() or 1  # timed, as every bake: the machine to itself
    made = []
    try:
        started_at = time.time()
        load_before = os.getloadavg()[0]
        names = [GROUP_STATS.replace("{model}", m["model"]) for m in members]
        _, walls, rss_max, runs = _run_repeats(spec, tmp, threads, spec.get("repeats", 1), names)
        load_after = os.getloadavg()[0]
        records = []
        for m, name in zip(members, names):
            mtmp = _tmp_for(m["dir"])
            shutil.rmtree(mtmp, ignore_errors=True)
            os.makedirs(mtmp)
            made.append(mtmp)
            os.rename(os.path.join(tmp, GROUP_VOX.replace("{model}", m["model"])), os.path.join(mtmp, "model.vox"))
            os.rename(os.path.join(tmp, name), os.path.join(mtmp, "stats.json"))
            rec = _record(m, spec, threads, walls, rss_max, runs[name], True, started_at, load_before, load_after)
            rec["baked_with"] = [o["label"] for o in members if o is not m]  # one pass of the sampler
            records.append(rec)
        for m, mtmp, rec in zip(members, made, records):
            _install(m, mtmp, rec)
        return records
    except BaseException:
        for d in made:
            shutil.rmtree(d, ignore_errors=True)
        raise
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
