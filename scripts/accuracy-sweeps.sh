#!/usr/bin/env bash
# The accuracy-speed sweeps the README shows, one folder per scene under docs/accuracy/
# (accuracy.csv, accuracy-speed and error-time as PNG and SVG, choices.txt with the
# fastest method within each error budget):
#   large         data/in/large.fld, the stable fluidanimate model, to 48 ms (steps from
#                 62.5 us: its errors are first order on both integrators)
#   dam-break     a generated dam break at 250 ppm, fluidanimate, to 48 ms
#   drop          a generated drop at 250 ppm, fluidanimate, to 48 ms
#   course-large  data/in/large.fld, the course model, to 3 ms
#   wcsph-dam-break  a generated dam break at 150 ppm, the weakly compressible model, to
#                 48 ms, against the reference at a fixed 10 us (its methods' steps are
#                 25-300 us and CFL steps; an eighth of the shortest would take an hour)
# Every method on both integrators, the leapfrog and the velocity Verlet.
# Every method against the compensated reference kernel at an eighth of the shortest step
# any method took. About 30 minutes on the 2-core Intel guest.
#
# Usage: scripts/accuracy-sweeps.sh [OUTPUT_ROOT] [-- EXTRA fluid-lab accuracy ARGS...]
#        default OUTPUT_ROOT: docs/accuracy
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
output=docs/accuracy
if [ $# -gt 0 ] && [ "$1" != "--" ]; then
    output="$1"
    shift
fi
if [ "${1:-}" = "--" ]; then
    shift
fi
cargo build --release --quiet --bin fluid-lab
lab=target/release/fluid-lab
scenes="$(mktemp -d)"
trap 'rm -rf "$scenes"' EXIT
"$lab" scene dam-break "$scenes/dam-break.fld" --ppm 250 --seed 1 >/dev/null
"$lab" scene drop "$scenes/drop.fld" --ppm 250 --seed 1 >/dev/null
"$lab" scene dam-break "$scenes/dam-break-150.fld" --ppm 150 --seed 1 >/dev/null
budgets=1e-6,1e-5,1e-4,0.1h
sweep() {
    local name="$1"; shift
    mkdir -p "$output/$name"
    echo "accuracy-sweeps.sh: $name" >&2
    "$lab" accuracy "$@" --output-dir "$output/$name" --budget "$budgets" "${extra[@]}" |
        { grep -v '^wrote ' || true; } | tee "$output/$name/choices.txt"
}
extra=("$@")
sweep large data/in/large.fld --model fluidanimate --dt-factors 0.0625,0.125,0.25,0.5,1,2,4
sweep dam-break "$scenes/dam-break.fld" --model fluidanimate
sweep drop "$scenes/drop.fld" --model fluidanimate
sweep course-large data/in/large.fld --model course
sweep wcsph-dam-break "$scenes/dam-break-150.fld" --model wcsph --reference-dt 1e-5
