"""
The package, one job per module: config (datasets, sweeps, seeds), common (notes, running a
command, formatting), files (the .opm reader), runs (datasets and factor runs), baselines
(scikit-learn and LAPACK), renders (the paper-style scene with every material; the renderer
against Embree and Cycles), environment (machine and versions), report (tables, goals and the
output files), plots (matplotlib), main (the command line). Run as `python3 -m methods_bench`
with bench/ on the path (bench_methods.sh does).
"""

import os
import sys

# paper_scene.py lives in bench/, the shared .opm reader in the add-on's folder (imported as the
# plain module `opm`: the add-on package's __init__ needs Blender), the PFM reader in tests/.
_BENCH = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
_ROOT = os.path.dirname(_BENCH)
for _p in (_BENCH, os.path.join(_ROOT, "blender_addon", "opaline"), os.path.join(_ROOT, "tests")):
    if _p not in sys.path:
        sys.path.insert(0, _p)
