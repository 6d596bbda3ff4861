#!/usr/bin/env python3
"""Seed corpora for the loader fuzz targets (tests/fuzz/README.md): make_seeds.py SRC OUT.

OUT/scene: every scene file of SRC/scenes and SRC/tests/data (one piece each), and multi-piece
inputs (scene.xml, inc.xml, mesh.obj, mesh.ply, mesh.serialized, split by lines "--8<--") whose
scene includes a fragment and refers to each mesh format.
OUT/obj: the OBJ files of SRC/scenes, and a few small ones with normals, uvs and polygons.
OUT/ply: an ascii, a binary little-endian and a binary big-endian PLY (normals, uvs, quads), and
the PLY files of SRC/tests/data.
OUT/serialized: Mitsuba .serialized files, versions 3 and 4, single and double precision, with
normals, uvs, colours and two shapes (so shape_index 1 and the end-of-file dictionary are read).
"""
import glob
import os
import struct
import sys
import zlib

SEP = "\n--8<--\n"


def ply(fmt, with_normals=True):
    verts = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    head = ["ply", f"format {fmt} 1.0", "comment seed", f"element vertex {len(verts)}",
            "property float x", "property float y", "property float z"]
    if with_normals:
        head += ["property float nx", "property float ny", "property float nz"]
    head += ["property float u", "property float v", "element face 1",
             "property list uchar int vertex_indices", "end_header"]
    out = ("\n".join(head) + "\n").encode()
    rows = [(x, y, z) + ((0, 0, 1) if with_normals else ()) + ((x + 1) / 2, (y + 1) / 2) for x, y, z in verts]
    if fmt == "ascii":
        out += "".join(" ".join(f"{c:g}" for c in r) + "\n" for r in rows).encode()
        out += b"4 0 1 2 3\n"
    else:
        e = "<" if fmt == "binary_little_endian" else ">"
        for r in rows:
            out += struct.pack(e + "f" * len(r), *r)
        out += struct.pack(e + "B4i", 4, 0, 1, 2, 3)
    return out


def serialized_body(version, double, name):
    flags = 0x0001 | 0x0002 | 0x0008 | (0x2000 if double else 0)
    pos = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    f = "d" if double else "f"
    body = struct.pack("<I", flags)
    if version == 4:
        body += name.encode() + b"\0"
    body += struct.pack("<QQ", len(pos), 2)
    for p in pos:
        body += struct.pack("<3" + f, *p)
    for _ in pos:
        body += struct.pack("<3" + f, 0, 0, 1)
    for p in pos:
        body += struct.pack("<2" + f, (p[0] + 1) / 2, (p[1] + 1) / 2)
    for _ in pos:
        body += struct.pack("<3" + f, 1, 0.5, 0.25)
    body += struct.pack("<6I", 0, 1, 2, 0, 2, 3)
    return body


def serialized_shape(version, double, name):
    return struct.pack("<HH", 0x041C, version) + zlib.compress(serialized_body(version, double, name))


def serialized(version, double):
    shapes = [serialized_shape(version, double, "first"), serialized_shape(version, double, "second")]
    out, offsets = b"", []
    for s in shapes:
        offsets.append(len(out))
        out += s
    for o in offsets:
        out += struct.pack("<Q" if version == 4 else "<I", o)
    return out + struct.pack("<I", len(shapes))


OBJ_SEEDS = [
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n"
    "f 1/1/1 2/2/1 3/3/1 4/4/1\n",
    "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\ng b\nv 0 0 1\nf -1 -2 -3\n",
    "mtllib missing.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n",
]

MULTI_SCENE = """<scene version="3.0.0">
    <default name="res" value="8"/>
    <include filename="inc.xml"/>
    <bsdf type="diffuse" id="white"><rgb name="reflectance" value="0.5"/></bsdf>
    <shape type="obj"><string name="filename" value="mesh.obj"/><ref id="white"/></shape>
    <shape type="ply"><string name="filename" value="mesh.ply"/><ref id="white"/>
        <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
    <shape type="serialized"><string name="filename" value="mesh.serialized"/>
        <integer name="shape_index" value="1"/><ref id="white"/></shape>
</scene>"""

MULTI_INC = """<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="$res"/><integer name="height" value="$res"/>
            <rfilter type="box"/></film>
    </sensor>
</scene>"""


def main():
    src, out = sys.argv[1], sys.argv[2]
    dirs = {t: os.path.join(out, t) for t in ("scene", "obj", "ply", "serialized")}
    for d in dirs.values():
        os.makedirs(d, exist_ok=True)

    def put(target, name, data):
        with open(os.path.join(dirs[target], name), "wb") as f:
            f.write(data if isinstance(data, bytes) else data.encode())

    xmls = sorted(glob.glob(os.path.join(src, "scenes", "**", "*.xml"), recursive=True) +
                  glob.glob(os.path.join(src, "tests", "data", "**", "*.xml"), recursive=True))
    for i, p in enumerate(xmls):
        with open(p, "rb") as f:
            put("scene", f"file{i:03d}.xml", f.read())
    meshes = [OBJ_SEEDS[0], ply("ascii").decode(), serialized(4, False)]
    pieces = [MULTI_SCENE.encode(), MULTI_INC.encode(), meshes[0].encode(), meshes[1].encode(), meshes[2]]
    put("scene", "multi.xml", SEP.encode().join(pieces))
    pieces[3] = ply("binary_big_endian")
    pieces[4] = serialized(3, True)
    put("scene", "multi_binary.xml", SEP.encode().join(pieces))

    for i, p in enumerate(sorted(glob.glob(os.path.join(src, "scenes", "**", "*.obj"), recursive=True))):
        with open(p, "rb") as f:
            put("obj", f"scene{i:02d}.obj", f.read())
    for i, s in enumerate(OBJ_SEEDS):
        put("obj", f"seed{i}.obj", s)

    for fmt in ("ascii", "binary_little_endian", "binary_big_endian"):
        put("ply", f"{fmt}.ply", ply(fmt))
        put("ply", f"{fmt}_no_normals.ply", ply(fmt, with_normals=False))
    for i, p in enumerate(sorted(glob.glob(os.path.join(src, "tests", "data", "**", "*.ply"), recursive=True))):
        with open(p, "rb") as f:
            put("ply", f"data{i:02d}.ply", f.read())

    for v in (3, 4):
        for dbl in (False, True):
            # the target's mode byte (fuzz_loaders.h): 0 the file as it is, 1 one shape's body uncompressed
            kind = 'double' if dbl else 'single'
            put("serialized", f"v{v}_{kind}.serialized", b"\0" + serialized(v, dbl))
            put("serialized", f"v{v}_{kind}_raw.serialized",
                b"\1" + struct.pack("<H", v) + serialized_body(v, dbl, "raw"))


if __name__ == "__main__":
    main()
