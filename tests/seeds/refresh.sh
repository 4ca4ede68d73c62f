#!/usr/bin/env bash
# Make tests/seeds again: the README's test command on an empty cache, then the records and film slices it built
# become the seeds (see tests/conftest.py, "seeds"). Run after a change to the code that makes them (film/,
# rotor/, verification/, the tables), when a run ends with "the seeds are stale or missing". ~20 min on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/../.."
cache=$(mktemp -d)
trap 'rm -rf "$cache"' EXIT
rm -rf tests/seeds/slices tests/seeds/independent tests/seeds/turns  # no seed planted: it builds every file
LUBEVIZ_CACHE_DIR="$cache" .venv/bin/python -m pytest -q -n auto --dist loadfile "$@" || true
for sub in slices independent turns; do
    rm -rf "tests/seeds/$sub" && mkdir -p "tests/seeds/$sub"
    find "$cache/$sub" -maxdepth 1 -name '*.npz' ! -name '.*' -exec cp {} "tests/seeds/$sub/" \;
done
echo "seeds: $(find tests/seeds -name '*.npz' | wc -l) files, $(du -sh tests/seeds | cut -f1)"
