#!/usr/bin/python3
"""Writes the animated scene of issue 17 (moving objects by voxel transformation): N procedural
tori (scenes/meshes/torus.ply) or Stanford bunnies spinning and gliding over a checkered ground,
lit by one directional light with shadows, over `frames` frames. The object count is the parameter
the experiment sweeps (`make dynamic`); scenes/dynamic.json is this script's default output.

    scenes/dynamic.py [--objects N] [--frames F] [--shape torus|bunny] [--seed S] [-o OUT.json]
"""
import argparse
import json
import math
import os
import random
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def torus_ply(path, R=1.0, r=0.35, nu=24, nv=12):
    """A torus about the y axis (outward normals from the vertex order), ASCII PLY."""
    verts, faces = [], []
    for i in range(nu):
        u = 2 * math.pi * i / nu
        for j in range(nv):
            v = 2 * math.pi * j / nv
            verts.append(((R + r * math.cos(v)) * math.cos(u), r * math.sin(v), (R + r * math.cos(v)) * math.sin(u)))
    for i in range(nu):
        for j in range(nv):
            a, b = i * nv + j, ((i + 1) % nu) * nv + j
            c, d = ((i + 1) % nu) * nv + (j + 1) % nv, i * nv + (j + 1) % nv
            faces += [(a, d, c), (a, c, b)]
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\ncomment a torus about y (major radius %g, minor %g), scenes/dynamic.py\n" % (R, r))
        f.write("element vertex %d\nproperty float x\nproperty float y\nproperty float z\n" % len(verts))
        f.write("element face %d\nproperty list uchar int vertex_indices\nend_header\n" % len(faces))
        for p in verts:
            f.write("%.6f %.6f %.6f\n" % p)
        for t in faces:
            f.write("3 %d %d %d\n" % t)


def scene(objects=12, frames=24, shape="torus", seed=1):
    rng = random.Random(seed)
    side = max(1, math.ceil(math.sqrt(objects)))
    ground = 2.2 * side + 2.0
    objs = [{"ply": "meshes/plate.ply", "material": "ground", "transform": {"scale": [ground, 1, ground]}}]
    last = frames - 1
    for k in range(objects):
        gx, gz = k % side, k // side
        x0, z0 = (gx - (side - 1) / 2) * 2.2, (gz - (side - 1) / 2) * 2.2
        size = 0.45 + 0.25 * rng.random()
        if shape == "torus":
            obj = {"ply": "meshes/torus.ply", "material": "m%d" % (k % 3),
                   "transform": {"scale": size, "rotate_deg": [rng.uniform(-60, 60), 0, rng.uniform(-60, 60)]}}
            lift = 0.7 * size + 0.1
        else:
            obj = {"ply": "../../shared/data/meshes/bunny.ply", "material": "m%d" % (k % 3),
                   "transform": {"scale": 6.0 * size, "translate": [0.1 * size, -0.2 * size, 0.0]}}
            lift = 0.05
        spin = rng.choice([-1, 1]) * rng.uniform(90, 270)  # degrees over the sequence
        dx, dz = rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6)
        keys = [{"frame": 0, "translate": [x0, lift, z0]},
                {"frame": max(1, last // 2), "translate": [x0 + dx, lift + 0.3, z0 + dz],
                 "rotate_deg": [0, spin / 2, rng.uniform(-20, 20)]},
                {"frame": max(2, last), "translate": [x0 - dx, lift, z0 - dz], "rotate_deg": [0, spin, 0]}]
        obj["animation"] = {"keys": keys}
        objs.append(obj)
    dist = 2.4 * side + 6.0
    return {
        "name": "dynamic",
        "description": "%d %s%s spinning and gliding over a plate for %d frames (scenes/dynamic.py): the moving objects "
                       "of issue 17's voxel-transformation experiment." % (objects, shape, "" if objects == 1 else "s", frames),
        "size": [256, 256],
        "background": [0.55, 0.62, 0.72],
        "effects": ["shadows"],
        "frames": [0, last],
        "camera": {"orbit": {"distance": dist, "elevation_deg": 35, "azimuth_deg": 30}, "look_at": [0, 0.5, 0],
                   "up": [0, 1, 0], "fov_deg": 40},
        "lights": [{"type": "directional", "direction": [0.45, 1.0, 0.35], "irradiance": [3.0, 2.9, 2.7]}],
        "materials": {"ground": {"color": [0.6, 0.6, 0.62]}, "m0": {"color": [0.75, 0.25, 0.15]},
                      "m1": {"color": [0.2, 0.4, 0.75]}, "m2": {"color": [0.85, 0.75, 0.3]}},
        "objects": objs,
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--objects", type=int, default=12)
    ap.add_argument("--frames", type=int, default=24)
    ap.add_argument("--shape", choices=["torus", "bunny"], default="torus")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("-o", default=os.path.join(HERE, "dynamic.json"))
    a = ap.parse_args(argv)
    if not 1 <= a.objects <= 4096 or not 3 <= a.frames <= 100000:
        sys.exit("scenes/dynamic.py: --objects must be 1..4096 and --frames 3..100000")
    s = scene(a.objects, a.frames, a.shape, a.seed)
    out_dir = os.path.dirname(os.path.abspath(a.o))
    # Mesh paths are relative to the scene file: point them at scenes/ wherever the scene goes.
    for o in s["objects"]:
        o["ply"] = os.path.relpath(os.path.join(HERE, o["ply"]), out_dir)
    torus = os.path.join(HERE, "meshes", "torus.ply")
    if not os.path.exists(torus):
        torus_ply(torus)
    tmp = a.o + ".tmp"
    with open(tmp, "w") as f:
        json.dump(s, f, indent=1)
        f.write("\n")
    os.replace(tmp, a.o)


if __name__ == "__main__":
    main()
