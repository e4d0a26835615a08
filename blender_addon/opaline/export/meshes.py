"""Evaluated Blender geometry -> binary little-endian PLY files, one per (mesh, material slot).

`export_mesh(mesh, folder, name)` writes an evaluated mesh as per-material triangle lists with
positions, normals (Blender's split normals: flat faces get the face normal, smooth faces the
vertex normal, custom/auto-smooth normals respected) and UVs (the active render UV map, stored
as (u, 1 - v): Mitsuba's convention, the same as its OBJ reader's default flip; a mesh without a
UV map is written without u, v). Corners of one material equal in vertex, normal and UV are
merged into one PLY vertex (compared as floats: -0.0 equals 0.0, and is written as 0.0), in the
order of their first corner in Blender's loop triangles.

Files are content-addressed: NAME-<hash>.ply where the hash covers the whole file, so a mesh
whose data did not change is not rewritten on the next export, instances share one file, and
an animated mesh exported frame by frame never overwrites a file an earlier frame uses. A mesh
whose Blender data is the same as at an earlier export to the same folder in this session
(frame to frame, F12 to F12, in batch.py) is not even converted again: it gets the files of
that export.

NumPy does the work, on arrays filled by Blender's bulk access (foreach_get): Blender's own
builds bundle it; Debian's Blender uses the system's (python3-numpy).
"""

import hashlib
import os
import re
import struct

from ..errors import OpalineError

_SAFE = re.compile(r"[^A-Za-z0-9_.-]+")


def safe_name(name):
    """A file-name-safe version of a Blender name."""
    s = _SAFE.sub("_", name).strip("._")
    return s[:60] or "mesh"


def _numpy():
    try:
        import numpy
    except ImportError:
        raise OpalineError("exporting meshes needs NumPy in Blender's Python: Blender's own "
                           "builds have it; with Debian's Blender, install python3-numpy")
    return numpy


class MeshData:
    """The arrays of an evaluated mesh that its PLY files are made of: co (vertices x 3
    float32), loop_vertex (loops, int32), loop_normal (loops x 3 float32; None until
    read_normals), uv (loops x 2 float32; None without a UV map), tri_loops (loop triangles x 3
    int32), tri_material (loop triangles, int32); and `digest`, the hex digest of what decides
    the PLY files: those arrays, with the normals' sources (loop edges, smooth faces, sharp
    edges, Auto Smooth before 4.1) in place of the normals unless the mesh has custom normals.
    (Blender 3.x sums vertex normals in parallel, so that they can differ in the last bit from
    one evaluation of the same mesh to the next.)"""

    def __init__(self):
        self.co = self.loop_vertex = self.loop_normal = self.uv = None
        self.tri_loops = self.tri_material = None
        self.digest = None

    @property
    def has_uv(self):
        return self.uv is not None


def _render_uv_layer(mesh):
    layers = mesh.uv_layers
    if not len(layers):
        return None
    for lay in layers:
        if lay.active_render:
            return lay
    return layers.active or layers[0]


def _get(np, collection, prop, dtype, count, width=1):
    a = np.empty(count * width, dtype)
    collection.foreach_get(prop, a)
    return a.reshape(count, width) if width > 1 else a


def read_normals(mesh, data):
    """Fills data.loop_normal: the mesh's corner normals (`corner_normals` since Blender 4.1,
    loop normals after calc_normals_split before)."""
    np = _numpy()
    nl = len(mesh.loops)
    if len(data.tri_material) == 0:
        data.loop_normal = np.zeros((nl, 3), np.float32)
    elif hasattr(mesh, "corner_normals"):
        data.loop_normal = _get(np, mesh.corner_normals, "vector", np.float32, nl, 3)
    else:
        mesh.calc_normals_split()
        data.loop_normal = _get(np, mesh.loops, "normal", np.float32, nl, 3)


def read_mesh(mesh):
    """MeshData of an evaluated mesh by Blender's bulk access, its normals read only where the
    digest needs them (custom normals): read_normals reads them."""
    np = _numpy()
    mesh.calc_loop_triangles()
    d = MeshData()
    ntri = len(mesh.loop_triangles)
    nv, ne, nl, npoly = len(mesh.vertices), len(mesh.edges), len(mesh.loops), len(mesh.polygons)
    d.co = _get(np, mesh.vertices, "co", np.float32, nv, 3)
    d.loop_vertex = _get(np, mesh.loops, "vertex_index", np.int32, nl)
    layer = _render_uv_layer(mesh)
    if layer is not None:
        d.uv = _get(np, layer.data, "uv", np.float32, nl, 2)
    d.tri_loops = _get(np, mesh.loop_triangles, "loops", np.int32, ntri, 3)
    d.tri_material = _get(np, mesh.loop_triangles, "material_index", np.int32, ntri)
    h = hashlib.sha1(b"uv" if d.has_uv else b"no uv")
    sharp = _get(np, mesh.edges, "use_edge_sharp", np.bool_, ne)
    sources = [d.co, d.loop_vertex, d.uv, d.tri_loops, d.tri_material, sharp,
               _get(np, mesh.polygons, "loop_start", np.int32, npoly),
               _get(np, mesh.polygons, "use_smooth", np.bool_, npoly)]
    if sharp.any():  # which loops the sharp edges part
        sources.append(_get(np, mesh.loops, "edge_index", np.int32, nl))
    if getattr(mesh, "has_custom_normals", False):
        read_normals(mesh, d)
        sources.append(d.loop_normal)
    if getattr(mesh, "use_auto_smooth", False):  # before 4.1
        sources.append(np.array([mesh.auto_smooth_angle], np.float64))
    for a in sources:
        if a is not None:
            h.update(struct.pack("<2sq", a.dtype.str[1:].encode(), a.size))
            h.update(np.ascontiguousarray(a))
        else:
            h.update(b"-")
    d.digest = h.hexdigest()
    return d


class Part:
    """One material's PLY body: nverts records x y z nx ny nz [u v] (little-endian floats) in
    `vertices`, nfaces records (uchar 3, three int32) in `faces` (bytes-like)."""

    def __init__(self, nverts, vertices, nfaces, faces):
        self.nverts, self.vertices, self.nfaces, self.faces = nverts, vertices, nfaces, faces


# Odd 64-bit constants of the key hash's rounds (splitmix64's and xxHash's primes).
_MIX = (0x9E3779B97F4A7C15, 0xBF58476D1CE4E5B9, 0x94D049BB133111EB, 0xC2B2AE3D27D4EB4F,
        0x165667B19E3779F9, 0x27D4EB2F165667C5, 0x85EBCA77C2B2AE63, 0xFF51AFD7ED558CCD)


def _hash_rows(np, keys, seed):
    """A uint64 hash of each row of the uint64 matrix keys (rows x columns)."""
    h = np.full(len(keys), _MIX[seed % len(_MIX)], np.uint64)
    for c in range(keys.shape[1]):
        h ^= keys[:, c]
        h *= np.uint64(_MIX[(seed + c + 1) % len(_MIX)])
        h ^= h >> np.uint64(29)
    return h


def _weld(np, keys, hashes, corners):
    """(first, group) for the corners (loop indices) of a part: first[k] the loop of the k-th
    distinct key in first-corner order, group[i] the index k of corner i's key. keys: one row
    of uint64 a loop (the bits of its vertex index, normal and UV); hashes: {seed: the loops'
    _hash_rows}, filled as needed."""
    n = len(corners)
    with np.errstate(over="ignore"):
        for seed in range(len(_MIX)):
            if seed not in hashes:
                hashes[seed] = _hash_rows(np, keys, seed)
            hc = hashes[seed][corners]
            order = np.argsort(hc)
            hs = hc[order]
            new = np.empty(n, bool)
            new[0] = True
            np.not_equal(hs[1:], hs[:-1], out=new[1:])
            start = np.flatnonzero(new)
            gid_sorted = np.cumsum(new) - 1
            gid = np.empty(n, np.int64)
            gid[order] = gid_sorted
            first_corner = np.minimum.reduceat(order, start)
            # Every loop of a group has its first corner's key, unless two keys shared a hash
            # (the corners of one loop share its group: any of them may set group_of_loop).
            group_of_loop = np.full(len(keys), -1, np.int64)
            group_of_loop[corners] = gid
            rep = keys[corners[first_corner]][np.maximum(group_of_loop, 0)]
            if not np.any((keys != rep).any(axis=1) & (group_of_loop >= 0)):
                break
        else:
            raise OpalineError("mesh export: every key hash collided")  # 8 in a row
    by_first = np.argsort(first_corner)
    rank = np.empty(len(start), np.int64)
    rank[by_first] = np.arange(len(start))
    return corners[first_corner[by_first]], rank[gid]


def _part(np, data, keys, hashes, normals, uv, corners):
    """The Part of the triangles whose corners are the loop indices `corners`."""
    first, group = _weld(np, keys, hashes, corners)
    width = 8 if uv is not None else 6
    v = np.empty((len(first), width), "<f4")
    v[:, 0:3] = data.co[data.loop_vertex[first]]
    v[:, 3:6] = normals[first]
    if uv is not None:
        v[:, 6] = uv[first, 0]
        v[:, 7] = np.float32(1.0) - uv[first, 1]
    nf = len(corners) // 3
    f = np.empty(nf, np.dtype([("count", "u1"), ("index", "<i4", (3,))]))
    f["count"] = 3
    f["index"] = group.reshape(nf, 3)
    return Part(len(first), v.tobytes(), nf, f.tobytes())


def mesh_parts(data, progress=None):
    """{material_index: Part} of a MeshData; progress(fraction), when given, hears how far it
    got."""
    np = _numpy()
    report = progress or (lambda fraction: None)
    if len(data.tri_material) == 0:
        return {}
    # The floats as they compare: -0.0 + 0.0 is 0.0.
    normals = data.loop_normal + np.float32(0.0)
    uv = data.uv + np.float32(0.0) if data.has_uv else None
    cols = [data.loop_vertex.view(np.uint32)[:, None], normals.view(np.uint32)]
    if uv is not None:
        cols.append(uv.view(np.uint32))
    keys = np.ascontiguousarray(np.hstack(cols)).view(np.uint64)  # 4 or 6 uint32 a row
    report(0.2)
    materials = np.unique(data.tri_material)
    parts = {}
    hashes = {}
    for i, m in enumerate(materials):
        if len(materials) == 1:
            corners = data.tri_loops.ravel()
        else:
            corners = data.tri_loops[data.tri_material == m].ravel()
        parts[int(m)] = _part(np, data, keys, hashes, normals, uv, corners)
        report(0.2 + 0.8 * (i + 1) / len(materials))
    return parts


def ply_header(part, has_uv):
    """The PLY header of a Part, from its element lines on (without the format and hash
    lines). has_uv False leaves the u, v properties out (a mesh without a UV map: the renderer
    then lays measured materials by its box projection at their physical size instead of
    collapsing them to the texel at uv (0, 0))."""
    return ("element vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
            "property float nx\nproperty float ny\nproperty float nz\n"
            "%s"
            "element face %d\nproperty list uchar int vertex_indices\nend_header\n"
            % (part.nverts, "property float u\nproperty float v\n" if has_uv else "",
               part.nfaces)).encode("ascii")


def write_ply(folder, name, part, has_uv=True):
    """Writes (or reuses) folder/NAME-<hash>.ply; returns (file_name, written: bool)."""
    from .xml_writer import write_bytes
    header = ply_header(part, has_uv)
    h = hashlib.sha1()
    for b in (header, part.vertices, part.faces):
        h.update(b)
    digest = h.hexdigest()[:16]
    fname = "%s-%s.ply" % (safe_name(name), digest)
    path = os.path.join(folder, fname)
    if os.path.exists(path) and _has_hash(path, digest):
        return fname, False
    pre = ("ply\nformat binary_little_endian 1.0\ncomment opaline-hash %s\n" % digest).encode()
    write_bytes(path, (pre, header, part.vertices, part.faces))
    return fname, True


def _has_hash(path, digest):
    try:
        with open(path, "rb") as fh:
            head = fh.read(256)
    except OSError:
        return False
    return ("comment opaline-hash %s\n" % digest).encode() in head


class Exported:
    """What export_mesh did: files ({material_index: file name}), has_uv, written (files
    written), reused (files already there), unchanged (True when the mesh data was the same as
    at an earlier export to that folder, so nothing was converted)."""

    def __init__(self, files, has_uv):
        self.files, self.has_uv = files, has_uv
        self.written = self.reused = 0
        self.unchanged = False


# (folder, name, digest of the MeshData) -> Exported of this Blender session's export_mesh
# calls, the most recently used last, at most _DONE_MAX of them.
_done = {}
_DONE_MAX = 4096


def export_mesh(mesh, folder, name, progress=None):
    """Writes an evaluated mesh's PLY files (folder/NAME_m<material index>-<hash>.ply) and
    returns an Exported; progress(fraction), when given, hears how far it got. A mesh whose data
    equals that of an earlier export_mesh of (folder, name) in this session gets that export's
    files without being converted again, while they are still there."""
    report = progress or (lambda fraction: None)
    data = read_mesh(mesh)
    key = (folder, name, data.digest)
    report(0.1)
    prev = _done.pop(key, None)
    if prev is not None and all(os.path.exists(os.path.join(folder, f))
                                for f in prev.files.values()):
        _done[key] = prev
        out = Exported(prev.files, prev.has_uv)
        out.reused, out.unchanged = len(out.files), True
        report(1.0)
        return out
    out = Exported({}, data.has_uv)
    if data.loop_normal is None:
        read_normals(mesh, data)
    parts = mesh_parts(data, lambda f: report(0.1 + 0.8 * f))
    for i, (mi, part) in enumerate(sorted(parts.items())):
        fname, written = write_ply(folder, "%s_m%d" % (name, mi), part, data.has_uv)
        out.files[mi] = fname
        if written:
            out.written += 1
        else:
            out.reused += 1
        report(0.9 + 0.1 * (i + 1) / len(parts))
    _done[key] = out
    while len(_done) > _DONE_MAX:
        del _done[next(iter(_done))]
    return out


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
