"""The sweep engine's scheduler: jobs keyed by their inputs, run on an executor, dependencies first.

Exists to decide what runs, where and when. A job's outputs live in a cache directory keyed by the
sha256 of everything that decides them (the scene file and every file it references, the options,
the sources of the job's code path: code_keys.py), so a second run with the same inputs does no
work, adding a model reruns only its jobs, and the expensive ground truth is computed once per
scene, size, spp and seed and shared by every experiment. Jobs run through an executor
(executors.py: this machine, Dask or SLURM; jobexec.py runs one job); a timed job (truth, bake,
render) runs alone on its machine with every core and repeats R times; the bakes of one scene,
resolution, rays and seed that are ready together run as one `voxlab bake --model a,b,...` (one pass
of the sampler, each model's own cache entry and own bake time); progress for the whole sweep
(done / total, elapsed, estimate) goes to stderr; a failing job is recorded (status "failed" and
voxlab's message) and never aborts the sweep.
"""
import hashlib
import os
import shutil
import subprocess
import sys
import threading
import time

import code_keys
import executors
import jobexec

from .errors import VoxlabError
from .files import load_json, write_json
from .hashing import file_sha256, sha256_of
from .jobs import kill_running, metric_names, models_info, run_measured
from .provenance import git_info, now_iso
from .report import fmt_duration
from .scenes import scene_fingerprint
from .schema import slug



TIMED_KINDS = ("truth", "bake", "render")  # their times enter tables and plots: measured alone
TIMING_FIELD = {"truth": "seconds", "bake": "bake_seconds", "render": "seconds"}  # in voxlab's --stats
BAKE_MAX_MODELS = 16  # the most models `voxlab bake --model a,b,...` takes (tracer/bake/bake.h)


class Job:
    """One voxlab invocation whose outputs live in a cache directory named by its inputs' hash.

    key: sha256 of everything that decides the outputs (kind, options, scene fingerprint, the code
    path's sources, the keys of the jobs it reads). identity: the same without the code and with the
    dependencies' identities: an entry with this identity and another key is an invalidated one."""

    def __init__(self, kind, label, inputs, deps, cost, calib, code):
        self.kind, self.label, self.inputs, self.deps = kind, label, inputs, deps
        self.code_hash, self.code_files = code[0], code[1]
        ids = {d.key: d.identity for d in deps}
        public = {k: ids.get(v, v) if isinstance(v, str) else v for k, v in inputs.items() if not k.startswith("_")}
        self.identity = sha256_of({"kind": kind, **public})
        self.key = sha256_of({"kind": kind, "code": self.code_hash, **{k: v for k, v in inputs.items()
                                                                        if not k.startswith("_")}})
        self.cost, self.calib = cost, calib  # estimated work and the group whose speed predicts it
        self.timed = kind in TIMED_KINDS
        self.repeats = 1
        self.dir = None
        self.status = "pending"  # pending | cached | ok | failed | skipped
        self.error = None
        self.record = None  # job.json
        self.ran = False

    def path(self, name):
        return os.path.join(self.dir, name)

    def timing(self):
        """{runs, min, median, spread} of the job's timed runs (seconds), else None."""
        return (self.record or {}).get("timing")


class Progress:
    """Done / total, elapsed and an estimate for the jobs that have to run. The estimate scales each
    job's predicted work (pixels x samples, voxels x rays) by the measured speed of finished jobs of
    the same kind and model, so a few slow vmesh bakes do not make the compares look slow."""

    def __init__(self, name, jobs, workers, machines=1):
        self.name, self.jobs, self.workers, self.machines = name, jobs, workers, machines
        self.total, self.done, self.failed = len(jobs), 0, 0
        self.start = time.monotonic()
        self.lock = threading.Lock()
        self.speed = {}  # calibration group -> [seconds, cost]
        self.timed = [0.0, 0]  # seconds and count of every finished job

    def _estimate(self, job):
        """Predicted seconds: the job's work times the speed of its group, else of its kind, else
        the mean time of any finished job (work units differ between kinds)."""
        for g in (job.calib, job.kind):
            s = self.speed.get(g)
            if s and s[1] > 0:
                return s[0] / s[1] * job.cost
        if self.timed[1]:
            return self.timed[0] / self.timed[1]
        return None

    def finished(self, job, seconds, msg):
        with self.lock:
            self.done += 1
            if job.status == "failed":
                self.failed += 1
            elif seconds is not None:
                self.timed[0] += seconds
                self.timed[1] += 1
                for g in (job.calib, job.kind):
                    s = self.speed.setdefault(g, [0.0, 0.0])
                    s[0] += seconds
                    s[1] += job.cost
            left = [j for j in self.jobs if j.status == "pending"]
            est = [self._estimate(j) for j in left]
            if left and all(e is not None for e in est):
                # Timed jobs run one at a time per machine; untimed ones share the slots.
                timed = sum(e for j, e in zip(left, est) if j.timed) / max(1, self.machines)
                eta = f"~{fmt_duration(timed + sum(e for j, e in zip(left, est) if not j.timed) / self.workers)} left"
            else:
                eta = "done" if not left else "estimating"
            elapsed = fmt_duration(time.monotonic() - self.start)
            print(f"{self.name}: [{self.done}/{self.total}] {elapsed} elapsed, {eta} | {msg}", file=sys.stderr,
                  flush=True)


class Sweep:
    """Jobs keyed by their inputs; run() executes those without a complete cache entry.

    voxlab is snapshotted into <cache>/bin/<sha256>/ first (with its OpenImageIO plugin, which it
    loads from beside itself): colleagues rebuild build/voxlab all day, and one sweep must not mix two
    binaries, nor hash one binary and run another."""

    def __init__(self, voxlab, cache_dir, jobs=2, fresh=False, name="sweep", timeout=1800, executor="local",
                 scheduler=None, slurm_args="", repeats=None, group_bakes=True):
        self.cache_dir = os.path.abspath(cache_dir)
        # Bakes that differ only by model share one pass of the sampler (issue 15: bakes were 84 % of
        # table1's CPU time, and every model reads the same sample rays).
        self.group_bakes = group_bakes
        self.jobs = max(1, jobs)
        # Untimed jobs (compares) run with one thread; a timed job has its machine to itself and
        # every core of it (jobexec).
        self.threads = os.cpu_count() or 1
        self.fresh, self.name, self.timeout = fresh, name, timeout
        self.repeats_override = repeats
        self.executor_name, self.scheduler, self.slurm_args = executor, scheduler, slurm_args
        self.executor = None  # made on the first run(): a Dask client connects then
        self.source = None
        stale = code_keys.newer_sources(os.path.abspath(voxlab))
        if stale:
            # The keys hash the sources: a binary older than them would file its outputs under code it
            # does not contain.
            raise VoxlabError(f"--voxlab {voxlab} is older than {len(stale)} source file(s) ({', '.join(stale[:3])}"
                              f"{', ...' if len(stale) > 3 else ''}): run `make` first")
        self.voxlab, self.voxlab_sha256 = self._snapshot(os.path.abspath(voxlab))
        # In every key: an -O0 or sanitizer build's timings are filed apart from an -O3 build's.
        self.build = code_keys.binary_build(self.voxlab)
        self.models = models_info(self.voxlab)
        self.metrics = metric_names(self.voxlab)  # the columns `compare --json` fills
        self.all = {}  # key -> Job
        self.invalidated = []  # [{kind, label, changed}] reported by run()
        self.legacy_entries = 0
        self.baseline_rss = None

    def _read_source(self, dest):
        try:
            self.source = load_json(os.path.join(dest, "source.json"))
        except (OSError, ValueError):
            self.source = None

    def _snapshot(self, voxlab):
        if not os.access(voxlab, os.X_OK):
            raise VoxlabError(f"--voxlab {voxlab}: not an executable (run `make` first)")
        plugin = os.path.join(os.path.dirname(voxlab), "libvoxlab_oiio.so")
        for attempt in range(3):
            h = hashlib.sha256(file_sha256(voxlab).encode())
            if os.path.isfile(plugin):
                h.update(file_sha256(plugin).encode())
            digest = h.hexdigest()
            dest = os.path.join(self.cache_dir, "bin", digest[:16])
            exe = os.path.join(dest, "voxlab")
            if os.path.isfile(exe) and os.path.isfile(os.path.join(dest, ".complete")):
                self._read_source(dest)
                return exe, digest
            tmp = f"{dest}.tmp.{os.getpid()}"
            shutil.rmtree(tmp, ignore_errors=True)
            os.makedirs(tmp)
            shutil.copy2(voxlab, os.path.join(tmp, "voxlab"))
            if os.path.isfile(plugin):
                shutil.copy2(plugin, os.path.join(tmp, "libvoxlab_oiio.so"))
            # A binary copied while the linker was writing it would not match its hash (or not run).
            same = file_sha256(os.path.join(tmp, "voxlab")) == file_sha256(voxlab)
            ok = same and subprocess.run([os.path.join(tmp, "voxlab"), "models"], capture_output=True).returncode == 0
            if ok:
                # Which checkout the binary was built from, as far as we can tell: the cache may keep
                # using this snapshot after the tree has moved on.
                write_json(os.path.join(tmp, "source.json"), {"git": git_info(), "snapshot_date": now_iso(),
                                                              "from": voxlab})
                open(os.path.join(tmp, ".complete"), "w").close()
                try:
                    os.rename(tmp, dest)
                except OSError:  # another run made the same snapshot meanwhile
                    shutil.rmtree(tmp, ignore_errors=True)
                self._read_source(dest)
                return exe, digest
            shutil.rmtree(tmp, ignore_errors=True)
            time.sleep(2)
        raise VoxlabError(f"{voxlab} keeps changing or does not run `voxlab models` (is a build in progress?)")

    # -- job constructors --------------------------------------------------------------------------

    def _job(self, kind, label, inputs, deps, cost, calib, model=None):
        j = Job(kind, label, inputs, deps, cost, calib, code_keys.code_key(kind, model, self.build))
        if j.key in self.all:
            return self.all[j.key]
        j.dir = os.path.join(self.cache_dir, kind, f"{slug(label)[:80]}-{j.key[:16]}")
        self.all[j.key] = j
        return j

    def truth(self, scene_path, scene_name, size, spp, seed, shadows="march"):
        w, h = size
        # The method is always an input and always passed (_command): a scene may declare its own
        # ("shadows": {"method"}), which an unstated march would have left in force under a row that
        # says march.
        return self._job("truth", f"{scene_name}-{w}x{h}-spp{spp}-seed{seed}{'' if shadows == 'march' else '-' + shadows}",
                         {"scene": scene_fingerprint(scene_path), "size": [w, h], "spp": spp, "seed": seed,
                          "shadows": shadows, "_scene_path": scene_path, "_scene_name": scene_name},
                         [], w * h * spp, ("truth", scene_name))

    def bake(self, scene_path, scene_name, model, res, rays, seed):
        return self._job("bake", f"{scene_name}-{model}-r{res}-k{rays}-seed{seed}",
                         {"scene": scene_fingerprint(scene_path, for_bake=True), "model": model, "res": res,
                          "rays": rays, "seed": seed, "_scene_path": scene_path, "_scene_name": scene_name},
                         [], res * res * rays, ("bake", model), model)

    def render(self, bake, scene_path, scene_name, size, spp, seed, cache, shadow_skip, shadows="march"):
        w, h = size
        b = bake.inputs
        return self._job("render", f"{scene_name}-{b['model']}-r{b['res']}-{w}x{h}-spp{spp}"
                                   f"{'' if cache else '-nocache'}{'' if shadow_skip else '-noskip'}"
                                   f"{'' if shadows == 'march' else '-' + shadows}",
                         {"bake": bake.key, "scene": scene_fingerprint(scene_path), "size": [w, h], "spp": spp,
                          "seed": seed, "cache": cache, "shadow_skip": shadow_skip, "shadows": shadows,  # as in truth()
                          "_scene_path": scene_path,
                          "_scene_name": scene_name, "_model": b["model"], "_res": b["res"]},
                         [bake], w * h * spp, ("render", b["model"]), b["model"])

    def compare(self, ref, img):
        # A compare's time is mostly voxlab starting and reading two files: one unit each.
        return self._job("compare", f"{img.label}-vs-{ref.label}", {"ref": ref.key, "image": img.key}, [ref, img],
                         1, ("compare",))

    # -- execution ---------------------------------------------------------------------------------

    def _command(self, job):
        """voxlab's arguments; "{tmp}" is the job's output folder and "{threads}" its thread count,
        both filled in where the job runs (jobexec)."""
        i = job.inputs
        out, stats = "{tmp}/image.exr", "{tmp}/stats.json"
        t = ["--threads", "{threads}"]
        if job.kind == "truth":
            w, h = i["size"]
            return ["truth", i["_scene_path"], "--spp", i["spp"], "--size", f"{w}x{h}", "--seed", i["seed"], *t,
                    "--shadows", i["shadows"], "-o", out, "--stats", stats]
        if job.kind == "bake":
            return self._bake_command(i, [i["model"]], "{tmp}/model.vox", stats)
        if job.kind == "render":
            w, h = i["size"]
            return ["render", i["_scene_path"], "--model", i["_model"], "--vox", job.deps[0].path("model.vox"),
                    "--spp", i["spp"], "--size", f"{w}x{h}", "--seed", i["seed"], *t,
                    *([] if i["cache"] else ["--no-cache"]), *([] if i["shadow_skip"] else ["--no-shadow-skip"]),
                    "--shadows", i["shadows"], "-o", out, "--stats", stats]
        if job.kind == "compare":
            # No --heatmap: it costs `voxlab compare` as much again as the metrics, and the figures
            # draw their own heat maps on one scale per scene (voxlab scales each to its own maximum).
            return ["compare", job.deps[0].path("image.exr"), job.deps[1].path("image.exr"), "--json"]
        raise AssertionError(job.kind)

    def spec(self, job):
        """The plain dict an executor hands to jobexec.execute (see there)."""
        outputs = {"truth": ["image.exr", "image.png", "stats.json"], "render": ["image.exr", "image.png", "stats.json"],
                   "bake": ["model.vox", "stats.json"], "compare": ["metrics.json"]}[job.kind]
        return {"key": job.key, "identity": job.identity, "kind": job.kind, "label": job.label, "dir": job.dir,
                "cmd": [self.voxlab, *map(str, self._command(job))], "outputs": outputs, "timed": job.timed,
                "repeats": job.repeats if job.timed else 1, "timing_field": TIMING_FIELD.get(job.kind),
                "threads": 1, "timeout": self.timeout, "code_files": job.code_files,
                "inputs": {k: v for k, v in job.inputs.items() if not k.startswith("_")},
                "voxlab_sha256": self.voxlab_sha256, "executor": self.executor_name,
                **({"model": job.inputs["model"]} if job.kind == "bake" else {})}

    @staticmethod
    def _bake_command(i, models, vox, stats):
        """`voxlab bake` of the bake inputs i for these models, into vox and stats (with {model} in
        them when there are several)."""
        return ["bake", i["_scene_path"], "--model", ",".join(models), "--res", i["res"], "--rays", i["rays"],
                "--seed", i["seed"], "--threads", "{threads}", "-o", vox, "--stats", stats]

    def _bake_group_key(self, job):
        i = job.inputs
        return (i["scene"], i["_scene_path"], i["res"], i["rays"], i["seed"])

    def units(self, ready):
        """The ready jobs as the lists that run together, in `ready`'s order: a bake with the other
        ready bakes of its scene, resolution, rays and seed (at most BAKE_MAX_MODELS to a pass), every
        other job alone."""
        out, bakes = [], {}
        for j in ready:
            if not (self.group_bakes and j.kind == "bake"):
                out.append([j])
                continue
            key = self._bake_group_key(j)
            unit = bakes.get(key)
            if unit is not None and len(unit) < BAKE_MAX_MODELS:
                unit.append(j)
            else:
                bakes[key] = unit = [j]
                out.append(unit)
        return out

    def unit_spec(self, unit):
        """A unit's spec: the job's own, or for several bakes one `voxlab bake --model a,b,...` whose
        outputs jobexec moves into each member's entry."""
        if len(unit) == 1:
            return self.spec(unit[0])
        members = [self.spec(j) for j in unit]
        cmd = self._bake_command(unit[0].inputs, [j.inputs["model"] for j in unit], f"{{tmp}}/{jobexec.GROUP_VOX}",
                                 f"{{tmp}}/{jobexec.GROUP_STATS}")
        return {**members[0], "key": sha256_of([m["key"] for m in members]),
                "label": f"{len(unit)} bakes in one pass: {', '.join(j.label for j in unit)}",
                "cmd": [self.voxlab, *map(str, cmd)], "repeats": max(j.repeats for j in unit), "group": members}

    def _complete(self, job):
        return jobexec.complete({"dir": job.dir, "key": job.key, "repeats": job.repeats if job.timed else 1})

    def _invalidated(self, todo):
        """Cache entries of the jobs about to run that have the same identity (kind, options, scene,
        dependencies) and another key: their code changed. Returns [{kind, label, changed}]."""
        by_kind = {}
        out = []
        for j in todo:
            entries = by_kind.setdefault(j.kind, None)
            if entries is None:
                entries = {}
                try:
                    names = os.listdir(os.path.join(self.cache_dir, j.kind))
                except OSError:
                    names = []
                for n in names:
                    if ".tmp." not in n and ".old." not in n and "-" in n:
                        entries.setdefault(n.rsplit("-", 1)[0], []).append(n)
                by_kind[j.kind] = entries
            for n in entries.get(slug(j.label)[:80], []):
                if n == os.path.basename(j.dir):
                    continue
                try:
                    rec = load_json(os.path.join(self.cache_dir, j.kind, n, "job.json"))
                except (OSError, ValueError):
                    continue
                if "identity" not in rec and rec.get("key") != j.key:
                    self.legacy_entries += 1  # keyed by the whole binary (before code_keys.py)
                if rec.get("identity") == j.identity and rec.get("key") != j.key:
                    changed = code_keys.changed_files(rec.get("code_files", {}), j.code_files)
                    redo = sorted({d.kind for d in j.deps if d.status == "pending"})
                    out.append({"kind": j.kind, "label": j.label, "entry": n, "changed": changed,
                                "reason": f"{', '.join(changed[:4])}{' and more' if len(changed) > 4 else ''} "
                                          f"changed" if changed else
                                          f"its input {' and '.join(redo) or 'job'} is recomputed"})
        return out

    def _report_invalidated(self, inv):
        if self.legacy_entries:
            print(f"{self.name}: {self.legacy_entries} cache entr(ies) keyed by the whole voxlab binary (an older "
                  f"version of this script) are not reused", file=sys.stderr, flush=True)
            self.legacy_entries = 0
        groups = {}
        for x in inv:
            groups.setdefault((x["kind"], x["reason"]), []).append(x["label"])
        for (kind, reason), labels in groups.items():
            jobs = list(dict.fromkeys(labels))  # a job may have entries from several older versions
            entries = f"{len(labels)} cached entries of " if len(labels) > len(jobs) else ""
            print(f"{self.name}: invalidated {entries}{len(jobs)} cached {kind} job(s) ({', '.join(jobs[:3])}"
                  f"{', ...' if len(jobs) > 3 else ''}): {reason}", file=sys.stderr, flush=True)

    def _place(self, job, places, busy, draining):
        """Where a ready job may start now, or None. A timed job needs a place where nothing runs;
        an untimed one a free slot on a place that runs no timed job and is not being emptied for
        one."""
        if not self.executor.exclusive_by_sweep:
            return next(iter(places))
        free = [p for p, n in places.items() if not busy[p]["timed"] and len(busy[p]["jobs"]) < n]
        if job.timed:
            free = [p for p in free if not busy[p]["jobs"]]
        else:
            free = [p for p in free if p not in draining]
        return min(free, key=lambda p: len(busy[p]["jobs"])) if free else None

    def run(self, wanted):
        """Runs every job `wanted` needs (dependencies first) on the executor. Returns the counts.
        Failures are recorded on the jobs (status, error) and skip their dependants."""
        order, seen = [], set()

        def visit(j):
            if j.key in seen:
                return
            seen.add(j.key)
            for d in j.deps:
                visit(d)
            order.append(j)

        for j in wanted:
            visit(j)
        todo = []
        for j in order:
            if j.status != "pending":
                continue
            rec = None if self.fresh and not j.ran else self._complete(j)
            if rec is not None:
                j.status, j.record = "cached", rec
            else:
                todo.append(j)
        # A compare or render whose inputs are all cached still runs if its own entry is missing.
        os.makedirs(self.cache_dir, exist_ok=True)
        inv = self._invalidated(todo)
        self.invalidated += inv
        self._report_invalidated(inv)
        if self.executor is None:
            self.executor = executors.make_executor(self.executor_name, jobs=self.jobs, scheduler=self.scheduler,
                                                    slurm_args=self.slurm_args, cache_dir=self.cache_dir)
        ex = self.executor
        places = ex.places()
        slots = sum(places.values()) if ex.exclusive_by_sweep else len(todo) or 1
        print(f"{self.name}: {len(todo)} job(s) to run, {len(order) - len(todo)} cached; executor {ex.name} "
              f"({', '.join(f'{p}: {n}' for p, n in places.items()) if ex.exclusive_by_sweep else 'SLURM places'}); "
              f"timed jobs alone on their machine, all its cores; voxlab sha256 {self.voxlab_sha256[:12]}",
              file=sys.stderr, flush=True)
        prog = Progress(self.name, todo, slots, len(places) if ex.exclusive_by_sweep else slots)
        pending = list(todo)
        running = {}  # future -> (job, place)
        busy = {p: {"jobs": set(), "timed": False} for p in places}
        try:
            while pending or running:
                # Skip what can no longer run; start the costliest ready jobs (bakes gate renders).
                for j in list(pending):
                    bad = [d for d in j.deps if d.status in ("failed", "skipped")]
                    if bad:
                        j.status = "skipped"
                        j.error = bad[0].error or f"{bad[0].kind} failed"
                        pending.remove(j)
                        prog.finished(j, None, f"skipped {j.kind} {j.label}: needs {bad[0].kind} {bad[0].label}")
                ready = sorted((j for j in pending if all(d.status in ("ok", "cached") for d in j.deps)),
                               key=lambda j: -j.cost)
                if ex.exclusive_by_sweep:
                    draining = set()
                    for unit in self.units(ready):
                        j = unit[0]
                        p = self._place(j, places, busy, draining)
                        if p is None:
                            if j.timed and not draining:
                                # Empty the least busy place for it: nothing new starts there.
                                draining.add(min(places, key=lambda q: len(busy[q]["jobs"])))
                            continue
                        for u in unit:
                            pending.remove(u)
                        busy[p]["jobs"].add(j.key)
                        busy[p]["timed"] = busy[p]["timed"] or j.timed
                        running[ex.submit(self.unit_spec(unit), p)] = (unit, p)
                elif ready:  # SLURM: one array per kind and timing class; --exclusive for the timed
                    groups = {}
                    for unit in self.units(ready):
                        groups.setdefault((unit[0].kind, unit[0].timed), []).append(unit)
                    for (kind, timed), us in groups.items():
                        for unit, f in zip(us, ex.submit_batch([self.unit_spec(u) for u in us], exclusive=timed)):
                            for u in unit:
                                pending.remove(u)
                            running[f] = (unit, "slurm")
                if not running:
                    if pending:  # cannot happen with a dependency-ordered list; never spin
                        raise AssertionError(f"jobs stuck: {[j.label for j in pending]}")
                    continue
                for f in ex.wait(list(running)):
                    unit, p = running.pop(f)
                    if p in busy:
                        busy[p]["jobs"].discard(unit[0].key)
                        if unit[0].timed:
                            busy[p]["timed"] = False
                    try:
                        result = f.result()
                        records = result if len(unit) > 1 else [result]
                        if len(records) != len(unit):
                            raise AssertionError(f"{len(records)} records for {len(unit)} jobs")
                    except (VoxlabError, jobexec.JobFailed) as e:
                        detail = f"\n    command: {e.args[1]}\n    " + e.args[2].replace("\n", "\n    ") \
                            if len(e.args) > 2 else ""
                        self._failed(unit, str(e.args[0]), detail, prog)
                        continue
                    except Exception as e:  # a broken image or stats file, a lost worker: this job's failure
                        self._failed(unit, f"{type(e).__name__}: {e}", "", prog)
                        continue
                    own = [(r.get("timing") or {}).get("median") or 0.0 for r in records]
                    shares = {j.key: (o / sum(own) if sum(own) > 0 else 1.0 / len(unit)) for j, o in zip(unit, own)}
                    for j, rec in zip(unit, records):
                        j.ran = True
                        j.record = rec
                        wall = rec["wall_seconds"]
                        j.status = "ok"
                        t = j.timing()
                        shown = (f"median {t['median']:.3g} s of {len(t['runs'])}, spread {t['spread']:.2g} s"
                                 if t else f"{wall:.1f} s")
                        flag = f"; LOAD {rec['load_average']:.1f} > {rec['cores']} cores" \
                            if rec.get("loaded") and j.timed else ""
                        shared = f"; one pass with {len(unit) - 1} other model(s)" if len(unit) > 1 else ""
                        # The estimate's speeds: a shared pass's wall time split between its jobs in
                        # the proportions of their own times (so it is counted once).
                        ran = wall * (len(t["runs"]) if t else 1) * shares[j.key]
                        prog.finished(j, ran, f"{j.kind} {j.label} ({shown}{flag}{shared})")
        except BaseException:
            # Interrupted (Ctrl-C) or broken: the children run in their own sessions and would
            # otherwise go on rendering after we exit.
            kill_running()
            raise
        failed = sum(j.status in ("failed", "skipped") for j in todo)
        return {"jobs": len(order), "ran": sum(j.ran for j in todo), "cached": len(order) - len(todo),
                "failed": failed, "invalidated": len(inv), "seconds": time.monotonic() - prog.start}

    @staticmethod
    def _failed(unit, error, detail, prog):
        for j in unit:
            j.ran = True
            j.status, j.error = "failed", error
            prog.finished(j, None, f"FAILED {j.kind} {j.label}: {j.error}{detail}")

    def close(self):
        if self.executor is not None:
            self.executor.close()
            self.executor = None

    def baseline_memory(self):
        """Peak RSS of a voxlab process that loads no scene (`voxlab models`): subtracted from the
        truth's peak RSS to estimate the memory of the triangle representation."""
        if self.baseline_rss is None:
            self.baseline_rss = run_measured([self.voxlab, "models"])[4]
        return self.baseline_rss
