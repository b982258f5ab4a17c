#!/usr/bin/env bash
# The lockstep loop is deterministic (issue 13), and so is a run interrupted in any of the ways a run can be
# (issue 19): the same campaign (6 experiments and 1 goal, one seed), run on a fresh system each time, gives the
# same knowledge base, every stored field of every experiment, goal and notion (times aside: scripts/compare_kb.py):
#   first       uninterrupted;
#   second      uninterrupted again;
#   resumed     stopped with `xpersif stop` once STOP_AFTER experiments are stored, then `xpersif run ... --resume`;
#   kb_manager, sim_manager, embodiment_manager
#               that manager SIGKILLed once STOP_AFTER experiments are stored (mid-experiment, as a rule): roslaunch
#               respawns it, LOOPMODEL restarts its components, puts the world back in the state the interrupted
#               experiment began from (XPERSim's checkpoint in the knowledge base) and does that experiment again;
#   sim_host    the simulator's and the embodiment's managers SIGKILLed together (a multi-host system's sim host
#               dying): the experiment under way ends at once and is done again;
#   goal_sim_manager
#               the simulator's manager SIGKILLed in the goal phase, once the goal's first push is stored: the push
#               under way is done again from its own world state;
#   system      every process of the system SIGKILLed at that moment (the master, roslaunch, every manager), the
#               system started again on the same knowledge base, and the run resumed from the stored world state.
# Usage: determinism.sh [WORLD [DESIGN]]   (default: worlds/default.yaml, curiosity); ONLY="system sim_manager"
# runs the first take and those.
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
world=${1:-$repo/worlds/default.yaml}
design=${2:-curiosity}
stop_after=3
campaign=(campaign --experiments 6 --goals 1 --design "$design" --seed 11)
work=$(mktemp -d)
launch=0
cleanup() {
  [ "$launch" -gt 0 ] && kill -INT "$launch" 2>/dev/null && wait "$launch" 2>/dev/null
  if [ -n "${KEEP_WORK:-}" ]; then echo "determinism: kept $work"; else rm -rf "$work"; fi
}
trap cleanup EXIT

stored() {  # experiments stored in the knowledge base $1 so far
  /usr/bin/python3 -c 'import sqlite3,sys; print(sqlite3.connect(f"file:{sys.argv[1]}?mode=ro", uri=True).execute("SELECT count(*) FROM experiments").fetchone()[0])' "$1" 2>/dev/null || echo 0
}

take() {  # take NAME [resume|kill:MANAGER|system [STOP_AFTER]]
  local name=$1 interrupt=${2:-} stop_after=${3:-$stop_after}
  XPERSIF_NEW_MASTER=1 source "$repo/scripts/env.sh"
  set -u
  roslaunch -p "${ROS_MASTER_URI##*:}" xpersif xpersif.launch world:="$world" database:="$work/$name.db" \
    run_dir:="$work/$name" snapshot:=false trace_file:="${TRACE:+$work/$name.trace}" >"$work/$name.launch.log" 2>&1 &
  launch=$!
  xpersif wait --timeout 180 /xpersif/loop_model >/dev/null || { tail -20 "$work/$name.launch.log"; exit 1; }
  local started=$(date +%s)
  if [ "$interrupt" = resume ]; then
    xpersif run "${campaign[@]}" >"$work/$name.run1.log" 2>&1 &
    local runner=$!
    until [ "$(stored "$work/$name.db")" -ge "$stop_after" ] || ! kill -0 "$runner" 2>/dev/null; do sleep 0.2; done
    xpersif stop >/dev/null
    wait "$runner" || true  # a stopped run ends unsuccessfully
    echo "determinism: $name: stopped: $(tail -1 "$work/$name.run1.log") ($(stored "$work/$name.db") stored)"
    xpersif run "${campaign[@]}" --resume | tail -1
  elif [ -n "$interrupt" ]; then  # kill:MANAGER or system
    xpersif run "${campaign[@]}" >"$work/$name.run1.log" 2>&1 &
    local runner=$!
    until [ "$(stored "$work/$name.db")" -ge "$stop_after" ] || ! kill -0 "$runner" 2>/dev/null; do sleep 0.2; done
    if [ "$interrupt" = system ]; then
      # Every process that talks to this take's master, and the master and roslaunch themselves.
      local pids="$launch" pid
      for pid in $(pgrep -f "ros|nodelet|xpersif" || true); do
        [ "$pid" = "$$" ] || [ "$pid" = "$runner" ] && continue  # the client must notice by itself
        tr '\0' '\n' <"/proc/$pid/environ" 2>/dev/null | grep -qx "ROS_MASTER_URI=${ROS_MASTER_URI%/}/\?" && pids="$pids $pid"
      done
      kill -KILL $pids 2>/dev/null || true
      wait "$launch" 2>/dev/null || true
      # The client is not killed: it must notice that its master is gone, and say so (exit 1), within 10 s.
      local waited=0
      while kill -0 "$runner" 2>/dev/null && [ "$waited" -lt 60 ]; do sleep 1; waited=$((waited + 1)); done
      if kill -0 "$runner" 2>/dev/null; then
        kill -KILL "$runner"
        echo "determinism: $name: xpersif run still waits $waited s after its master died"
        exit 1
      fi
      wait "$runner" && { echo "determinism: $name: xpersif run ended successfully although its master died"; exit 1; }
      echo "determinism: $name: the client said: $(grep 'has been gone' "$work/$name.run1.log" || tail -1 "$work/$name.run1.log")"
      echo "determinism: $name: killed the whole system ($(echo $pids | wc -w) processes) after $(stored "$work/$name.db") experiments"
      sleep 1
      roslaunch -p "${ROS_MASTER_URI##*:}" xpersif xpersif.launch world:="$world" database:="$work/$name.db" \
        run_dir:="$work/$name" snapshot:=false trace_file:="${TRACE:+$work/$name.trace2}" >>"$work/$name.launch.log" 2>&1 &
      launch=$!
      xpersif wait --timeout 180 /xpersif/loop_model >/dev/null || { tail -20 "$work/$name.launch.log"; exit 1; }
      xpersif run "${campaign[@]}" --resume | tail -1
    else
      # kill:M1+M2 kills several managers at once (the sim host of a multi-host system dying).
      local manager_name managers="" pid manager
      for manager_name in $(tr '+' ' ' <<<"${interrupt#kill:}"); do
        manager=""
        # This take's manager: the one talking to this take's master (other systems may run on the machine).
        for pid in $(pgrep -f "__name:=$manager_name" || true); do
          tr '\0' '\n' <"/proc/$pid/environ" 2>/dev/null | grep -qx "ROS_MASTER_URI=${ROS_MASTER_URI%/}/\?" && manager=$pid
        done
        [ -n "$manager" ] || { echo "determinism: no $manager_name process to kill"; exit 1; }
        managers="$managers $manager"
      done
      kill -KILL $managers
      echo "determinism: $name: killed ${interrupt#kill:} (pids$managers) after $(stored "$work/$name.db") experiments"
      wait "$runner" || { cat "$work/$name.run1.log"; exit 1; }
      tail -1 "$work/$name.run1.log"
    fi
  else
    xpersif run "${campaign[@]}" | tail -1
  fi
  echo "determinism: $name campaign took $(($(date +%s) - started)) s"
  kill -INT "$launch"
  wait "$launch" || true
  launch=0
}

takes="second resumed kb_manager sim_manager embodiment_manager sim_host goal_sim_manager system"
take first
for name in ${ONLY:-$takes}; do
  case $name in
    second) take second ;;
    resumed) take resumed resume ;;
    system) take system system ;;
    goal_sim_manager) take goal_sim_manager kill:sim_manager 7 ;;  # mid-goal: its first push is stored
    sim_host) take sim_host kill:sim_manager+embodiment_manager ;;  # both at once, as multi_host.sh does
    *) take "$name" "kill:$name" ;;
  esac
done
failed=0 compared=0
for other in ${ONLY:-$takes}; do
  echo "determinism: first against $other:"
  compared=$((compared + 1))
  /usr/bin/python3 "$repo/scripts/compare_kb.py" "$work/first.db" "$work/$other.db" || failed=$((failed + 1))
done
echo "$((compared - failed)) passed, $failed failed"
[ "$failed" -eq 0 ]
