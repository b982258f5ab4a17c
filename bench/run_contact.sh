#!/usr/bin/env bash
# How objects answer off-centre pushes, the old friction model (ODE's pyramid) beside the new one (Coulomb), in
# the same run: every object of each world pushed on its -x and -y faces at 9 offsets from -max to +max, 120 mm
# (or the arena's limit), and the redrawn object 8 times at 3 offsets. See bench/contact.md.
#   bash bench/run_contact.sh [BUILD_DIR=build] [OUT_DIR=bench/results/contact]
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$here/build}"
out="${2:-$here/bench/results/contact}"
bench="$build/devel/lib/xpersif/contact_bench"
[ -x "$bench" ] || cmake --build "$build" --target contact_bench
mkdir -p "$out"
{
  echo "# $(date -u +%FT%TZ) $(git -C "$here" describe --always --dirty --tags 2>/dev/null || true)" >&2
  for world in default structured; do
    for model in pyramid coulomb; do
      "$bench" "$here/worlds/$world.yaml" --label "$world/$model" --friction-model "$model" --offsets 9 \
        > "$out/${world}_${model}.csv"
      if [ "$world" = structured ]; then
        "$bench" "$here/worlds/$world.yaml" --label "$world/$model/repeats" --friction-model "$model" \
          --objects red_cube,orange_bar,purple_cube --offsets 3 --repeats 8 > "$out/${world}_${model}_repeats.csv"
      fi
    done
  done
} 2> "$out/summary.txt"
cat "$out/summary.txt"
