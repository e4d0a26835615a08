#!/usr/bin/env bash
# README command 2: installs what is missing, builds with AddressSanitizer, UBSan and warnings as
# errors, and runs the whole test suite (cmocka, end-to-end, Blender add-on) through ctest.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build="$root/build-test"

bash "$root/scripts/install-deps.sh"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DOPALINE_SANITIZE=ON \
  -DOPALINE_WERROR=ON >/dev/null
cmake --build "$build" --parallel "$(nproc)"
cd "$build"
ctest --output-on-failure --parallel "$(nproc)" "$@"
