"""Shared pieces of the experiment scripts: running voxlab, images, atomic files, and the sweep engine.

    from voxlab_runner import ...      (the scripts in experiments/ put this directory on sys.path)

Three layers:

1. Utilities, factored out of compare_models.py: run_voxlab, list_models, read_exr, exr_to_png,
   atomic_write / write_text / write_json, git and machine descriptions, make_strip.
2. Declarations (load_declaration): an experiment is a JSON file in experiments/ naming scenes
   (or scene variants), models, resolutions and render parameters; it is checked field by field
   and a bad field is a DeclarationError that names the file and the field.
3. The sweep engine (Sweep, run_experiment): the declared configurations become truth / bake /
   render / compare jobs; each job's outputs live in a cache directory keyed by the sha256 of
   everything that decides them (the scene file and every file it references, the options, the
   sources of the job's code path: code_keys.py), so a second run with the same inputs does no work,
   adding a model reruns only its jobs, and the expensive ground truth is computed once per scene,
   size, spp and seed and shared by every experiment. Jobs run through an executor (executors.py:
   this machine, Dask or SLURM; jobexec.py runs one job); a timed job (truth, bake, render) runs
   alone on its machine with every core and repeats R times; progress for the whole sweep (done /
   total, elapsed, estimate) goes to stderr; a failing job is recorded in its rows (status "failed"
   and voxlab's message) and never aborts the sweep.
"""
import csv
import datetime
import fcntl
import hashlib
import io
import itertools
import json
import math
import os
import platform
import re
import shutil
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import code_keys  # noqa: E402
import executors  # noqa: E402
import jobexec  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SEED = 1
DEFAULT_RESULTS = os.path.join(REPO, "results")
PYTHON = "/usr/bin/python3"


class VoxlabError(Exception):
    pass


class DeclarationError(VoxlabError):
    """A declared experiment that cannot be run as written (the message names the file and field)."""


# ----------------------------------------------------------------------------------------------
# Files


def atomic_write(path, write):
    """Calls write(tmp) for a temporary name next to path (same file system), then renames."""
    tmp = f"{path}.tmp.{os.getpid()}.{threading.get_ident()}"
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def write_text(path, text):
    def w(tmp):
        with open(tmp, "w", newline="") as f:
            f.write(text)

    atomic_write(path, w)


def write_json(path, obj):
    write_text(path, json.dumps(obj, indent=1, sort_keys=False, allow_nan=False, default=str) + "\n")


def save_png(img, path):
    atomic_write(path, lambda tmp: img.save(tmp, format="PNG"))


def save_figure(fig, path, **kw):
    """matplotlib figures too are written under a temporary name (format from path's extension)."""
    fmt = os.path.splitext(path)[1][1:]
    atomic_write(path, lambda tmp: fig.savefig(tmp, format=fmt, **kw))


def write_csv(path, rows, fields):
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=fields, lineterminator="\n", extrasaction="ignore")
    w.writeheader()
    for r in rows:
        # repr keeps every digit of a float (it round-trips to the double voxlab printed).
        w.writerow({k: ("" if v is None else repr(v) if isinstance(v, float) else v) for k, v in r.items()})
    write_text(path, buf.getvalue())


def file_sha256(path, _memo={}, _lock=threading.Lock()):
    """sha256 of a file's contents, remembered per (path, size, mtime) for the life of the process."""
    st = os.stat(path)
    key = (os.path.abspath(path), st.st_size, st.st_mtime_ns)
    with _lock:
        if key in _memo:
            return _memo[key]
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    with _lock:
        _memo[key] = h.hexdigest()
    return _memo[key]


def canonical(obj):
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def sha256_of(obj):
    return hashlib.sha256(canonical(obj).encode()).hexdigest()


# ----------------------------------------------------------------------------------------------
# voxlab


def run_voxlab(voxlab, args):
    """Runs voxlab; returns stdout, or raises VoxlabError with the command and its stderr."""
    cmd = [voxlab, *map(str, args)]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise VoxlabError(f"`{' '.join(cmd)}` exited with status {p.returncode}:\n{p.stderr.rstrip()}")
    return p.stdout


# Running a job (GNU time, process groups, timeouts) lives in jobexec, which every executor calls.
GNU_TIME = jobexec.GNU_TIME
run_measured = jobexec.run_measured
kill_running = jobexec.kill_running


def models_info(voxlab):
    """`voxlab models`: [{name, bytes_per_voxel, rule, description}] in registry order."""
    out = []
    for line in run_voxlab(voxlab, ["models"]).splitlines():
        if not line.strip():
            continue
        m = re.match(r"(\S+)\s+(\d+)\s+B/voxel\s+(\S+)\s+(.*)", line)
        if m:
            out.append({"name": m[1], "bytes_per_voxel": int(m[2]), "rule": m[3], "description": m[4].strip()})
        else:  # a format we do not know yet: the name is still the first word
            out.append({"name": line.split()[0], "bytes_per_voxel": None, "rule": "", "description": line})
    return out


def list_models(voxlab):
    return [line.split()[0] for line in run_voxlab(voxlab, ["models"]).splitlines() if line.strip()]


# ----------------------------------------------------------------------------------------------
# Images


read_exr = jobexec.read_exr
srgb8 = jobexec.srgb8
exr_to_png = jobexec.exr_to_png


def label_font(size):
    from PIL import ImageFont

    try:  # matplotlib ships DejaVu Sans, so this works wherever the script's dependencies are installed
        from matplotlib import font_manager

        return ImageFont.truetype(font_manager.findfont("DejaVu Sans"), size)
    except Exception:
        return ImageFont.load_default()


def make_strip(tiles, size, path):
    """tiles: [(title, subtitle, PIL image size x size)]; one column each, labels in a band above.
    Each label shrinks until it fits its column and is clipped to it, so narrow strips (32 px
    columns) stay legible instead of running labels into each other."""
    from PIL import Image, ImageDraw

    font_px = max(8, min(13, size // 6))
    band = 2 * font_px + 6
    strip = Image.new("RGB", (size * len(tiles), band + size), (255, 255, 255))
    fonts = {}
    for i, (title, subtitle, img) in enumerate(tiles):
        label = Image.new("RGB", (size, band), (255, 255, 255))
        draw = ImageDraw.Draw(label)
        for row, (text, colour) in enumerate([(title, (0, 0, 0)), (subtitle, (70, 70, 70))]):
            px = font_px
            while True:
                font = fonts.setdefault(px, label_font(px))
                if px <= 6 or draw.textlength(text, font=font) <= size - 3:
                    break
                px -= 1
            draw.text((2, 2 + row * (font_px + 2)), text, fill=colour, font=font)
        if i:
            draw.line([(0, 0), (0, band - 1)], fill=(190, 190, 190))  # separators only in the label band
        strip.paste(label, (i * size, 0))
        strip.paste(img.convert("RGB").resize((size, size)), (i * size, band))
    save_png(strip, path)


# ----------------------------------------------------------------------------------------------
# Where and what we ran on


def git_commit():
    try:
        head = subprocess.run(["git", "-C", REPO, "rev-parse", "HEAD"], capture_output=True, text=True, check=True)
        # results/ is left out: runs append to results/history.csv, which must not make the next
        # run's checkout count as modified.
        dirty = subprocess.run(["git", "-C", REPO, "status", "--porcelain", "--untracked-files=no", "--", ".",
                                ":(exclude)results"], capture_output=True, text=True, check=True)
    except (OSError, subprocess.CalledProcessError):
        return "unknown (not a git checkout)"
    return head.stdout.strip() + (" (with uncommitted changes)" if dirty.stdout.strip() else "")


def git_info():
    """{"commit": 40 hex or "unknown", "dirty": bool}: tracked files differing from HEAD make it dirty."""
    s = git_commit()
    if s.startswith("unknown"):
        return {"commit": "unknown", "dirty": False, "text": s}
    return {"commit": s.split()[0], "dirty": "uncommitted" in s, "text": s}


def machine_info():
    u = platform.uname()
    cpu = ""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem = ""
    try:
        with open("/proc/meminfo") as f:
            kb = int(f.readline().split()[1])
            mem = f"{kb / 2**20:.0f} GiB"
    except (OSError, ValueError, IndexError):
        pass
    return {"host": u.node, "system": f"{u.system} {u.release} {u.machine}", "cpu": cpu, "nproc": os.cpu_count(),
            "memory": mem}


def machine_text(m):
    return f"{m['cpu'] or 'unknown CPU'}, {m['nproc']} cores, {m['memory']} RAM, {m['system']} (host {m['host']})"


def now_iso():
    return datetime.datetime.now().astimezone().isoformat(timespec="seconds")


def resolve_scene(arg, base_dir=None):
    """A scene name (scenes/<name>.json) or a path to a scene file (relative to base_dir, then cwd)."""
    for cand in ([os.path.join(base_dir, arg)] if base_dir and not os.path.isabs(arg) else []) + [arg]:
        if os.path.exists(cand) and os.path.isfile(cand):
            return os.path.abspath(cand)
    path = os.path.join(REPO, "scenes", arg + ".json")
    if os.path.exists(path):
        return path
    raise VoxlabError(f"--scene {arg}: no such file, and no scenes/{arg}.json")


def fmt_duration(s):
    if s is None or not math.isfinite(s):
        return "?"
    s = int(round(s))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


# ----------------------------------------------------------------------------------------------
# Scenes: fingerprints and variants


def _scene_file_refs(scene):
    """Yields (container, key) for every file path a scene references (PLY/glTF meshes, textures)."""
    objs = scene.get("objects") if isinstance(scene, dict) else None
    for o in objs if isinstance(objs, list) else []:
        if isinstance(o, dict):
            for k in ("ply", "gltf"):
                if isinstance(o.get(k), str):
                    yield o, k
    mats = scene.get("materials") if isinstance(scene, dict) else None
    for m in mats.values() if isinstance(mats, dict) else []:
        if isinstance(m, dict) and isinstance(m.get("texture"), str):
            yield m, "texture"


def _referenced_fingerprint(path):
    """Content hash of a referenced file; for a .gltf also of the buffers and images it names."""
    if not os.path.isfile(path):
        return "missing"
    h = file_sha256(path)
    if path.lower().endswith(".gltf"):
        try:
            with open(path) as f:
                g = json.load(f)
            extra = []
            for item in (g.get("buffers") or []) + (g.get("images") or []):
                uri = item.get("uri") if isinstance(item, dict) else None
                if isinstance(uri, str) and not uri.startswith("data:"):
                    p = os.path.join(os.path.dirname(path), uri)
                    extra.append(file_sha256(p) if os.path.isfile(p) else "missing:" + uri)
            h = sha256_of([h, extra])
        except (OSError, ValueError, AttributeError):
            pass
    return h


# The fields of a scene that the voxel bake never reads: the grid covers the triangles' bounds and the
# bake sampler's rays start outside them (tracer/bake/bake.c), and voxlab's own scene identity, which a
# .vox file must match, also leaves them out. Variants that differ only here (another camera, another
# background) share one bake.
BAKE_IRRELEVANT = ("camera", "size", "background", "description", "name")


def scene_fingerprint(path, for_bake=False):
    """sha256 of what a scene's images depend on: its JSON with each referenced file replaced by that
    file's content hash (so a variant with absolute paths hashes like its base, and an edited mesh
    changes the hash); for_bake drops the fields the bake ignores. An unparseable file hashes as its
    bytes (voxlab will report the problem when a job reads it)."""
    try:
        with open(path) as f:
            scene = json.load(f)
    except (OSError, ValueError):
        return file_sha256(path) if os.path.isfile(path) else "missing"
    if not isinstance(scene, dict):
        return file_sha256(path)
    base = os.path.dirname(os.path.abspath(path))
    for container, key in _scene_file_refs(scene):
        container[key] = "sha256:" + _referenced_fingerprint(os.path.join(base, container[key]))
    if for_bake:
        for k in BAKE_IRRELEVANT:
            scene.pop(k, None)
    return sha256_of(scene)


def _set_dotted(obj, dotted, value, where):
    keys = dotted.split(".")
    for k in keys[:-1]:
        if not isinstance(obj.get(k), dict):
            obj[k] = {}
        obj = obj[k]
    if value is None:
        obj.pop(keys[-1], None)
    else:
        obj[keys[-1]] = value


def write_variant(base_path, name, settings, out_dir):
    """Writes base_path with settings ({"camera.orbit.elevation_deg": 30, ...}; None deletes) applied
    into out_dir (named by its content, so concurrent runs write the same file) and returns its path.
    Relative file references are made absolute: paths in a scene are relative to the scene file."""
    with open(base_path) as f:
        scene = json.load(f)
    base = os.path.dirname(os.path.abspath(base_path))
    for container, key in _scene_file_refs(scene):
        container[key] = os.path.normpath(os.path.join(base, container[key]))
    for dotted, value in settings.items():
        _set_dotted(scene, dotted, value, name)
    scene["name"] = name
    text = json.dumps(scene, indent=1) + "\n"
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, f"{name}-{hashlib.sha256(text.encode()).hexdigest()[:12]}.json")
    if not os.path.exists(path):
        write_text(path, text)
    return path


# ----------------------------------------------------------------------------------------------
# Declarations

NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.+=-]*$")
RUN_DEFAULTS = {"models": "all", "size": "res", "spp": [4], "rays": [150], "cache": [True], "shadow_skip": [True]}
TOLERANCE_FIELDS = {"better", "rel", "abs", "gate"}
MAX_CONFIGS = 100000  # scene variants of one entry, or configurations of one run


class _Check:
    """Type checks that name the file and the field (runs[0].res[1]) in their message."""

    def __init__(self, path):
        self.path = path

    def fail(self, where, msg):
        raise DeclarationError(f"{self.path}: {where}: {msg}")

    @staticmethod
    def show(v):
        return json.dumps(v) if not isinstance(v, str) or len(v) < 60 else json.dumps(v[:57] + "...")

    def int_(self, v, where, lo=1, hi=None):
        if isinstance(v, bool) or not isinstance(v, int) or v < lo or (hi is not None and v > hi):
            rng = f"an integer from {lo} to {hi}" if hi is not None else ("a positive integer" if lo == 1 else
                                                                          f"an integer >= {lo}")
            self.fail(where, f"expected {rng}, got {self.show(v)}")
        return v

    def num(self, v, where, lo=0.0):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < lo:
            self.fail(where, f"expected a number >= {lo}, got {self.show(v)}")
        return v

    def bool_(self, v, where):
        if not isinstance(v, bool):
            self.fail(where, f"expected true or false, got {self.show(v)}")
        return v

    def str_(self, v, where, pattern=None):
        if not isinstance(v, str) or not v or (pattern and not pattern.match(v)):
            self.fail(where, f"expected a name (letters, digits, _ . + = -), got {self.show(v)}" if pattern
                      else f"expected a non-empty string, got {self.show(v)}")
        return v

    def list_(self, v, where, each, allow_scalar=False):
        if allow_scalar and not isinstance(v, list):
            v = [v]
        if not isinstance(v, list) or not v:
            self.fail(where, f"expected a non-empty list, got {self.show(v)}")
        out = [each(x, f"{where}[{i}]") for i, x in enumerate(v)]
        return list(dict.fromkeys(out))  # unique, in the order given

    def obj(self, v, where, known, required=()):
        if not isinstance(v, dict):
            self.fail(where, f"expected an object, got {self.show(v)}")
        for k in v:
            if k not in known:
                self.fail(f"{where}.{k}" if where else k,
                          f"unknown field (known: {', '.join(sorted(known))})")
        for k in required:
            if k not in v:
                self.fail(where or "(top level)", f"missing required field \"{k}\"")
        return v

    def size(self, v, where, allow_res=True):
        """'res' (image N x N for voxel resolution N), 'scene' (the scene's own size), N or [W, H]."""
        if v == "res" and allow_res or v == "scene":
            return v
        if isinstance(v, list) and len(v) == 2:
            return [self.int_(v[0], f"{where}[0]", 1, 16384), self.int_(v[1], f"{where}[1]", 1, 16384)]
        if isinstance(v, int) and not isinstance(v, bool):
            n = self.int_(v, where, 1, 16384)
            return [n, n]
        choices = '"res", "scene", N or [W, H]' if allow_res else '"scene", N or [W, H]'
        self.fail(where, f"expected {choices}, got {self.show(v)}")


def load_declaration(path):
    """Reads and checks an experiment declaration; returns it with defaults filled in and its scenes
    expanded (variants written into the cache later, by Sweep). See experiments/README.md."""
    path = os.path.abspath(path)
    shown = os.path.relpath(path, REPO) if path.startswith(REPO + os.sep) else path
    c = _Check(shown)
    try:
        with open(path) as f:
            d = json.load(f)
    except OSError as e:
        raise DeclarationError(f"{shown}: cannot read: {e.strerror}")
    except ValueError as e:
        raise DeclarationError(f"{shown}: not valid JSON: {e}")
    known = {"name", "description", "seed", "truth_spp", "scenes", "runs", "truth_curve", "history", "timeout_s",
             "tolerances", "figure", "comment", "repeats", "bake_repeats"}
    c.obj(d, "", known, required=("name", "scenes", "runs"))
    decl = {
        "path": path,
        "shown": shown,
        "name": c.str_(d["name"], "name", NAME_RE),
        "description": d.get("description", ""),
        "seed": c.int_(d.get("seed", SEED), "seed", 0),
        "truth_spp": c.int_(d.get("truth_spp", 1024), "truth_spp", 1, 1 << 20),
        "history": c.bool_(d.get("history", False), "history"),
        "timeout_s": c.num(d.get("timeout_s", 1800), "timeout_s", 1),
        "repeats": c.int_(d.get("repeats", 5), "repeats", 1, 100),  # timed truth and render runs
        "bake_repeats": c.int_(d.get("bake_repeats", 1), "bake_repeats", 1, 100),
        "figure": d.get("figure", {}),
        "raw": d,
    }
    if not isinstance(decl["description"], str):
        c.fail("description", "expected a string")
    if not isinstance(decl["figure"], dict):
        c.fail("figure", "expected an object")
    base_dir = os.path.dirname(path)

    def scene_entry(v, where):
        if isinstance(v, str):
            try:
                p = resolve_scene(v, base_dir)
            except VoxlabError:
                c.fail(where, f"no scene file {v} (relative to the declaration) and no scenes/{v}.json")
            return [{"name": os.path.splitext(os.path.basename(p))[0], "path": p, "base": None, "set": {},
                     "vary": {}}]
        c.obj(v, where, {"base", "name", "set", "vary"}, required=("base",))
        c.str_(v["base"], f"{where}.base")
        try:
            base = resolve_scene(v["base"], base_dir)
        except VoxlabError:
            c.fail(f"{where}.base", f"no scene file {v['base']} and no scenes/{v['base']}.json")
        base_name = os.path.splitext(os.path.basename(base))[0]
        name = c.str_(v.get("name", base_name), f"{where}.name", NAME_RE)
        sets = v.get("set", {})
        c.obj(sets, f"{where}.set", set(sets) if isinstance(sets, dict) else set())
        vary = v.get("vary", {})
        c.obj(vary, f"{where}.vary", set(vary) if isinstance(vary, dict) else set())
        for k, vals in vary.items():
            if not isinstance(vals, list) or not vals:
                c.fail(f"{where}.vary.{k}", f"expected a non-empty list of values, got {c.show(vals)}")
        out = []
        keys = list(vary)
        # Counted before they are made: a few long lists multiply into more variants than any
        # experiment could run (and once hung the loader building them).
        combos = 1
        for k in keys:
            combos *= len(vary[k])
        if combos > MAX_CONFIGS:
            c.fail(f"{where}.vary", f"{combos} combinations of values (more than {MAX_CONFIGS})")
        for combo in itertools.product(*(vary[k] for k in keys)) if keys else [()]:
            settings = dict(sets)
            settings.update(zip(keys, combo))
            suffix = "".join(f"_{k.split('.')[-1]}{_slug(val)}" for k, val in zip(keys, combo))
            out.append({"name": name + suffix, "path": None, "base": base, "base_name": name,
                        "set": settings, "vary": dict(zip(keys, combo))})
        if not sets and not vary:  # {"base": "bunny"} is the plain scene
            out = [{"name": name, "path": base, "base": None, "set": {}, "vary": {}}]
        return out

    if not isinstance(d["scenes"], list) or not d["scenes"]:
        c.fail("scenes", f"expected a non-empty list, got {c.show(d['scenes'])}")
    scenes = [s for i, v in enumerate(d["scenes"]) for s in scene_entry(v, f"scenes[{i}]")]
    seen = {}
    for s in scenes:
        if s["name"] in seen:
            c.fail("scenes", f"two scenes are named \"{s['name']}\" (give variants a \"name\")")
        seen[s["name"]] = s
    decl["scenes"] = scenes
    # A run may name a subset by scene name or by the name of a variant family (base_name).
    families = {}
    for s in scenes:
        families.setdefault(s["name"], []).append(s["name"])
        if s.get("base_name") and s["base_name"] != s["name"]:
            families.setdefault(s["base_name"], []).append(s["name"])

    def scene_subset(v, where):
        names = c.list_(v, where, lambda x, w: c.str_(x, w))
        out = []
        for i, n in enumerate(names):
            if n not in families:
                c.fail(f"{where}[{i}]", f"\"{n}\" is not one of the declared scenes ({', '.join(families)})")
            out += families[n]
        return list(dict.fromkeys(out))

    runs = []
    if not isinstance(d["runs"], list) or not d["runs"]:
        c.fail("runs", f"expected a non-empty list of runs, got {c.show(d['runs'])}")
    for i, r in enumerate(d["runs"]):
        w = f"runs[{i}]"
        c.obj(r, w, {"models", "res", "size", "spp", "rays", "cache", "shadow_skip", "scenes", "comment"},
              required=("res",))
        r = {**RUN_DEFAULTS, **r}
        models = r["models"]
        if models != "all":
            models = c.list_(models, f"{w}.models", lambda x, ww: c.str_(x, ww), allow_scalar=False)
        runs.append({
            "models": models,
            "res": c.list_(r["res"], f"{w}.res", lambda x, ww: c.int_(x, ww, 1, 1 << 16)),
            "size": c.size(r["size"], f"{w}.size"),
            "spp": c.list_(r["spp"], f"{w}.spp", lambda x, ww: c.int_(x, ww, 1, 1 << 16)),
            "rays": c.list_(r["rays"], f"{w}.rays", lambda x, ww: c.int_(x, ww, 1, 1 << 20)),
            "cache": c.list_(r["cache"], f"{w}.cache", c.bool_),
            "shadow_skip": c.list_(r["shadow_skip"], f"{w}.shadow_skip", c.bool_),
            "scenes": scene_subset(r["scenes"], f"{w}.scenes") if "scenes" in r else [s["name"] for s in scenes],
        })
    for i, r in enumerate(runs):
        n = len(r["scenes"]) * (len(r["models"]) if r["models"] != "all" else 1)
        for k in ("res", "spp", "rays", "cache", "shadow_skip"):
            n *= len(r[k])
        if n > MAX_CONFIGS:
            c.fail(f"runs[{i}]", f"{n} configurations (scenes x models x res x spp x rays x cache x shadow_skip; "
                                 f"more than {MAX_CONFIGS})")
    decl["runs"] = runs
    tc = d.get("truth_curve")
    if tc is not None:
        c.obj(tc, "truth_curve", {"spp", "seed", "size", "scenes", "comment"}, required=("spp",))
        decl["truth_curve"] = {
            "spp": c.list_(tc["spp"], "truth_curve.spp", lambda x, w: c.int_(x, w, 1, 1 << 20)),
            "seed": c.int_(tc.get("seed", decl["seed"] + 1), "truth_curve.seed", 0),
            "size": c.size(tc.get("size", "scene"), "truth_curve.size", allow_res=False),
            "scenes": scene_subset(tc["scenes"], "truth_curve.scenes") if "scenes" in tc
            else [s["name"] for s in scenes],
        }
        if decl["truth_curve"]["seed"] == decl["seed"]:
            # Same seed, same sample pattern: the low-spp images would be correlated with the reference.
            c.fail("truth_curve.seed", "must differ from the experiment's seed (the reference's samples)")
    else:
        decl["truth_curve"] = None
    tol = d.get("tolerances", {})
    c.obj(tol, "tolerances", set(tol) if isinstance(tol, dict) else set())
    for k, t in tol.items():
        c.obj(t, f"tolerances.{k}", TOLERANCE_FIELDS, required=("better",))
        if t["better"] not in ("lower", "higher"):
            c.fail(f"tolerances.{k}.better", f"expected \"lower\" or \"higher\", got {c.show(t['better'])}")
        c.num(t.get("rel", 0), f"tolerances.{k}.rel")
        c.num(t.get("abs", 0), f"tolerances.{k}.abs")
        c.bool_(t.get("gate", True), f"tolerances.{k}.gate")
    decl["tolerances"] = tol
    return decl


def _slug(v):
    s = json.dumps(v) if not isinstance(v, str) else v
    return re.sub(r"[^A-Za-z0-9.+=-]+", "-", s).strip("-") or "x"


def expand_configs(decl, model_names):
    """Every configuration the declaration asks for, deduplicated, in declaration order. A model the
    binary does not know stays in the list (its rows record that it is not registered)."""
    out, seen = [], set()
    scenes = {s["name"]: s for s in decl["scenes"]}
    for r in decl["runs"]:
        models = model_names if r["models"] == "all" else r["models"]
        for sc, res, m, spp, rays, cache, skip in itertools.product(r["scenes"], r["res"], models, r["spp"],
                                                                     r["rays"], r["cache"], r["shadow_skip"]):
            size = r["size"]
            cfg = {"scene": sc, "model": m, "res": res, "size": size, "spp": spp, "rays": rays, "cache": cache,
                   "shadow_skip": skip}
            k = canonical(cfg)
            if k not in seen:
                seen.add(k)
                cfg["scene_decl"] = scenes[sc]
                out.append(cfg)
    return out


# ----------------------------------------------------------------------------------------------
# The sweep engine


TIMED_KINDS = ("truth", "bake", "render")  # their times enter tables and plots: measured alone
TIMING_FIELD = {"truth": "seconds", "bake": "bake_seconds", "render": "seconds"}  # in voxlab's --stats


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
                 scheduler=None, slurm_args="", repeats=None):
        self.cache_dir = os.path.abspath(cache_dir)
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
        self.models = models_info(self.voxlab)
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
        j = Job(kind, label, inputs, deps, cost, calib, code_keys.code_key(kind, model))
        if j.key in self.all:
            return self.all[j.key]
        j.dir = os.path.join(self.cache_dir, kind, f"{_slug(label)[:80]}-{j.key[:16]}")
        self.all[j.key] = j
        return j

    def truth(self, scene_path, scene_name, size, spp, seed):
        w, h = size
        return self._job("truth", f"{scene_name}-{w}x{h}-spp{spp}-seed{seed}",
                         {"scene": scene_fingerprint(scene_path), "size": [w, h], "spp": spp, "seed": seed,
                          "_scene_path": scene_path, "_scene_name": scene_name},
                         [], w * h * spp, ("truth", scene_name))

    def bake(self, scene_path, scene_name, model, res, rays, seed):
        return self._job("bake", f"{scene_name}-{model}-r{res}-k{rays}-seed{seed}",
                         {"scene": scene_fingerprint(scene_path, for_bake=True), "model": model, "res": res,
                          "rays": rays, "seed": seed, "_scene_path": scene_path, "_scene_name": scene_name},
                         [], res * res * rays, ("bake", model), model)

    def render(self, bake, scene_path, scene_name, size, spp, seed, cache, shadow_skip):
        w, h = size
        b = bake.inputs
        return self._job("render", f"{scene_name}-{b['model']}-r{b['res']}-{w}x{h}-spp{spp}"
                                   f"{'' if cache else '-nocache'}{'' if shadow_skip else '-noskip'}",
                         {"bake": bake.key, "scene": scene_fingerprint(scene_path), "size": [w, h], "spp": spp,
                          "seed": seed, "cache": cache, "shadow_skip": shadow_skip, "_scene_path": scene_path,
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
                    "-o", out, "--stats", stats]
        if job.kind == "bake":
            return ["bake", i["_scene_path"], "--model", i["model"], "--res", i["res"], "--rays", i["rays"],
                    "--seed", i["seed"], *t, "-o", "{tmp}/model.vox", "--stats", stats]
        if job.kind == "render":
            w, h = i["size"]
            return ["render", i["_scene_path"], "--model", i["_model"], "--vox", job.deps[0].path("model.vox"),
                    "--spp", i["spp"], "--size", f"{w}x{h}", "--seed", i["seed"], *t,
                    *([] if i["cache"] else ["--no-cache"]), *([] if i["shadow_skip"] else ["--no-shadow-skip"]),
                    "-o", out, "--stats", stats]
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
                "voxlab_sha256": self.voxlab_sha256, "executor": self.executor_name}

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
            for n in entries.get(_slug(j.label)[:80], []):
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
                    for j in ready:
                        p = self._place(j, places, busy, draining)
                        if p is None:
                            if j.timed and not draining:
                                # Empty the least busy place for it: nothing new starts there.
                                draining.add(min(places, key=lambda q: len(busy[q]["jobs"])))
                            continue
                        pending.remove(j)
                        busy[p]["jobs"].add(j.key)
                        busy[p]["timed"] = busy[p]["timed"] or j.timed
                        running[ex.submit(self.spec(j), p)] = (j, p)
                elif ready:  # SLURM: one array per kind and timing class; --exclusive for the timed
                    groups = {}
                    for j in ready:
                        groups.setdefault((j.kind, j.timed), []).append(j)
                    for (kind, timed), js in groups.items():
                        for j, f in zip(js, ex.submit_batch([self.spec(j) for j in js], exclusive=timed)):
                            pending.remove(j)
                            running[f] = (j, "slurm")
                if not running:
                    if pending:  # cannot happen with a dependency-ordered list; never spin
                        raise AssertionError(f"jobs stuck: {[j.label for j in pending]}")
                    continue
                for f in ex.wait(list(running)):
                    j, p = running.pop(f)
                    if p in busy:
                        busy[p]["jobs"].discard(j.key)
                        if j.timed:
                            busy[p]["timed"] = False
                    j.ran = True
                    try:
                        j.record = f.result()
                        wall = j.record["wall_seconds"]
                        j.status = "ok"
                        t = j.timing()
                        shown = (f"median {t['median']:.3g} s of {len(t['runs'])}, spread {t['spread']:.2g} s"
                                 if t else f"{wall:.1f} s")
                        flag = f"; LOAD {j.record['load_average']:.1f} > {j.record['cores']} cores" \
                            if j.record.get("loaded") and j.timed else ""
                        prog.finished(j, wall * (len(t["runs"]) if t else 1), f"{j.kind} {j.label} ({shown}{flag})")
                    except (VoxlabError, jobexec.JobFailed) as e:
                        j.status, j.error = "failed", str(e.args[0])
                        detail = f"\n    command: {e.args[1]}\n    " + e.args[2].replace("\n", "\n    ") \
                            if len(e.args) > 2 else ""
                        prog.finished(j, None, f"FAILED {j.kind} {j.label}: {j.error}{detail}")
                    except Exception as e:  # a broken image or stats file, a lost worker: this job's failure
                        j.status, j.error = "failed", f"{type(e).__name__}: {e}"
                        prog.finished(j, None, f"FAILED {j.kind} {j.label}: {j.error}")
        except BaseException:
            # Interrupted (Ctrl-C) or broken: the children run in their own sessions and would
            # otherwise go on rendering after we exit.
            kill_running()
            raise
        failed = sum(j.status in ("failed", "skipped") for j in todo)
        return {"jobs": len(order), "ran": sum(j.ran for j in todo), "cached": len(order) - len(todo),
                "failed": failed, "invalidated": len(inv), "seconds": time.monotonic() - prog.start}

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


def load_json(path):
    with open(path) as f:
        return json.load(f)


# ----------------------------------------------------------------------------------------------
# Experiments: declaration -> jobs -> rows

ROW_FIELDS = ["experiment", "scene", "base_scene", "variant", "kind", "model", "res", "width", "height", "spp", "rays",
              "cache", "shadow_skip", "seed", "truth_spp", "status", "error", "mse", "psnr", "ssim", "render_s",
              "render_ms", "render_ms_min", "render_ms_spread", "repeats", "bake_s", "bake_s_min", "bake_s_spread",
              "truth_s_min", "truth_s_spread", "load", "loaded", "bytes_per_voxel", "voxels", "model_bytes", "grid_bytes", "mb",
              "peak_rss_bytes", "cache_hits", "model_evals", "triangles", "truth_s", "image", "preview",
              "truth_image", "truth_preview", "computed", "jobs_cached"]


def row_key(r):
    """What identifies a configuration across runs (baseline, history)."""
    return "/".join(str(x) for x in (r["scene"], r["model"], f"r{r['res']}", f"{r['width']}x{r['height']}",
                                     f"spp{r['spp']}", f"k{r['rays']}", "cache" if r["cache"] else "nocache",
                                     f"truth{r['truth_spp']}", f"seed{r['seed']}"))


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


def load_columns(*jobs):
    """The highest 1-minute load average seen while the row's timed jobs ran, and whether any of them
    ran under a load above its machine's cores (its times are then inflated)."""
    recs = [j.record for j in jobs if j is not None and j.record and j.timed]
    loads = [max(r.get("load_average") or 0, r.get("load_after") or 0) for r in recs if "load_average" in r]
    return {"load": max(loads) if loads else None,
            "loaded": int(any(r.get("loaded") for r in recs)) if recs else None}


def _rel(path, root):
    path = os.path.abspath(path)
    root = os.path.abspath(root)
    return os.path.relpath(path, root) if path.startswith(root + os.sep) else path


def run_experiment(decl, results=DEFAULT_RESULTS, cache_dir=None, voxlab=None, jobs=2, fresh=False, out_dir=None,
                   sweep=None, executor="local", scheduler=None, slurm_args="", repeats=None):
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
                        slurm_args=slurm_args, repeats=repeats)
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
    for cfg in expand_configs(decl, model_names):
        s = scenes[cfg["scene"]]
        size = size_of(cfg["size"], cfg["res"], s)
        cfg["width"], cfg["height"] = size
        if cfg["model"] not in model_names:
            plan.append((cfg, None, None, None, None))
            continue
        t = sw.truth(s["path"], s["name"], size, truth_spp, seed)
        b = sw.bake(s["path"], s["name"], cfg["model"], cfg["res"], cfg["rays"], seed)
        r = sw.render(b, s["path"], s["name"], size, cfg["spp"], seed, cfg["cache"], cfg["shadow_skip"])
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

    rows = []
    for cfg, t, b, r, c in plan:
        s = scenes[cfg["scene"]]
        row = base_row(s, {"kind": "model", "model": cfg["model"], "res": cfg["res"], "width": cfg["width"],
                           "height": cfg["height"], "spp": cfg["spp"], "rays": cfg["rays"], "cache": cfg["cache"],
                           "shadow_skip": cfg["shadow_skip"]})
        if t is None:
            row.update(status="failed", error=f"model {cfg['model']} is not registered in this voxlab "
                                              f"(voxlab models: {', '.join(model_names)})")
            rows.append(row)
            continue
        err = first_failure(t, b, r, c)
        ts = stats(t) if t.status in ("ok", "cached") else {}
        row.update(triangles=ts.get("triangles"), **timing_columns(t, "truth_s", 1.0),
                   truth_image=_rel(t.path("image.exr"), results), truth_preview=_rel(t.path("image.png"), results))
        if err:
            row.update(status="failed", error=err)
            rows.append(row)
            continue
        rs, ms = stats(r), stats(c, "metrics.json")
        row.update(
            status="ok", error="", mse=ms.get("mse"), psnr=ms.get("psnr"), ssim=ms.get("ssim"),
            **timing_columns(r, "render_ms", 1000.0), **timing_columns(b, "bake_s", 1.0),
            **load_columns(t, b, r), bytes_per_voxel=rs.get("bytes_per_voxel"), voxels=rs.get("voxels"),
            model_bytes=rs.get("model_bytes"), grid_bytes=rs.get("grid_bytes"),
            mb=(rs["model_bytes"] + rs["grid_bytes"]) / 1e6 if "model_bytes" in rs and "grid_bytes" in rs else None,
            peak_rss_bytes=rs.get("peak_rss_bytes"), cache_hits=rs.get("cache_hits"),
            model_evals=rs.get("model_evals"), triangles=rs.get("triangles", row["triangles"]),
            image=_rel(r.path("image.exr"), results), preview=_rel(r.path("image.png"), results),
            computed=(r.record or {}).get("date"),
            jobs_cached=sum(j.status == "cached" for j in (b, r, c)))
        rows.append(row)
    base_rss = sw.baseline_memory() if curve else 0
    for s, size, spp, ref, t, c in curve:
        row = base_row(s, {"kind": "truth", "model": "truth", "res": 0, "width": size[0], "height": size[1],
                           "spp": spp, "rays": 0, "cache": True, "shadow_skip": True})
        err = first_failure(ref, t, c)
        if err:
            row.update(status="failed", error=err)
            rows.append(row)
            continue
        ts, ms = stats(t), stats(c, "metrics.json")
        rss = (t.record or {}).get("peak_rss_bytes")
        row.update(status="ok", error="", seed=decl["truth_curve"]["seed"], mse=ms.get("mse"), psnr=ms.get("psnr"),
                   ssim=ms.get("ssim"), **timing_columns(t, "render_ms", 1000.0), **load_columns(t), bake_s=0.0,
                   triangles=ts.get("triangles"), peak_rss_bytes=rss,
                   # Triangles' memory: voxlab reports mesh_bytes when it can, else peak RSS minus a
                   # process that loads no scene (mesh + BVH + framebuffer: an overestimate).
                   mb=(ts["mesh_bytes"] / 1e6 if "mesh_bytes" in ts else
                       max(0, rss - base_rss) / 1e6 if rss else None),
                   image=_rel(t.path("image.exr"), results), preview=_rel(t.path("image.png"), results),
                   truth_image=_rel(ref.path("image.exr"), results),
                   truth_preview=_rel(ref.path("image.png"), results), computed=(t.record or {}).get("date"),
                   jobs_cached=sum(j.status == "cached" for j in (t, c)))
        rows.append(row)

    cached_dates = sorted(j.record["date"] for j in sw.all.values() if j.status == "cached" and j.record)
    meta = {
        "experiment": decl["name"], "declaration": decl["shown"], "description": decl["description"],
        "settings": decl["raw"], "date": date, "finished": now_iso(),
        "elapsed_s": time.monotonic() - started, "machine": machine_info(), "git": git_info(),
        "voxlab_sha256": sw.voxlab_sha256, "voxlab_source": sw.source, "models": sw.models, "jobs": sw.jobs, "threads": sw.threads,
        "counts": counts, "oldest_cached": cached_dates[0] if cached_dates else None,
        "failed_rows": sum(r["status"] != "ok" for r in rows), "results_root": results,
        # Other processes on the machine slow the timed jobs down: say how busy it was when the
        # jobs behind these rows ran (recorded per job, so cached jobs keep their own).
        "load_average": _load_summary([j for j in sw.all.values() if j.kind in ("bake", "render", "truth")]),
        "executor": sw.executor_name, "repeats": sw.repeats_override or decl["repeats"],
        "bake_repeats": sw.repeats_override or decl["bake_repeats"],
        "invalidated": [x for x in sw.invalidated if x["kind"]],
        # Timed jobs measured while the machine's load exceeded its cores: their times are inflated.
        "loaded_jobs": sorted(f"{j.kind} {j.label} (load {max(j.record.get('load_average') or 0, j.record.get('load_after') or 0):.1f}"
                              f" on {j.record.get('cores')} cores)" for j in wanted_all(wanted)
                              if j.timed and j.record and j.record.get("loaded")),
    }
    os.makedirs(out_dir, exist_ok=True)
    write_csv(os.path.join(out_dir, "rows.csv"), rows, ROW_FIELDS)
    write_json(os.path.join(out_dir, "rows.json"), {"meta": meta, "rows": rows})
    bad = [r for r in rows if r["status"] != "ok"]
    print(f"{decl['name']}: {len(rows)} row(s), {len(bad)} failed; {counts['ran']} job(s) ran, {counts['cached']} "
          f"cached, in {fmt_duration(meta['elapsed_s'])}; wrote {_rel(out_dir, REPO)}/rows.csv", file=sys.stderr,
          flush=True)
    for r in bad:
        print(f"{decl['name']}:   failed: {r['scene']} {r['model']} {r['res']}^3: {r['error']}", file=sys.stderr)
    return meta, rows


# ----------------------------------------------------------------------------------------------
# History and baseline

HISTORY_FIELDS = ["run_id", "date", "commit", "dirty", "experiment", "scene", "model", "res", "width", "height", "spp",
                  "rays", "cache", "status", "mse", "ssim", "psnr", "render_ms", "bake_s", "mb", "bytes_per_voxel",
                  "host", "voxlab_sha256"]


HISTORY_KEY = ["commit", "experiment", "scene", "model", "res", "width", "height", "spp", "rays", "cache"]


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


BASELINE_METRICS = ["mse", "ssim", "psnr", "render_ms", "bake_s", "mb", "bytes_per_voxel"]


def baseline_section(meta, rows):
    return {"date": meta["date"], "commit": meta["git"]["commit"], "dirty": meta["git"]["dirty"],
            "machine": meta["machine"], "voxlab_sha256": meta["voxlab_sha256"],
            "models": [m["name"] for m in meta["models"]],
            "entries": {row_key(r): {"scene": r["scene"], "model": r["model"], "res": r["res"],
                                     "status": r["status"], **{m: r.get(m) for m in BASELINE_METRICS}}
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
            # Failing where the baseline worked is a regression; a new configuration that fails is news.
            item["status"] = "failed" if base else "new"
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


# ----------------------------------------------------------------------------------------------
# Command-line plumbing shared by the scripts


def add_common_args(ap, experiment=None):
    ap.add_argument("--experiment", default=experiment, help="declaration (default %(default)s)")
    ap.add_argument("--results", default=DEFAULT_RESULTS, help="results root (default results/)")
    ap.add_argument("--cache", help="job cache (default <results>/cache)")
    ap.add_argument("--jobs", type=int, default=2, help="untimed jobs at a time on this machine (default 2)")
    ap.add_argument("--voxlab", default=os.path.join(REPO, "build", "voxlab"), help="voxlab binary")
    ap.add_argument("--force", "--fresh", dest="fresh", action="store_true",
                    help="recompute every job (fresh timings), replacing its cache entry")
    ap.add_argument("--repeats", type=int, help="timed runs per timed job (default: the declaration's, else 5)")
    ap.add_argument("--executor", choices=["local", "dask", "slurm"], default="local",
                    help="where jobs run: this machine (default), a Dask scheduler, a SLURM cluster")
    ap.add_argument("--scheduler", help="--executor dask: the scheduler's address, tcp://HOST:PORT")
    ap.add_argument("--slurm-args", default="", help="--executor slurm: extra sbatch options, one string")


def sweep_args(a):
    """run_experiment's keyword arguments from add_common_args' options."""
    return {"results": a.results, "cache_dir": a.cache, "voxlab": a.voxlab, "jobs": a.jobs, "fresh": a.fresh,
            "executor": a.executor, "scheduler": a.scheduler, "slurm_args": a.slurm_args, "repeats": a.repeats}


def experiment_from_args(a, **kw):
    decl = load_declaration(a.experiment)
    return run_experiment(decl, **sweep_args(a), **kw)


def main_wrapper(fn, prog):
    """Runs fn(); a DeclarationError exits 2 and any other VoxlabError 1, each with one clear line."""
    try:
        return fn()
    except DeclarationError as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return 2
    except (VoxlabError, executors.ExecutorError) as e:
        print(f"{prog}: error: {e.args[0]}", file=sys.stderr)
        return 1


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
                                 f"({meta['threads']} here), its voxlab run repeated {rep} times (bakes "
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
