#!/usr/bin/env bash
# The dataset generator works in blocks of rows: making a 292 MB dataset (chess4x4, 170 x 170
# pixels, K 29, five 64 MiB blocks) must peak (VmHWM, as the command logs it) well under the
# dataset's size, where holding it whole peaked above it. The file is then checked whole.
set -euo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup dataset_memory opaline-factor

"$F" dataset chess4x4 --pixels 170 --kernel 29 --size-cm 7.7x7.7 -o "$T/d.opm" 2> "$T/log"
bytes=$(stat -c %s "$T/d.opm")
peak=$(sed -n 's/.*peak memory \([0-9]*\)\.[0-9]* MiB.*/\1/p' "$T/log")
echo "dataset $(( bytes >> 20 )) MiB, generator peak ${peak:-?} MiB"
[ -n "$peak" ] || { echo "FAIL: no peak memory in the log:"; cat "$T/log"; exit 1; }
[ "$bytes" -gt $(( 256 << 20 )) ] || { echo "FAIL: dataset smaller than planned"; exit 1; }
# 64 MiB block + tables + the program (and the sanitizers' own, in the test build)
[ "$peak" -lt 160 ] || { echo "FAIL: peak $peak MiB: the dataset is held whole"; exit 1; }
"$F" info "$T/d.opm" > /dev/null # reads it back whole: header, table, every checksum
echo "bounded generation OK"
