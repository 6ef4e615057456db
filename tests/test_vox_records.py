"""What a .vox file may hold, checked on load: every record is validated by its model
(vx_model.validate_record), so a crafted file with a valid checksum but NaN, infinite or
out-of-range fields is refused with the voxel index and the field, exit status 1, no output. Also
the exit status and exact message of a model mismatch (it once freed the records twice), header
fields that name the file, that a .vox is refused once its scene's texture (a checker's colour, an
image's texels) changed, and that a bake's file is a pure function of its inputs.

The files are crafted here from the layout in tracer/bake/voxfile.h (magic, header, records, the
grid's level-0 cells, FNV-1a checksum over 64-bit words), independently of voxlab's reader; the
checksum is recomputed so that only the record validation (or the cells' checks) can catch them.
vicini's 11-byte records make words that straddle records, header and cells."""
import json
import os
import random
import struct
import subprocess

from testlib import REPO, TMP, VOXLAB, finish, report, voxlab

SPHERES = os.path.join(REPO, "scenes", "spheres.json")
SMALL = ["--size", "16x16", "--spp", "1"]
HEADER = 360  # 8 magic bytes + voxfile_header (version 4, same header as 3): records start here
# voxfile_header offsets (after the magic): n at 48, voxel_bytes 64, record_count 72, voxels 80,
# layout_version 88, params 96 (256 bytes)
OFF_N, OFF_VOXEL_BYTES, OFF_RECORDS, OFF_VOXELS = 8 + 48, 8 + 64, 8 + 72, 8 + 80
OFF_LAYOUT, OFF_PARAMS = 8 + 88, 8 + 96


def path(name):
    return os.path.join(TMP, name)


def fnv1a(data):
    """FNV-1a over 64-bit little-endian words, the last one completed with zero bytes."""
    data = data + b"\0" * (-len(data) % 8)
    h = 0xCBF29CE484222325
    for (w,) in struct.iter_unpack("<Q", data):
        h = ((h ^ w) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return h


def with_checksum(body):
    return body + struct.pack("<Q", fnv1a(body))


def u64(raw, off):
    return struct.unpack_from("<Q", raw, off)[0]


def records_end(raw):
    """Where the records end and the grid's cells (uint32 each, `voxels` of them) begin."""
    return HEADER + u64(raw, OFF_VOXEL_BYTES) * u64(raw, OFF_RECORDS)


def craft(name, raw, patch):
    """raw with patch(bytearray of everything before the checksum) applied, checksum recomputed."""
    body = bytearray(raw[:-8])
    patch(body)
    p = path(name)
    with open(p, "wb") as f:
        f.write(with_checksum(bytes(body)))
    return p


def render_fails(name, vox, pattern_words, model=None):
    out = path(name + ".exr")
    args = ["render", SPHERES, "--vox", vox, *SMALL, "-o", out]
    if model:
        args += ["--model", model]
    p = voxlab(*args, check=False)
    err = p.stderr.strip()
    report(f"{name}: exit status 1", p.returncode == 1, f"rc {p.returncode}: {err}")
    report(f"{name}: one line naming the file and the problem",
           err.startswith("voxlab render: " + vox + ": ") and "\n" not in err and all(w in err for w in pattern_words),
           err)
    report(f"{name}: no output", not any(f.startswith(name + ".exr") for f in os.listdir(TMP)), str(os.listdir(TMP)))
    return err


# ---------- one small bake per model ----------
bakes = {}
for model in ("binary", "alpha", "vmesh", "heitz-neyret", "vicini"):
    bakes[model] = path(f"{model}.vox")
    voxlab("bake", SPHERES, "--model", model, "--res", "16", "--rays", "16", "-o", bakes[model])
    raw = open(bakes[model], "rb").read()
    p = voxlab("render", SPHERES, "--vox", bakes[model], *SMALL, "-o", path(f"{model}_ok.exr"), check=False)
    report(f"a genuine {model} bake passes its record validation", p.returncode == 0, p.stderr)
    report(f"{model}: the stored checksum is FNV-1a over the file's 64-bit words (computed here)",
           u64(raw, len(raw) - 8) == fnv1a(raw[:-8]))

# ---------- the model mismatch that freed the records twice ----------
p = voxlab("render", SPHERES, "--vox", bakes["alpha"], "--model", "binary", *SMALL, "-o", path("mismatch.exr"),
           check=False)
report("model mismatch: exit status 1 (not a crash)", p.returncode == 1, f"rc {p.returncode}: {p.stderr}")
report("model mismatch: exactly the one message",
       p.stderr == f'voxlab render: {bakes["alpha"]}: baked with model "alpha", not --model binary\n', repr(p.stderr))

# ---------- crafted records with a valid checksum ----------
# (model, field offset in the record, bytes written there, words the message must hold)
NAN, INF = struct.pack("<f", float("nan")), struct.pack("<f", float("inf"))
cases = [
    ("binary", 0, NAN, ["color[0]"]),
    ("binary", 12, INF, ["normal[0]"]),
    ("binary", 32, struct.pack("<I", 7), ["opaque"]),
    ("alpha", 24, struct.pack("<f", 1.5), ["opacity"]),
    ("alpha", 24, NAN, ["opacity"]),
    ("alpha", 12, struct.pack("<3f", 1, 1, 1), ["normal", "length"]),
    ("vmesh", 0, b"\x80", ["axis[0][0]"]),
    ("heitz-neyret", 0, NAN, ["field h"]),
    ("heitz-neyret", 0, INF, ["field h"]),
    ("heitz-neyret", 10, struct.pack("<H", 0x7E00), ["var_h"]),  # a half NaN
    ("vicini", 3, b"\xff", ["corr[0]"]),  # correlation codes stop at 254
    ("vicini", 0, b"\x00\x00\x00", ["sigma"]),  # the bake normalises the largest to 255
]
for model, off, data, words in cases:
    raw = open(bakes[model], "rb").read()
    vb, count = u64(raw, OFF_VOXEL_BYTES), u64(raw, OFF_RECORDS)
    k = min(5, count - 1)  # a record other than the first, so that the index is checked

    def patch(b, at=HEADER + k * vb + off, data=data):
        b[at:at + len(data)] = data

    name = f"crafted_{model}_{off}_{data.hex()}"
    render_fails(name, craft(name + ".vox", raw, patch), [f"voxel {k} ", f"{model} record field"] + words)

# Random record bytes: whatever they are, the file is refused or renders; never a crash. Records are
# validated one by one, so random bytes in every record of a model with float fields are refused.
rng = random.Random(13)
for model in ("binary", "alpha", "heitz-neyret", "vmesh"):
    raw = open(bakes[model], "rb").read()

    def patch(b):
        for i in range(HEADER, records_end(raw)):
            b[i] = rng.randrange(256)

    name = f"random_{model}"
    render_fails(name, craft(name + ".vox", raw, patch), ["voxel 0 ", "record field"])
# vicini's record is bytes only, almost all of them valid codes: random ones render or are refused,
# never crash, and what renders is finite.
raw = open(bakes["vicini"], "rb").read()
for trial in range(3):
    def patch(b):
        for i in range(HEADER, records_end(raw)):
            b[i] = rng.randrange(256)

    name = f"random_vicini_{trial}"
    vox = craft(name + ".vox", raw, patch)
    p = voxlab("render", SPHERES, "--vox", vox, *SMALL, "-o", path(name + ".exr"), check=False)
    ok = p.returncode == 1 and "record field" in p.stderr
    if p.returncode == 0:
        import numpy as np
        from testlib import read_image
        ok = bool(np.isfinite(read_image(path(name + ".exr"))).all())
    report(f"{name}: random record bytes render finite pixels or are refused (rc {p.returncode})", ok, p.stderr)

# ---------- header fields that once gave misleading messages ----------
raw = open(bakes["alpha"], "rb").read()
name = "bad_resolution"
render_fails(name, craft(name + ".vox", raw, lambda b: b.__setitem__(slice(OFF_N, OFF_N + 4), struct.pack("<i", 100000))),
             ["header field n", "100000", "1..1024"])
# One more cell than records: a valid cell after the last one (the file's size stays consistent).
name = "voxel_count_mismatch"
voxels, n_grid = u64(raw, OFF_VOXELS), struct.unpack_from("<i", raw, OFF_N)[0]
cells = list(struct.unpack_from(f"<{voxels}I", raw, records_end(raw)))
last = cells[-1]
extra = last + 1 if (last & 1023) + 1 < n_grid else ((last >> 20) + 1) << 20
assert (extra >> 20) < n_grid


def add_cell(b):
    struct.pack_into("<Q", b, OFF_VOXELS, voxels + 1)
    b.extend(struct.pack("<I", extra))


err = render_fails(name, craft(name + ".vox", raw, add_cell), ["do not match"])
report("count mismatch: says what this grid expects (not 'expected 0')",
       f"expected {voxels + 1} of {u64(raw, OFF_VOXEL_BYTES)} for {voxels + 1}" in err, err)

# ---------- the grid's cells, checked as the grid is rebuilt from them ----------
k = len(cells) // 2
name = "cells_out_of_order"
swapped = cells[:k] + [cells[k + 1], cells[k]] + cells[k + 2:]
render_fails(name, craft(name + ".vox", raw, lambda b: struct.pack_into(f"<{voxels}I", b, records_end(raw), *swapped)),
             ["level-0 cells", f"cell {k + 1},", "order"])
name = "cell_repeated"
twice = cells[:k] + [cells[k - 1]] + cells[k + 1:]
render_fails(name, craft(name + ".vox", raw, lambda b: struct.pack_into(f"<{voxels}I", b, records_end(raw), *twice)),
             ["level-0 cells", f"cell {k},", "once each"])
name = "cell_outside"
render_fails(name, craft(name + ".vox", raw, lambda b: struct.pack_into("<I", b, len(b) - 4, n_grid << 20)),
             ["level-0 cells", f"cell {voxels - 1},", f"({n_grid}, 0, 0)", "outside"])
name = "cells_truncated"
render_fails(name, craft(name + ".vox", raw, lambda b: b.__delitem__(slice(len(b) - 4, len(b)))),
             ["truncated", "header promises"])

# ---------- the record layout version and the model parameters in the header ----------
name = "layout_mismatch"
render_fails(name, craft(name + ".vox", raw, lambda b: struct.pack_into("<I", b, OFF_LAYOUT, 7)),
             ["header field layout_version is 7", "record layout 1", "bake it again"])
hn = open(bakes["heitz-neyret"], "rb").read()
params = hn[OFF_PARAMS:OFF_PARAMS + 256].split(b"\0")[0].decode()
report("the bake's model parameters are in the header", params == "edge_clear=0.40000000000000002", params)
tuned = path("hn_edge0.vox")
voxlab("bake", SPHERES, "--model", "heitz-neyret", "--res", "16", "--rays", "16", "--threads", "1",
       "--param", "edge_clear=0", "-o", tuned)
t = open(tuned, "rb").read()
report("--param edge_clear=0 is written and changes the coarser levels",
       t[OFF_PARAMS:OFF_PARAMS + 16].startswith(b"edge_clear=0\0") and t[HEADER:] != hn[HEADER:])
st = path("hn_edge0.json")
voxlab("render", SPHERES, "--vox", tuned, *SMALL, "-o", path("hn_edge0.exr"), "--stats", st)
report("render --stats reports the .vox's parameters", json.load(open(st))["model_params"] == "edge_clear=0")
p = subprocess.run([VOXLAB, "bake", SPHERES, "--model", "heitz-neyret", "--res", "8", "--param", "edge=1", "-o",
                    path("nope.vox")], capture_output=True, text=True)
report("an unknown --param is refused, naming the model's parameters",
       p.returncode == 1 and 'no parameter "edge"' in p.stderr and "edge_clear" in p.stderr
       and not os.path.exists(path("nope.vox")), p.stderr)
p = subprocess.run([VOXLAB, "bake", SPHERES, "--model", "heitz-neyret", "--res", "8", "--param", "edge_clear=0.9",
                    "-o", path("nope.vox")], capture_output=True, text=True)
report("a --param out of range is refused with the range", p.returncode == 1 and "[0, 0.5]" in p.stderr, p.stderr)

# ---------- a texture's content is part of the scene's identity ----------
# A material's `texture` is an index: a .vox baked before a checker's colour or an image's texels
# changed was accepted and rendered the old texture (MSE 0.011 against a fresh bake). Both kinds are
# checked, each against the same scene with the texture unchanged (which must still load).
def variant(name, edit):
    with open(SPHERES) as f:
        d = json.load(f)
    edit(d)
    p = path(name + ".json")
    with open(p, "w") as f:
        json.dump(d, f)
    return p


def texture_png(name, value):
    import numpy as np
    import OpenImageIO as oiio
    px = np.full((8, 8, 3), 0.5, np.float32)
    px[3, 5] = value
    buf = oiio.ImageBuf(oiio.ImageSpec(8, 8, 3, oiio.UINT8))
    buf.set_pixels(oiio.ROI(), px)
    p = path(name)
    buf.write(p)
    return p


def uses_image(tex):
    return lambda d: d["materials"]["ground"].update(texture=tex)


for kind, same, changed in [
        ("checker", variant("tex_same", lambda d: None),
         variant("tex_checker",
                 lambda d: d["materials"]["ground"]["texture"]["checker"].update(color2=[0.6, 0.1, 0.1]))),
        ("image", variant("tex_img", uses_image(texture_png("img_a.png", 0.5))),
         variant("tex_img2", uses_image(texture_png("img_b.png", 0.9))))]:
    vox = path(f"tex_{kind}.vox")
    voxlab("bake", same, "--model", "binary", "--res", "16", "--rays", "16", "-o", vox)
    ok = voxlab("render", same, "--vox", vox, *SMALL, "-o", path(f"tex_{kind}_ok.exr"), check=False)
    report(f"a .vox loads with its own scene ({kind} texture)", ok.returncode == 0, ok.stderr)
    p = voxlab("render", changed, "--vox", vox, *SMALL, "-o", path(f"tex_{kind}_bad.exr"), check=False)
    report(f"a .vox is refused once its scene's {kind} texture changed",
           p.returncode == 1 and "baked from another scene" in p.stderr and
           not os.path.exists(path(f"tex_{kind}_bad.exr")), p.stderr)

# ---------- a bake is a pure function of its inputs ----------
for model in ("alpha", "heitz-neyret"):
    again = path(f"{model}_again.vox")
    voxlab("bake", SPHERES, "--model", model, "--res", "16", "--rays", "16", "--threads", "1", "-o", again)
    report(f"two bakes of the same inputs are byte-identical ({model})",
           open(again, "rb").read() == open(bakes[model], "rb").read())
finish()
