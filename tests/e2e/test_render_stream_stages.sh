#!/usr/bin/env bash
# opaline-render --stream: PROGRESS records carry their stage (the subsurface pre-pass's
# "irradiance" and "subsurface", then "render"), each stage's fraction rising to 1; every log
# line also goes into the stream as a LOG record (level and text) with --stream-log, and still
# to stderr;
# --limit sss-max-points sets the per-shape cap of irradiance points (its warning arrives as a
# LOG record, the shapes it held counted in the STATS record before END). --crop renders only a window of the film, each pixel bit-identical to the full
# render's (a translucent scene: the pre-pass too); a window outside the film exits 2.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup render_stream_stages opaline-render

dipole_sphere_scene "$T" '<float name="intIOR" value="1.5"/>' # unused: a warning to log

"$R" --stream --stream-log -t 2 --limit sss-max-points=300 -o "$T/full.pfm" "$T/scene.xml" \
    >"$T/stream" 2>"$T/err" || fail "the stream run exited $?"
grep -q "warning: .*capped at 300 " "$T/err" || fail "no capped warning on stderr"
python3 - "$T/stream" <<'PY' || fail "the stream's stage and log records"
import struct, sys
data = open(sys.argv[1], "rb").read()
pos, stages, order, logs, end, stats = 0, {}, [], [], None, None
while pos < len(data):
    magic, typ, n = struct.unpack_from("<4sIQ", data, pos)
    assert magic == b"OPTS", magic
    p = data[pos + 16:pos + 16 + n]
    pos += 16 + n
    if typ == 3:
        frac, = struct.unpack_from("<d", p)
        ln, = struct.unpack_from("<I", p, 8)
        assert n == 12 + ln, (n, ln)
        label = p[12:].decode()
        if label not in stages:
            order.append(label)
        stages.setdefault(label, []).append(frac)
    elif typ == 5:
        logs.append((struct.unpack_from("<I", p)[0], p[4:].decode()))
    elif typ == 6:
        assert n == 72 and end is None, (n, end)
        stats = struct.unpack_from("<5q4I2d", p)
    elif typ == 4:
        end = struct.unpack_from("<I", p)[0]
assert pos == len(data) and end == 0, (pos, len(data), end)
# STATS: the points laid, the one shape held at 300 points, every tile done
assert stats[0] > 0 and stats[5:7] == (1, 1) and stats[7] == stats[8] > 0, stats
assert order == ["irradiance", "subsurface", "render"], order
for label, fr in stages.items():
    assert fr == sorted(fr) and fr[-1] == 1.0 and all(0 <= f <= 1 for f in fr), (label, fr)
warn = [t for lv, t in logs if lv == 1]
assert any("unused parameter 'intIOR'" in t for t in warn), logs
assert any("capped at 300 " in t for t in warn), logs
assert any(lv == 2 and t.startswith("wrote ") for lv, t in logs), logs
print("stages", {k: len(v) for k, v in stages.items()}, "logs", len(logs))
PY

# Without --stream-log, no LOG record (a reader of the first version refuses unknown types).
"$R" --stream -t 2 "$T/scene.xml" >"$T/stream1" 2>"$T/err" || fail "the plain stream exited $?"
python3 - "$T/stream1" <<'PY' || fail "a LOG record without --stream-log"
import struct, sys
data, pos, types = open(sys.argv[1], "rb").read(), 0, set()
while pos < len(data):
    magic, typ, n = struct.unpack_from("<4sIQ", data, pos)
    types.add(typ)
    pos += 16 + n
assert types == {1, 2, 3, 4}, types
PY

# The crop window: the same pixels as the full render, bit for bit.
"$R" --stream -t 2 --limit sss-max-points=300 --crop 13,7,20,25 -o "$T/crop.pfm" \
    "$T/scene.xml" >"$T/cstream" 2>"$T/err" || fail "the crop run exited $?"
python3 - "$T/full.pfm" "$T/crop.pfm" "$T/cstream" <<'PY' || fail "crop pixels differ"
import struct, sys
import pfm
def rows(path):  # width, height, rows bottom first
    im = pfm.read(path)
    return im.width, im.height, im.rows()
fw, fh, full = rows(sys.argv[1])
cw, ch, crop = rows(sys.argv[2])
assert (fw, fh, cw, ch) == (48, 40, 20, 25), (fw, fh, cw, ch)
x0, top = 13, 7
for y in range(ch):          # crop row y (from the bottom) is full row fh - top - ch + y
    fy = fh - top - ch + y
    assert crop[y] == full[fy][3 * x0:3 * (x0 + cw)], ("row", y)
assert sum(sum(r) for r in crop) > 0
s, pos, begin = open(sys.argv[3], "rb").read(), 0, None
while pos < len(s) and begin is None:
    magic, typ, n = struct.unpack_from("<4sIQ", s, pos)
    if typ == 1:
        assert n == 16, n
        begin = struct.unpack_from("<4I", s, pos + 16)
    pos += 16 + n
assert begin == (20, 25, 4, 32), begin  # the crop's size, 4 channels, 32-pixel tiles
PY

for bad in 40,0,9,1 0,0,0,5 1,2,3 a,b,c,d 0,0,49,40; do
    "$R" --crop "$bad" -o "$T/x.pfm" "$T/scene.xml" >/dev/null 2>"$T/err"
    rc=$?
    [ $rc -eq 2 ] || fail "--crop $bad exited $rc, expected 2"
    grep -q -- "--crop" "$T/err" || fail "--crop $bad: the message does not name --crop"
done
echo "ok"
