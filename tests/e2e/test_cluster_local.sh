#!/usr/bin/env bash
# opaline-cluster without SLURM (needs neither root nor the packages): submit --local renders a
# still cut into 4 tiles, merged byte-identical (EXR and PNG) to the single render, and
# resumes (nothing to render; a damaged tile only); --dry-run prints the job graph (a
# merge job depending afterok on the render job's array); opaline-render --estimate prints
# the film and a memory estimate; --merge-tiles refuses a gap and an overlap by line.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup cluster_local opaline-render opaline-cluster

sphere_scene "$T/still.xml" 30 22 3 '<bsdf type="roughplastic"/>'
"$R" --estimate -q "$T/still.xml" > "$T/est" || fail "--estimate exited $?"
grep -Eq '^width=30 height=22 full_width=30 full_height=22 spp=3 translucent=0 memory_mb=[1-9][0-9]* ' "$T/est" ||
  fail "--estimate printed: $(cat "$T/est")"

"$C" submit "$T/still.xml" -o "$T/out" --tiles 4 --threads 1 --local >"$T/log" 2>&1 ||
  fail "submit --local exited $?: $(tail -5 "$T/log")"
"$R" -q -t 2 "$T/still.xml" -o "$T/single.exr" -o "$T/single.png" || fail "single render"
cmp "$T/single.exr" "$T/out/still.exr" || fail "merged EXR differs from the single render"
cmp "$T/single.png" "$T/out/still.png" || fail "merged PNG differs from the single render"
[ "$(grep -c '^[0-9]' "$T/out/.cluster/tiles/still/tiles.txt")" = 4 ] || fail "not 4 tiles"
ls "$T/out" | grep -q partial && fail "a partial image was left"

"$C" submit "$T/still.xml" -o "$T/out" --tiles 4 --threads 1 --local >"$T/log" 2>&1 ||
  fail "second submit --local exited $?"
grep -q "nothing to render" "$T/log" || fail "the second submit rendered: $(cat "$T/log")"
TILE=$T/out/.cluster/tiles/still/tile_001.exr
head -c 100 "$TILE" > "$T/cut" && cat "$T/cut" > "$TILE"
rm "$T/out/still.exr"
"$C" submit "$T/still.xml" -o "$T/out" --tiles 4 --threads 1 --local >"$T/log" 2>&1 ||
  fail "third submit --local exited $?"
[ "$(grep -c ': attempt 1 of' "$T/log")" = 2 ] || fail "not one tile and the merge: $(cat "$T/log")"
grep -q "still.tile001: attempt 1" "$T/log" || fail "tile 1 was not rendered again"
cmp "$T/single.exr" "$T/out/still.exr" || fail "re-merged EXR differs"

rm "$T/out/still.exr" "$TILE"
"$C" submit "$T/still.xml" -o "$T/out" --tiles 4 --threads 1 --dry-run >"$T/dry" 2>&1 ||
  fail "--dry-run exited $?"
grep -q -- "--job-name opaline-render --array 0 --cpus-per-task 1" "$T/dry" || fail "dry run: $(cat "$T/dry")"
grep -q -- "--job-name opaline-merge .*--dependency afterok:" "$T/dry" || fail "dry run: $(cat "$T/dry")"

L=$T/out/.cluster/tiles/still/tiles.txt
printf '0 0 15 22 a.exr\n15 0 14 22 b.exr\n' > "$T/gap.txt"
"$R" -q "$T/still.xml" --merge-tiles "$T/gap.txt" -o "$T/m.exr" 2>"$T/err"
[ $? = 2 ] && grep -q "no tile covers pixel 29,0" "$T/err" || fail "gap: $(cat "$T/err")"
printf '0 0 16 22 a.exr\n15 0 15 22 b.exr\n' > "$T/overlap.txt"
"$R" -q "$T/still.xml" --merge-tiles "$T/overlap.txt" -o "$T/m.exr" 2>"$T/err"
[ $? = 2 ] && grep -q "overlap.txt:2: tile 15,0 15x22 overlaps" "$T/err" || fail "overlap: $(cat "$T/err")"
[ -e "$T/m.exr" ] && fail "a refused merge wrote its output"
echo "ok"
