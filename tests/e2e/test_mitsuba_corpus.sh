#!/usr/bin/env bash
# The published Mitsuba scenes of ../shared/scenes/mitsuba against what this checkout promises
# for each, tests/e2e/mitsuba_corpus_expect.tsv: a line per scene of the corpus' MANIFEST.tsv,
#   SCENE <tab> render            opaline-render --check loads it
#   SCENE <tab> match             ... and its render at 32 spp passes opaline-image-compare
#                                 against Mitsuba 3's reference (docs/testing.md)
#   SCENE <tab> refused:TEXT      it is refused, and its reason (as scripts/mitsuba-corpus-report
#                                 gives it: the error without its file:line) contains TEXT
# and, after another tab, an optional note (why a refusal is final, for instance).
# Each scene is classified by scripts/mitsuba-corpus-report (fails < refused < render < match).
# The test fails when a scene does worse than its line (a crash or time-out is worse than
# anything, a refusal worse than a render, a render that no longer matches worse than a match)
# and when the table and the manifest disagree; when a scene does better, or is refused for
# another reason, it passes and prints the line to put in the table. First, the same on a small
# corpus made here, whose outcomes are known, with a table that is wrong on purpose. Skips when
# the shared corpus is absent.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup mitsuba_corpus opaline-render opaline-image-compare
CORPUS=${OPALINE_SHARED_DIR:-$SRC/../shared}/scenes/mitsuba
[ -f "$CORPUS/MANIFEST.tsv" ] || e2e_skip "$CORPUS/MANIFEST.tsv is absent (the shared scenes)"

# classify CORPUS RESULTS: the report's line per scene. 32 spp: a 48 x 48 reference scene
# renders in about a second under the sanitizers, and the z-test takes the sample count into
# account (the report's figures give each comparison's resolution).
classify() {
  python3 "$SRC/scripts/mitsuba-corpus-report" --bin "$BIN" --corpus "$1" --spp 32 --jobs 2 \
    --timeout 120 --format tsv --work "$T" >"$2" 2>"$T/err" \
    || fail "scripts/mitsuba-corpus-report failed on $1"
}

# judge EXPECT RESULTS: prints each scene's outcome, the lines to update; exit 1 when a scene
# does worse than its line or the table and the results disagree on which scenes there are.
judge() {
  python3 - "$1" "$2" <<'PY'
import sys

RANK = {"fails": 0, "refused": 1, "render": 2, "match": 3}
expect_path, results_path = sys.argv[1], sys.argv[2]
expected, problems = {}, []
with open(expect_path) as f:
    for n, line in enumerate(f, 1):
        if not line.strip() or line.startswith("#"):
            continue
        fields = line.rstrip("\n").split("\t")
        want = fields[1] if len(fields) in (2, 3) else ""  # the third: a note
        if not (want in ("render", "match") or (want.startswith("refused:") and len(want) > 8)):
            problems.append("%s:%d: not SCENE<tab>render|match|refused:TEXT[<tab>NOTE]: %r" % (
                expect_path, n, line.rstrip("\n")))
            continue
        if fields[0] in expected:
            problems.append("%s:%d: %s listed twice" % (expect_path, n, fields[0]))
        expected[fields[0]] = want

counts, updates, seen = {}, [], set()
with open(results_path) as f:
    for line in f:
        scene, folder, outcome, detail = line.rstrip("\n").split("\t", 3)
        seen.add(scene)
        counts[outcome] = counts.get(outcome, 0) + 1
        got = "refused:" + detail if outcome == "refused" else outcome
        want = expected.get(scene)
        if want is None:
            problems.append("%s has no line in the table; today's: %s\t%s" % (scene, scene, got))
            continue
        want_outcome, text = want.split(":", 1)[0], want[8:]
        same = outcome == want_outcome and (outcome != "refused" or text in detail)
        print("%-78s %-8s %s%s" % (scene, outcome, "" if same else "(line: %s) " % want, detail))
        if RANK[outcome] < RANK[want_outcome]:
            problems.append("%s does worse than its line '%s': %s %s" % (scene, want, outcome,
                                                                          detail))
        elif not same:
            updates.append("%s\t%s" % (scene, got))
for scene in sorted(set(expected) - seen):
    problems.append("%s is in the table but not in the corpus' MANIFEST.tsv" % scene)

print("outcomes: " + ", ".join("%s %d" % (o, counts.get(o, 0)) for o in RANK))
if updates:
    print("These scenes do better than (or differently from) their lines; put these lines in "
          "%s:" % expect_path)
    for u in updates:
        print("  " + u)
for p in problems:
    print("FAIL: " + p)
sys.exit(1 if problems else 0)
PY
}

# A corpus whose outcomes are known: an environment of constant radiance seen directly (every
# pixel exactly that radiance) against its own value (match) and twice it (renders, does not
# match), an integrator no one has (refused), a plain scene (renders); and a table that
# promises too much for the second and third and too little for the fourth.
M=$T/mini
mkdir -p "$M/s/refs"
sky() { # sky FILE INTEGRATOR
  cat > "$1" <<XML
<scene version="0.6.0">
  <integrator type="$2"/>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="toWorld"><lookat origin="0, 0, 0" target="0, 0, 1" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/>
      <rfilter type="box"/></film>
  </sensor>
  <emitter type="constant"><rgb name="radiance" value="0.25, 0.5, 0.75"/></emitter>
  <shape type="rectangle"><transform name="toWorld"><translate z="-5"/></transform></shape>
</scene>
XML
}
sky "$M/s/sky_path.xml" path
sky "$M/s/wrong_path.xml" path
sky "$M/s/unknown.xml" opaline_test_unknown
sky "$M/s/plain.xml" path
python3 - "$M/s/refs" <<'PY'
import struct, sys
def pfm(path, rgb):
    with open(path, "wb") as f:
        f.write(b"PF\n16 16\n-1.0\n" + struct.pack("<3f", *rgb) * 256)
pfm(sys.argv[1] + "/sky_ref_rgb.pfm", (0.25, 0.5, 0.75))
pfm(sys.argv[1] + "/wrong_ref_rgb.pfm", (0.5, 1.0, 1.5))
for name in ("sky", "wrong"):
    pfm(sys.argv[1] + "/%s_ref_rgb_var.pfm" % name, (0.0, 0.0, 0.0))
PY
tsv() { local IFS=$'\t'; printf '%s\n' "$*"; } # tsv FIELD...: one tab-separated line
{ tsv s/sky_path.xml 0.6.0 s/refs/sky_ref_rgb.pfm
  tsv s/wrong_path.xml 0.6.0 s/refs/wrong_ref_rgb.pfm
  tsv s/unknown.xml 0.6.0 -; tsv s/plain.xml 0.6.0 -; } > "$M/MANIFEST.tsv"
{ tsv s/sky_path.xml match; tsv s/wrong_path.xml match; tsv s/unknown.xml render
  tsv s/plain.xml refused:unknown; } > "$M/expect.tsv"
classify "$M" "$T/mini.tsv"
judge "$M/expect.tsv" "$T/mini.tsv" >"$T/mini.out"; rc=$?
sed 's/^/  small corpus, its wrong table on purpose: /' "$T/mini.out"
[ $rc = 1 ] || fail "the small corpus' wrong table passed"
for want in "$(tsv s/sky_path.xml s match)" "$(tsv s/wrong_path.xml s render 'does not match')" \
            "$(tsv s/unknown.xml s refused '<integrator type="opaline_test_unknown">')" \
            "$(tsv s/plain.xml s render)"; do
  grep -qF "$want" "$T/mini.tsv" || fail "the small corpus: no line '$want' in the report's results"
done
grep -q '^FAIL: s/wrong_path.xml does worse' "$T/mini.out" || fail "a lost match was not caught"
grep -q '^FAIL: s/unknown.xml does worse' "$T/mini.out" || fail "a lost render was not caught"
grep -q '^FAIL: s/sky_path.xml\|^FAIL: s/plain.xml' "$T/mini.out" \
  && fail "a scene that keeps its line failed"
grep -qF "  $(tsv s/plain.xml render)" "$T/mini.out" || fail "a scene doing better got no new line"
python3 "$SRC/scripts/mitsuba-corpus-report" --bin "$BIN" --corpus "$M" --spp 32 >"$T/mini.md" \
  2>"$T/err" || fail "scripts/mitsuba-corpus-report (Markdown) failed on the small corpus"
for want in '| s/ | 4 | 3 | 2 | 1 | 1 | 0 |' \
            '| `<integrator type="opaline_test_unknown">: unknown integrator` | 1 | s 1 |' \
            '- `s/wrong_path.xml`: does not match at 32 spp'; do
  grep -qF -- "$want" "$T/mini.md" \
    || { cat "$T/mini.md"; fail "the Markdown report lacks '$want'"; }
done
echo "ok   the small corpus: classified as built, its wrong table caught, its Markdown report"

classify "$CORPUS" "$T/results.tsv"
judge "$SRC/tests/e2e/mitsuba_corpus_expect.tsv" "$T/results.tsv"
