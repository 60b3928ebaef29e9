#!/usr/bin/env python3
"""Writes the loader seed corpora of tests/fuzz/: tiny valid .tfx, .hair, .obj and .tfxmesh
images (layouts in shared/assets/README.md and server/groom/groom.h). Run from anywhere;
the output is deterministic (the committed seeds are its output)."""
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


def strand(s, n):
    """n points of strand s: a line stepping 0.01 from (0.1 s, 1, 0)."""
    return [(0.1 * s + 0.004 * v, 1.0 - 0.009 * v, 0.002 * v) for v in range(n)]


def tfx(ns, nv):
    pos = 160
    uv = pos + ns * nv * 16
    b = bytearray(uv + ns * 8)
    struct.pack_into("<fIIII", b, 0, 4.0, ns, nv, pos, uv)
    for s in range(ns):
        for v, p in enumerate(strand(s, nv)):
            struct.pack_into("<4f", b, pos + (s * nv + v) * 16, *p, 0.0 if v == 0 else 1.0)
        struct.pack_into("<2f", b, uv + 8 * s, 0.5, 0.5)
    return bytes(b)


def hair(counts, flags):
    """flags: 1 segments, 2 points, 4 thickness, 8 transparency, 16 colours."""
    nh = len(counts)
    n = counts if flags & 1 else [counts[0]] * nh
    np_ = sum(n)
    head = bytearray(128)
    struct.pack_into("<4sIIII", head, 0, b"HAIR", nh, np_, flags, counts[0] - 1)
    struct.pack_into("<fff", head, 20, 1.0, 0.5, 1.0)
    head[40:63] = b"strandcast fuzz seed   "
    body = bytearray()
    if flags & 1:
        body += b"".join(struct.pack("<H", c - 1) for c in n)
    for s, c in enumerate(n):
        for p in strand(s, c):
            body += struct.pack("<3f", *p)
    for bit, per in ((4, 1), (8, 1), (16, 3)):
        if flags & bit:
            body += struct.pack("<f", 0.25) * (per * np_)
    return bytes(head + body)


# A unit-ish tetrahedron, counter-clockwise seen from outside.
TET_V = [(0.0, 0.0, 0.0), (0.1, 0.0, 0.0), (0.0, 0.1, 0.0), (0.0, 0.0, 0.1)]
TET_F = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
# A cube as quads (fan-triangulated by the loader).
CUBE_V = [(x * 0.1, y * 0.1, z * 0.1) for x in (0, 1) for y in (0, 1) for z in (0, 1)]
CUBE_Q = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]


def obj(verts, faces, style):
    lines = ["# strandcast fuzz seed", "o mesh"]
    lines += ["v %g %g %g" % v for v in verts]
    lines += ["vn 0 0 1", "vt 0 0"]
    for f in faces:
        if style == 0:
            lines.append("f " + " ".join(str(i + 1) for i in f))
        elif style == 1:
            lines.append("f " + " ".join("%d/1/1" % (i + 1) for i in f))
        else:
            lines.append("f " + " ".join("%d//1" % (i - len(verts)) for i in f))
    return ("\n".join(lines) + "\n").encode()


def tfxmesh(verts, faces, bones):
    lines = ["# TressFX collision mesh", ""]
    if bones:
        lines += ["numOfBones 2", "0 root", "1 head"]
    lines.append("numOfVertices %d" % len(verts))
    lines += ["%d %g %g %g 0 0 1 0 0 0 0 1 0 0 0" % ((i,) + v) for i, v in enumerate(verts)]
    lines.append("numOfTriangles %d" % len(faces))
    lines += ["%d %d %d %d" % ((i,) + f) for i, f in enumerate(faces)]
    lines.append("# end")
    return ("\r\n" if bones else "\n").join(lines).encode() + b"\n"


def tris(quads):
    return [t for q in quads for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]


def write(folder, name, data):
    os.makedirs(os.path.join(HERE, folder), exist_ok=True)
    with open(os.path.join(HERE, folder, name), "wb") as f:
        f.write(data)


write("tfx", "3x5.tfx", tfx(3, 5))
write("tfx", "1x2.tfx", tfx(1, 2))
write("hair", "all.hair", hair([2, 5, 3], 31))
write("hair", "points.hair", hair([4, 4], 2))
write("hair", "segments.hair", hair([3, 6], 3))
write("obj", "tet.obj", obj(TET_V, TET_F, 0))
write("obj", "cube_quads.obj", obj(CUBE_V, CUBE_Q, 1))
write("obj", "cube_negative.obj", obj(CUBE_V, CUBE_Q, 2))
write("tfxmesh", "tet.tfxmesh", tfxmesh(TET_V, TET_F, False))
write("tfxmesh", "cube_bones.tfxmesh", tfxmesh(CUBE_V, tris(CUBE_Q), True))
