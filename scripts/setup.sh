#!/usr/bin/env bash
# One-time set-up after `git clone` on Debian (as root, or with sudo): the Rust components
# the checks use (rustfmt, clippy) and the tools the scripts and tests call: shellcheck
# (lint), linux-perf (energy, flamegraphs, the perf window test), hyperfine (revision
# comparisons), valgrind (instruction counts), and slurm-wlm with munge (the local
# one-node Slurm of scripts/slurm-local.sh, for the job-array tests). Installs only what
# is missing.
set -euo pipefail

if ! cargo fmt --version >/dev/null 2>&1 || ! cargo clippy --version >/dev/null 2>&1; then
    echo "setup.sh: adding rustfmt and clippy"
    rustup component add rustfmt clippy
fi

missing=()
command -v shellcheck >/dev/null || missing+=(shellcheck)
command -v perf >/dev/null || missing+=(linux-perf)
command -v hyperfine >/dev/null || missing+=(hyperfine)
command -v valgrind >/dev/null || missing+=(valgrind)
command -v sbatch >/dev/null || missing+=(slurm-wlm)
[ -x /usr/sbin/munged ] || missing+=(munge)
if [ ${#missing[@]} -gt 0 ]; then
    sudo=()
    [ "$(id -u)" -eq 0 ] || sudo=(sudo)
    echo "setup.sh: installing ${missing[*]} (apt)"
    "${sudo[@]}" apt-get update -qq
    "${sudo[@]}" apt-get install -y -qq "${missing[@]}" >/dev/null
fi
echo "setup.sh: rustfmt, clippy, shellcheck, perf, hyperfine, valgrind and Slurm are ready"
