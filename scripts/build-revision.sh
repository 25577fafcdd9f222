#!/usr/bin/env bash
# Builds one binary of a git revision, once, in its own worktree, and prints its path.
# The worktree is target/revisions/<short hash>, built with the current
# .cargo/config.toml (target-cpu=native), so revisions compare on the same flags.
#
# Usage: scripts/build-revision.sh REV BINARY      e.g. scripts/build-revision.sh HEAD~3 fluid
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
if [ $# -ne 2 ]; then
    echo "usage: $0 REV BINARY" >&2
    exit 2
fi
hash="$(git rev-parse --short "$1^{commit}")"
tree="target/revisions/$hash"
if [ ! -x "$tree/target/release/$2" ]; then
    if [ ! -d "$tree" ]; then
        git worktree add --detach --force "$tree" "$hash" >&2
    fi
    mkdir -p "$tree/.cargo"
    cp .cargo/config.toml "$tree/.cargo/config.toml"
    (cd "$tree" && cargo build --release --quiet --bin "$2" >&2)
fi
echo "$root/$tree/target/release/$2"
