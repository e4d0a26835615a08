#!/usr/bin/env bash
# SLURM benchmark: the paper-style scene (bench/paper_scene.py: Spot, or a sphere where
# ../shared is absent, with SVD_S10_Chess4x4) rendered through a one-node SLURM cluster started
# in a temp folder (cluster/local_cluster.sh; needs root, slurm-wlm and munge) as 1, 4 and 16
# tiles, and an 8-frame animation; against the single render: total CPU time of every task
# (pre-pass, tiles, merge; measured by opaline-cluster run), the overhead in per cent (goal:
# within 10 % at 4 tiles, the pre-pass done once), wall time, whether the merged image is
# bit-identical. Details: bench_cluster.py, docs/cluster.md.
# Usage: bench/bench_cluster.sh [BUILD_DIR]
#   Environment: RES (image side, default 256), SPP (default 16), FRAMES (default 8),
#   TILES (default "1 4 16"), THREADS (per task, default 1), OPALINE_SHARED_DIR.
set -uo pipefail
SRC=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "${1:-$SRC/build}" && pwd)
for tool in opaline-render opaline-cluster; do
  [ -x "$BUILD/bin/$tool" ] || { echo "error: $BUILD/bin/$tool not built"; exit 1; }
done
source "$SRC/cluster/local_cluster.sh"
D=$(mktemp -d "${TMPDIR:-/tmp}/bench-cluster.XXXXXX")
chmod 755 "$D"
trap 'ids=$(squeue -h -o %A 2>/dev/null | sort -u); [ -n "$ids" ] && scancel $ids; sleep 1;
      local_cluster_stop "$D/slurm"; rm -rf "$D"' EXIT
trap 'exit 130' INT TERM
local_cluster_start "$D/slurm"
rc=$?
[ $rc = 77 ] && { echo "(the benchmark needs a local SLURM cluster)"; exit 0; }
[ $rc = 0 ] || exit 1
python3 "$SRC/bench/bench_cluster.py" --build "$BUILD" --src "$SRC" --work "$D" \
  --res "${RES:-256}" --spp "${SPP:-16}" --frames "${FRAMES:-8}" --tiles "${TILES:-1 4 16}" \
  --threads "${THREADS:-1}"
