#!/usr/bin/env bash
# Checks the README's fresh-machine promise for real, without a Docker engine: a new Debian 12 root
# (debootstrap --variant=minbase bookworm: bash and apt-get, no python3, no make) gets a clean copy of the repo at
# /bridgefem and runs, inside a chroot, with an empty environment:
#   1. ./run demo     as root (the first call: installs the Debian packages and .venv, then computes the default bridge)
#   2. ./run test     as root (the test suite, MPI cases included)
#   3. what docker/Dockerfile's image does: `./run mpirun -n 2 bridgefem run demos/bare_arch.toml` with the
#      Dockerfile's ENV lines and a host folder mounted on /bridgefem/results, as root (`docker run -v ...`) and as
#      an unnamed non-root user with HOME=/ (`docker run --user UID:GID -v ...`); results.json must be in the folder.
# Like a container it gets /proc, a read-only /sys, the host's /dev with its own /dev/pts and a 64 MiB tmpfs on
# /dev/shm (Docker's default size). Prints pass/fail and seconds per step; exits 0 only if every step passed. Mounts
# are undone on exit, whatever happens. Needs root, Linux, git and the network to a Debian mirror; takes 6-15
# minutes on 2 cores (most of it apt installing DOLFINx, PETSc, Gmsh and their dependencies: 718 packages, 4.1 GB).
#
# usage: sudo docker/check_fresh_debian.sh [--worktree] [--keep] [--log-dir DIR] [TARGET]
#   TARGET        where to build the root: a new or empty folder, kept afterwards
#                 (default: a temporary folder, removed afterwards unless --keep)
#   --worktree    copy the working tree (tracked and untracked, not ignored files) instead of `git archive HEAD`
#   --keep        keep the temporary root for inspection (chroot TARGET bash)
#   --log-dir DIR where the step logs and the mounted results folders go (default: a new temporary folder)
#   MIRROR=URL    environment: the Debian mirror for debootstrap (default: debootstrap's own default)
# shellcheck disable=SC2317  # cleanup and umount_all run from the EXIT trap
set -euo pipefail

say() { printf '[check_fresh_debian] %s\n' "$*"; }
die() { printf '[check_fresh_debian] error: %s\n' "$*" >&2; exit 2; }

worktree=0 keep=0 logdir="" target=""
while [ $# -gt 0 ]; do
  case "$1" in
    --worktree) worktree=1 ;;
    --keep) keep=1 ;;
    --log-dir) [ $# -ge 2 ] || die "--log-dir needs a folder"; logdir=$2; shift ;;
    -h|--help) sed -n '2,/^# shellcheck/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    -*) die "unknown option $1 (see --help)" ;;
    *) [ -z "$target" ] || die "only one TARGET allowed"; target=$1 ;;
  esac
  shift
done

[ "$(uname -s)" = Linux ] || die "needs Linux (debootstrap, chroot, mount)"
[ "$(id -u)" -eq 0 ] || die "needs root (debootstrap, chroot and mount do): run it with sudo"
command -v git >/dev/null || die "needs git on the host to copy the repository"
repo=$(git -C "$(dirname "${BASH_SOURCE[0]}")" rev-parse --show-toplevel) || die "not inside the bridgefem git repository"
[ -x "$repo/run" ] || die "$repo/run not found or not executable"

created=0
if [ -z "$target" ]; then
  target=$(mktemp -d "${TMPDIR:-/tmp}/bridgefem-fresh-root.XXXXXX")
  created=1
else
  if [ -e "$target" ] && [ -n "$(ls -A "$target" 2>/dev/null)" ]; then
    die "TARGET $target is not empty: give a new or empty folder (the root must be fresh)"
  fi
  mkdir -p "$target"
fi
root=$(cd "$target" && pwd -P)
[ "$root" != / ] || die "TARGET must not be /"
chmod 755 "$root"   # it becomes /: mktemp's 0700 would lock out _apt and every non-root user
[ -n "$logdir" ] || logdir=$(mktemp -d "${TMPDIR:-/tmp}/bridgefem-fresh-logs.XXXXXX")
mkdir -p "$logdir"
logdir=$(cd "$logdir" && pwd -P)
case "$logdir/" in "$root"/*) die "--log-dir must not be inside TARGET" ;; esac

mounts=()  # mount points inside the root, in mount order
mount_in() {  # mount_in MOUNTPOINT MOUNT-ARGS... (MOUNTPOINT relative to the root)
  local mp="$root/$1"; shift
  mkdir -p "$mp"
  mount "$@" "$mp"
  mounts+=("$mp")
}
umount_last() { umount "${mounts[-1]}" && unset 'mounts[-1]'; }
umount_all() {
  local i
  for ((i = ${#mounts[@]} - 1; i >= 0; i--)); do
    umount "${mounts[i]}" 2>/dev/null || umount -l "${mounts[i]}" || say "WARNING: could not unmount ${mounts[i]}"
  done
  mounts=()
}
in_root_pids() {
  local p
  for p in /proc/[0-9]*; do
    if [ "$(readlink "$p/root" 2>/dev/null)" = "$root" ]; then echo "${p#/proc/}"; fi
  done
}
still_mounted() { awk -v r="$root" '$2 == r || index($2, r "/") == 1 { found = 1 } END { exit !found }' /proc/mounts; }
cleanup() {
  local rc=$? sig i
  trap - EXIT INT TERM
  # processes left inside the root (an interrupted run): ended one by one, by pid; KILL after 10 s
  for sig in TERM KILL; do
    for ((i = 0; i < 10; i++)); do
      [ -n "$(in_root_pids)" ] || break 2
      [ "$i" -gt 0 ] || in_root_pids | xargs -r kill "-$sig" 2>/dev/null || true
      sleep 1
    done
  done
  umount_all
  if still_mounted; then
    say "WARNING: something is still mounted under $root; not removing it (check /proc/mounts)"
  elif [ "$created" -eq 1 ] && [ "$keep" -eq 0 ]; then
    rm -rf --one-file-system "$root"
  else
    say "root kept: $root (enter it with: chroot $root bash)"
  fi
  say "logs: $logdir"
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# a clean environment, as `docker run` gives: no LANG, no proxy, no host PATH. run_as=UID:GID runs as that user
# with HOME=/, as `docker run --user UID:GID` does for a user the image does not know.
run_as=""
in_root() {
  local user=() home=/root
  if [ -n "$run_as" ]; then user=(--userspec="$run_as"); home=/; fi
  chroot "${user[@]}" "$root" /usr/bin/env -i HOME="$home" TERM=dumb HOSTNAME=bridgefem-check \
    PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin "$@"
}
now() { date +%s; }
steps=() results=() times=()
record() { steps+=("$1"); results+=("$2"); times+=("$3"); }

# --- 0. debootstrap on the host -------------------------------------------------------------------------------------
if ! command -v debootstrap >/dev/null; then
  say "installing debootstrap on the host (apt-get)"
  DEBIAN_FRONTEND=noninteractive apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap >/dev/null
fi

# --- 1. a fresh Debian 12 root ---------------------------------------------------------------------------------------
say "debootstrap --variant=minbase bookworm $root ${MIRROR:-} (log: $logdir/debootstrap.log)"
t0=$(now)
if ! debootstrap --variant=minbase bookworm "$root" ${MIRROR:+"$MIRROR"} >"$logdir/debootstrap.log" 2>&1; then
  tail -n 20 "$logdir/debootstrap.log" >&2
  die "debootstrap failed (network to the Debian mirror? set MIRROR=URL); log: $logdir/debootstrap.log"
fi
record "debootstrap bookworm (minbase)" pass $(($(now) - t0))

# apt sources as on an installed Debian 12 or the debian:bookworm image: bookworm, -updates and -security, same mirror
mirror=$(awk '$1 == "deb" { print $2; exit }' "$root/etc/apt/sources.list")
[ -n "$mirror" ] || die "no mirror in $root/etc/apt/sources.list"
mirror=${mirror%/}
cat >"$root/etc/apt/sources.list.d/debian.sources" <<EOF
Types: deb
URIs: $mirror
Suites: bookworm bookworm-updates
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg

Types: deb
URIs: ${mirror%/debian}/debian-security
Suites: bookworm-security
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
EOF
rm -f "$root/etc/apt/sources.list"
[ -s "$root/etc/resolv.conf" ] || cp -L /etc/resolv.conf "$root/etc/resolv.conf"

# the README's promise: only bash and apt-get; no python3, no make
say "what the fresh root has (README: 'only bash and apt-get needed'):"
promise_ok=1
for cmd in bash apt-get python3 python make gcc git sudo curl wget; do
  if in_root /bin/sh -c "command -v $cmd" >/dev/null 2>&1; then have=present; else have=absent; fi
  printf '  %-8s %s\n' "$cmd" "$have"
  case "$cmd:$have" in
    bash:absent|apt-get:absent|python3:present|python:present|make:present) promise_ok=0 ;;
  esac
done
for pkg in python3 make ca-certificates locales; do
  # shellcheck disable=SC2016  # ${Status} is dpkg-query's field, not a shell variable
  if chroot "$root" dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    have=installed; else have="not installed"; fi
  printf '  package %-16s %s\n' "$pkg" "$have"
  case "$pkg:$have" in python3:installed|make:installed) promise_ok=0 ;; esac
done
[ "$promise_ok" -eq 1 ] || die "the new root is not a bash+apt-get-only Debian (python3 or make present, or bash/apt-get missing)"
say "packages in the fresh root: $(chroot "$root" dpkg-query -W -f='.\n' | wc -l), size $(du -sh --one-file-system "$root" | cut -f1)"

# --- 2. the repository, clean --------------------------------------------------------------------------------------
mkdir -p "$root/bridgefem"
if [ "$worktree" -eq 1 ]; then
  say "copying the working tree of $repo (git ls-files: tracked + untracked, not ignored) to /bridgefem"
  git -C "$repo" ls-files -z --cached --others --exclude-standard |
    (cd "$repo" && while IFS= read -r -d '' f; do if [ -e "$f" ]; then printf '%s\0' "$f"; fi; done) |
    tar -C "$repo" --null -T - -cf - | tar -C "$root/bridgefem" -xf -
  source_desc="working tree of $(git -C "$repo" rev-parse --short HEAD)$(git -C "$repo" diff --quiet HEAD || echo ' + local changes')"
else
  say "copying git archive HEAD ($(git -C "$repo" rev-parse --short HEAD)) of $repo to /bridgefem"
  git -C "$repo" diff --quiet HEAD || say "note: uncommitted changes are NOT tested (use --worktree for them)"
  git -C "$repo" archive --format=tar HEAD | tar -C "$root/bridgefem" -xf -
  source_desc="git archive $(git -C "$repo" rev-parse --short HEAD)"
fi
[ ! -e "$root/bridgefem/.venv" ] || die "the copy contains .venv"

# --- 3. container-like mounts ---------------------------------------------------------------------------------------
mount_in proc -t proc proc
mount_in sys -t sysfs -o ro sysfs                     # hwloc (Open MPI) reads the topology there
mount_in dev --bind /dev
mount --make-private "$root/dev"                      # nothing mounted below it reaches the host's /dev
mount_in dev/pts -t devpts -o newinstance,ptmxmode=0666,mode=0620 devpts
mount_in dev/shm -t tmpfs -o size=64m,mode=1777 shm   # Open MPI's shared-memory segments; Docker's default size

step() {  # step NAME LOGFILE SECONDS COMMAND... : COMMAND inside the root in /bridgefem, output shown and logged
  local name=$1 log=$2 limit=$3 t rc=0 dt; shift 3
  say "=== $name (log: $log)"
  t=$(now)
  # in the background and waited for, so that Ctrl-C reaches the traps at once
  (in_root timeout --kill-after=30 "$limit" /bin/bash -c 'cd /bridgefem && exec "$@"' bash "$@" 2>&1 | tee "$log") &
  wait $! || rc=$?
  dt=$(($(now) - t))
  local res=pass
  [ "$rc" -eq 0 ] || res="FAIL (exit $rc$([ "$rc" -ne 124 ] || echo ": timed out after $limit s"))"
  record "$name" "$res" "$dt"
  say "=== $name: $res in ${dt} s"
}

# --- 4. the README's two commands, as root --------------------------------------------------------------------------
step "./run demo (first call: installs)" "$logdir/demo.log" 3600 ./run demo
step "./run test" "$logdir/test.log" 1800 ./run test

# --- 5. what the image does: Dockerfile ENV, 2 MPI ranks, results written to a mounted folder -------------------------
docker_env=()
if [ -f "$root/bridgefem/docker/Dockerfile" ]; then
  # ENV KEY=VALUE [KEY=VALUE ...] lines (the only form the Dockerfile uses; no quotes, no continuation lines)
  read -r -a docker_env <<<"$(sed -n 's/^ENV[[:space:]]\{1,\}//p' "$root/bridgefem/docker/Dockerfile" | tr '\n' ' ')"
fi
image_step() {  # image_step LABEL UID:GID|"" : docker run [--user UID:GID] -v DIR:/bridgefem/results bridgefem mpirun ...
  local label=$1 out="$logdir/results-$1" uid
  run_as=$2
  rm -rf "$out"; mkdir -p "$out"
  [ -z "$run_as" ] || chown "$run_as" "$out"
  mount_in tmp -t tmpfs -o mode=1777 tmp     # a new container's /tmp: empty (no JIT cache from an earlier step)
  mount_in bridgefem/results --bind "$out"
  step "image ($label): mpirun -n 2 bridgefem run demos/bare_arch.toml" "$logdir/mpi-$label.log" 900 \
    env "${docker_env[@]}" ./run mpirun -n 2 bridgefem run demos/bare_arch.toml
  umount_last
  umount_last
  run_as=""
  local json="$out/bare_arch/results.json" want=${2%%:*}
  if [ -f "$json" ] && grep -q '"mpi_ranks": 2' "$json" && uid=$(stat -c %u "$json") && [ "$uid" = "${want:-0}" ]; then
    record "  results.json (mpi_ranks 2, uid ${want:-0}) in the mounted folder" pass 0
  else
    record "  results.json (mpi_ranks 2, uid ${want:-0}) in the mounted folder" "FAIL (missing or wrong owner)" 0
  fi
}
image_step root ""
image_step user 4242:4242

# --- summary --------------------------------------------------------------------------------------------------------
# shellcheck disable=SC2016  # ${Version} is dpkg-query's field
installed=$(chroot "$root" dpkg-query -W -f='${Version}' python3-dolfinx 2>/dev/null || echo '?')
say "summary: $source_desc in a fresh Debian $(cat "$root/etc/debian_version") root ($root)"
say "  python3-dolfinx $installed; $(chroot "$root" dpkg-query -W -f='.\n' | wc -l) packages, root $(du -sh --one-file-system "$root" | cut -f1); ENV from Dockerfile: ${docker_env[*]:-none}"
grep -E '^(bare_arch:|  hinges|  rigid-block)' "$logdir/demo.log" | sed 's/^/  demo: /' || true
tail -n 1 "$logdir/test.log" | sed 's/^/  test: /' || true
failed=0
for i in "${!steps[@]}"; do
  printf '  %-66s %-16s %6s s\n' "${steps[i]}" "${results[i]}" "${times[i]}"
  [ "${results[i]}" = pass ] || failed=1
done
if [ "$failed" -eq 0 ]; then say "ALL PASSED"; else say "SOME STEPS FAILED"; fi
exit "$failed"
