#!/usr/bin/env bash
# Installs the Debian packages opaline builds, tests and runs with. Idempotent:
# does nothing when every package is already installed. Runs as root or via sudo.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libembree-dev liblapacke-dev libopenblas-dev libxml2-dev libcmocka-dev
  libopenexr-dev libpng-dev zlib1g-dev
  blender python3
  clang libclang-rt-14-dev
)
# --bench adds what the benchmarks compare against (bench/): scikit-learn, plots, Embree's
# own path tracer.
if [ "${1:-}" = --bench ]; then
  packages+=(python3-numpy python3-sklearn python3-matplotlib embree-tools)
fi

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
