"""Which source files decide a job's output: the code part of a sweep job's cache key.

A cache entry must be recomputed when the code that produced it changes, and only then: adding a
model must not re-render the ten 1024-spp ground truths, and editing the truth renderer must not
re-bake every model. So a job's key holds the sha256 of the sources on its code path, not of the
whole binary (experiments/README.md, "What a cache key holds"):

- every job: the compiler (`gcc --version`), the Makefile's compile-flag lines (OPT, CFLAGS, ...) and the
  binary's own build line (`voxlab --version`: the compiler and the flags it was built with, which
  show `make OPT=-O0` or SANITIZE=1 where the Makefile's lines do not).
- truth: tracer/ and scenes/generators/ (scene loading, meshes, textures, images, Embree ray
  casting, the truth renderer, the CLI) without the voxel-only translation units in VOXEL_ONLY; of
  the headers only those the remaining files include (directly or not), models/model.h among them;
  plus Embree's version.
- bake and render of model M: tracer/ and scenes/generators/ without the truth-only units in
  TRUTH_ONLY, models/model.h, and M's own folder models/<m>/ (its .c files) with every models/ header
  those include (models/common/ among them) and the models/common/ units behind those headers. models/registry.c and registry.def (one line per model) and the other
  models' folders are not part of it: adding a model leaves every other model's entries valid. Plus
  Embree's version: the bake samples with Embree's rays and point queries, and a render with
  --shadows slicemap casts Embree rays.
- compare: tracer/ and scenes/generators/ (metrics, image readers).
- none: tracer/api/ (the Python library's entry points; the voxlab binary that jobs run lacks them).

The lists are conservative by default: a new file in tracer/ belongs to every code path until it is
named here. tests/test_cache_keys.py checks them against the linker's view (no unit a code path
leaves out defines a symbol that one it keeps refers to), independently of these rules.
Nothing in experiments/ is part of a key: the scripts do not change voxlab's outputs.
"""
import glob
import hashlib
import os
import re
import subprocess
import threading

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# The Makefile's -I order (SOURCE_DIRS: every folder of tracer/ and models/, sorted, then the generators).
INCLUDE_DIRS = sorted(os.path.relpath(root, REPO) for top in ("tracer", "models")
                      for root, _, _ in os.walk(os.path.join(REPO, top))) + ["scenes/generators"]
EMBREE_HEADER = "/usr/include/embree3/rtcore_config.h"

# Translation units only voxel jobs (bake, render, compare) run: never part of a truth's key.
VOXEL_ONLY = ["tracer/bake/*.c", "tracer/grid/*.c", "tracer/render/*.c", "tracer/backends/*.c",
              "tracer/backends/opencl/*.c", "tracer/backends/opencl/cl/*", "tracer/cli/cmd_bake.c",
              "tracer/cli/cmd_render.c", "tracer/cli/cmd_compare.c", "tracer/cli/stats_bake.c",
              "tracer/image/metrics.c", "tracer/shadows/slicemap_model.c", "tracer/cli/render_frames.c",
              "tracer/dynamic/*.c"]
# Translation units only the truth runs: never part of a model job's key.
TRUTH_ONLY = ["tracer/truth/truth.c", "tracer/truth/truth.h", "tracer/cli/cmd_truth.c"]
SOURCE_EXT = (".c", ".h", ".cpp", ".cl")
# The Python library's entry points (build/libvoxlab.so only): in no key, and no reason to rebuild voxlab.
NOT_IN_BINARY = "tracer/api/"
_INCLUDE_RE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)
_memo, _lock = {}, threading.Lock()


def _rel(p):
    return os.path.relpath(p, REPO)


def _expand(patterns):
    out = set()
    for p in patterns:
        out.update(_rel(x) for x in glob.glob(os.path.join(REPO, p)))
    return out


def tracer_sources():
    """Every source under tracer/ (kernels in tracer/backends/opencl/cl included) and scenes/generators/,
    but tracer/api/: the Python library's functions, which the voxlab binary does not contain."""
    out = set()
    for top in ("tracer", "scenes/generators"):
        for root, _, files in os.walk(os.path.join(REPO, top)):
            out.update(_rel(os.path.join(root, f)) for f in files if f.endswith(SOURCE_EXT))
    return {f for f in out if not f.startswith(NOT_IN_BINARY)}


def includes(path):
    """Repo-relative files `#include "..."`d by path, resolved as the compiler does (the file's own
    folder first, then the -I folders)."""
    try:
        with open(os.path.join(REPO, path), errors="replace") as f:
            names = _INCLUDE_RE.findall(f.read())
    except OSError:
        return set()
    out = set()
    for n in names:
        for d in [os.path.dirname(path), *INCLUDE_DIRS]:
            cand = os.path.normpath(os.path.join(d, n))
            if os.path.isfile(os.path.join(REPO, cand)):
                out.add(cand)
                break
    return out


def include_closure(files):
    seen, todo = set(files), list(files)
    while todo:
        for inc in includes(todo.pop()):
            if inc not in seen:
                seen.add(inc)
                todo.append(inc)
    return seen


def _headers_of(units, pool):
    """The units plus the headers of `pool` they include, directly or through other headers."""
    return {f for f in include_closure(units) if f in pool or f in units}


def model_stem(model):
    return model.replace("-", "_")


def model_sources(model):
    """models/<m>/*.c and the models/ headers they include (model.h among them), with the shared
    units behind those headers (models/common/x.c for an included models/common/x.h)."""
    stem = model_stem(model)
    units = {_rel(p) for p in glob.glob(os.path.join(REPO, "models", stem, "*.c"))} | {"models/model.h"}
    while True:
        files = {f for f in include_closure(units) if f.startswith("models/") and os.path.isfile(os.path.join(REPO, f))}
        shared = {f[:-2] + ".c" for f in files if f.startswith("models/common/") and f.endswith(".h")
                  and os.path.isfile(os.path.join(REPO, f[:-2] + ".c"))}
        if shared <= units:
            return files
        units |= shared


def code_files(kind, model=None):
    """Sorted repo-relative paths whose contents decide the output of a job of this kind."""
    tracer = tracer_sources()
    if kind == "truth":
        units = {f for f in tracer - _expand(VOXEL_ONLY) if not f.endswith(".h")}
        # Of models/, the headers the truth's files include (models/model.h, whose VX_MAX_LIGHTS the
        # truth's shadow code reads), not the models' own files.
        models_headers = {f for f in include_closure(units) if f.startswith("models/") and f.endswith(".h")}
        return sorted(_headers_of(units, tracer | models_headers) - _expand(VOXEL_ONLY))
    if kind in ("bake", "render"):
        return sorted((tracer - _expand(TRUTH_ONLY)) | model_sources(model))
    if kind == "compare":
        return sorted(tracer)
    raise ValueError(kind)


def file_sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _tool_versions():
    """The compiler, the Makefile's flag lines, Embree's version: what changes code without a source."""
    flags = []
    try:
        with open(os.path.join(REPO, "Makefile")) as f:
            flags = [ln.rstrip() for ln in f if re.match(r"(OPT|CFLAGS|CXXFLAGS|SANFLAGS|INCLUDES|NOWARN)\s", ln)]
    except OSError:
        pass
    try:
        gcc = subprocess.run(["gcc", "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    except (OSError, IndexError):
        gcc = "unknown"
    embree = "unknown"
    try:
        with open(EMBREE_HEADER) as f:
            m = re.search(r'#define\s+RTC_VERSION_STRING\s+"([^"]+)"', f.read())
            embree = m[1] if m else embree
    except OSError:
        pass
    return {"gcc": gcc, "makefile_flags": flags, "embree": embree}


def code_key(kind, model=None, build=None):
    """(sha256 of the code path, {path: sha256} of its files, tool versions) for a job kind, memoised
    for the life of the process (a sweep hashes each file once). build: the binary's build line
    (binary_build), so that jobs run by binaries compiled differently are filed apart."""
    with _lock:
        if (kind, model, build) in _memo:
            return _memo[(kind, model, build)]
        if "tools" not in _memo:
            _memo["tools"] = _tool_versions()
    files = {p: file_sha256(os.path.join(REPO, p)) for p in code_files(kind, model)}
    tools = dict(_memo["tools"])
    if kind == "compare":
        tools.pop("embree")  # reads images only; a bake samples with Embree's rays and point queries,
        # and a render with --shadows slicemap casts Embree rays into the triangles
    if build is not None:
        tools["build"] = build
    h = hashlib.sha256(repr((sorted(files.items()), sorted(tools.items()))).encode()).hexdigest()
    with _lock:
        _memo[(kind, model, build)] = (h, files, tools)
    return _memo[(kind, model, build)]


def binary_build(binary):
    """The compiler and flags `binary` was built with (the `build:` line of `voxlab --version`), or
    "unknown" for a binary that does not say."""
    try:
        out = subprocess.run([binary, "--version"], capture_output=True, text=True, timeout=60).stdout
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    for line in out.splitlines():
        if line.startswith("build: "):
            return line[len("build: "):].strip()
    return "unknown"


def newer_sources(binary):
    """Sources (tracer/, models/, scenes/generators/) modified after the binary was built: keys from
    them would describe code the binary does not contain."""
    try:
        built = os.stat(binary).st_mtime
    except OSError:
        return []
    out = []
    for top in ("tracer", "models", "scenes/generators"):
        for root, _, files in os.walk(os.path.join(REPO, top)):
            for f in files:
                p = os.path.join(root, f)
                if f.endswith(SOURCE_EXT) and not _rel(p).startswith(NOT_IN_BINARY) and os.stat(p).st_mtime > built + 1:
                    out.append(_rel(p))
    return sorted(out)


def changed_files(old, new):
    """Paths whose hash differs between two {path: sha256} maps (added and removed files too)."""
    return sorted(p for p in set(old) | set(new) if old.get(p) != new.get(p))
