#!/usr/bin/env bash
# Measures the build settings side by side: the current settings (target-cpu=native from
# .cargo/config.toml, the release profile of Cargo.toml) against variants given as
# environment overrides, each built into target/builds/<name>, on two workloads timed in
# one hyperfine run each: the course model blowing up (fluid 1000 large.fld) and the
# stable dense phase (fluid-lab run --model fluidanimate --steps 300 large.fld).
#
# Usage: scripts/compare-builds.sh
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
if ! command -v hyperfine >/dev/null; then
    echo "compare-builds.sh: hyperfine is not installed (apt-get install hyperfine)" >&2
    exit 1
fi
variants=(
    "current:"
    "no-native:RUSTFLAGS="
    "lto-fat:CARGO_PROFILE_RELEASE_LTO=fat"
    "codegen-units-1:CARGO_PROFILE_RELEASE_CODEGEN_UNITS=1"
    "lto-cgu1-abort:CARGO_PROFILE_RELEASE_LTO=fat CARGO_PROFILE_RELEASE_CODEGEN_UNITS=1 CARGO_PROFILE_RELEASE_PANIC=abort"
)
course=()
dense=()
for variant in "${variants[@]}"; do
    name="${variant%%:*}"
    read -r -a overrides <<<"${variant#*:}"
    env "${overrides[@]}" cargo build --release --quiet --target-dir "target/builds/$name" \
        --bin fluid --bin fluid-lab
    bin="target/builds/$name/release"
    course+=(-n "$name" "$bin/fluid 1000 data/in/large.fld /dev/null")
    dense+=(-n "$name" "$bin/fluid-lab run --model fluidanimate --steps 300 data/in/large.fld")
done
for workload in course dense; do
    declare -n commands="$workload"
    hyperfine -N --warmup 1 --runs 7 --export-csv "target/builds/$workload.csv" \
        "${commands[@]}" >&2
    awk -F, -v what="$workload" '
        NR == 1 { next }
        { name[NR] = $1; median[NR] = $4; last = NR }
        END {
            printf "| %s | median [s] | vs current |\n|:---|---:|---:|\n", what
            for (i = 2; i <= last; i++)
                printf "| %s | %.4f | %.2fx |\n", name[i], median[i], median[i] / median[2]
        }' "target/builds/$workload.csv"
    echo
done
