#!/usr/bin/env bash
# Time per particle-step against scene size: blocks of fluid at 800 particles per metre
# (the box then holds 1,557,504) of 3,000 to 1,000,000 particles (fluid-lab scene), 100
# steps of the stable fluidanimate model each (fluid-lab run), the median of 3 runs per size.
#
# Usage: scripts/scaling.sh [STEPS] [KERNEL]      (defaults: 100 simd)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
steps="${1:-100}"
kernel="${2:-simd}"
cargo build --release --quiet --bin fluid-lab
lab="$root/target/release/fluid-lab"
mkdir -p target/scenes
echo "particles ns_per_particle_step (median of 3; $steps steps, fluidanimate, $kernel)"
for count in 3000 10000 30000 100000 300000 1000000; do
    scene="target/scenes/block-800-$count.fld"
    [ -f "$scene" ] || "$lab" scene corner-block --ppm 800 --particles "$count" "$scene"
    for _ in 1 2 3; do
        "$lab" run --model fluidanimate --kernel "$kernel" --steps "$steps" "$scene" |
            sed -n 's/.*ns_per_particle_step=\([0-9.]*\).*/\1/p'
    done | sort -g | sed -n 2p | sed "s/^/$count /"
done
