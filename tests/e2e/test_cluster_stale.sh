#!/usr/bin/env bash
# opaline-cluster never shows a wrong frame (--local, no SLURM): an edited scene (its included
# file: a grey sphere made red) re-submitted renders again every tile and frame of the old key,
# with a tile missing or not, merged byte-identical to the single render of the new scene;
# -D and -s changes count too; opaline-render --merge-tiles refuses tiles of another scene or
# crop, a file listed twice and a number over 2^31-1 (2^32 + 16), writing nothing; parts of an
# animation submitted into one folder keep every part's frames; the state is not written
# through a link planted at its name.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup cluster_stale opaline-render opaline-cluster

# look SCENE-DIR RGB: the sphere's <bsdf id="look">, in the file the scene includes.
look() {
  printf '<scene version="0.6.0">\n  <bsdf type="diffuse" id="look"><rgb name="reflectance" value="%s"/></bsdf>\n</scene>\n' \
    "$2" > "$1/look.xml"
}
mkdir -p "$T/s"
sphere_scene "$T/s/still.xml" 30 22 2 '<ref id="look"/>'
sed -i 's#<scene version="0.6.0">#<scene version="0.6.0">\n  <include filename="look.xml"/>#' "$T/s/still.xml"
look "$T/s" "0.5"
"$R" -q --list-inputs "$T/s/still.xml" > "$T/inputs" || fail "--list-inputs exited $?"
[ "$(cat "$T/inputs")" = "$(printf '%s\n%s' "$T/s/still.xml" "$T/s/look.xml")" ] ||
  fail "--list-inputs printed: $(cat "$T/inputs")"
key() { "$R" -q --estimate "$@" | sed -n 's/.* key=\([0-9a-f]\{16\}\)$/\1/p'; }
K0=$(key "$T/s/still.xml")
[ -n "$K0" ] || fail "--estimate printed no key"
[ "$(key -s 3 "$T/s/still.xml")" != "$K0" ] || fail "the key does not change with -s"

sub() { "$C" submit "$@" --threads 1 --local >"$T/log" 2>&1; }
single() { "$R" -q -t 2 "$@" -o "$T/single.exr" -o "$T/single.png" || fail "single render"; }
same() {
  cmp -s "$T/single.exr" "$1.exr" && cmp -s "$T/single.png" "$1.png" ||
    fail "$2: $1 is not the single render of the scene as it is now: $(cat "$T/log")"
}

# 1. Tiled: grey, then red with one tile missing, then green with every tile there.
sub "$T/s/still.xml" -o "$T/out" --tiles 4 || fail "submit exited $?: $(tail -5 "$T/log")"
cp -r "$T/out/.cluster/tiles/still" "$T/grey_tiles"
look "$T/s" "0.8, 0.1, 0.1"
rm "$T/out/.cluster/tiles/still/tile_002.exr"
sub "$T/s/still.xml" -o "$T/out" --tiles 4 || fail "red submit exited $?: $(tail -5 "$T/log")"
[ "$(grep -c 'tile00[0-9]: attempt 1 of' "$T/log")" = 4 ] || fail "not 4 tiles rendered: $(cat "$T/log")"
grep -q "tile000: rendering it again: .*another render" "$T/log" || fail "no reason said: $(cat "$T/log")"
single "$T/s/still.xml"
same "$T/out/still" "red, a tile missing"
look "$T/s" "0.1, 0.8, 0.1"
sub "$T/s/still.xml" -o "$T/out" --tiles 4 || fail "green submit exited $?"
grep -q "nothing to render" "$T/log" && fail "the edited scene was not rendered again"
single "$T/s/still.xml"
same "$T/out/still" "green, every tile there"
sub "$T/s/still.xml" -o "$T/out" --tiles 4 || fail "repeat submit exited $?"
grep -q "nothing to render" "$T/log" || fail "an unchanged scene was rendered again: $(cat "$T/log")"

# 2. Untiled: an edit, then -s, re-render the frame.
sub "$T/s/still.xml" -o "$T/whole" || fail "untiled submit exited $?"
look "$T/s" "0.2, 0.2, 0.9"
sub "$T/s/still.xml" -o "$T/whole" || fail "blue submit exited $?"
grep -q "still: rendering it again: .*another version" "$T/log" || fail "blue: $(cat "$T/log")"
single "$T/s/still.xml"
same "$T/whole/still" "blue, untiled"
sub "$T/s/still.xml" -o "$T/whole" -s 3 || fail "-s 3 submit exited $?"
grep -q "nothing to render" "$T/log" && fail "-s 3 was not rendered again"
single -s 3 "$T/s/still.xml"
same "$T/whole/still" "-s 3"
# Another file put in place of an output does not inherit its key.
cp "$T/grey_tiles/tile_000.exr" "$T/whole/still.exr"
sub "$T/s/still.xml" -o "$T/whole" -s 3 --formats exr || fail "replaced submit exited $?"
grep -q "nothing to render" "$T/log" && fail "a replaced output was kept"

# 3. --merge-tiles refuses a tile of another scene (the grey tiles for the green scene), a tile
# listed at another crop, a file listed twice and a number that does not fit in an int.
L=$T/grey_tiles/tiles.txt
"$R" -q "$T/s/still.xml" --merge-tiles "$L" -o "$T/m.exr" 2>"$T/err"
[ $? = 2 ] && grep -q "line 2, tile 0,0 15x11: .*tile_000.exr: a tile of another render (key=$K0 film=30x22 crop=0,0,15,11" "$T/err" ||
  fail "stale tiles merged: $(cat "$T/err")"
look "$T/s" "0.5"
"$R" -q "$T/s/still.xml" --merge-tiles "$L" -o "$T/m.exr" 2>"$T/err" || fail "the grey tiles do not merge for the grey scene"
rm "$T/m.exr"
sed 's/tile_001.exr/tile_000.exr/' "$L" > "$T/grey_tiles/twice.txt"
"$R" -q "$T/s/still.xml" --merge-tiles "$T/grey_tiles/twice.txt" -o "$T/m.exr" 2>"$T/err"
[ $? = 2 ] && grep -q "twice.txt:3: tile_000.exr is listed twice (line 2 too)" "$T/err" || fail "twice: $(cat "$T/err")"
sed -e 's/tile_000.exr/T/; s/tile_001.exr/tile_000.exr/; s/^\(.*\) T$/\1 tile_001.exr/' "$L" > "$T/grey_tiles/swap.txt"
"$R" -q "$T/s/still.xml" --merge-tiles "$T/grey_tiles/swap.txt" -o "$T/m.exr" 2>"$T/err"
[ $? = 2 ] && grep -q "line 2, tile 0,0 15x11: .*tile_001.exr: a tile of another render" "$T/err" || fail "swapped: $(cat "$T/err")"
printf '4294967312 0 15 22 tile_000.exr\n0 0 16 22 tile_001.exr\n' > "$T/grey_tiles/wrap.txt"
"$R" -q "$T/s/still.xml" --merge-tiles "$T/grey_tiles/wrap.txt" -o "$T/m.exr" 2>"$T/err"
[ $? = 2 ] && grep -q "wrap.txt:1: need X Y W H FILE" "$T/err" || fail "2^32 + 16: $(cat "$T/err")"
[ -e "$T/m.exr" ] && fail "a refused merge wrote its output"

# 4. An animation in two parts into one folder: every frame stays in the state.
for f in 1 2 3 4; do sphere_scene "$T/s/f$f.xml" 12 10 1 '<bsdf type="diffuse"/>'; done
sub "$T/s/f1.xml" "$T/s/f2.xml" -o "$T/anim" || fail "part 1 exited $?"
sub "$T/s/f3.xml" "$T/s/f4.xml" -o "$T/anim" || fail "part 2 exited $?"
rm "$T/anim/f1.exr"
"$C" status "$T/anim" > "$T/st" 2>&1
grep -q " 3 of 4 frames complete" "$T/st" || fail "status after the parts: $(cat "$T/st")"
sub "$T/s/f1.xml" "$T/s/f2.xml" -o "$T/anim" || fail "part 1 again exited $?"
grep -q "f1: attempt 1" "$T/log" && ! grep -q "f2: attempt" "$T/log" || fail "part 1 again: $(cat "$T/log")"

# 5. A link planted at the state file's name is replaced, not written through.
echo victim > "$T/victim"
rm "$T/anim/opaline-cluster.json"
ln -s "$T/victim" "$T/anim/opaline-cluster.json"
sub "$T/s/f1.xml" -o "$T/anim" || fail "submit over a link exited $?"
[ "$(cat "$T/victim")" = victim ] || fail "the state was written through a link"
[ -L "$T/anim/opaline-cluster.json" ] && fail "the link is still there"
echo "ok"
