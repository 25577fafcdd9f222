#!/usr/bin/env bash
# Times two commands interleaved: A B, B A, A B, ... so that the slow drift of a shared
# machine (here +-15% over minutes) falls on both alike, and prints the median wall time
# of each and the median, smallest and largest of the pair ratios B/A. Ratios under ~15%
# measured by hyperfine's sequential blocks (scripts/compare-revisions.sh) can flip on such
# a machine; these do not.
#
# Usage: scripts/interleave.sh PAIRS "COMMAND A" "COMMAND B"
#   e.g. scripts/interleave.sh 10 "target/revisions/8b7bd25/target/release/fluid 1000 data/in/large.fld /dev/null" \
#                                 "target/release/fluid 1000 data/in/large.fld /dev/null"
# Each command runs through bash -c with its output discarded; one warm-up run each first.
set -euo pipefail
if [ $# -ne 3 ] || ! [[ "$1" =~ ^[1-9][0-9]*$ ]]; then
    echo "usage: $0 PAIRS \"COMMAND A\" \"COMMAND B\"  (PAIRS a whole number from 1)" >&2
    exit 2
fi
pairs="$1"
commands=("$2" "$3")

# Wall time of one run in nanoseconds; a failing command stops the script.
run() {
    local start end
    start=$(date +%s%N)
    if ! bash -c "$1" >/dev/null 2>&1; then
        echo "interleave.sh: the command failed: $1" >&2
        exit 1
    fi
    end=$(date +%s%N)
    echo $((end - start))
}

run "${commands[0]}" >/dev/null
run "${commands[1]}" >/dev/null
times_a=()
times_b=()
for ((pair = 0; pair < pairs; pair++)); do
    if ((pair % 2 == 0)); then
        times_a+=("$(run "${commands[0]}")")
        times_b+=("$(run "${commands[1]}")")
    else
        times_b+=("$(run "${commands[1]}")")
        times_a+=("$(run "${commands[0]}")")
    fi
done
paste <(printf '%s\n' "${times_a[@]}") <(printf '%s\n' "${times_b[@]}") | awk '
    function median(values, count,    sorted, i, j, t) {
        for (i = 1; i <= count; i++) sorted[i] = values[i]
        for (i = 1; i <= count; i++)
            for (j = i + 1; j <= count; j++)
                if (sorted[j] < sorted[i]) { t = sorted[i]; sorted[i] = sorted[j]; sorted[j] = t }
        if (count % 2) return sorted[(count + 1) / 2]
        return (sorted[count / 2] + sorted[count / 2 + 1]) / 2
    }
    {
        n++; a[n] = $1; b[n] = $2; r[n] = $2 / $1
        if (n == 1 || r[n] < low) low = r[n]
        if (n == 1 || r[n] > high) high = r[n]
    }
    END {
        printf "A median %.2f ms\nB median %.2f ms\nB/A median %.3f (smallest %.3f, largest %.3f; %d pairs)\n",
            median(a, n) / 1e6, median(b, n) / 1e6, median(r, n), low, high, n
    }'
