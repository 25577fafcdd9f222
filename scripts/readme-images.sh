#!/usr/bin/env bash
# Regenerates the pictures the README shows: large.fld as given, and a
# generated dam break after 0.4 s of the stable fluidanimate model, as PNG (docs/images/;
# the README also gives the command for an animated GIF of the dam break, which at about
# 3 MB is not committed); the accuracy-speed and error-time charts of four scenes
# (docs/accuracy/*/, scripts/accuracy-sweeps.sh) and the stability map of every model,
# precision and time-step rule (docs/stability/), and every model against the dam-break
# experiments of Martin and Moyce and of Koshizuka and Oka (docs/validation/; the
# settings table docs/validation/settings.md is scripts/water-settings.sh's), and the
# 2-D validations (docs/validation/{2d,still-water-2d,poiseuille}/).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
cargo build --release --quiet --bin fluid-lab
lab=target/release/fluid-lab
mkdir -p docs/images target/scenes
echo "method: $lab render, accuracy, stability and validate (plotters, embedded DejaVu Sans)" >&2
"$lab" render data/in/large.fld docs/images/large.png --steps 0
"$lab" scene dam-break target/scenes/dam-break.fld --ppm 300 --seed 1
"$lab" render target/scenes/dam-break.fld docs/images/dam-break.png --model fluidanimate --steps 400
# Accuracy against speed, and where each method fails (CSV, PNG and SVG in each folder).
scripts/accuracy-sweeps.sh docs/accuracy
"$lab" stability --kernels simd,mixed --output-dir docs/stability
"$lab" stability --kernels simd8 --integrators leapfrog,verlet --output-dir docs/stability/integrators
# The course model fails (it is unstable), so the validation exits 1 after its outputs.
{ "$lab" validate dam-break --models course,fluidanimate,wcsph --ppms 200,300,400,600 --width 0.026 \
    --until-t 3.65 --output-dir docs/validation || [ $? -eq 1 ]; } | tee docs/validation/summary.txt
scripts/water-settings.sh target/water-settings >docs/validation/settings.md
# In two dimensions: the dam break beside 3-D, still water, and Poiseuille flow (its
# steady profile and start-up). A validation whose check fails exits 1 after its outputs.
mkdir -p docs/validation/2d docs/validation/still-water-2d docs/validation/poiseuille
{ "$lab" validate dam-break --dimensions 2,3 --models wcsph --ppms 200,300,400,600 --width 0.026 \
    --until-t 3.65 --output-dir docs/validation/2d || [ $? -eq 1 ]; } | tee docs/validation/2d/summary.txt
"$lab" validate still-water --case cases/still-water-2d.toml --output-dir docs/validation/still-water-2d \
    | tee docs/validation/still-water-2d/summary.txt
"$lab" --quiet validate poiseuille --case cases/poiseuille.toml --output-dir docs/validation/poiseuille \
    | tee docs/validation/poiseuille/summary.txt
