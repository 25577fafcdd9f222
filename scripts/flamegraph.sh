#!/usr/bin/env bash
# Flamegraph of a whole `fluid` run, or of a `fluid-lab` command: samples the release
# binary with Linux perf at 250 Hz (the kernel tick here; software cpu-clock events work
# without hardware counters) and folds the stacks with inferno (installed into
# target/tools on first use).
#
# Usage: scripts/flamegraph.sh [STEPS] [INPUT] [OUTPUT.svg]
#        defaults: 1000 data/in/large.fld target/flamegraph-fluid.svg
#        scripts/flamegraph.sh --lab OUTPUT.svg FLUID-LAB-ARGUMENTS...
#        e.g. scripts/flamegraph.sh --lab target/stable.svg run --model fluidanimate \
#                 --steps 300 data/in/large.fld
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
frequency=250
if [ "${1:-}" = "--lab" ]; then
    if [ $# -lt 3 ]; then
        echo "flamegraph.sh: --lab takes OUTPUT.svg and fluid-lab's arguments" >&2
        exit 2
    fi
    output="$2"
    shift 2
    binary=fluid-lab
    arguments=("$@")
    title="fluid-lab $*"
else
    steps="${1:-1000}"
    input="${2:-data/in/large.fld}"
    output="${3:-target/flamegraph-fluid.svg}"
    binary=fluid
    arguments=("$steps" "$input" /dev/null)
    title="fluid $steps $input"
fi

if ! command -v perf >/dev/null; then
    echo "flamegraph.sh: perf is not installed (apt-get install linux-perf)" >&2
    exit 1
fi
tools="$root/target/tools"
if ! command -v inferno-flamegraph >/dev/null && [ ! -x "$tools/bin/inferno-flamegraph" ]; then
    echo "flamegraph.sh: installing inferno into $tools" >&2
    cargo install --quiet --locked --root "$tools" inferno
fi
export PATH="$tools/bin:$PATH"

cargo build --release --quiet --bin "$binary"
scratch="$(mktemp -d)"
trap 'rm -rf "$scratch"' EXIT
echo "method: perf record -F $frequency --call-graph dwarf, inferno" >&2
if ! perf record --quiet -F "$frequency" --call-graph dwarf -o "$scratch/perf.data" \
    "target/release/$binary" "${arguments[@]}" >/dev/null 2>"$scratch/perf.err"; then
    echo "flamegraph.sh: perf cannot sample here:" >&2
    cat "$scratch/perf.err" >&2
    exit 1
fi
mkdir -p "$(dirname "$output")"
perf script -i "$scratch/perf.data" 2>/dev/null | inferno-collapse-perf |
    inferno-flamegraph --title "$title" >"$output"
echo "flamegraph: $output"
