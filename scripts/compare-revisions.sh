#!/usr/bin/env bash
# Times whole `fluid` runs of several git revisions side by side, in one hyperfine run
# (ratios measured together are what a noisy machine can support). Each revision is
# built by scripts/build-revision.sh (target/revisions/<hash>, the current
# .cargo/config.toml: target-cpu=native).
#
# Usage: scripts/compare-revisions.sh "STEPS INPUT" REV [REV ...]
#   e.g. scripts/compare-revisions.sh "1000 data/in/large.fld" f0edf9e HEAD
# First runs each revision once and compares its output file byte for byte with that of
# the last revision: a change that only skips or fuses work must leave it identical. It
# prints "same" or "DIFFERENT" for each revision but the last, and exits 3 after the
# timings if any differs.

# Prints a markdown table of the median, fastest and slowest of 10 runs per revision
# (also kept in target/revisions/<STEPS>-<input>.md; hyperfine's CSV beside it).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
if [ $# -lt 2 ]; then
    echo "usage: $0 \"STEPS INPUT\" REV [REV ...]" >&2
    exit 2
fi
read -r steps input <<<"$1"
shift
if ! command -v hyperfine >/dev/null; then
    echo "compare-revisions.sh: hyperfine is not installed (apt-get install hyperfine)" >&2
    exit 1
fi
mkdir -p target/revisions
report="target/revisions/$steps-$(basename "$input" .fld)"
commands=()
binaries=()
outputs=()
for rev in "$@"; do
    hash="$(git rev-parse --short "$rev^{commit}")"
    binaries+=("$(scripts/build-revision.sh "$rev" fluid)")
    commands+=(-n "$rev ($hash)" "${binaries[-1]} $steps $input /dev/null")
    outputs+=("$report-$hash.fld")
done
for ((k = 0; k < ${#binaries[@]}; k++)); do
    "${binaries[$k]}" "$steps" "$input" "${outputs[$k]}" >/dev/null
done
differ=0
for ((k = 0; k < ${#outputs[@]} - 1; k++)); do
    if cmp -s "${outputs[$k]}" "${outputs[-1]}"; then
        echo "output of ${*:k+1:1}: same as ${*: -1}" >&2
    else
        echo "output of ${*:k+1:1}: DIFFERENT from ${*: -1}" >&2
        differ=3
    fi
done
hyperfine -N --warmup 2 --runs 10 --export-csv "$report.csv" "${commands[@]}" >&2
# CSV columns: command,mean,stddev,median,user,system,min,max (seconds).
awk -F, -v what="fluid $steps $input" '
    NR == 1 { next }
    { name[NR] = $1; median[NR] = $4; low[NR] = $7; high[NR] = $8; last = NR }
    END {
        printf "| %s | median [s] | min [s] | max [s] | vs last |\n|:---|---:|---:|---:|---:|\n", what
        for (i = 2; i <= last; i++)
            printf "| %s | %.4f | %.4f | %.4f | %.2fx |\n", name[i], median[i], low[i], high[i],
                median[i] / median[last]
    }' "$report.csv" | tee "$report.md"
exit "$differ"
