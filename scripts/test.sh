#!/usr/bin/env bash
# Every test: install what is missing, build the package and its tests (scripts/setup.sh --tests), then run the
# gtest units and the rostest integration tests through ctest. Arguments go to ctest, e.g. `-R core_checks`.
#
#   bash scripts/test.sh [CTEST_ARGUMENTS...]
# Exit status: ctest's (0 every test passed, 8 a test failed), 1 the set-up failed.
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
if [[ "${1:-}" == -h || "${1:-}" == --help ]]; then
  echo "usage: bash scripts/test.sh [CTEST_ARGUMENTS...]   (set-up, build with the tests, then ctest)"
  echo "exit: 0 every test passed, 1 the set-up failed, 8 a test failed (ctest's code)"
  exit 0
fi

bash "$repo/scripts/setup.sh" --tests
source "$repo/scripts/env.sh"
set -u
# One job per core: the ROS systems run in two lanes of their own (test/CMakeLists.txt, "Scheduling").
ctest --test-dir "$repo/build" --output-on-failure -j "$(nproc)" "$@"
