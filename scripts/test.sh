#!/usr/bin/env bash
# Every test: install what is missing, build, build the tests, run gtest units and rostest
# integration tests through ctest.
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

bash "$repo/scripts/setup.sh"
# add_rostest_gtest targets are EXCLUDE_FROM_ALL: they are built by the 'tests' target.
cmake --build "$repo/build" --target tests -j"$(nproc)" >>"$repo/build.log" 2>&1 || { tail -50 "$repo/build.log"; exit 1; }
source "$repo/scripts/env.sh"
set -u
ctest --test-dir "$repo/build" --output-on-failure "$@"
