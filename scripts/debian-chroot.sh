#!/usr/bin/env bash
# debian-chroot.sh SUITE COMMAND [ARG...]
#
# Runs COMMAND inside a minimal Debian SUITE system (trixie, sid, ...) that has opaline's core
# packages (scripts/install-deps.sh --print core), with this repository at /opaline and the
# repository's sibling folder ../shared (when present) read-only at /shared.
#
# The system is made once with debootstrap from the Debian registry the host's apt already uses,
# and cached in $OPALINE_CHROOT_CACHE (default /var/cache/opaline-chroot), one tree per suite
# and package list: a changed list makes a new tree and removes the old one. Each run works in
# a throwaway overlay of the cached tree, so runs never change the cache. Every mount this
# script makes (the overlay, /proc, /dev, /dev/shm, the repository) is unmounted when it exits,
# even on failure or interruption, and only then is anything deleted.
#
# Exit: COMMAND's exit status; 77 (skip) with a message on stderr when the system cannot be made
# or entered here (not root, no debootstrap, no overlayfs, the registry unreachable, or the
# suite's packages not installable today, as happens to sid).
set -euo pipefail

suite=${1:?usage: debian-chroot.sh SUITE COMMAND [ARG...]}
shift
[ $# -gt 0 ] || { echo "usage: debian-chroot.sh SUITE COMMAND [ARG...]" >&2; exit 2; }
root_dir=$(cd "$(dirname "$0")/.." && pwd)
cache=${OPALINE_CHROOT_CACHE:-/var/cache/opaline-chroot}

skip() { echo "debian-chroot: skipping Debian $suite: $*" >&2; exit 77; }

[ "$(id -u)" = 0 ] || skip "needs root (debootstrap, chroot and mounts)"
command -v debootstrap >/dev/null || skip "debootstrap is not installed (scripts/install-deps.sh installs it)"
command -v chroot >/dev/null || skip "chroot is not available"
grep -qw overlay /proc/filesystems || modprobe overlay 2>/dev/null || true
grep -qw overlay /proc/filesystems || skip "the kernel has no overlay filesystem"

# The Debian registry: the first URI of the host's apt sources that serves Debian's main archive.
mirror=$( { cat /etc/apt/sources.list.d/*.sources 2>/dev/null |
              awk '/^URIs:/ { for (i = 2; i <= NF; i++) print $i }'
            cat /etc/apt/sources.list /etc/apt/sources.list.d/*.list 2>/dev/null |
              awk '$1 == "deb" { for (i = 2; i <= NF; i++) if ($i ~ /^[a-z]+:\/\//) { print $i; break } }'
          } | grep -E '/debian/?$' | head -n 1 || true)
[ -n "$mirror" ] || skip "the host's apt sources name no Debian archive to debootstrap from"

packages=$(bash "$root_dir/scripts/install-deps.sh" --print core | sort | tr '\n' ' ')
key=$(printf '%s\n%s\n' "$suite" "$packages" | sha256sum | cut -c1-16)
tree="$cache/$suite-$key"

# Mount bookkeeping: every mount point made here, unmounted in reverse order by cleanup.
mounts=()
scratch=""
mounted_under() { awk -v p="$1" '$2 == p || index($2, p "/") == 1 { print $2 }' /proc/mounts; }
cleanup() {
  local rc=$? i
  for ((i = ${#mounts[@]} - 1; i >= 0; i--)); do
    umount "${mounts[i]}" 2>/dev/null || umount -l "${mounts[i]}" 2>/dev/null || true
  done
  mounts=()
  if [ -n "$scratch" ]; then
    if [ -n "$(mounted_under "$scratch")" ]; then
      echo "debian-chroot: still mounted under $scratch, leaving it in place:" >&2
      mounted_under "$scratch" >&2
    else
      rm -rf "$scratch"
    fi
  fi
  return $rc
}
trap cleanup EXIT
trap 'exit 130' INT TERM HUP

# mount_in TARGET MOUNT-ARGS...: mounts and records TARGET for cleanup.
mount_in() {
  local target=$1; shift
  mount "$@" "$target"
  mounts+=("$target")
}

# Kills what still runs inside the tree at $1 (a daemon a test left behind), so it unmounts.
kill_inside() {
  local p r
  for p in /proc/[0-9]*; do
    r=$(readlink "$p/root" 2>/dev/null) || continue
    case $r in "$1" | "$1"/*) kill -9 "${p#/proc/}" 2>/dev/null || true ;; esac
  done
}

# The system api (/proc, /dev) that apt, Blender and the sanitizers need, inside $1.
mount_system() {
  mount_in "$1/proc" -t proc proc
  mount_in "$1/dev" --bind /dev
  mount_in "$1/dev/shm" -t tmpfs -o mode=1777 tmpfs
}

make_tree() {
  mkdir -p "$cache"
  local new
  new=$(mktemp -d "$cache/.new-$suite-XXXXXX")
  scratch=$new
  echo "debian-chroot: making Debian $suite in $tree (debootstrap from the host's registry)" >&2
  if ! debootstrap --variant=minbase "$suite" "$new/root" "$mirror" >"$new/debootstrap.log" 2>&1; then
    tail -n 5 "$new/debootstrap.log" >&2
    skip "debootstrap $suite failed (registry unreachable?)"
  fi
  # The host's apt settings (proxies, date checks) apply inside too.
  cp -a /etc/apt/apt.conf.d/. "$new/root/etc/apt/apt.conf.d/" 2>/dev/null || true
  mount_system "$new/root"
  local ok=1
  chroot "$new/root" apt-get update -qq >"$new/apt.log" 2>&1 &&
    chroot "$new/root" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
      --no-install-recommends $packages >>"$new/apt.log" 2>&1 || ok=0
  chroot "$new/root" apt-get clean >/dev/null 2>&1 || true
  kill_inside "$new/root"
  cleanup_mounts
  if [ "$ok" = 0 ]; then
    tail -n 8 "$new/apt.log" >&2
    skip "Debian $suite's packages cannot be installed today"
  fi
  [ -z "$(mounted_under "$new")" ] || { echo "debian-chroot: mounts left in $new" >&2; exit 1; }
  # Older trees of this suite (another package list) go, unless something is mounted in them.
  local old
  for old in "$cache/$suite"-*; do
    [ -d "$old" ] && [ "$old" != "$tree" ] && [ -z "$(mounted_under "$old")" ] && rm -rf "$old"
  done
  mv "$new/root" "$tree"
  rm -rf "$new"
  scratch=""
}

cleanup_mounts() {
  local i
  for ((i = ${#mounts[@]} - 1; i >= 0; i--)); do
    umount "${mounts[i]}" 2>/dev/null || umount -l "${mounts[i]}"
  done
  mounts=()
}

# One maker at a time per cache; runs share the finished tree read-only.
mkdir -p "$cache"
exec 9>"$cache/.lock-$suite"
flock 9
[ -d "$tree" ] || make_tree
flock -u 9

# A throwaway overlay of the cached tree for this run.
scratch=$(mktemp -d "${TMPDIR:-/tmp}/opaline-chroot-$suite.XXXXXX")
mkdir -p "$scratch/upper" "$scratch/work" "$scratch/root"
mount_in "$scratch/root" -t overlay overlay \
  -o "lowerdir=$tree,upperdir=$scratch/upper,workdir=$scratch/work" ||
  skip "cannot mount an overlay of $tree"
mount_system "$scratch/root"
mkdir -p "$scratch/root/opaline" "$scratch/root/shared"
mount_in "$scratch/root/opaline" --bind "$root_dir"
if [ -d "$root_dir/../shared" ]; then
  mount_in "$scratch/root/shared" --bind "$root_dir/../shared"
  mount -o remount,bind,ro "$scratch/root/shared"
fi

rc=0
chroot "$scratch/root" env -i HOME=/root TERM="${TERM:-dumb}" PATH=/usr/sbin:/usr/bin:/sbin:/bin \
  LANG=C.UTF-8 OPALINE_FUZZ_SECONDS=0 OPALINE_PLATFORMS=none OPALINE_CLUSTER=none "$@" || rc=$?
kill_inside "$scratch/root"
exit $rc
