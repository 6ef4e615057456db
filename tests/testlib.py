"""Python test helpers: report(name, cond, why) prints the protocol lines tests/run_all.sh counts."""
import glob
import json
import os
import subprocess
import sys
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
VOXLAB = os.environ.get("VOXLAB", os.path.join(REPO, "build", "voxlab"))
TMP = os.environ.get("TEST_TMP") or tempfile.mkdtemp()
os.makedirs(TMP, exist_ok=True)
_failures = 0


def report(name, cond, why=""):
    global _failures
    if cond:
        print(f"ok {name}", flush=True)
    else:
        _failures += 1
        print(f"not ok {name}: {why}", flush=True)


def voxlab(*args, check=True):
    """Runs build/voxlab; returns the CompletedProcess (text mode)."""
    p = subprocess.run([VOXLAB, *map(str, args)], capture_output=True, text=True)
    if check and p.returncode != 0:
        raise RuntimeError(f"voxlab {' '.join(map(str, args))} failed: {p.stderr}")
    return p


def voxlab_json(*args):
    return json.loads(voxlab(*args).stdout)


def finish():
    sys.exit(1 if _failures else 0)


def read_csv(path):
    """A CSV file's rows as dicts (the experiments' rows.csv, tables, results/history.csv)."""
    import csv

    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def read_image(path):
    """Reads an image as float32 (H, W, C) with OpenImageIO's Python bindings (Debian's
    python3-openimageio): an independent reader of the files voxlab writes."""
    import OpenImageIO as oiio
    import numpy as np

    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise RuntimeError(f"cannot open {path}: {oiio.geterror()}")
    pixels = inp.read_image(oiio.FLOAT)
    inp.close()
    return np.asarray(pixels, dtype=np.float32)


def write_ply(path, verts, faces, extra=()):
    """An ASCII PLY: each vertex x, y, z, then a float per name in extra (nx, red, u, ...)."""
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\n")
        f.write(f"element vertex {len(verts)}\n" + "".join(f"property float {p}\n" for p in ("x", "y", "z", *extra)))
        f.write(f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
        for v in verts:
            f.write(" ".join(repr(float(c)) for c in v) + "\n")
        for fc in faces:
            f.write(f"{len(fc)} " + " ".join(map(str, fc)) + "\n")


def write_gltf(path, primitives):
    """A glTF 2.0 file (one node, one mesh, one data-URI buffer): each primitive is (positions,
    triangles, normals or None: then the primitive has no NORMAL), float VEC3s and uint32 indices."""
    import base64
    import struct
    buf, views, accessors, prims = b"", [], [], []

    def add(values, fmt, kind, minmax=False):
        nonlocal buf
        data = b"".join(struct.pack(fmt, *v) if kind == "VEC3" else struct.pack(fmt, v) for v in values)
        views.append({"buffer": 0, "byteOffset": len(buf), "byteLength": len(data)})
        acc = {"bufferView": len(views) - 1, "componentType": 5126 if kind == "VEC3" else 5125,
               "count": len(values), "type": kind}
        if minmax:
            acc.update(min=[min(v[k] for v in values) for k in range(3)],
                       max=[max(v[k] for v in values) for k in range(3)])
        accessors.append(acc)
        buf += data
        return len(accessors) - 1

    for positions, triangles, normals in primitives:
        attributes = {"POSITION": add(positions, "<3f", "VEC3", minmax=True)}
        if normals is not None:
            attributes["NORMAL"] = add(normals, "<3f", "VEC3")
        prims.append({"attributes": attributes, "indices": add([i for t in triangles for i in t], "<I", "SCALAR")})
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
           "meshes": [{"primitives": prims}], "bufferViews": views, "accessors": accessors,
           "buffers": [{"byteLength": len(buf),
                        "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}]}
    with open(path, "w") as f:
        json.dump(doc, f)


def leftovers(directory, stem):
    """The files in directory whose name starts with stem: an output and its temporary files
    (OUT.tmp.PID.N), which a refused or failed command must not leave behind."""
    return sorted(os.path.basename(p) for p in glob.glob(os.path.join(directory, glob.escape(stem) + "*")))


def write_scene(name, objects, lights, camera, effects=(), materials=None, size=(16, 16), background=(0, 0, 0),
                extra=None):
    """Writes a scene file into TMP and returns its path; extra: further top-level fields (a
    `shadows` block)."""
    scene = {
        "name": name,
        "size": list(size),
        "background": list(background),
        "effects": list(effects),
        "camera": camera,
        "lights": lights,
        "materials": materials or {"grey": {"color": [0.5, 0.5, 0.5]}},
        "objects": objects,
        **(extra or {}),
    }
    path = os.path.join(TMP, name + ".json")
    with open(path, "w") as f:
        json.dump(scene, f)
    return path
