#!/usr/bin/env bash
# Regenerates the pictures the README shows (docs/images/): large.fld as given, and a
# generated dam break after 0.4 s of the stable fluidanimate model, as PNG. (The README
# also gives the command for an animated GIF of the dam break; at about 3 MB it is not
# committed.)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
cargo build --release --quiet --bin fluid-lab
lab=target/release/fluid-lab
mkdir -p docs/images target/scenes
echo "method: $lab render (plotters, embedded DejaVu Sans)" >&2
"$lab" render data/in/large.fld docs/images/large.png --steps 0
"$lab" scene dam-break target/scenes/dam-break.fld --ppm 300 --seed 1
"$lab" render target/scenes/dam-break.fld docs/images/dam-break.png --model fluidanimate --steps 400
