#!/usr/bin/env python3
"""Writes the binary mesh fixtures of tests/test_loader.cpp (run from anywhere; output beside
this script). The files are committed; rerun only to change them.

quad_le.ply / quad_be.ply: binary PLY (little / big endian) of the unit quad [0,1]^2 at z=0 as ONE
  quad face, with normals (+z), texture_u/texture_v, an extra per-vertex uchar property, and an
  extra element ("edge") after the faces that the reader must skip.
meshes_v4.serialized: Mitsuba serialized version 4 with two meshes and the end-of-file dictionary:
  shape 0: one triangle, single precision, no normals, name "tri";
  shape 1: a quad (2 triangles) in double precision with normals and uvs, name "quad".
meshes_v3.serialized: the same two meshes in version 3 (no names, uint32 dictionary).
"""
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))

QUAD_P = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
QUAD_UV = [(0, 0), (1, 0), (1, 1), (0, 1)]


def ply(endian, index_type):
    e = '<' if endian == 'little' else '>'
    head = (
        "ply\n"
        f"format binary_{endian}_endian 1.0\n"
        "comment quad for test_loader\n"
        "element vertex 4\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property double nx\nproperty double ny\nproperty double nz\n"
        "property float texture_u\nproperty float texture_v\n"
        "property uchar red\n"
        "element face 1\n"
        f"property list uchar {index_type} vertex_indices\n"
        "element edge 1\n"
        "property int vertex1\nproperty int vertex2\n"
        "end_header\n").encode()
    body = b""
    for p, uv in zip(QUAD_P, QUAD_UV):
        body += struct.pack(e + "fff", *p) + struct.pack(e + "ddd", 0, 0, 1) + struct.pack(e + "ff", *uv)
        body += struct.pack(e + "B", 200)
    code = {"int": "i", "uint": "I", "uchar": "B"}[index_type]
    body += struct.pack(e + "B", 4) + struct.pack(e + code * 4, 0, 1, 2, 3)
    body += struct.pack(e + "ii", 0, 1)
    return head + body


def serialized_mesh(version, name, flags, positions, normals, uvs, tris):
    dbl = flags & 0x2000
    f = "d" if dbl else "f"
    raw = struct.pack("<I", flags)
    if version == 4:
        raw += name.encode() + b"\0"
    raw += struct.pack("<QQ", len(positions), len(tris))
    for p in positions:
        raw += struct.pack("<" + f * 3, *p)
    if flags & 1:
        for n in normals:
            raw += struct.pack("<" + f * 3, *n)
    if flags & 2:
        for uv in uvs:
            raw += struct.pack("<" + f * 2, *uv)
    for t in tris:
        raw += struct.pack("<III", *t)
    return struct.pack("<HH", 0x041C, version) + zlib.compress(raw)


def serialized(version):
    a = serialized_mesh(version, "tri", 0x1000, [(0, 0, 0), (2, 0, 0), (0, 2, 0)], None, None, [(0, 1, 2)])
    b = serialized_mesh(version, "quad", 0x2000 | 1 | 2, QUAD_P, [(0, 0, 1)] * 4, QUAD_UV, [(0, 1, 2), (0, 2, 3)])
    data = a + b
    if version == 4:
        data += struct.pack("<QQ", 0, len(a))
    else:
        data += struct.pack("<II", 0, len(a))
    return data + struct.pack("<I", 2)


def write(name, data):
    with open(os.path.join(HERE, name), "wb") as fh:
        fh.write(data)


write("quad_le.ply", ply("little", "int"))
write("quad_be.ply", ply("big", "uint"))
write("meshes_v4.serialized", serialized(4))
write("meshes_v3.serialized", serialized(3))
# A truncated binary PLY for tests/data/bad/bad_ply.xml.
write(os.path.join("..", "bad", "truncated.ply"), ply("little", "int")[:-20])
