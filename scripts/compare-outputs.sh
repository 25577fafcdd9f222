#!/usr/bin/env bash
# Behaviour side by side: builds two git revisions' fluid-lab (in target/revisions/<rev>,
# as compare-revisions.sh does) and runs the same workbench simulations with both, on
# every kernel: fluidanimate on a dam break and on large.fld (also with lists kept with a
# skin of 0.3h, and with an adaptive step), wcsph on the dam break (STEPS steps each), and
# the course model on large.fld (5 steps). Compares the .fld outputs byte for byte, and
# the full f64 state (the checkpoint's ids and particle fields, whatever its header's
# format version; runs with --skin write none, which revisions before format 6 refused;
# the weakly compressible model's own skin, from format 6 on, is skipped over).
#
# Usage: scripts/compare-outputs.sh REV_A REV_B [STEPS] [PPM]   (defaults: 200 steps, 200 per metre)
# Prints one line per run (same/DIFFERENT) and exits 1 if any differs.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
if [ $# -lt 2 ]; then
    echo "usage: $0 REV_A REV_B [STEPS] [PPM]" >&2
    exit 2
fi
steps="${3:-200}"
ppm="${4:-200}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
labs=()
for rev in "$1" "$2"; do
    labs+=("$(scripts/build-revision.sh "$rev" fluid-lab)")
done
"${labs[0]}" scene dam-break "$work/dam.fld" --ppm "$ppm" >/dev/null

# The particle count of a .fld file (its header: ppm f32, count i32).
count() { od -An -t d4 -j 4 -N 4 "$1" | tr -d ' '; }

# The ids and f64 fields of a checkpoint: the n * (4 + 13 * 8) bytes after its particle
# count, which end right before the CRC, or (format 6, a skin's last build kept) before
# that build's 3 n f64.
state() {
    local n="$2" body size extra start
    body=$((n * (4 + 13 * 8)))
    size=$(stat -c %s "$1")
    for extra in 0 $((n * 24)); do
        start=$((size - 4 - extra - body))
        if [ "$start" -ge 8 ] && [ "$(od -An -t u8 -j $((start - 8)) -N 8 "$1" | tr -d ' ')" = "$n" ]; then
            tail -c +$((start + 1)) "$1" | head -c "$body"
            return
        fi
    done
    echo "compare-outputs.sh: no particle block of $n in $1" >&2
    exit 1
}

status=0
for kernel in scalar simd simd8 mixed reference; do
    for case in "fluidanimate dam $work/dam.fld $steps" "fluidanimate large data/in/large.fld $steps" \
        "fluidanimate large data/in/large.fld $steps --skin 0.3" \
        "fluidanimate dam $work/dam.fld $steps --adaptive 0.3" \
        "wcsph dam $work/dam.fld $steps" "course large data/in/large.fld 5"; do
        read -r model name input run_steps extra <<<"$case"
        read -ra options <<<"$extra"
        for side in 0 1; do
            rm -f "$work/$side.ck"
            checkpoint=(--checkpoint-every "$run_steps" --checkpoint "$work/$side.ck")
            [[ "$extra" == *--skin* ]] && checkpoint=()
            "${labs[$side]}" run --steps "$run_steps" --model "$model" --kernel "$kernel" "$input" \
                "$work/$side.fld" "${options[@]}" "${checkpoint[@]}" >/dev/null
        done
        n="$(count "$work/0.fld")"
        if ! cmp -s "$work/0.fld" "$work/1.fld"; then
            verdict=DIFFERENT
        elif [ ! -f "$work/0.ck" ]; then
            verdict="same (.fld only)"
        elif cmp -s <(state "$work/0.ck" "$n") <(state "$work/1.ck" "$n"); then
            verdict=same
        else
            verdict=DIFFERENT
        fi
        [[ "$verdict" == DIFFERENT ]] && status=1
        echo "$verdict $model $name ($n particles, $run_steps steps${extra:+, $extra}) $kernel"
    done
done
exit "$status"
