#!/usr/bin/env python3
"""Regenerates the binary mesh fixtures of tests/unit_mesh_load.c (run from anywhere; writes next
to this script). The ASCII PLY fixtures are hand-written; everything with binary data, or base64
inside JSON, is generated here so that its contents stay reviewable."""
import base64
import json
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


def write(name, data):
    with open(os.path.join(HERE, name), "wb") as f:
        f.write(data)


# ---- PLY ---------------------------------------------------------------------------------------

# Big-endian, properties in an unusual order with mixed types, a list and a scalar to skip in the
# vertex element, an unused element before and after the faces. Normals are (2, 0, 0): not unit
# and not what smoothing would give, so the test can tell they were read and normalised.
be_header = b"""ply
format binary_big_endian 1.0
comment voxlab test fixture: mixed types, odd order, properties and elements to skip
element vertex 4
property uchar red
property float x
property double y
property list uchar short extra
property float z
property float nx
property float ny
property float nz
property ushort confidence
property uchar green
property uchar blue
element material 1
property list uchar float coeffs
element face 2
property list uchar uint vertex_indices
property int flags
element edge 1
property int vertex1
property int vertex2
end_header
"""
quad = [(0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
body = b""
for i, (x, y, z) in enumerate(quad):
    extra = list(range(i))  # lists of varying length: 0..3 shorts
    body += struct.pack(">Bfd", 255, x, y)
    body += struct.pack(">B%dh" % len(extra), len(extra), *extra)
    body += struct.pack(">ffffHBB", z, 2.0, 0.0, 0.0, 1000 + i, 0, 51 * i)
body += struct.pack(">B3f", 3, 0.5, 0.25, 0.125)
body += struct.pack(">B3Ii", 3, 0, 1, 2, 7) + struct.pack(">B3Ii", 3, 0, 2, 3, 9)
body += struct.pack(">ii", 0, 1)
write("be_normals_colors.ply", be_header + body)

# Little-endian with the data cut off inside the second face.
trunc_header = b"""ply
format binary_little_endian 1.0
element vertex 4
property float x
property float y
property float z
element face 2
property list uchar int vertex_indices
end_header
"""
body = b"".join(struct.pack("<3f", *p) for p in quad)
body += struct.pack("<B3i", 3, 0, 1, 2) + struct.pack("<B3i", 3, 0, 2, 3)
write("truncated.ply", trunc_header + body[:-6])

# ---- glTF --------------------------------------------------------------------------------------

# A quad (two triangles) with normals and texture coordinates, under a child node scaled (2, 1, 1)
# whose parent is translated (1, 2, 3): world = T * S * local. The normal (-1, -1, 0)/sqrt(2) is
# the winding's and becomes (-1, -2, 0)/sqrt(5) under the inverse transpose of the scale.
Q_POS = [(0, 0, 0), (1, -1, 0), (1, -1, 1), (0, 0, 1)]
s = 1 / math.sqrt(2)
Q_NRM = [(-s, -s, 0)] * 4
Q_UV = [(0, 0), (1, 0), (1, 1), (0, 1)]
Q_IDX = [0, 1, 2, 0, 2, 3]
NODES = [
    {"name": "parent", "translation": [1, 2, 3], "children": [1]},
    {"name": "child", "scale": [2, 1, 1], "mesh": 0},
]
MATERIALS = [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.4, 0.2, 1.0]}}]
ASSET = {"version": "2.0", "generator": "voxlab tests/data/make_fixtures.py"}


def pad4(b, fill=b"\0"):
    return b + fill * (-len(b) % 4)


def data_uri(b):
    return "data:application/octet-stream;base64," + base64.b64encode(b).decode()


def dump(doc):
    return json.dumps(doc, separators=(",", ":")).encode()


def f32(values):
    return b"".join(struct.pack("<%df" % len(v), *v) for v in values)


def minmax(points):
    return {"min": [min(p[k] for p in points) for k in range(3)],
            "max": [max(p[k] for p in points) for k in range(3)]}


# quad.gltf: one bufferView per attribute (tightly packed), unsigned short indices, data URI.
pos, nrm, uv, idx = f32(Q_POS), f32(Q_NRM), f32(Q_UV), pad4(struct.pack("<6H", *Q_IDX))
buf = pos + nrm + uv + idx
views, off = [], 0
for part in (pos, nrm, uv, idx):
    views.append({"buffer": 0, "byteOffset": off, "byteLength": len(part)})
    off += len(part)
views[3]["byteLength"] = 12  # without the padding
gltf = {
    "asset": ASSET, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": NODES, "materials": MATERIALS,
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                                "indices": 3, "material": 0}]}],
    "buffers": [{"byteLength": len(buf), "uri": data_uri(buf)}],
    "bufferViews": views,
    "accessors": [
        dict({"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"}, **minmax(Q_POS)),
        {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
        {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"},
    ],
}
write("quad.gltf", dump(gltf))

# quad.glb: the same quad, but interleaved (byteStride 32, accessor byteOffsets 0/12/24) with
# unsigned byte indices; plus a second primitive (one triangle, no indices, no normals, no
# material: sequential, smoothed, white) and a POINTS primitive that must be skipped.
inter = b"".join(struct.pack("<8f", *p, *n, *t) for p, n, t in zip(Q_POS, Q_NRM, Q_UV))
idx8 = pad4(bytes(Q_IDX))
tri = f32([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
bin_chunk = inter + idx8 + tri
glb_doc = {
    "asset": ASSET, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": NODES, "materials": MATERIALS,
    "meshes": [{"primitives": [
        {"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0},
        {"attributes": {"POSITION": 4}},
        {"attributes": {"POSITION": 4}, "mode": 0},
    ]}],
    "buffers": [{"byteLength": len(bin_chunk)}],
    "bufferViews": [
        {"buffer": 0, "byteOffset": 0, "byteLength": len(inter), "byteStride": 32},
        {"buffer": 0, "byteOffset": len(inter), "byteLength": 6},
        {"buffer": 0, "byteOffset": len(inter) + len(idx8), "byteLength": len(tri)},
    ],
    "accessors": [
        dict({"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
             **minmax(Q_POS)),
        {"bufferView": 0, "byteOffset": 12, "componentType": 5126, "count": 4, "type": "VEC3"},
        {"bufferView": 0, "byteOffset": 24, "componentType": 5126, "count": 4, "type": "VEC2"},
        {"bufferView": 1, "componentType": 5121, "count": 6, "type": "SCALAR"},
        dict({"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC3"},
             **minmax([(0, 0, 0), (1, 0, 0), (0, 1, 0)])),
    ],
}
json_chunk = pad4(dump(glb_doc), b" ")
bin_chunk = pad4(bin_chunk)
glb = struct.pack("<I4s", len(json_chunk), b"JSON") + json_chunk
glb += struct.pack("<I4s", len(bin_chunk), b"BIN\0") + bin_chunk
write("quad.glb", struct.pack("<4sII", b"glTF", 2, 12 + len(glb)) + glb)


def one_primitive(points, mode=None, count=None, scene=True, node=None, normals=None, uvs=None):
    """A document with a single node and a single primitive over `points` (float VEC3)."""
    b = f32(points)
    prim = {"attributes": {"POSITION": 0}}
    if mode is not None:
        prim["mode"] = mode
    accessors = [{"bufferView": 0, "componentType": 5126, "count": count or len(points), "type": "VEC3"}]
    views = [{"buffer": 0, "byteLength": len(b)}]
    if normals:
        views.append({"buffer": 0, "byteOffset": len(b), "byteLength": 12 * len(normals)})
        accessors.append({"bufferView": 1, "componentType": 5126, "count": len(normals), "type": "VEC3"})
        prim["attributes"]["NORMAL"] = 1
        b += f32(normals)
    if uvs:
        views.append({"buffer": 0, "byteOffset": len(b), "byteLength": 8 * len(uvs)})
        accessors.append({"bufferView": len(views) - 1, "componentType": 5126, "count": len(uvs), "type": "VEC2"})
        prim["attributes"]["TEXCOORD_0"] = len(accessors) - 1
        b += f32(uvs)
    doc = {
        "asset": ASSET, "nodes": [dict(node or {}, mesh=0)], "meshes": [{"primitives": [prim]}],
        "buffers": [{"byteLength": len(b), "uri": data_uri(b)}],
        "bufferViews": views, "accessors": accessors,
    }
    if scene:
        doc.update({"scene": 0, "scenes": [{"nodes": [0]}]})
    return dump(doc)


write("points.gltf", one_primitive([(0, 0, 0), (1, 0, 0), (0, 1, 0)], mode=0))
# No "scenes": the loader must find the triangle through the root nodes to report the NaN.
write("nan_position.gltf", one_primitive([(0, 0, 0), (float("nan"), 0, 0), (0, 1, 0)], scene=False))
# A NaN texture coordinate: refused like a NaN position (a NaN texel lookup makes NaN pixels).
write("nan_uv.gltf", one_primitive([(0, 0, 0), (1, 0, 0), (0, 1, 0)], uvs=[(0, 0), (float("nan"), 0), (0, 1)]))
# The accessor claims 6 vertices; its bufferView holds 3.
write("out_of_bounds.gltf", one_primitive([(0, 0, 0), (1, 0, 0), (0, 1, 0)], count=6))
# Mirrored by scale (1, 1, -1): the winding must flip so that counter-clockwise stays the front
# face, and the normal (0, 0, 1) becomes (0, 0, -1).
write("mirrored.gltf", one_primitive([(0, 0, 0), (1, 0, 0), (0, 1, 0)], node={"scale": [1, 1, -1]},
                                     normals=[(0, 0, 1)] * 3))

# textured_quad.glb: a quad whose material has a baseColorFactor and a 2x2 PNG baseColorTexture in
# the binary chunk (the fuzz seed of the glTF loader's image path; PNG written by hand: zlib, CRCs).
import zlib  # noqa: E402


def png_rgb(width, height, rows):
    raw = b"".join(b"\0" + bytes(r) for r in rows)

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


png = png_rgb(2, 2, [[255, 0, 0, 0, 255, 0], [0, 0, 255, 255, 255, 255]])
corners = [(0, 0), (1, 0), (1, 1), (0, 1)]
blob = f32([(x, y, 0) for x, y in corners]) + f32([(0, 0, 1)] * 4)
blob += f32([(x, 1 - y) for x, y in corners]) + struct.pack("<6H", 0, 1, 2, 0, 2, 3)
offset = len(blob)
blob = pad4(blob + png)
textured = {"asset": {"version": "2.0", "generator": "voxlab tests/data/make_fixtures.py"}, "scene": 0,
            "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3,
                                        "material": 0}]}],
            "materials": [{"name": "tinted", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.9, 0.7, 1.0],
                                                                      "baseColorTexture": {"index": 0}}}],
            "textures": [{"source": 0}], "images": [{"bufferView": 4, "mimeType": "image/png"}],
            "buffers": [{"byteLength": len(blob)}],
            "bufferViews": [{"buffer": 0, "byteOffset": o, "byteLength": n}
                            for o, n in ((0, 48), (48, 48), (96, 32), (128, 12), (offset, len(png)))],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0],
                           "max": [1, 1, 0]},
                          {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
                          {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
                          {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}]}
json_chunk = pad4(dump(textured), b" ")
glb = struct.pack("<I4s", len(json_chunk), b"JSON") + json_chunk + struct.pack("<I4s", len(blob), b"BIN\0") + blob
write("textured_quad.glb", struct.pack("<4sII", b"glTF", 2, 12 + len(glb)) + glb)
