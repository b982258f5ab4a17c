#!/usr/bin/env bash
# A study: N seeds x designs x budget on the lockstep loop, headless, as many cells at once as there are cores,
# with a progress bar and the time left; resumable (run the same command again); a report with learning curves
# and 95 % bands, experiments needed to reach random design's final error, paired tests, the share of
# experiments per object over time, and the notions. doc/studies.md; the options: scripts/study.py --help.
#
#   bash scripts/study.sh --seeds 3 --designs random,learning_progress,error_max --budget 40 --out studies/small
#
# It installs and builds first (scripts/setup.sh) unless XPERSIF_SKIP_SETUP=1.
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
# The usage needs no build.
for argument in "$@"; do
  [[ "$argument" == -h || "$argument" == --help ]] && exec /usr/bin/python3 "$repo/scripts/study.py" --help
done
[[ "${XPERSIF_SKIP_SETUP:-0}" == 1 ]] || bash "$repo/scripts/setup.sh"
# shellcheck disable=SC1091
source "$repo/scripts/env.sh"
set -u
exec /usr/bin/python3 "$repo/scripts/study.py" "$@"
