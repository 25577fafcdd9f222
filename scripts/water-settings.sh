#!/usr/bin/env bash
# Which of the weakly compressible model's settings move the dam-break front: the validated
# defaults, then one change at a time (the walls, the artificial viscosity, water's laminar
# viscosity, the smoothing length, the sound speed), and DualSPHysics' constants on our
# walls, each run by `fluid-lab validate dam-break` (a = 25 mm at 200 and 400 per metre,
# 26.7 mm at 300, to T = 3.65) at each resolution. Prints a Markdown table: per setting and
# resolution, the worst and mean |error| over each experiment's points with T <= 3.6
# (Martin and Moyce 1952, Koshizuka and Oka 1996), the worst over both, and CPU seconds
# per simulated second; the runs' folders stay in OUTPUT_DIR.
#
# Usage: scripts/water-settings.sh [OUTPUT_DIR] [PPMS]
#        defaults: target/water-settings 300,400   (about 6 minutes on 2 cores)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
out="${1:-target/water-settings}"
ppms="${2:-300,400}"
cargo build --release --quiet --bin fluid-lab
lab=target/release/fluid-lab
mkdir -p "$out"
# name|options (empty: the defaults)
variants=(
    "validated defaults (no-slip walls)|"
    "free-slip walls|--walls free-slip"
    "free slip, alpha 0.3|--walls free-slip --artificial-viscosity 0.3"
    "free slip, alpha 0.5|--walls free-slip --artificial-viscosity 0.5"
    "alpha 0.05|--artificial-viscosity 0.05"
    "alpha 0.2|--artificial-viscosity 0.2"
    "water's laminar viscosity, 1e-6 m2/s|--laminar-viscosity 1e-6"
    "laminar viscosity alone (alpha 0)|--artificial-viscosity 0 --laminar-viscosity 1e-6"
    "h = 1.73 spacings|--smoothing 1.73"
    "c0 = 14.1 sqrt(2gH) (20 sqrt(gH))|--sound-speed 14.142"
    "c0 = 20 sqrt(2gH)|--sound-speed 20"
    "DualSPHysics' constants (alpha 0.01, h 1.73, c0 20 sqrt(gH))|--artificial-viscosity 0.01 --smoothing 1.73 --sound-speed 14.142"
)
echo "| setting | ppm | Martin and Moyce worst / mean | Koshizuka and Oka worst / mean | worst of both | CPU s per simulated s |"
echo "|---|---|---|---|---|---|"
for index in "${!variants[@]}"; do
    name="${variants[$index]%%|*}"
    read -r -a options <<<"${variants[$index]#*|}"
    dir="$out/$index"
    "$lab" validate dam-break --models wcsph --ppms "$ppms" --width 0.026 --until-t 3.65 \
        --output-dir "$dir" "${options[@]}" >"$dir.txt"
    grep '^model=wcsph' "$dir.txt" | while read -r line; do
        field() { sed -E "s/.* $1=([^ ]+).*/\1/" <<<"$line"; }
        percent() { awk -v x="$1" 'BEGIN { if (x == "none") print "-"; else printf "%.1f%%", 100 * x }'; }
        mm="$(percent "$(field martin_worst)") / $(percent "$(field martin_mean)")"
        ko="$(percent "$(field koshizuka_worst)") / $(percent "$(field koshizuka_mean)")"
        both=$(awk -v a="$(field martin_worst)" -v b="$(field koshizuka_worst)" \
            'BEGIN { printf "%.1f%%", 100 * (a > b ? a : b) }')
        cost=$(awk -v x="$(field seconds_per_simulated_s)" 'BEGIN { printf "%.0f", x }')
        echo "| $name | $(field ppm) | $mm | $ko | $both | $cost |"
    done
done
