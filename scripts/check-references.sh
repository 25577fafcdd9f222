#!/usr/bin/env bash
# Checks the optimised (release) fluid binary against the bundled reference outputs:
# 0 steps must reproduce each input and 1..5 steps must equal data/out/<input>-<n>.fld
# byte for byte. `cargo test` checks the debug build; this checks the build users run.
# Usage: scripts/check-references.sh        (exit 0 when all 12 files match)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

cargo build --release --quiet
fluid="$root/target/release/fluid"
scratch="$(mktemp -d)"
trap 'rm -rf "$scratch"' EXIT

failures=0
checks=0
for input in small large; do
    for steps in 0 1 2 3 4 5; do
        if [ "$steps" -eq 0 ]; then
            expected="data/in/$input.fld"
        else
            expected="data/out/$input-$steps.fld"
        fi
        actual="$scratch/$input-$steps.fld"
        "$fluid" "$steps" "data/in/$input.fld" "$actual" >/dev/null
        checks=$((checks + 1))
        if cmp -s "$actual" "$expected"; then
            echo "ok    $input, $steps steps = $expected"
        else
            differing=$(cmp -l "$actual" "$expected" 2>/dev/null | wc -l || true)
            echo "FAIL  $input, $steps steps: $differing bytes differ from $expected"
            failures=$((failures + 1))
        fi
    done
done
echo "$((checks - failures)) passed, $failures failed"
[ "$failures" -eq 0 ]
