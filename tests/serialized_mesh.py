#!/usr/bin/env python3
"""serialized_mesh.py - Mitsuba's serialized mesh format (versions 3 and 4), written and read
independently of opaline's C reader: the fuzz seeds come from here, and the end-to-end test
compares opaline's counts with this reader's.

  serialized_mesh.py seeds DIR         writes the fuzz seeds (small valid files) into DIR
  serialized_mesh.py counts FILE [I]   prints "VERTICES TRIANGLES" of mesh I, or a line for
                                       each mesh of the file (its dictionary's count)

Layout (little endian): per mesh a uint16 0x041C and a uint16 version, then a zlib stream of
a uint32 flag word (0x1 normals, 0x2 texture coordinates, 0x8 vertex colours, 0x10 face
normals, 0x1000 single, 0x2000 double precision), the NUL-terminated name (version 4 only),
uint64 vertex and triangle counts, the positions, normals, texture coordinates and colours,
and uint32 triangle indices; after the meshes, their offsets (uint64 in version 4, uint32 in
version 3) and a uint32 count."""
import struct
import sys
import zlib

NORMALS, UVS, COLORS, FACE_NORMALS, SINGLE, DOUBLE = 0x1, 0x2, 0x8, 0x10, 0x1000, 0x2000


def mesh_bytes(positions, triangles, normals=None, uvs=None, colors=None, version=4,
               double=False, name='mesh', face_normals=False):
    """One mesh: its header and zlib stream. positions etc. are lists of tuples."""
    flags = (DOUBLE if double else SINGLE) | (NORMALS if normals else 0) | \
        (UVS if uvs else 0) | (COLORS if colors else 0) | (FACE_NORMALS if face_normals else 0)
    fmt = '<%dd' if double else '<%df'
    body = struct.pack('<I', flags)
    if version == 4:
        body += name.encode() + b'\0'
    body += struct.pack('<QQ', len(positions), len(triangles))
    for arr in (positions, normals, uvs, colors):
        if arr:
            flat = [x for v in arr for x in v]
            body += struct.pack(fmt % len(flat), *flat)
    flat = [i for t in triangles for i in t]
    body += struct.pack('<%dI' % len(flat), *flat)
    return struct.pack('<HH', 0x041C, version) + zlib.compress(body)


def file_bytes(meshes, version=4):
    """A file of the given mesh_bytes, with its offset dictionary."""
    out, offsets = b'', []
    for m in meshes:
        offsets.append(len(out))
        out += m
    fmt = '<%dQ' if version == 4 else '<%dI'
    return out + struct.pack(fmt % len(offsets), *offsets) + struct.pack('<I', len(offsets))


def read(data, index=0):
    """Mesh index of a file's bytes: a dict of its flags, name, counts and arrays."""
    magic, version = struct.unpack_from('<HH', data, 0)
    if magic != 0x041C or version not in (3, 4):
        raise ValueError('not a serialized mesh of version 3 or 4')
    offset = 0
    if index:
        count, = struct.unpack_from('<I', data, len(data) - 4)
        if index >= count:
            raise ValueError('shape index %d out of range (%d meshes)' % (index, count))
        size = 8 if version == 4 else 4
        pos = len(data) - 4 - size * (count - index)
        offset, = struct.unpack_from('<Q' if version == 4 else '<I', data, pos)
    body = zlib.decompressobj().decompress(data[offset + 4:])
    flags, = struct.unpack_from('<I', body, 0)
    p, name = 4, ''
    if version == 4:
        end = body.index(b'\0', p)
        name, p = body[p:end].decode(), end + 1
    nv, nt = struct.unpack_from('<QQ', body, p)
    p += 16
    size, code = (8, 'd') if flags & DOUBLE else (4, 'f')
    mesh = {'flags': flags, 'name': name, 'vertices': nv, 'triangles': nt}
    for key, bit, dim in (('positions', None, 3), ('normals', NORMALS, 3), ('uvs', UVS, 2),
                          ('colors', COLORS, 3)):
        if bit is None or flags & bit:
            mesh[key] = struct.unpack_from('<%d%s' % (nv * dim, code), body, p)
            p += nv * dim * size
    mesh['indices'] = struct.unpack_from('<%dI' % (3 * nt), body, p)
    return mesh


def write_seeds(folder):
    """Small valid files covering both versions, both precisions and every optional array, and
    two uncompressed mesh streams as the fuzz target takes them (after "Z3" or "Z4")."""
    import os
    quad = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    tris = [(0, 1, 2), (0, 2, 3)]
    up = [(0, 0, 1)] * 4
    uv = [(0, 0), (1, 0), (1, 1), (0, 1)]
    rgb = [(1, 0, 0)] * 4
    tri = mesh_bytes([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(0, 1, 2)], version=3)
    seeds = {
        'v4_single.serialized': file_bytes([mesh_bytes(quad, tris)]),
        'v4_double_all.serialized': file_bytes([mesh_bytes(quad, tris, up, uv, rgb, double=True,
                                                           face_normals=True)]),
        'v3_single_uv.serialized': file_bytes([mesh_bytes(quad, tris, uvs=uv, version=3)], 3),
        'v3_two.serialized': file_bytes([tri, mesh_bytes(quad, tris, up, version=3)], 3),
        'v4_three.serialized': file_bytes([mesh_bytes(quad, tris, name='a'),
                                           mesh_bytes(quad, tris, up, uv, name='b'),
                                           mesh_bytes(quad[:3], tris[:1], name='c')]),
        'v3_no_dictionary.serialized': tri,
    }
    for version, double in ((4, False), (3, True)):  # fuzz_serialized.c's "Z3"/"Z4" inputs
        m = mesh_bytes(quad, tris, up, uv, rgb, version=version, double=double)
        seeds['stream_v%d' % version] = b'Z%d' % version + zlib.decompress(m[4:])
    os.makedirs(folder, exist_ok=True)
    for name, data in seeds.items():
        with open(os.path.join(folder, name), 'wb') as f:
            f.write(data)


def main(argv):
    if len(argv) == 3 and argv[1] == 'seeds':
        write_seeds(argv[2])
    elif len(argv) in (3, 4) and argv[1] == 'counts':
        with open(argv[2], 'rb') as f:
            data = f.read()
        indices = [int(argv[3])] if len(argv) == 4 else \
            range(struct.unpack_from('<I', data, len(data) - 4)[0])
        for i in indices:
            m = read(data, i)
            print(m['vertices'], m['triangles'])
    else:
        sys.stderr.write(__doc__.split('\n\n')[1] + '\n')
        return 2
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
