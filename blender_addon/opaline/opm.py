"""opm.py - the one Python reader of the .opm container (docs/formats.md): the header, the
section table and the META section; the data sections are left to the caller (offset and size).

Imports neither bpy nor anything outside the standard library, and nothing relative, so that
the benchmark (bench/methods_bench) imports this file as a plain module; the add-on uses it
through presets.py. libopaline/material_file.c is the C reader (which also checks CRCs)."""

import os
import struct

MAGIC = b"OPALINEM"
VERSION = 1
HEADER_BYTES = 64
ENTRY_BYTES = 32     # tag (8 bytes, NUL-padded), offset u64, size u64, CRC u32, reserved u32
MAX_SECTIONS = 4096
MAX_META_BYTES = 1 << 20


class OpmError(ValueError):
    """The file is not a readable .opm container; the message names the file."""


def sections(path):
    """{tag: (offset, size)} of the container at path. Checks the magic, the version, the
    declared file size against the file's and the section table's bounds; raises OpmError
    (or OSError when the file cannot be read)."""
    with open(path, "rb") as fh:
        head = fh.read(HEADER_BYTES)
        if len(head) < HEADER_BYTES or head[:8] != MAGIC:
            raise OpmError("%s: not an opaline material file" % path)
        version, count, fsize, table = struct.unpack_from("<IIQQ", head, 8)
        real = os.fstat(fh.fileno()).st_size
        if version != VERSION or fsize != real:
            raise OpmError("%s: version %d or size %d unexpected (file of %d bytes)" %
                           (path, version, fsize, real))
        if not 1 <= count <= MAX_SECTIONS or table + ENTRY_BYTES * count > real:
            raise OpmError("%s: section table (%d entries at %d) out of bounds" %
                           (path, count, table))
        fh.seek(table)
        raw = fh.read(ENTRY_BYTES * count)
    secs = {}
    for i in range(count):
        e = raw[ENTRY_BYTES * i:ENTRY_BYTES * (i + 1)]
        tag = e[:8].rstrip(b"\0").decode("ascii", "replace")
        off, size = struct.unpack_from("<QQ", e, 8)
        if off + size > real:
            raise OpmError("%s: section %s out of bounds" % (path, tag))
        secs[tag] = (off, size)
    return secs


def read_meta(path, secs=None):
    """The META section of the container at path as a dict of stripped strings ("key=value"
    lines); secs from sections(path) when the caller has it. Raises OpmError when there is none
    or it is over MAX_META_BYTES."""
    if secs is None:
        secs = sections(path)
    if "META" not in secs:
        raise OpmError("%s: no META section" % path)
    off, size = secs["META"]
    if size > MAX_META_BYTES:
        raise OpmError("%s: META section of %d bytes" % (path, size))
    with open(path, "rb") as fh:
        fh.seek(off)
        text = fh.read(size).decode("utf-8", "replace")
    meta = {}
    for line in text.splitlines():
        k, sep, v = line.partition("=")
        if sep:
            meta[k.strip()] = v.strip()
    return meta


def meta(path):
    """read_meta(path), or {} when the file cannot be read or is not a valid container (the
    add-on's preset browser lists what it can)."""
    try:
        return read_meta(path)
    except (OSError, ValueError, struct.error):
        return {}
