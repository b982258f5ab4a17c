#!/usr/bin/env bash
# What Slurm adds per array task (issue 39; bench/slurm.md), on the test's two-node cluster (test/slurm_cluster.sh):
# an array of N tasks, each as a study's task starts (it sources scripts/env.sh and imports scripts/study.py), then
# sleeps WORK seconds, then writes a file as a cell's end does. Measured:
#   first start     sbatch until the first task runs;
#   start-up        the task's env.sh and python start-up;
#   per task        (wall time x nodes) / N - WORK: what each task costs beyond its work, the gaps between tasks
#                   included;
#   noticed         a task's end until the study runner sees it (it looks every second).
#   bash bench/run_slurm_overhead.sh [N] [WORK]      (root; default 20 tasks of 5 s)
set -eo pipefail
HERE=$(cd "$(dirname "$0")/.." && pwd)
N=${1:-20}
WORK=${2:-5}
export PATH=/usr/bin:/usr/sbin:$PATH
T=$(mktemp -d /tmp/xpersif-slurm-bench-XXXXXX)
# shellcheck source=test/slurm_cluster.sh
source "$HERE/test/slurm_cluster.sh"
trap 'slurm_cluster_stop; rm -rf "$T"' EXIT
slurm_cluster_start "$T/cluster"
cat >"$T/task.sh" <<EOF
#!/bin/bash
echo "start \$(date +%s.%N)" >"$T/\$SLURM_ARRAY_TASK_ID.times"
source $HERE/scripts/env.sh
/usr/bin/python3 -c "import sys; sys.path.insert(0, '$HERE/scripts'); import study"
echo "ready \$(date +%s.%N)" >>"$T/\$SLURM_ARRAY_TASK_ID.times"
sleep $WORK
echo "end \$(date +%s.%N)" >>"$T/\$SLURM_ARRAY_TASK_ID.times"
EOF
submitted=$(date +%s.%N)
job=$(sbatch --parsable --array=0-$((N - 1)) --output=/dev/null "$T/task.sh")
declare -A noticed
while ((${#noticed[@]} < N)); do  # the runner's loop: a look every second
  sleep 1
  for ((i = 0; i < N; i++)); do
    [[ -z "${noticed[$i]:-}" ]] && grep -q "^end" "$T/$i.times" 2>/dev/null && noticed[$i]=$(date +%s.%N)
  done
done
finished=$(date +%s.%N)
for ((i = 0; i < N; i++)); do
  echo "$i $(awk '{print $2}' "$T/$i.times" | tr '\n' ' ') ${noticed[$i]}"
done | /usr/bin/python3 -c '
import sys
submitted, finished, n, work = float(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4])
rows = [list(map(float, line.split()[1:])) for line in sys.stdin]
first = min(r[0] for r in rows) - submitted
startup = sorted(r[1] - r[0] for r in rows)
noticed = sorted(r[3] - r[2] for r in rows)
wall = max(r[3] for r in rows) - submitted
print("%d tasks of %.0f s on 2 nodes (job %s): wall %.1f s" % (n, work, sys.argv[5], wall))
print("first start %.2f s after sbatch" % first)
print("start-up (env.sh, python) median %.2f s, max %.2f s" % (startup[n // 2], startup[-1]))
print("per task beyond its work: %.2f s ((wall x 2 nodes) / tasks - work)" % (wall * 2 / n - work))
print("noticed by the runner median %.2f s, max %.2f s after the end" % (noticed[n // 2], noticed[-1]))
' "$submitted" "$finished" "$N" "$WORK" "$job"
