#!/usr/bin/env bash
# opaline-render --sss-cache FILE (docs/subsurface-rendering.md, "Pre-pass cache"): a render
# writing a fresh cache, the same render reusing it and a render without one give the same bits;
# a moved camera reuses the irradiance already computed (it computes only what its new receivers'
# sums need beyond it: at most a quarter of what it needs) and its image is the uncached one's; a changed light, medium or mesh file changes the key (recomputed);
# what is not a cache (text, a truncated or corrupted cache, a directory) is refused with exit 2
# and left as it was; an older format version is replaced; --sss-cache-only writes the cache for
# the whole film and cropped tiles then compute nothing and match the full render bit for bit;
# two renders writing one cache at once each leave a complete file; a large dipole square laid in
# levels around the view gives the uncached image from a fresh, reused and moved camera's cache.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup render_sss_cache opaline-render

dipole_sphere_scene "$T"
render() { "$R" -v -t 2 --limit sss-max-points=2000 "$@" "$T/scene.xml" 2>"$T/err"; }
# "computed: irradiance at N" of the -v log (the irradiance values this run computed)
computed_irr() { sed -n 's/.*computed: irradiance at \([0-9]*\),.*/\1/p' "$T/err"; }
needs_irr() { sed -n 's/.*the camera needs exitance at [0-9]*, irradiance at \([0-9]*\)$/\1/p' "$T/err"; }

# (a) fresh cache, (b) reused, (c) no cache: the same bits
render -o "$T/none.pfm" || fail "render without a cache exited $?"
full_irr=$(needs_irr)
[ -n "$full_irr" ] && [ "$full_irr" -gt 0 ] || fail "no irradiance count in the log"
render --sss-cache "$T/c" -o "$T/fresh.pfm" || fail "render with a fresh cache exited $?"
grep -q "pre-pass cache $T/c: none yet" "$T/err" || fail "the fresh cache run does not say so"
[ -s "$T/c" ] || fail "no cache written"
render --sss-cache "$T/c" -o "$T/reused.pfm" || fail "render reusing the cache exited $?"
grep -q "pre-pass cache $T/c: reused [0-9]* sources / [1-9][0-9]* receivers, computed 0 new" \
    "$T/err" || fail "the second render did not reuse everything"
cmp -s "$T/none.pfm" "$T/fresh.pfm" || fail "fresh-cache image differs from the uncached one"
cmp -s "$T/none.pfm" "$T/reused.pfm" || fail "reused-cache image differs from the uncached one"

# A moved camera: the irradiance is reused, only new receivers are computed; the same image.
cp "$T/c" "$T/c.before"
render -D camx=2 -o "$T/moved_none.pfm" || fail "moved camera without cache exited $?"
moved_irr=$(needs_irr)
render -D camx=2 --sss-cache "$T/c" -o "$T/moved.pfm" || fail "moved camera with cache exited $?"
grep -q "pre-pass cache $T/c: reused [1-9][0-9]* sources" "$T/err" || fail "moved: nothing reused"
[ "$moved_irr" -gt 0 ] || fail "moved: the view needs no irradiance ($moved_irr)"
[ "$(computed_irr)" -le $((moved_irr / 4)) ] ||
    fail "moved: irradiance computed at $(computed_irr) of the $moved_irr points it needs"
cmp -s "$T/moved_none.pfm" "$T/moved.pfm" || fail "moved camera: image differs with the cache"
cmp -s "$T/c" "$T/c.before" && fail "moved camera: new receivers not added to the cache"

# What the pre-pass depends on changes the key.
for change in lightz=5 medium=Skin2; do
    cp "$T/c" "$T/c.$change"
    render -D $change --sss-cache "$T/c.$change" -o "$T/x.pfm" || fail "$change exited $?"
    grep -q "key differs" "$T/err" || fail "$change: the key did not change"
    [ "$(computed_irr)" -gt 0 ] || fail "$change: nothing recomputed"
    render -D $change -o "$T/y.pfm" || fail "$change without cache exited $?"
    cmp -s "$T/x.pfm" "$T/y.pfm" || fail "$change: image differs from the uncached one"
done
cp "$T/c" "$T/c.mesh"
printf 'v -3 -3 0\nv 3 -3 0\nv 3 3 0\nv -3 3 0.25\nf 1 2 3\nf 1 3 4\n' > "$T/floor.obj"
render --sss-cache "$T/c.mesh" -o "$T/x.pfm" || fail "changed mesh exited $?"
grep -q "key differs" "$T/err" || fail "a changed mesh file did not change the key"
printf 'v -3 -3 0\nv 3 -3 0\nv 3 3 0\nv -3 3 0\nf 1 2 3\nf 1 3 4\n' > "$T/floor.obj"
render --sss-cache "$T/c" -o "$T/x.pfm" || fail "restored mesh exited $?"
grep -q "computed 0 new" "$T/err" || fail "the restored mesh file does not match its cache"

# Not a cache: refused (exit 2), never overwritten.
printf 'my notes\n' > "$T/notes"
head -c 100 "$T/c" > "$T/trunc"
python3 - "$T/c" "$T/flip" <<'PY'
import sys
b = bytearray(open(sys.argv[1], "rb").read())
b[len(b) // 2] ^= 0x40
open(sys.argv[2], "wb").write(b)
PY
mkdir "$T/dir"
for f in notes trunc flip dir; do
    [ -f "$T/$f" ] && cp "$T/$f" "$T/$f.orig"
    render --sss-cache "$T/$f" -o "$T/x.pfm"
    rc=$?
    [ $rc -eq 2 ] || fail "--sss-cache $f exited $rc, expected 2"
    grep -q "$T/$f" "$T/err" || fail "--sss-cache $f: the message does not name the file"
    [ -f "$T/$f" ] && { cmp -s "$T/$f" "$T/$f.orig" || fail "$f was modified"; }
done
grep -q "not an opaline pre-pass cache" <(render --sss-cache "$T/notes" -o "$T/x.pfm"; cat "$T/err") ||
    fail "no clear message for a file that is not a cache"

# Another format version: recomputed and replaced.
python3 - "$T/c" "$T/old" <<'PY'
import sys
b = bytearray(open(sys.argv[1], "rb").read())
b[8:12] = (0).to_bytes(4, "little")
open(sys.argv[2], "wb").write(b)
PY
render --sss-cache "$T/old" -o "$T/x.pfm" || fail "old version exited $?"
grep -q "format version 0" "$T/err" || fail "an old format version is not reported"
render --sss-cache "$T/old" -o "$T/x.pfm" || fail "rewritten old version exited $?"
grep -q "computed 0 new" "$T/err" || fail "the old version was not replaced"

# --sss-cache-only, then cropped tiles: nothing new, the full render's pixels.
render -D camx=1 --sss-cache "$T/tiles" --sss-cache-only --crop 0,0,5,5 ||
    fail "--sss-cache-only exited $?"
[ -s "$T/tiles" ] || fail "--sss-cache-only wrote no cache"
render -D camx=1 -o "$T/full.pfm" || fail "full render exited $?"
for c in 0,0,24,20 24,0,24,20 0,20,24,20 24,20,24,20; do
    render -D camx=1 --sss-cache "$T/tiles" --crop $c -o "$T/tile_$c.pfm" || fail "tile $c exited $?"
    grep -q "computed 0 new" "$T/err" || fail "tile $c computed something new"
done
python3 - "$T" <<'PY' || fail "tiles differ from the full render"
import sys
import pfm
def rows(path):  # width, height, rows bottom first
    im = pfm.read(path)
    return im.width, im.height, im.rows()
fw, fh, full = rows(sys.argv[1] + "/full.pfm")
for c in ["0,0,24,20", "24,0,24,20", "0,20,24,20", "24,20,24,20"]:
    x0, top, cw, ch = map(int, c.split(","))
    w, h, tile = rows(sys.argv[1] + "/tile_%s.pfm" % c)
    for y in range(ch):
        assert tile[y] == full[fh - top - ch + y][3 * x0:3 * (x0 + cw)], (c, y)
PY
render --sss-cache-only -o "$T/x.pfm" --sss-cache "$T/tiles"
[ $? -eq 2 ] || fail "--sss-cache-only with -o did not exit 2"
render --sss-cache-only
[ $? -eq 2 ] || fail "--sss-cache-only without --sss-cache did not exit 2"

# Concurrent writers: each leaves a complete file, which the next render reads.
render -D camx=-1 --sss-cache "$T/shared" -o "$T/p1.pfm" & p1=$!
"$R" -q -t 1 --limit sss-max-points=2000 -D camx=2 --sss-cache "$T/shared" -o "$T/p2.pfm" \
    "$T/scene.xml" 2>/dev/null & p2=$!
wait $p1 || fail "concurrent writer 1 exited $?"
wait $p2 || fail "concurrent writer 2 exited $?"
render -D camx=2 --sss-cache "$T/shared" -o "$T/p3.pfm" || fail "reading the shared cache exited $?"
grep -q "pre-pass cache $T/shared: reused" "$T/err" || fail "the shared cache is not valid"
cmp -s "$T/p3.pfm" "$T/moved_none.pfm" || fail "the shared cache gives another image"
# A large dipole square seen close up is laid in levels around the view (docs/subsurface-
# rendering.md, "Large objects"): the cache lends its irradiance, its exitance is summed again,
# so a render from the cache, fresh, reused or with the camera moved, is the uncached one.
cat > "$T/large.xml" <<'XML'
<scene version="0.6.0"><integrator type="path"/>
 <default name="camx" value="30"/>
 <sensor type="perspective"><float name="fov" value="28"/>
  <transform name="toWorld"><lookat origin="$camx,0,60" target="$camx,0,0" up="0,1,0"/></transform>
  <sampler type="independent"><integer name="sampleCount" value="2"/></sampler>
  <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="24"/>
  <rfilter type="box"/></film></sensor>
 <emitter type="spot"><transform name="toWorld"><lookat origin="0,0,200" target="0,0,0"/></transform>
  <spectrum name="intensity" value="40000"/><float name="cutoffAngle" value="5.71"/>
  <float name="beamWidth" value="5.71"/></emitter>
 <shape type="rectangle"><transform name="toWorld"><scale x="150" y="150" z="1"/></transform>
  <subsurface type="dipole"><string name="material" value="Marble"/><float name="sceneUnitsPerMetre" value="1000"/>
  <integer name="maxPoints" value="60000"/><integer name="irrSamples" value="1"/></subsurface></shape>
</scene>
XML
large() { "$R" -v -t 2 "$@" "$T/large.xml" 2>"$T/err"; }
large -o "$T/l_none.pfm" || fail "large square without a cache exited $?"
grep -q "regions around the view" "$T/err" || fail "the large square was not laid in levels"
grep -q "capped at" "$T/err" && fail "the large square was capped"
large --sss-cache "$T/lc" -o "$T/l_fresh.pfm" || fail "large square, fresh cache: exit $?"
large --sss-cache "$T/lc" -o "$T/l_reused.pfm" || fail "large square, reused cache: exit $?"
grep -q "pre-pass cache $T/lc: reused [1-9][0-9]* sources / 0 receivers, computed 0 new" \
    "$T/err" || fail "large square: the irradiance was not all reused"
cmp -s "$T/l_none.pfm" "$T/l_fresh.pfm" || fail "large square: fresh-cache image differs"
cmp -s "$T/l_none.pfm" "$T/l_reused.pfm" || fail "large square: reused-cache image differs"
large -D camx=36 -o "$T/l_moved_none.pfm" || fail "large square moved: exit $?"
large -D camx=36 --sss-cache "$T/lc" -o "$T/l_moved.pfm" || fail "large square moved, cache: $?"
grep -q "pre-pass cache $T/lc: reused [1-9][0-9]* sources" "$T/err" ||
    fail "large square moved: nothing reused"
cmp -s "$T/l_moved_none.pfm" "$T/l_moved.pfm" || fail "large square moved: image differs"

ls "$T" | grep -q "tmp-opaline" && fail "temporary files left behind"
echo "ok"
