#!/usr/bin/env bash
# README command 2: installs what is missing, builds with AddressSanitizer, UBSan and warnings as
# errors, and runs the whole test suite (cmocka, end-to-end, Blender add-on) through ctest.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${OPALINE_BUILD_DIR:-$root/build-test}

bash "$root/scripts/install-deps.sh"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DOPALINE_SANITIZE=ON \
  -DOPALINE_WERROR=ON >/dev/null
cmake --build "$build" --parallel "$(nproc)"
(cd "$build" && ctest --output-on-failure --parallel "$(nproc)" "$@")

# The tests that cannot run under the sanitizers (ulimit -v: their shadow memory reserves
# terabytes of address space) run again on a build without them, which skips none of them.
if [ $# -eq 0 ]; then
  plain="$build-plain"
  cmake -S "$root" -B "$plain" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DOPALINE_WERROR=ON \
    -DOPALINE_BUILD_PRESETS=OFF >/dev/null
  cmake --build "$plain" --parallel "$(nproc)" --target opaline-render
  echo "== tests needing a build without sanitizers =="
  OPALINE_BIN_DIR="$plain/bin" OPALINE_TEST_TMP="$plain" bash "$root/tests/e2e/test_robust_scene_memory.sh"
fi

# Fuzzing (clang's libFuzzer): every reader of untrusted input for OPALINE_FUZZ_SECONDS each
# (default 30; 0 skips), in its own build folder. The replay of the saved inputs ran above.
seconds=${OPALINE_FUZZ_SECONDS:-30}
if [ "$seconds" != 0 ] && [ $# -eq 0 ]; then
  fuzz="$root/build-fuzz"
  CC=clang CXX=clang++ cmake -S "$root" -B "$fuzz" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DOPALINE_SANITIZE=ON \
    -DOPALINE_WERROR=ON -DOPALINE_FUZZ=ON -DOPALINE_BUILD_PRESETS=OFF \
    -DOPALINE_FUZZ_SECONDS="$seconds" >/dev/null
  cmake --build "$fuzz" --parallel "$(nproc)" --target opaline_fuzz_targets
  (cd "$fuzz" && ctest --output-on-failure --parallel "$(nproc)" -R '^fuzz\.')
fi

# The same suite on Debian 13 (Embree 4, Blender 4.3) and Debian sid (the newest Blender), each
# in a cached chroot made by scripts/debian-chroot.sh; OPALINE_PLATFORMS picks the suites
# ("none" skips). A suite that cannot be made here (no root, no registry, sid's packages not
# installable today) is reported and skipped; one that runs must pass.
platforms=${OPALINE_PLATFORMS-trixie sid}
if [ "$platforms" != none ] && [ $# -eq 0 ]; then
  for suite in $platforms; do
    echo "== opaline tests on Debian $suite =="
    rc=0
    bash "$root/scripts/debian-chroot.sh" "$suite" \
      env OPALINE_BUILD_DIR=/root/build-test bash /opaline/scripts/test.sh || rc=$?
    case $rc in
      0) echo "== Debian $suite: all tests passed ==" ;;
      77) echo "== Debian $suite: skipped (see above) ==" ;;
      *) echo "== Debian $suite: FAILED (exit $rc) =="; exit "$rc" ;;
    esac
  done
fi
