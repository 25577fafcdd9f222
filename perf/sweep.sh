#!/usr/bin/env bash
# Iteration sweep of `fluid`: for each input x iteration count x repeat, wall/user/sys time,
# peak memory and energy (RAPL through `perf stat -a`, else powercap, else "not available"
# with the reason: never a made-up number), plus idle windows as a separate baseline; then
# the charts. Everything lands in one results folder: sweep.csv, {time,energy,power}.{png,svg},
# the commands that made them, and optionally a flamegraph of a whole run.
#
# Usage: perf/sweep.sh [--short] [--flamegraph] [--out DIR] [--slurm [SLURM-OPTIONS...]]
#                      [-- SWEEP-OPTIONS... [INPUTS...]]
#   --short       iterations 0,1,10,100, 3 repeats, 0.5 s idle windows (a few seconds)
#   --flamegraph  also flamegraph.svg of `fluid 1000 data/in/large.fld` (scripts/flamegraph.sh)
#   --out DIR     the results folder (default: results/sweep-DATE-TIME; results/latest links it)
#   --slurm       run the sweep as a Slurm job array, one point per task on a node of its
#                 own (`fluid-lab slurm submit --wait`, job folder DIR/slurm), then merge
#                 the shards into DIR/sweep.csv and chart it (`fluid-lab slurm merge`);
#                 every row also records the Slurm job id, array index and node, and
#                 DIR/slurm/tasks.csv each task's status and Slurm's energy accounting.
#                 SLURM-OPTIONS: --partition P, --time T (per task), --account A, --shared
#   after --       options and inputs for `fluid-lab sweep` (see `fluid-lab sweep --help`);
#                  the defaults are small.fld and large.fld, iterations
#                  0,1,10,100,250,500,1000,2000, 5 repeats, 1 s idle windows.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

short=false
flamegraph=false
out=""
slurm=false
slurm_options=()
while [ $# -gt 0 ]; do
    case "$1" in
        --short) short=true ;;
        --flamegraph) flamegraph=true ;;
        --out) out="${2:?--out needs a folder}"; shift ;;
        --slurm) slurm=true ;;
        --partition|--time|--account) slurm_options+=("$1" "${2:?$1 needs a value}"); shift ;;
        --shared) slurm_options+=("$1") ;;
        --) shift; break ;;
        *) echo "sweep.sh: unknown option $1 (see the header of $0)" >&2; exit 2 ;;
    esac
    shift
done

sweep_options=()
if $short; then
    sweep_options=(--iterations "0,1,10,100" --repeats 3 --idle-seconds 0.5)
fi
sweep_options+=("$@")

if [ -z "$out" ]; then
    out="results/sweep-$(date +%Y%m%d-%H%M%S)"
    mkdir -p "$out"
    ln -sfn "$(basename "$out")" results/latest
fi
mkdir -p "$out"

cargo build --release --quiet --bins
lab=target/release/fluid-lab
echo "method: $lab sweep runs target/release/fluid ITERATIONS INPUT /dev/null, one run at a time" >&2
if $slurm; then
    submit=("$lab" slurm submit --job-dir "$out/slurm" --wait "${slurm_options[@]}"
        -- sweep "${sweep_options[@]}" --output "$out/sweep.csv")
    echo "${submit[*]}" >"$out/commands.txt"
    "${submit[@]}"
    echo "$lab slurm merge $out/slurm" >>"$out/commands.txt"
    "$lab" slurm merge "$out/slurm"
else
    [ ${#slurm_options[@]} -eq 0 ] || { echo "sweep.sh: ${slurm_options[0]} needs --slurm" >&2; exit 2; }
    echo "$lab sweep ${sweep_options[*]} --output $out/sweep.csv" >"$out/commands.txt"
    "$lab" sweep "${sweep_options[@]}" --output "$out/sweep.csv"
    echo "$lab chart $out/sweep.csv" >>"$out/commands.txt"
    "$lab" chart "$out/sweep.csv"
fi

if $flamegraph; then
    echo "scripts/flamegraph.sh 1000 data/in/large.fld $out/flamegraph.svg" >>"$out/commands.txt"
    scripts/flamegraph.sh 1000 data/in/large.fld "$out/flamegraph.svg"
fi
echo "results: $out"
