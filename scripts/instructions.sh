#!/usr/bin/env bash
# Instructions per time step, counted by valgrind's callgrind (noise-free, unlike timings).
# valgrind cannot decode AVX-512, so this builds fluid-lab for x86-64-v3 (AVX2, FMA) into
# target/x86-64-v3 and counts there. A step's count is the difference between two runs
# that differ only in their number of steps, so start-up and file input cancel out.
#
# Usage: scripts/instructions.sh [input.fld ...]     (default: data/in/small.fld data/in/large.fld)
# Prints one line per input, state, model and kernel:
#   input state model kernel instructions_per_step
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

if ! command -v valgrind >/dev/null; then
    echo "instructions.sh: valgrind is not installed (apt-get install valgrind)" >&2
    exit 1
fi
RUSTFLAGS="-C target-cpu=x86-64-v3" cargo build --release --quiet --bin fluid-lab \
    --target-dir target/x86-64-v3
lab="$root/target/x86-64-v3/release/fluid-lab"

# Instructions of one run: fluid-lab run --steps $2 --model $3 --kernel $4 $1
count() {
    valgrind --tool=callgrind --callgrind-out-file=/dev/null \
        "$lab" run --steps "$2" --model "$3" --kernel "$4" "$1" 2>&1 >/dev/null |
        sed -n 's/.*Collected : \([0-9]*\).*/\1/p'
}

# Instructions per step between $2 and $3 steps.
per_step() {
    local before after
    before=$(count "$1" "$2" "$4" "$5")
    after=$(count "$1" "$3" "$4" "$5")
    echo $(((after - before) / ($3 - $2)))
}

echo "input state model kernel instructions_per_step"
inputs=("$@")
[ ${#inputs[@]} -gt 0 ] || inputs=(data/in/small.fld data/in/large.fld)
for input in "${inputs[@]}"; do
    for kernel in scalar simd simd8 mixed; do
        # Dense: the first step of the course model; steps 50-52 of the stable model,
        # which stays in the box. Blown up: steps 50-60 of the course model.
        echo "$input dense course $kernel $(per_step "$input" 0 1 course "$kernel")"
        echo "$input dense fluidanimate $kernel $(per_step "$input" 50 52 fluidanimate "$kernel")"
        echo "$input blown-up course $kernel $(per_step "$input" 50 60 course "$kernel")"
    done
done
