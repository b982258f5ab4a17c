#!/usr/bin/env bash
# Curiosity-driven against random design over several seeds: runs the main job (scripts/run.sh) once per seed
# and collects, from each run's report.md, the error random design ends with, the experiments curiosity needed
# to reach it, and the goal success rate. Usage: bash bench/run_loop_designs.sh OUT_DIR [SEED...]
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=${1:?usage: run_loop_designs.sh OUT_DIR [SEED...]}
shift
seeds=("$@")
((${#seeds[@]})) || seeds=(1 2 3)
mkdir -p "$out"
summary="$out/summary.md"
{
  echo "| seed | random's final error (m) | random: experiments | curiosity reaches it after | curiosity's final error (m) | goals reached | main job (s) |"
  echo "|---|---|---|---|---|---|---|"
} >"$summary"
for seed in "${seeds[@]}"; do
  run_dir="$out/seed-$seed"
  rm -rf "$run_dir"
  XPERSIF_RUN_DIR="$run_dir" bash "$repo/scripts/run.sh" --set seed="$seed" >"$out/seed-$seed.log" 2>&1 || {
    echo "seed $seed failed; see $out/seed-$seed.log" >&2
    continue
  }
  report="$run_dir/report.md"
  final=$(sed -n 's/^Random design ends at \([0-9.]*\) m after \([0-9]*\) experiments.*/\1/p' "$report")
  n=$(sed -n 's/^Random design ends at \([0-9.]*\) m after \([0-9]*\) experiments.*/\2/p' "$report")
  reach=$(sed -n 's/^- curiosity reaches it after \(.*\)$/\1/p' "$report")
  cfinal=$(awk -F'|' '/^\| [0-9]+ \|/ && $3 ~ /[0-9]/ {v=$3} END {gsub(/ /, "", v); print v}' "$report")
  goals=$(sed -n 's/^Success rate: \(.*\) goals reached.*/\1/p' "$report")
  took=$(sed -n 's/.* done in \([0-9]*\) s.*/\1/p' "$out/seed-$seed.log" | tail -1)
  echo "| $seed | $final | $n | $reach | $cfinal | $goals | $took |" >>"$summary"
done
cat "$summary"
