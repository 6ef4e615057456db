"""The architecture's promises (ARCHITECTURE.md), each checked by doing what it promises:

1. A new voxel model is one folder models/<name>/ plus one line in models/registry.def: in a scratch
   copy of the tree (the built objects copied with their times, so make rebuilds only what changed),
   a model made from binary's files under another name is added that way, `make` builds it with no
   other edit, and it renders on both backends, the same image as binary's.
2. The OpenCL kernels' sources are embedded at build time: a copy of the binary far from any source
   tree renders on OpenCL, and an edit of a .cl file after the build changes nothing until `make`.
3. The include graph has no circles (quoted #include between the tracer's and the models' files),
   and no two translation units need each other's symbols (nm on the built objects): stage by stage.
4. Every subcommand's --help lists its options with their defaults, exits 0, and every option it
   lists is one the command accepts; `voxlab --version` names the build."""
import os
import re
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from testlib import REPO, TMP, VOXLAB, finish, read_image, report, voxlab  # noqa: E402

import numpy as np  # noqa: E402

BUILD = os.path.join(REPO, os.environ.get("BUILD", "build"))
# The scratch tree's build folder has the same name as ours (the copied dependency files name their
# targets by it) and the same flavour (make test-asan runs this file with build-asan).
BDIR = os.path.basename(BUILD)
MAKE_ARGS = ["BUILD=" + BDIR] + (["SANITIZE=1"] if "asan" in BDIR else [])
SPHERES = os.path.join(REPO, "scenes", "spheres.json")
SMALL = ["--size", "24x16", "--spp", "2"]


def run(cmd, **kw):
    return subprocess.run(cmd, capture_output=True, text=True, **kw)


# ---------- 1. a new model: one folder + one registry line ----------
def new_model():
    root = os.path.join(TMP, "tree")
    shutil.rmtree(root, ignore_errors=True)
    os.makedirs(root)
    for d in ("tracer", "models", "tests", "scenes", "experiments"):
        shutil.copytree(os.path.join(REPO, d), os.path.join(root, d), symlinks=True,
                        ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy2(os.path.join(REPO, "Makefile"), root)
    # The built tree, times kept: only the new model, the registry and the embedded sources rebuild.
    shutil.copytree(BUILD, os.path.join(root, BDIR), symlinks=True,
                    ignore=shutil.ignore_patterns("tests", "fuzz", "pocl-cache", "*.log"))
    os.makedirs(os.path.join(root, "models", "toy"))
    for src, dst in (("binary.c", "toy.c"), ("binary_eval.h", "toy_eval.h")):
        with open(os.path.join(REPO, "models", "binary", src)) as f:
            text = f.read().replace("binary", "toy").replace("BINARY", "TOY")
        with open(os.path.join(root, "models", "toy", dst), "w") as f:
            f.write(text)
    with open(os.path.join(root, "models", "registry.def"), "a") as f:
        f.write("VX_MODEL(toy)\n")
    p = run(["make", "-s", "-j2", BDIR + "/voxlab", *MAKE_ARGS], cwd=root)
    report("a new model folder + one registry line builds with no other edit", p.returncode == 0, p.stderr[-2000:])
    if p.returncode:
        return
    exe = os.path.join(root, BDIR, "voxlab")
    listed = [line.split()[0] for line in run([exe, "models"]).stdout.splitlines() if line.strip()]
    report("the new model is listed", "toy" in listed, str(listed))
    images = {}
    for model in ("toy", "binary"):
        for backend in ("c", "opencl"):
            out = os.path.join(TMP, f"{model}_{backend}.exr")
            p = run([exe, "render", SPHERES, "--model", model, "--res", "16", "--rays", "16", *SMALL,
                     "--backend", backend, "-o", out])
            report(f"the new model's tree renders {model} on {backend}", p.returncode == 0, p.stderr[-1500:])
            if p.returncode == 0:
                images[model, backend] = read_image(out)
    if len(images) == 4:
        report("the new model renders on both backends, the same image as the model it copies",
               all(np.array_equal(images["toy", b], images["binary", b]) for b in ("c", "opencl"))
               and float(np.abs(images["toy", "c"] - images["toy", "opencl"]).max()) <= 1e-4
               and float(images["toy", "c"].std()) > 0.01)


# ---------- 2. kernels embedded in the binary ----------
def embedded_kernels():
    far = os.path.join(TMP, "far", "away")
    os.makedirs(far, exist_ok=True)
    exe = os.path.join(far, "voxlab")
    shutil.copy2(VOXLAB, exe)
    plugin = os.path.join(os.path.dirname(VOXLAB), "libvoxlab_oiio.so")
    if os.path.exists(plugin):
        shutil.copy2(plugin, far)
    outs = {}
    for name, binary in (("in_tree", VOXLAB), ("far", exe)):
        outs[name] = os.path.join(TMP, f"embedded_{name}.exr")
        p = run([binary, "render", SPHERES, "--model", "alpha", "--res", "16", "--rays", "16", *SMALL,
                 "--backend", "opencl", "-o", outs[name]], cwd=far)
        report(f"OpenCL render by the {name} binary", p.returncode == 0, p.stderr[-1500:])
    if all(os.path.exists(o) for o in outs.values()):
        report("a copy of the binary far from the sources renders the same OpenCL image",
               np.array_equal(read_image(outs["in_tree"]), read_image(outs["far"])))
    # An edit of a .cl file after the build changes nothing until make: the scratch tree's binary
    # (built above) renders the same after its render.cl is broken.
    root = os.path.join(TMP, "tree")
    tree_exe = os.path.join(root, BDIR, "voxlab")
    cl = os.path.join(root, "tracer", "backends", "opencl", "cl", "render.cl")
    if os.path.exists(tree_exe) and os.path.exists(cl):
        with open(cl, "a") as f:
            f.write("\nthis is not OpenCL C;\n")
        out = os.path.join(TMP, "edited_cl.exr")
        p = run([tree_exe, "render", SPHERES, "--model", "alpha", "--res", "16", "--rays", "16", *SMALL,
                 "--backend", "opencl", "-o", out])
        report("a .cl edit after the build changes nothing until make", p.returncode == 0 and
               np.array_equal(read_image(out), read_image(outs["in_tree"])), p.stderr[-800:])
        p = run(["make", "-s", BDIR + "/voxlab", *MAKE_ARGS], cwd=root)
        p = run([tree_exe, "render", SPHERES, "--model", "alpha", "--res", "16", "--rays", "16", *SMALL,
                 "--backend", "opencl", "-o", os.path.join(TMP, "edited_cl_made.exr")])
        report("... and after make the edited kernel is the one built (here: refused, with the build log)",
               p.returncode == 1 and "render.cl" in p.stderr, p.stderr[-800:])


# ---------- 3. no circles ----------
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def source_files():
    out = []
    for top in ("tracer", "models"):
        for root, _, files in os.walk(os.path.join(REPO, top)):
            out += [os.path.join(root, f) for f in files if f.endswith((".c", ".h", ".cpp", ".cl", ".def"))]
    return out


def no_circles():
    files = source_files()
    by_name = {}
    for f in files:
        by_name.setdefault(os.path.basename(f), []).append(f)
    report("no two sources share a file name (headers are found by name on the include path)",
           all(len(v) == 1 for k, v in by_name.items() if k.endswith(".h")),
           str({k: v for k, v in by_name.items() if len(v) > 1 and k.endswith(".h")}))
    graph = {}
    for f in files:
        with open(f, errors="replace") as fh:
            names = INCLUDE.findall(fh.read())
        graph[f] = [by_name[os.path.basename(n)][0] for n in names if os.path.basename(n) in by_name]
    cycles = strongly_connected(graph)
    report("the include graph has no circles", not cycles,
           str([[os.path.relpath(x, REPO) for x in c] for c in cycles]))
    # Link-level: which unit needs which (an undefined symbol of one defined by another).
    objs = {}
    for root, _, fs in os.walk(BUILD):
        if os.sep + "tests" in root or os.sep + "fuzz" in root:
            continue
        for f in fs:
            if f.endswith(".o"):
                objs[os.path.join(root, f)] = None
    defined, needed = {}, {}
    for o in objs:
        d = run(["nm", "--defined-only", "-g", o]).stdout.split("\n")
        u = run(["nm", "--undefined-only", "-g", o]).stdout.split("\n")
        defined[o] = {x.split()[-1] for x in d if x.strip()}
        needed[o] = {x.split()[-1] for x in u if x.strip()}
    owner = {}
    for o, syms in defined.items():
        for s in syms:
            owner[s] = o
    units = {o: sorted({owner[s] for s in needed[o] if s in owner and owner[s] != o}) for o in objs}
    # The registry and the command dispatcher name every model and command by design: a table.
    tables = [o for o in objs if o.endswith(("registry.c.o", "main.c.o", "backends.c.o"))]
    for t in tables:
        units[t] = []
    cycles = strongly_connected(units)
    report("no two translation units need each other's symbols (no link-level circles)", bool(objs) and not cycles,
           str([[os.path.relpath(x, BUILD) for x in c] for c in cycles]))


def strongly_connected(graph):
    """Tarjan's algorithm; the components of more than one node (the circles)."""
    index, low, on, stack, out, counter = {}, {}, set(), [], [], [0]
    sys.setrecursionlimit(10000)

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, []):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in list(graph):
        if v not in index:
            visit(v)
    return out


# ---------- 4. --help and --version ----------
def help_pages():
    p = voxlab("--version")
    report("voxlab --version names the build", p.returncode == 0 and re.match(r"voxlab \S+", p.stdout), p.stdout)
    p = voxlab("--help")
    commands = re.findall(r"^  (\w+) {2,}", p.stdout.split("commands:")[-1], re.M)
    report("voxlab --help lists the commands", p.returncode == 0 and
           {"truth", "bake", "render", "compare", "models"} <= set(commands), p.stdout)
    for cmd in commands:
        p = voxlab(cmd, "--help", check=False)
        options = re.findall(r"^  (-[-\w]+)(?: (\S+))? +(.*)$", p.stdout, re.M)
        report(f"{cmd} --help: exit 0, a usage line and its options", p.returncode == 0 and
               p.stdout.startswith("usage: voxlab " + cmd) and (options or cmd == "models"), p.stdout + p.stderr)
        with_value = [o for o in options if o[1]]
        defaults = [o for o in with_value if "(default: " in o[2] or "required" in o[2]]
        report(f"{cmd} --help: every option with a value says its default or that it is required",
               len(defaults) == len(with_value), str(with_value))
        for flag, value, _ in options:
            # The option given (with a value when it takes one): whatever else fails, it is not unknown.
            args = [cmd, flag] + (["x"] if value else [])
            q = voxlab(*args, check=False)
            report(f"{cmd} accepts {flag}", "unknown option" not in q.stderr, q.stderr)
    q = voxlab("render", "--frobnicate", "x", check=False)
    report("an option no command lists is refused as unknown", q.returncode == 1 and "unknown option" in q.stderr)


help_pages()
no_circles()
new_model()
embedded_kernels()
finish()
