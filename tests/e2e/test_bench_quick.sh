#!/usr/bin/env bash
# test_bench_quick.sh - keeps bench/bench_methods.sh working: its quick mode (tiny datasets,
# every method, one run each) must finish and write sane runs.csv, results.json and tables.md,
# and render the paper-style scene (32 x 32, 2 spp) with raw and every factored material:
# renders.csv and the table "Render time and image error per method", raw's image error 0.
# Needs python3 only (numpy, scikit-learn and matplotlib parts run when present, else are
# skipped by the benchmark with a message). Exit 77 (skip) when python3 is absent.
set -euo pipefail
command -v python3 >/dev/null || { echo "python3 not installed: skipped"; exit 77; }
src=${OPALINE_SOURCE_DIR:-$(cd "$(dirname "$0")/../.." && pwd)}
bin=${OPALINE_BIN_DIR:?OPALINE_BIN_DIR must name the built binaries}
tmp=${OPALINE_TEST_TMP:-${TMPDIR:-/tmp}}
out=$(mktemp -d "$tmp/bench_quick.XXXXXX")
trap 'rm -rf "$out"' EXIT

bash "$src/bench/bench_methods.sh" --quick --build "$bin/.." --out "$out" > "$out/stdout.txt" ||
  { cat "$out/stdout.txt" "$out/commands.log" >&2; exit 1; }
for f in runs.csv results.json tables.md baselines.csv renders.csv; do
  [ -s "$out/$f" ] || { echo "FAIL: $f missing or empty" >&2; exit 1; }
done
# opaline-bench-rsvd refuses a matrix file of the wrong size, naming it.
head -c 100 /dev/zero > "$out/short.f32"
rc=0
"$bin/opaline-bench-rsvd" "$out/short.f32" 10 5 2 2> "$out/err.txt" || rc=$?
[ "$rc" = 2 ] && grep -q "short.f32: too short" "$out/err.txt" ||
  { echo "FAIL: opaline-bench-rsvd on a short file: exit $rc, $(cat "$out/err.txt")" >&2; exit 1; }
grep -q "^## Goals" "$out/stdout.txt" || { echo "FAIL: no goals in the output" >&2; exit 1; }
grep -q "^## Render time and image error per method" "$out/tables.md" ||
  { echo "FAIL: no render table in tables.md" >&2; exit 1; }

python3 - "$out" <<'PY'
import csv, json, math, os, sys
out = sys.argv[1]
res = json.load(open(os.path.join(out, "results.json")))
rows = list(csv.DictReader(open(os.path.join(out, "runs.csv"))))
def fail(msg):
    sys.exit("FAIL: " + msg)
datasets = {"chess4x4", "chess8x8", "veined-marble", "chess4x4-mc"}
if set(res["datasets"]) != datasets:
    fail(f"datasets {sorted(res['datasets'])}")
if len(rows) != len(res["runs"]) or len(rows) != 8 * len(datasets):
    fail(f"{len(rows)} CSV rows, {len(res['runs'])} runs in the JSON, expected {8 * 4}")
for key in ("cpu", "python", "opaline_factor"):
    if key not in res["environment"]:
        fail(f"environment lacks {key}")
for ds in datasets:
    got = {r["method"] for r in rows if r["dataset"] == ds}
    if got != {"raw", "svd", "tucker", "kcta", "nmf"}:
        fail(f"{ds}: methods {sorted(got)}")
    by = {r["label"]: r for r in rows if r["dataset"] == ds}
    raw = by["raw"]
    # nmf twice over: the issue's baseline (E=1) and NMF of Rd itself (E=0), its own series
    e0 = by.get("nmf E=0 T=4")
    if not (e0 and e0["series"] == "nmf E=0" and e0["E"] == "0" and e0["T"] == "4" and
            by["nmf T=4"]["series"] == "nmf" and by["nmf T=4"]["E"] == "1"):
        fail(f"{ds}: nmf series/E columns wrong: {e0}, {by.get('nmf T=4')}")
    for r in by.values():
        size, cr, rmse = int(r["size_bytes"]), float(r["compression_ratio"]), float(r["rmse"])
        ft, ev = float(r["factor_seconds"]), float(r["eval_ns"])
        if not (size > 0 and math.isfinite(rmse) and rmse >= 0 and ft >= 0 and ev > 0):
            fail(f"{ds} {r['label']}: size {size}, RMSE {rmse}, factor {ft} s, eval {ev} ns")
        if abs(cr - int(r["original_bytes"]) / size) > 1e-6 * cr:
            fail(f"{ds} {r['label']}: compression ratio {cr} is not original / size")
        if r["method"] != "raw" and not (size < int(raw["size_bytes"]) and rmse > 0):
            fail(f"{ds} {r['label']}: a factored material ({size} bytes, RMSE {rmse}) should be "
                 f"smaller than the dataset ({raw['size_bytes']}) and inexact")
    if float(raw["rmse"]) > 1e-3 * float(by["svd T=4"]["rmse"]):
        fail(f"{ds}: raw RMSE {raw['rmse']} is not ~0")
    # svd: more terms, less error, larger file (nmf minimizes the remainder's error, not Rd's, so
    # its RMSE of Rd need not fall with T)
    for m in ("svd",):
        lo, hi = by[f"{m} T=2"], by[f"{m} T=4"]
        if not (float(hi["rmse"]) <= float(lo["rmse"]) * 1.0001 and
                int(hi["size_bytes"]) > int(lo["size_bytes"])):
            fail(f"{ds} {m}: T=4 (RMSE {hi['rmse']}, {hi['size_bytes']} B) vs T=2 "
                 f"(RMSE {lo['rmse']}, {lo['size_bytes']} B)")
# renders: raw and every factored material of each dataset, at the quick size, raw the reference
renders = list(csv.DictReader(open(os.path.join(out, "renders.csv"))))
if len(renders) != len(rows) or len(res["renders"]) != len(rows):
    fail(f"{len(renders)} renders in the CSV, {len(res['renders'])} in the JSON, "
         f"expected {len(rows)} (one per configuration)")
table = open(os.path.join(out, "tables.md")).read().split("## Render time and image error")[1]
for ds in datasets:
    by = {r["label"]: r for r in renders if r["dataset"] == ds}
    if set(by) != {r["label"] for r in rows if r["dataset"] == ds}:
        fail(f"{ds}: rendered {sorted(by)}")
    for r in by.values():
        t, e = float(r["render_seconds"]), float(r["image_rmse"])
        if not (t > 0 and math.isfinite(e) and e >= 0 and int(r["res"]) == 32 and
                int(r["spp"]) == 2 and os.path.exists(r["image"])):
            fail(f"{ds} {r['label']}: render {t} s, image RMSE {e}, {r['res']} px, "
                 f"{r['spp']} spp, image {r['image']}")
        par = r["label"][len(r["series"]):].strip()
        if f"| {ds} | {r['series']} | {par} |" not in table:
            fail(f"{ds} {r['label']}: no row in the render table")
    if float(by["raw"]["image_rmse"]) != 0:
        fail(f"{ds}: raw's image RMSE against itself is {by['raw']['image_rmse']}")
    if not any(float(r["image_rmse"]) > 0 for r in by.values()):
        fail(f"{ds}: every factored material renders exactly like raw")
    # nmf misses Rd by far more than svd T=4 (see the data RMSE): so must its image
    if not float(by["nmf T=4"]["image_rmse"]) > float(by["svd T=4"]["image_rmse"]):
        fail(f"{ds}: image RMSE of nmf T=4 {by['nmf T=4']['image_rmse']} <= svd T=4's "
             f"{by['svd T=4']['image_rmse']}")
if len(res["render_rank_agreement"]) != len(datasets) or "Spearman" not in table:
    fail("no rank agreement between image and data error")
if res["plots"] and not any(p.endswith("renders.png") for p in res["plots"]):
    fail("no render plot among " + ", ".join(res["plots"]))
names = [g["goal"] for g in res["goals"]]
if not (any("Embree" in n for n in names) and any("0.5 x NMF of the remainder" in n for n in names)
        and any("0.5 x NMF of Rd itself" in n for n in names)):
    fail(f"goals incomplete: {names}")
if res["baselines"]:  # numpy present: opaline's svd against the LAPACK optimum
    for b in res["baselines"]:
        if "optimal_log_domain_error" in b:
            e = b["entries"][0]["error_over_optimal"]
            if not (e is not None and e <= 1.01):
                fail(f"{b['dataset']}: opaline svd error {e} x optimum")
            whos = [x["who"] for x in b["entries"]]
            if not (whos[1].startswith("opaline-factor") and b["entries"][0]["seconds"] > 0
                    and len(b["entries"][0]["seconds_runs"]) >= 3):
                fail(f"{b['dataset']}: opaline's svd not timed both ways: {whos}")
elif not any("numpy" in n for n in res["notes"]):
    fail("no baselines and no note saying why")
print(f"ok: {len(rows)} configurations on {len(datasets)} datasets, "
      f"{len(res['baselines'])} baseline comparisons, {len(renders)} renders, "
      f"{len(res['plots'])} plots, "
      f"{res['seconds']:.1f} s")
PY
