#!/usr/bin/env bash
# The main job: an experiment file run headless from start to end (the default: experiments/default.yaml,
# curiosity-driven against random design on the default world, then goals, then the report), on a roscore of
# its own. A thin wrapper around
#     roslaunch xpersif experiment.launch experiment:=FILE
# that installs and builds first (scripts/setup.sh) and exits with the experiment's outcome (Debian's
# roslaunch exits 0 however its required node ended; the runner writes the outcome to a status file).
#
#   bash scripts/run.sh [FILE] [--set KEY=VALUE]... [--run-dir DIR]
#     FILE             an experiment file (default experiments/default.yaml; doc/experiments.md)
#     --set KEY=VALUE  override a key of the file: --set seed=3, --set phases.1.experiments=8,
#                      --set recording.mode=bags, --set world=worlds/mixed.yaml (relative to FILE's directory)
#     --run-dir DIR    instead of the file's run_dir (also: XPERSIF_RUN_DIR)
#     --hosts 'ARGS'   where the parts run: xpersif.launch's host arguments as NAME=VALUE, e.g. 'sim_host=10.0.0.5
#                      view_host=10.0.0.7' (doc/hosts.md; set ROS_IP to this host's address first)
# Everything goes to the run directory (runs/<time>/ by default): report.md, learning_curve.png/.csv,
# knowledge.db, the experiment as run and its provenance, launch.log, ros_log/.
# Exit status (doc/exit-codes.md): 0 done, 1 a phase or the report failed, 2 usage or a bad experiment file
# (nothing started), 4 the run directory cannot be written, 5 a phase stopped on a cause that fails every experiment
# (the loop cannot perceive: doc/loop.md#when-the-loop-cannot-perceive).
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
experiment="$repo/experiments/default.yaml" overrides=() run_dir="${XPERSIF_RUN_DIR:-}" files=0 hosts=""
help() {
  cat <<'TEXT'
usage: bash scripts/run.sh [FILE] [--set KEY=VALUE]... [--run-dir DIR] [--hosts ARGS]
Runs an experiment file from start to end, headless, on a roscore of its own (installs and builds first).
  FILE             an experiment file (default experiments/default.yaml; doc/experiments.md)
  --set KEY=VALUE  override a key of the file: --set seed=3, --set phases.1.experiments=8,
                   --set recording.mode=bags, --set world=../worlds/mixed.yaml (relative to FILE's directory)
  --run-dir DIR    instead of the file's run_dir (also: XPERSIF_RUN_DIR)
  --hosts 'ARGS'   where the parts run: xpersif.launch's host arguments, e.g. 'sim_host=10.0.0.5' (doc/hosts.md)
  -h, --help       print this usage
Exit codes: 0 done; 1 a phase or the report failed; 2 usage or a bad experiment file (nothing started);
4 the run directory cannot be written; 5 a phase stopped on a cause that fails every experiment (the loop
cannot perceive; doc/exit-codes.md).
TEXT
}
usage() { echo "run.sh: $*" >&2; help >&2; exit 2; }
while (($#)); do
  case "$1" in
    -h|--help) help; exit 0 ;;
    --set) (($# >= 2)) || usage "--set needs KEY=VALUE"; [[ "$2" == *=* ]] || usage "--set $2: expected KEY=VALUE"
           overrides+=("$2"); shift 2 ;;
    --run-dir) (($# >= 2)) && [[ -n "$2" ]] || usage "--run-dir needs a directory"; run_dir=$2; shift 2 ;;
    --hosts) (($# >= 2)) || usage "--hosts needs ARGS"; hosts=$2; shift 2 ;;
    -*) usage "unknown option $1" ;;
    *) experiment=$1; files=$((files + 1)); shift ;;
  esac
done
((files <= 1)) || usage "give one experiment file, not $files"
[[ -e "$experiment" ]] || { echo "run.sh: $experiment: no such experiment file" >&2; exit 2; }
[[ -f "$experiment" && -r "$experiment" ]] || { echo "run.sh: $experiment: not a readable experiment file" >&2; exit 2; }
experiment=$(cd "$(dirname "$experiment")" && pwd)/$(basename "$experiment")  # the nodes run elsewhere
if [[ -n "$run_dir" ]]; then
  mkdir -p "$run_dir" 2>/dev/null && [[ -w "$run_dir" ]] ||
    { echo "run.sh: the run directory $run_dir cannot be created or written" >&2; exit 4; }
  run_dir=$(cd "$run_dir" && pwd)
fi
# Built already? Then a bad file (or --set) is refused at once, before the build and the master. The check runs in
# the run's environment (the devel space's setup): a world may name its robot package://xpersif/..., as generated
# worlds do, and that resolves through ROS_PACKAGE_PATH.
checker="$repo/build/devel/lib/xpersif/xpersif_experiment"
if [[ -x "$checker" && -f "$repo/build/devel/setup.bash" ]]; then
  (
    set +u
    # shellcheck disable=SC1091
    source "$repo/build/devel/setup.bash"
    "$checker" check "$experiment" --components "$repo/config/loop.yaml,$repo/config/embodiment.yaml" \
      "${overrides[@]}" >/dev/null
  ) || exit 2
fi

bash "$repo/scripts/setup.sh"
XPERSIF_NEW_MASTER=1 source "$repo/scripts/env.sh"
set -u
status_file=$(mktemp /tmp/xpersif_experiment_status.XXXXXX)
trap 'rm -f "$status_file"' EXIT
echo "run: master $ROS_MASTER_URI, experiment $experiment"
roslaunch_code=0
roslaunch -p "${ROS_MASTER_URI##*:}" xpersif experiment.launch experiment:="$experiment" run_dir:="$run_dir" \
  overrides:="${overrides[*]:-}" status_file:="$status_file" hosts:="$hosts" || roslaunch_code=$?
# roslaunch fails itself (exit 1) when the file is bad: the check's sentence is above.
((roslaunch_code == 0)) || exit 2
[[ -s "$status_file" ]] || { echo "run: the experiment ended without an outcome" >&2; exit 1; }
read -r code sentence <"$status_file"
echo "run: $sentence"
exit "$code"
