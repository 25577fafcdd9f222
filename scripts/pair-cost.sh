#!/usr/bin/env bash
# Cost of the pair loops: nanoseconds per pair closer than h (both passes, density and
# acceleration, together) and per particle-step, for each kernel, on one scene; and the
# useful fraction of the lanes a pass over every candidate evaluates (pairs closer than h
# over those lanes, the diagnostics' pair_lanes: masked lanes count).
#
# Each kernel runs once with `fluid-lab run --diagnostics --every K`: the run's own timing
# covers only the simulation steps (diagnostics are computed outside it), and the
# diagnostics count the pairs closer than h every K steps. The mean of those counts over
# the steps run (steps 0, K, 2K, ... before the last) is the pairs per step; ns per pair
# is the time per step divided by it. The time includes every stage, not only the pair
# loops, so it is an upper bound of the pair loops' own cost.
#
# Usage: scripts/pair-cost.sh [--steps N] [--every K] [--model M] [--pairs S] [INPUT] [KERNEL ...]
#        defaults: --steps 1000 --every 10 --model fluidanimate --pairs lists
#                  data/in/large.fld simd simd8 mixed scalar
# (--pairs tiles runs the SIMD kernels of every model on whole neighbour cells instead of
# neighbour lists; see `fluid-lab run --help`.
# On lists the useful fraction is that of the lists' lanes, rounded up per particle.)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
steps=1000
every=10
model=fluidanimate
structure=lists
while [ $# -gt 0 ]; do
    case "$1" in
    --steps) steps="$2"; shift 2 ;;
    --every) every="$2"; shift 2 ;;
    --model) model="$2"; shift 2 ;;
    --pairs) structure="$2"; shift 2 ;;
    --*) echo "pair-cost.sh: unknown option $1" >&2; exit 2 ;;
    *) break ;;
    esac
done
for number in "$steps" "$every"; do
    if ! [[ "$number" =~ ^[1-9][0-9]*$ ]]; then
        echo "pair-cost.sh: --steps and --every take a whole number from 1, not '$number'" >&2
        exit 2
    fi
done
input="${1:-data/in/large.fld}"
[ $# -gt 0 ] && shift
kernels=("$@")
[ ${#kernels[@]} -gt 0 ] || kernels=(simd simd8 mixed scalar)

cargo build --release --quiet --bin fluid-lab
lab="$root/target/release/fluid-lab"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

echo "input model kernel particles steps seconds ns_per_particle_step pairs_per_step ns_per_pair useful_fraction"
for kernel in "${kernels[@]}"; do
    line="$("$lab" run --model "$model" --kernel "$kernel" --pairs "$structure" --steps "$steps" "$input" \
        --diagnostics "$work/diagnostics.csv" --every "$every")"
    # The timing line: model=... kernel=... particles=N steps=N seconds=S ns_per_particle_step=T
    particles="$(sed -n 's/.* particles=\([0-9]*\) .*/\1/p' <<<"$line")"
    seconds="$(sed -n 's/.* seconds=\([0-9.]*\) .*/\1/p' <<<"$line")"
    per_particle="$(sed -n 's/.* ns_per_particle_step=\([0-9.]*\).*/\1/p' <<<"$line")"
    # Pairs of the states the steps ran on: every row but the last step's.
    # The mean of a column over those rows.
    mean() {
        awk -F, -v last="$steps" -v name="$1" '
            NR == 1 { for (k = 1; k <= NF; k++) if ($k == name) column = k; next }
            column && $1 < last { sum += $column; n++ }
            END { if (n > 0) printf "%.0f", sum / n }' "$work/diagnostics.csv"
    }
    pairs="$(mean pairs_within_h)"
    lanes="$(mean pair_lanes)"
    if [ -z "$particles" ] || [ -z "$seconds" ] || [ -z "${pairs:-}" ] || [ "$pairs" -eq 0 ] ||
        [ -z "${lanes:-}" ] || [ "$lanes" -eq 0 ]; then
        echo "pair-cost.sh: $kernel: no timing or no pairs closer than h (run: $line)" >&2
        exit 1
    fi
    per_pair="$(awk -v s="$seconds" -v n="$steps" -v p="$pairs" \
        'BEGIN { printf "%.2f", s / n / p * 1e9 }')"
    useful="$(awk -v p="$pairs" -v l="$lanes" 'BEGIN { printf "%.3f", p / l }')"
    echo "$(basename "$input") $model $kernel $particles $steps $seconds $per_particle $pairs $per_pair $useful"
done
