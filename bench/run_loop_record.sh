#!/usr/bin/env bash
# Recording the full loop (issue 6): the main job (scripts/run.sh) with recording on, measured from outside:
# the recorder's CPU share (utime+stime of the `record` process over its life, sampled every second from
# /proc until it exits; 100 % = one core), and bench/summarize_loop_record.py on the run directory
# (messages per topic recorded vs published, /tf frames and feature/image seqs dropped, bytes per simulated s).
#   bash bench/run_loop_record.sh OUT_DIR TAG RUN_SH_OPTIONS...     -> OUT_DIR/TAG.json, OUT_DIR/TAG.log
# e.g. bash bench/run_loop_record.sh bench/results/loop-record lz4 --set recording.mode=bags --set phases.0.experiments=4 \
#      --set phases.1.experiments=8 --set phases.2.experiments=8 --set phases.2.goals=1
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
out=$(mkdir -p "$1" && cd "$1" && pwd); tag=$2; shift 2
run_dir=$(mktemp -d /tmp/xpersif-loop-record-XXXXXX)
XPERSIF_RUN_DIR=$run_dir bash "$HERE/../scripts/run.sh" "$@" >"$out/$tag.log" 2>&1 &
job=$!
hz=$(getconf CLK_TCK)
rec= first= ticks0= ticks= t0= t= load=
while kill -0 "$job" 2>/dev/null; do
  if [ -z "$rec" ]; then
    rec=$(pgrep -f "^/usr/lib/rosbag/record .*$run_dir/xpersif.bag" | head -1 || true)
  fi
  if [ -n "$rec" ] && s=$(cat "/proc/$rec/stat" 2>/dev/null); then
    now=$(date +%s.%N)
    ticks=$(echo "$s" | awk '{print $14 + $15}')
    [ -n "$t0" ] || { t0=$now; ticks0=$ticks; }
    t=$now
    load=$(cut -d' ' -f1-3 /proc/loadavg)
  fi
  sleep 1
done
wait "$job" || { echo "run.sh failed; see $out/$tag.log" >&2; exit 1; }
cpu=$(awk -v a="$ticks0" -v b="$ticks" -v t0="$t0" -v t1="$t" -v hz="$hz" 'BEGIN{printf "%.1f", (b - a) / hz / (t1 - t0) * 100}')
wall=$(awk -v t0="$t0" -v t1="$t" 'BEGIN{printf "%.1f", t1 - t0}')
summary=$(/usr/bin/python3 "$HERE/summarize_loop_record.py" "$run_dir")
# rosbag record says so when its buffer overflows and it drops messages
exceeded=$(cat "$run_dir/launch.log" "$run_dir"/ros_log/*/*.log 2>/dev/null | grep -ci "buffer exceeded" || true)
echo "{\"run\":\"$tag\",\"options\":\"$*\",\"recorder_cpu_pct\":$cpu,\"recorder_wall_s\":$wall,\"loadavg_at_end\":\"$load\",\"rosbag_buffer_exceeded_lines\":${exceeded:-0},\"summary\":$summary}" |
  tee "$out/$tag.json"
cp "$run_dir/report.md" "$out/$tag.report.md" 2>/dev/null || true
rm -rf "$run_dir"
