#!/usr/bin/env bash
# Installs the Debian packages opaline builds, tests and runs with. Idempotent: does nothing
# when every package is already installed. Runs as root or via sudo. Works on Debian 12, 13 and
# sid (the same names everywhere).
#
#   install-deps.sh                 what the build, the demo and the tests need
#   install-deps.sh --bench         also what the benchmarks compare against (bench/)
#   install-deps.sh --screenshots   also the virtual display of scripts/addon-screenshots.sh
#   install-deps.sh --print GROUP   prints a group's packages, one a line, and installs nothing
#
# Groups: core (build, run, add-on tests), fuzz (clang's libFuzzer, left out when
# OPALINE_FUZZ_SECONDS=0), platforms (debootstrap, for the Debian 13 / sid test runs; left out
# when OPALINE_PLATFORMS=none), cluster (SLURM and munge, for the one-node cluster of
# tests/e2e/test_cluster.sh; left out when OPALINE_CLUSTER=none; no daemon is enabled: the test
# starts its own in a temp folder), bench, screenshots (Xvfb; only scripts/addon-screenshots.sh
# installs it).
set -euo pipefail

group() {
  case $1 in
    core) echo build-essential cmake pkg-config libembree-dev liblapacke-dev libopenblas-dev \
               libxml2-dev libcmocka-dev libopenexr-dev libpng-dev zlib1g-dev libxxhash-dev \
               libdeflate-dev libopenimageio-dev libopencolorio-dev blender python3 python3-numpy \
               acl ;;
    fuzz) echo clang libclang-rt-dev ;;
    platforms) echo debootstrap ;;
    cluster) echo slurm-wlm munge ;;
    bench) echo python3-numpy python3-sklearn python3-matplotlib embree-tools ;;
    screenshots) echo xvfb ;;
    *) echo "install-deps.sh: unknown group '$1' (core, fuzz, platforms, cluster, bench," \
            "screenshots)" >&2
       return 2 ;;
  esac
}

if [ "${1:-}" = --print ]; then
  group "${2:-core}" | tr ' ' '\n'
  exit 0
fi

packages=($(group core))
[ "${OPALINE_FUZZ_SECONDS:-30}" = 0 ] || packages+=($(group fuzz))
[ "${OPALINE_PLATFORMS:-}" = none ] || packages+=($(group platforms))
[ "${OPALINE_CLUSTER:-}" = none ] || packages+=($(group cluster))
[ "${1:-}" = --bench ] && packages+=($(group bench))
[ "${1:-}" = --screenshots ] && packages+=($(group screenshots))

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

echo "opaline: installing ${missing[*]}" >&2
sudo=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "opaline: run as root or install sudo" >&2; exit 1; }
  sudo="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
