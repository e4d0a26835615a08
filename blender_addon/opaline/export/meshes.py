"""Evaluated Blender geometry -> binary little-endian PLY files, one per (mesh, material slot).

`mesh_parts(mesh)` turns an evaluated mesh into per-material triangle lists with positions,
normals (Blender's split normals: flat faces get the face normal, smooth faces the vertex
normal, custom/auto-smooth normals respected) and UVs (the active render UV map, stored as
(u, 1 - v): Mitsuba's convention, the same as its OBJ reader's default flip; a mesh without a UV
map is written without u, v). Corners equal in position, normal and UV are merged into one PLY
vertex.

Files are content-addressed: NAME-<hash>.ply where the hash covers the whole file, so a mesh
whose data did not change is not rewritten on the next export, instances share one file, and
an animated mesh exported frame by frame never overwrites a file an earlier frame uses.
Pure Python (array + struct): Debian's Blender has no NumPy.
"""

import array
import hashlib
import os
import re
import struct
import sys

_SAFE = re.compile(r"[^A-Za-z0-9_.-]+")


def safe_name(name):
    """A file-name-safe version of a Blender name."""
    s = _SAFE.sub("_", name).strip("._")
    return s[:60] or "mesh"


def _loop_normals(mesh):
    """Per-corner normals as a flat array of floats (3 per loop)."""
    n = array.array('f', bytes(12 * len(mesh.loops)))
    if hasattr(mesh, "corner_normals"):  # Blender >= 4.1
        mesh.corner_normals.foreach_get("vector", n)
    else:
        mesh.calc_normals_split()
        mesh.loops.foreach_get("normal", n)
    return n


def mesh_parts(mesh):
    """{material_index: (vertices, faces)} for an evaluated mesh, where vertices is a flat
    array('f') of x y z nx ny nz u v records and faces a flat array('i') of triangle indices."""
    mesh.calc_loop_triangles()
    ntri = len(mesh.loop_triangles)
    if ntri == 0:
        return {}
    nv = len(mesh.vertices)
    nl = len(mesh.loops)
    co = array.array('f', bytes(12 * nv))
    mesh.vertices.foreach_get("co", co)
    lv = array.array('i', bytes(4 * nl))
    mesh.loops.foreach_get("vertex_index", lv)
    ln = _loop_normals(mesh)
    uvl = None
    layers = mesh.uv_layers
    if len(layers):
        layer = None
        for lay in layers:
            if lay.active_render:
                layer = lay
                break
        layer = layer or layers.active or layers[0]
        uvl = array.array('f', bytes(8 * nl))
        layer.data.foreach_get("uv", uvl)
    tl = array.array('i', bytes(12 * ntri))
    mesh.loop_triangles.foreach_get("loops", tl)
    mi = array.array('i', bytes(4 * ntri))
    mesh.loop_triangles.foreach_get("material_index", mi)

    parts = {}
    for t in range(ntri):
        m = mi[t]
        part = parts.get(m)
        if part is None:
            part = parts[m] = ({}, array.array('f'), array.array('i'))
        index, verts, faces = part
        for k in range(3):
            l = tl[3 * t + k]
            v = lv[l]
            if uvl is not None:
                u, w = uvl[2 * l], 1.0 - uvl[2 * l + 1]
            else:
                u, w = 0.0, 0.0
            key = (v, ln[3 * l], ln[3 * l + 1], ln[3 * l + 2], u, w)
            i = index.get(key)
            if i is None:
                i = index[key] = len(index)
                verts.extend((co[3 * v], co[3 * v + 1], co[3 * v + 2],
                              ln[3 * l], ln[3 * l + 1], ln[3 * l + 2], u, w))
            faces.append(i)
    return {m: (p[1], p[2]) for m, p in parts.items()}


def ply_bytes(verts, faces, has_uv=True):
    """(header_without_hash_line, body) of a binary little-endian PLY. has_uv False leaves the
    u, v properties out (a mesh without a UV map: the renderer then lays measured materials by
    its box projection at their physical size instead of collapsing them to the texel at uv
    (0, 0))."""
    nverts = len(verts) // 8
    nfaces = len(faces) // 3
    v = array.array('f', verts)
    if not has_uv:
        v = array.array('f', [x for i in range(nverts) for x in v[8 * i:8 * i + 6]])
    f = array.array('i', faces)
    if sys.byteorder != "little":
        v.byteswap()
        f.byteswap()
    # Faces: a uchar count (3) then three int32 per face.
    fb = f.tobytes()
    rec = bytearray(13 * nfaces)
    for i in range(nfaces):
        rec[13 * i] = 3
        rec[13 * i + 1:13 * i + 13] = fb[12 * i:12 * i + 12]
    header = ("element vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
              "property float nx\nproperty float ny\nproperty float nz\n"
              "%s"
              "element face %d\nproperty list uchar int vertex_indices\nend_header\n"
              % (nverts, "property float u\nproperty float v\n" if has_uv else "", nfaces))
    return header.encode("ascii"), v.tobytes() + bytes(rec)


def write_ply(folder, name, verts, faces, has_uv=True):
    """Writes (or reuses) folder/NAME-<hash>.ply; returns (file_name, written: bool)."""
    from .xml_writer import write_bytes
    header, body = ply_bytes(verts, faces, has_uv)
    h = hashlib.sha1()
    h.update(header)
    h.update(body)
    digest = h.hexdigest()[:16]
    fname = "%s-%s.ply" % (safe_name(name), digest)
    path = os.path.join(folder, fname)
    if os.path.exists(path) and _has_hash(path, digest):
        return fname, False
    pre = ("ply\nformat binary_little_endian 1.0\ncomment opaline-hash %s\n" % digest).encode()
    write_bytes(path, (pre, header, body))
    return fname, True


def _has_hash(path, digest):
    try:
        with open(path, "rb") as fh:
            head = fh.read(256)
    except OSError:
        return False
    return ("comment opaline-hash %s\n" % digest).encode() in head


def read_ply(path):
    """Reads a PLY written by write_ply: (verts as list of 8-tuples, or 6-tuples without UVs,
    faces as list of 3-tuples). For tests."""
    with open(path, "rb") as fh:
        data = fh.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    nv = nf = 0
    nprop = 0
    for line in data[:end].decode("ascii").splitlines():
        p = line.split()
        if p[:2] == ["element", "vertex"]:
            nv = int(p[2])
        elif p[:2] == ["element", "face"]:
            nf = int(p[2])
        elif p[:2] == ["property", "float"]:
            nprop += 1
    verts = [struct.unpack_from("<%df" % nprop, data, end + 4 * nprop * i) for i in range(nv)]
    off = end + 4 * nprop * nv
    faces = []
    for i in range(nf):
        cnt = data[off]
        faces.append(struct.unpack_from("<%di" % cnt, data, off + 1))
        off += 1 + 4 * cnt
    return verts, faces
