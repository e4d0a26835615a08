"""Unit tests of the method benchmark's report code (bench/methods_bench/report.py) on
synthetic records shaped like those of runs.factor_runs and renders.render_dataset: the CSV
files, the tables, the render table and its rank agreement, the goals and the summary. Fast and
standard library only; run by tests/e2e/test_bench_report.sh (python3 -m unittest)."""

import csv
import os
import sys
import tempfile
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "bench"))

from methods_bench import report  # noqa: E402
from methods_bench.config import QUICK_TYPICAL, SERIES  # noqa: E402
from methods_bench.runs import label, series  # noqa: E402

DATASETS = {"chess4x4": {"width": "24", "height": "24", "kernel": "9"},
            "veined-marble": {"width": "24", "height": "24", "kernel": "9"}}
KINDS = {"chess4x4": "chess", "veined-marble": "marble"}
SWEEP = ([("raw", {})] + [("svd", {"T": t}) for t in (2, 4)] + [("tucker", {"T": 3, "P": 2})]
         + [("kcta", {"C": 2, "Km": 1, "T": 2})] + [("nmf", {"T": t}) for t in (2, 4)]
         + [("nmf", {"E": 0, "T": 4})])
ORIGINAL = 559872


def run_record(ds, method, par, i):
    """A record like runs.factor_runs's: raw is the dataset (no error), the others smaller."""
    raw = method == "raw"
    size = ORIGINAL if raw else 4000 * (i + 1)
    rmse = 0.0 if raw else 0.01 / (i + 1) * (3 if method == "nmf" else 1)
    return {"dataset": ds, "method": method, "label": label(method, par),
            "series": series(method, par), "T": par.get("T", ""), "P": par.get("P", ""),
            "C": par.get("C", ""), "Km": par.get("Km", ""),
            "E": par.get("E", 1) if method == "nmf" else "", "size_bytes": size,
            "original_bytes": ORIGINAL, "compression_ratio": ORIGINAL / size, "rmse": rmse,
            "relative_rmse": rmse * 10, "psnr": None if raw else 40.0 + i,
            "se_ratio_db": None if raw else 20.0 + i, "max_error": rmse * 5,
            "factor_seconds": 0.01 * (i + 1), "total_seconds": 0.1, "eval_ns": 50.0 + i,
            "eval_random_ns": 60.0, "albedo_map_seconds": 1e-4, "peak_memory_bytes": 1 << 25,
            "channel0_seconds": 0.003, "repeats": 1}


def render_record(rec, i):
    raw = rec["method"] == "raw"
    return {"dataset": rec["dataset"], "method": rec["method"], "label": rec["label"],
            "series": rec["series"], "T": rec["T"], "P": rec["P"], "C": rec["C"],
            "Km": rec["Km"], "E": rec["E"], "size_bytes": rec["size_bytes"],
            "data_rmse": rec["rmse"], "data_psnr": rec["psnr"], "res": 32, "spp": 2,
            "threads": 2, "render_seconds": 0.5, "cpu_seconds": 0.9, "prepass_seconds": 0.1,
            "camera_seconds": 0.3, "image_rmse": 0.0 if raw else rec["rmse"] * 2,
            "image_relative_rmse": 0.0 if raw else rec["rmse"], "image_psnr": None,
            "repeats": 1, "image": "/nonexistent/%d.pfm" % i}


def records():
    runs = [run_record(ds, m, p, i) for ds in DATASETS for i, (m, p) in enumerate(SWEEP)]
    renders = [render_record(r, i) for i, r in enumerate(runs)]
    return runs, renders


RS = {"size": 32, "spp": 2, "threads": 2, "scene": "a sphere", "why": None}
RENDERER = {"embree": None, "embree_reason": "skipped in quick mode", "cycles": None,
            "cycles_reason": "skipped in quick mode"}
BASELINES = [
    {"dataset": "chess4x4", "channel": 0, "rows": 576, "cols": 81, "rank": 4,
     "optimal_log_domain_error": 0.1,
     "entries": [{"who": "opaline svd (in process)", "seconds": 0.01, "seconds_runs": [0.01] * 3,
                  "log_domain_error": 0.1, "error_over_optimal": 1.001, "rd_rmse": 0.001},
                 {"who": "opaline-factor --method svd", "seconds": 0.02,
                  "log_domain_error": 0.1, "error_over_optimal": 1.001, "rd_rmse": 0.001},
                 {"who": "sklearn randomized_svd", "seconds": 0.05, "log_domain_error": 0.1,
                  "error_over_optimal": 1.0, "rd_rmse": 0.001}]},
    {"dataset": "chess4x4", "channel": 0, "rows": 576, "cols": 81, "rank": 4,
     "entries": [{"who": "sklearn NMF", "seconds": 0.2, "remainder_relative_error": 0.3,
                  "rd_rmse": 0.004}]},
]


class TestReport(unittest.TestCase):
    def setUp(self):
        self.runs, self.renders = records()
        self.out = tempfile.mkdtemp(prefix="bench-report-",
                                    dir=os.environ.get("OPALINE_TEST_TMP") or None)

    def tearDown(self):
        for f in os.listdir(self.out):
            os.remove(os.path.join(self.out, f))
        os.rmdir(self.out)

    def read_csv(self, name):
        with open(os.path.join(self.out, name), newline="") as f:
            return list(csv.DictReader(f))

    def test_csv_files(self):
        report.write_csvs(self.out, self.runs, self.renders, BASELINES)
        rows = self.read_csv("runs.csv")
        self.assertEqual(len(rows), len(self.runs))
        self.assertEqual(list(rows[0]), report.RUN_FIELDS)
        for row, rec in zip(rows, self.runs):
            self.assertEqual(row["label"], rec["label"])
            self.assertEqual(int(row["size_bytes"]), rec["size_bytes"])
            cr = float(row["compression_ratio"])
            self.assertAlmostEqual(cr, int(row["original_bytes"]) / int(row["size_bytes"]),
                                   delta=1e-9 * cr)
        # nmf twice over: the issue's baseline (E=1) and NMF of Rd itself (E=0), its own series
        by = {r["label"]: r for r in rows if r["dataset"] == "chess4x4"}
        self.assertEqual((by["nmf E=0 T=4"]["series"], by["nmf E=0 T=4"]["E"]), ("nmf E=0", "0"))
        self.assertEqual((by["nmf T=4"]["series"], by["nmf T=4"]["E"]), ("nmf", "1"))
        self.assertEqual(by["svd T=2"]["E"], "")
        renders = self.read_csv("renders.csv")
        self.assertEqual(len(renders), len(self.renders))
        self.assertEqual(list(renders[0]), report.RENDER_FIELDS)
        base = self.read_csv("baselines.csv")
        self.assertEqual(len(base), 4)
        self.assertEqual([b["problem"] for b in base], ["svd", "svd", "svd", "nmf"])
        self.assertEqual(base[3]["relative_error"], "0.3")
        # nothing rendered: no renders.csv
        os.remove(os.path.join(self.out, "renders.csv"))
        report.write_csvs(self.out, self.runs, [], BASELINES)
        self.assertFalse(os.path.exists(os.path.join(self.out, "renders.csv")))

    def test_tables(self):
        tab = "\n".join(report.tables(self.runs, DATASETS, BASELINES, QUICK_TYPICAL,
                                      QUICK_TYPICAL["nmf"]))
        for head in ("## Table 1", "## Table 2", "## Table I", "## Baselines"):
            self.assertIn(head, tab)
        # Table I: every configuration, once
        for r in self.runs:
            par = r["label"][len(r["series"]):].strip()
            self.assertIn(f"| {r['dataset']} | {r['series']} | {par} |", tab)
        # Table 2: each series against the nmf target, the smallest configuration reaching it
        t2 = tab.split("## Table 2")[1].split("## Table I")[0]
        for ds in DATASETS:
            for s in SERIES:
                self.assertIn(f"| {ds} | ", t2)
                self.assertTrue(any(line.startswith(f"| {ds} |") and f"| {s} |" in line
                                    for line in t2.splitlines()), (ds, s))

    def test_render_table_and_agreement(self):
        agreement = [report.rank_agreement(self.renders, ds) for ds in DATASETS]
        for g in agreement:
            # image error here is twice the data error: the same ranking
            self.assertAlmostEqual(g["spearman"], 1.0)
            self.assertEqual(g["swapped"], [])
            self.assertEqual(g["materials"], len(SWEEP) - 1)  # raw is the reference
        tab = "\n".join(report.render_table(self.renders, RS, agreement))
        self.assertTrue(tab.startswith("## Render time and image error per method"))
        for r in self.renders:
            par = r["label"][len(r["series"]):].strip()
            self.assertIn(f"| {r['dataset']} | {r['series']} | {par} |", tab)
        self.assertIn("Spearman", tab)
        self.assertIn("rho = 1.000", tab)
        # a swapped pair is named
        swapped = [dict(r) for r in self.renders]
        a, b = [r for r in swapped if r["dataset"] == "chess4x4" and r["method"] == "svd"]
        a["image_rmse"], b["image_rmse"] = b["image_rmse"], a["image_rmse"]
        g = report.rank_agreement(swapped, "chess4x4")
        self.assertIn((a["label"], b["label"]), g["swapped"])
        self.assertLess(g["spearman"], 1.0)
        # not rendered: the reason instead of a table
        none = "\n".join(report.render_table([], dict(RS, why="--no-render given"), []))
        self.assertIn("Not rendered: --no-render given.", none)

    def test_spearman(self):
        self.assertAlmostEqual(report.spearman([1, 2, 3, 4], [10, 20, 30, 40]), 1.0)
        self.assertAlmostEqual(report.spearman([1, 2, 3, 4], [4, 3, 2, 1]), -1.0)
        self.assertIsNone(report.spearman([1, 2], [1, 2]))
        self.assertIsNone(report.spearman([1, 1, 1], [1, 2, 3]))

    def test_goals_and_summary(self):
        gl = report.goals(self.runs, DATASETS, KINDS, BASELINES, RENDERER)
        names = [g["goal"] for g in gl]
        self.assertTrue(any("0.5 x NMF of the remainder" in n for n in names), names)
        self.assertTrue(any("0.5 x NMF of Rd itself" in n for n in names), names)
        self.assertTrue(any("Embree" in n for n in names), names)
        self.assertTrue(any("Cycles" in n for n in names), names)
        # the NMF goal only for the chessboards
        self.assertFalse(any(n.startswith("veined-marble: at equal") for n in names))
        # nmf's RMSE is 3x the others' at each size here: the goal is met (ratio <= 0.5)
        nmf = [g for g in gl if "NMF of the remainder" in g["goal"]][0]
        self.assertEqual(nmf["verdict"], "met")
        svd = [g for g in gl if "randomized_svd" in g["goal"]][0]
        self.assertEqual(svd["verdict"], "met")
        self.assertEqual(svd["opaline_factor_seconds"], 0.02)
        env = {"cpu": "test cpu", "cpus": 2, "load_average": [0.5, 0.5, 0.5]}
        lines = report.summary_lines(True, 1, env, gl, ["numpy is not installed"])
        text = "\n".join(lines)
        self.assertIn("Mode: quick; 1 run(s)", text)
        self.assertIn("## Goals", text)
        for g in gl:
            self.assertIn(f"- **{g['verdict']}** - {g['goal']}", text)
        self.assertIn("## Skipped\n\n- numpy is not installed", text)
        self.assertNotIn("## Skipped", "\n".join(report.summary_lines(False, 3, env, gl, [])))


if __name__ == "__main__":
    unittest.main()
