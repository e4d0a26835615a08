"""The tile stream opaline-render writes with --stream (docs/rendering.md, "Tile stream"):
little-endian records, each b"OPTS", u32 type, u64 payload bytes, payload. `StreamReader`
turns them into named records; no bpy here, so plain Python tests can feed it bytes."""

import array
import struct
import sys
from collections import namedtuple

MAGIC = b"OPTS"
BEGIN, TILE, PROGRESS, END, LOG, STATS = 1, 2, 3, 4, 5, 6  # renderer/cli/stream.h
LOG_LEVELS = ("error", "warning", "info", "debug")
MAX_PAYLOAD = 1 << 34
_HEADER = struct.Struct("<4sIQ")
_BEGIN = struct.Struct("<4I")
_TILE = struct.Struct("<4I")
_STATS = struct.Struct("<5q4I2d")

Begin = namedtuple("Begin", "width height channels tile_size")
Tile = namedtuple("Tile", "x y width height rgba")  # rgba: array('f'), rows top to bottom
Progress = namedtuple("Progress", "fraction label")
End = namedtuple("End", "status")
Log = namedtuple("Log", "level text")  # level: one of LOG_LEVELS
Stats = namedtuple("Stats", "sss_points sss_sources sss_receivers sss_sources_reused "
                            "sss_receivers_reused sss_shapes_reached sss_shapes_capped tiles "
                            "tiles_done sss_seconds render_seconds")


class StreamError(Exception):
    pass


class StreamReader:
    """Reads the records of a binary file object. `next()` returns a Begin, Tile, Progress,
    End, Log or Stats, or None at a clean end of the file; records of a type it does not know
    (a newer renderer) are skipped. Raises StreamError on a malformed stream (bad magic, short
    payload, sizes that do not agree)."""

    def __init__(self, f):
        self.f = f
        self.begin = None  # the Begin record, once read

    def _read(self, n):
        chunks = []
        got = 0
        while got < n:
            c = self.f.read(n - got)
            if not c:
                break
            chunks.append(c)
            got += len(c)
        return b"".join(chunks)

    def __iter__(self):
        while True:
            rec = self.next()
            if rec is None:
                return
            yield rec

    def next(self):
        while True:
            header = self._read(_HEADER.size)
            if not header:
                return None
            if len(header) < _HEADER.size:
                raise StreamError("truncated record header")
            magic, typ, n = _HEADER.unpack(header)
            if magic != MAGIC:
                raise StreamError("bad magic %r (is this renderer writing the tile stream?)"
                                  % magic)
            if n > MAX_PAYLOAD:
                raise StreamError("record of %d bytes is too large" % n)
            p = self._read(n)
            if len(p) < n:
                raise StreamError("truncated record payload")
            parse = _PARSERS.get(typ)
            if parse is not None:
                return parse(self, p)

    def _begin(self, p):
        if len(p) < _BEGIN.size:
            raise StreamError("BEGIN of %d bytes (expected %d)" % (len(p), _BEGIN.size))
        rec = Begin(*_BEGIN.unpack_from(p))
        if rec.channels != 4:
            raise StreamError("BEGIN with %d channels (expected 4)" % rec.channels)
        if rec.tile_size < 1:
            raise StreamError("BEGIN with tiles of side %d" % rec.tile_size)
        self.begin = rec
        return rec

    def _tile(self, p):
        if len(p) < _TILE.size:
            raise StreamError("short TILE record")
        x, y, w, h = _TILE.unpack_from(p)
        if len(p) != _TILE.size + 16 * w * h:
            raise StreamError("TILE %dx%d with %d payload bytes" % (w, h, len(p)))
        b = self.begin
        if b is not None and (x + w > b.width or y + h > b.height):
            raise StreamError("TILE at %d,%d size %dx%d outside the %dx%d image" %
                              (x, y, w, h, b.width, b.height))
        a = array.array('f')
        a.frombytes(p[_TILE.size:])
        if sys.byteorder != "little":
            a.byteswap()
        return Tile(x, y, w, h, a)

    def _progress(self, p):
        if len(p) < 12:
            raise StreamError("short PROGRESS record")
        frac, n = struct.unpack_from("<dI", p)
        if 12 + n > len(p):
            raise StreamError("PROGRESS label of %d bytes in a %d-byte record" % (n, len(p)))
        return Progress(frac, p[12:12 + n].decode("utf-8", "replace"))

    def _end(self, p):
        if len(p) < 4:
            raise StreamError("short END record")
        return End(struct.unpack_from("<I", p)[0])

    def _log(self, p):
        if len(p) < 4:
            raise StreamError("short LOG record")
        lv = struct.unpack_from("<I", p)[0]
        return Log(LOG_LEVELS[lv] if lv < len(LOG_LEVELS) else "info",
                   p[4:].decode("utf-8", "replace"))

    def _stats(self, p):
        if len(p) < _STATS.size:
            raise StreamError("STATS of %d bytes (expected %d)" % (len(p), _STATS.size))
        return Stats(*_STATS.unpack_from(p))


_PARSERS = {BEGIN: StreamReader._begin, TILE: StreamReader._tile,
            PROGRESS: StreamReader._progress, END: StreamReader._end, LOG: StreamReader._log,
            STATS: StreamReader._stats}


def tile_count(width, height, tile_size):
    """The tiles of a width x height image cut in tile_size squares (the renderer's grid)."""
    return ((width + tile_size - 1) // tile_size) * ((height + tile_size - 1) // tile_size)
