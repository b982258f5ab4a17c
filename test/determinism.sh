#!/usr/bin/env bash
# The lockstep loop is deterministic (issue 13), and so is a run interrupted in any of the ways a run can be
# (issue 19): the same campaign (6 experiments and 1 goal, one seed), run on a fresh system each time, gives the
# same knowledge base, every stored field of every experiment, goal and notion (times aside: scripts/compare_kb.py):
#   first       uninterrupted;
#   second      uninterrupted again;
#   resumed     stopped with `xpersif stop` once STOP_AFTER experiments are stored, then `xpersif run ... --resume`;
#   stopped_sim_manager
#               the simulator's manager SIGSTOPped for 3 s (longer than the heartbeat timeout), then continued:
#               LOOPMODEL reports it lost (checked in the launch log), restarts it, and does the experiment again;
#   goal_sim_manager
#               the simulator's manager SIGKILLed in the goal phase, once the goal's first push is stored: the push
#               under way is done again from its own world state;
#   system      every process of the system SIGKILLed at that moment (the master, roslaunch, every manager), the
#               system started again on the same knowledge base, and the run resumed from the stored world state.
# Takes run by name only (ONLY=...):
#   kb_manager, sim_manager, embodiment_manager, loop_manager
#               that manager SIGKILLed once STOP_AFTER experiments are stored (mid-experiment, as a rule): roslaunch
#               respawns it, LOOPMODEL restarts its components (the loader respawns LOOPMODEL itself, and
#               `xpersif run` sends the run again with resume), puts the world back in the state the interrupted
#               experiment began from (XPERSim's checkpoint in the knowledge base) and does that experiment again;
#   sim_host    the simulator's and the embodiment's managers SIGKILLed together (a multi-host system's sim host);
#   crashN      the crash battery's take N (ctest crash_battery runs crash1..crash10): KILLS_PER_TAKE (2) SIGKILLs,
#               each of a manager chosen at random among the four and the sim host's pair, after a random number
#               of stored experiments (0-6, 6 being in the goal phase) and a random 0-1.5 s more, seeded by N.
# Usage: determinism.sh [WORLD [DESIGN]]   (default: worlds/default.yaml, curiosity); ONLY="system sim_manager"
# runs the first take and those.
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
# The disk takes mount a file system for the knowledge base: in a mount namespace of this script's own, so that
# nothing stays mounted whatever happens to it.
if [[ " ${ONLY:-} " =~ \ (disk_full|read_only)\  ]] && [ -z "${XPERSIF_OWN_MOUNTS:-}" ]; then
  XPERSIF_OWN_MOUNTS=1 exec unshare --mount --propagation private bash "${BASH_SOURCE[0]}" "$@"
fi
world=${1:-$repo/worlds/default.yaml}
design=${2:-curiosity}
stop_after=3
experiments=6
campaign=(campaign --experiments "$experiments" --goals 1 --design "$design" --seed 11)
work=$(mktemp -d)
launch=0
cleanup() {
  [ "$launch" -gt 0 ] && stop_launch cleanup
  [ -n "${XPERSIF_OWN_MOUNTS:-}" ] && for d in "$work"/*.disk; do mountpoint -q "$d" && umount -l "$d"; done; true
  if [ -n "${KEEP_WORK:-}" ]; then echo "determinism: kept $work"; else rm -rf "$work"; fi
}
trap cleanup EXIT

stored() {  # experiments stored in the knowledge base $1 so far
  /usr/bin/python3 -c 'import sqlite3,sys; print(sqlite3.connect(f"file:{sys.argv[1]}?mode=ro", uri=True).execute("SELECT count(*) FROM experiments").fetchone()[0])' "$1" 2>/dev/null || echo 0
}

manager_pids() {  # manager_pids M1+M2: the pids of those managers of this take's master (others may run here)
  local manager_name pid manager pids=""
  for manager_name in $(tr '+' ' ' <<<"$1"); do
    manager=""
    for pid in $(pgrep -f "__name:=$manager_name" || true); do
      tr '\0' '\n' <"/proc/$pid/environ" 2>/dev/null | grep -x "ROS_MASTER_URI=${ROS_MASTER_URI%/}/\?" >/dev/null && manager=$pid
    done
    [ -n "$manager" ] || { echo "determinism: no $manager_name process to interrupt" >&2; return 1; }
    pids="$pids $manager"
  done
  echo $pids
}

interrupt() {  # interrupt NAME kill:M1+M2|stop:M1+M2: SIGKILL them, or SIGSTOP them for 3 s (3 heartbeat timeouts)
  local name=$1 how=${2%%:*} managers=${2#*:} pids tries=0
  # A manager killed a moment ago may not be back yet (roslaunch respawns it): wait up to 15 s for it.
  until pids=$(manager_pids "$managers" 2>/dev/null); do
    tries=$((tries + 1))
    [ "$tries" -lt 75 ] || { manager_pids "$managers"; exit 1; }
    sleep 0.2
  done
  if [ "$how" = stop ]; then
    kill -STOP $pids
    sleep 3
    kill -CONT $pids
    echo "$name stop:$managers" >>"$work/interruptions"
    echo "determinism: $name: stopped $managers (pids $pids) for 3 s after $(stored "$db") stored"
  else
    kill -KILL $pids
    echo "$name kill:$managers" >>"$work/interruptions"
    echo "determinism: $name: killed $managers (pids $pids) after $(stored "$db") stored"
  fi
}

stop_launch() {  # stop_launch NAME: SIGINT to the take's roslaunch, which stops its nodes (at most 17 s each, in
  # parallel). One that still runs after 60 s is a roslaunch that hangs (seen once on CI, after crash10): the script
  # says what is left and what roslaunch last logged, kills them, and goes on; the knowledge base is already written.
  local tenths=0
  kill -INT "$launch" 2>/dev/null || true
  while kill -0 "$launch" 2>/dev/null && [ "$tenths" -lt 600 ]; do sleep 0.1; tenths=$((tenths + 1)); done
  if kill -0 "$launch" 2>/dev/null; then
    echo "determinism: $1: roslaunch (pid $launch) still runs 60 s after SIGINT; what is left of it:"
    ps -o pid,stat,etime,wchan:24,args --pid "$launch" --ppid "$launch" | cut -c1-200 | sed 's/^/determinism:   /' || true
    local own_log
    own_log=$(find "${ROS_LOG_DIR:-$HOME/.ros/log}" -name "roslaunch-*-$launch.log" 2>/dev/null | head -1) || true
    [ -n "$own_log" ] && tail -12 "$own_log" | cut -c1-300 | sed 's/^/determinism:   /'
    kill -KILL $(pgrep -P "$launch") "$launch" 2>/dev/null || true
    echo "$1" >>"$work/hung_shutdowns"
  fi
  wait "$launch" 2>/dev/null || true
  launch=0
}

launch_trouble() {  # launch_trouble NAME: what the take's system said went wrong (CI keeps no log file)
  echo "determinism: $1: the last warnings and errors of its launch log:"
  grep -aE "WARN|ERROR|died|restarting|components up" "$work/$1.launch.log" | tail -40 | cut -c1-400 || true
}

battery_plan() {  # battery_plan SEED: "K D kill:MANAGERS" lines, the seeded moments of one battery take
  /usr/bin/python3 - "$1" "${KILLS_PER_TAKE:-2}" <<'PLAN'
import random, sys
rng = random.Random(int(sys.argv[1]))
kills = int(sys.argv[2])
managers = ["sim_manager", "embodiment_manager", "kb_manager", "loop_manager", "sim_manager+embodiment_manager"]
# K: experiments stored before the kill (0-5: mid-experiment of 6; 6: in the goal phase), D: seconds after that.
moments = sorted(rng.sample(range(7), kills))
for k in moments:
    # Not LOOPMODEL's manager in the goal phase: a resumed run starts the unfinished goal again from its start,
    # and the pushes of it already stored stay (a known gap, doc/loop.md).
    choices = managers if k < 6 else [m for m in managers if m != "loop_manager"]
    print(k, "%.2f" % rng.uniform(0.0, 1.5), "kill:" + rng.choice(choices))
PLAN
}

pause_before() {  # pause_before SECONDS MANAGERS: the battery's wait before a kill
  if [[ "$2" != *loop_manager* ]]; then
    sleep "$1"
    return
  fi
  # LOOPMODEL lost after a goal push is stored is a known gap (doc/console.md): the battery kills its manager
  # before the goal phase (battery_plan), yet on a fast machine the seconds after the K-th experiment can hold
  # three more (a take of crash3 killed it after 7 stored, 1 in 12 here). So the wait ends with the last experiment.
  local end now
  end=$(awk -v d="$1" -v now="$(date +%s%N)" 'BEGIN { printf "%d", now + d * 1e9 }')
  now=$(date +%s%N)
  while [ "$now" -lt "$end" ] && [ "$(stored "$db")" -lt "$experiments" ]; do
    sleep 0.05
    now=$(date +%s%N)
  done
}

take() {  # take NAME [resume|kill:MANAGERS|stop:MANAGERS|battery:SEED|system [STOP_AFTER]]
  local name=$1 interrupt=${2:-} stop_after=${3:-$stop_after} db="$work/$1.db" disk=""
  if [[ "$interrupt" == disk:* ]]; then
    # The knowledge base on a file system of its own, which this take fills or turns read-only mid-run.
    disk="$work/$name.disk"
    mkdir -p "$disk"
    if [ "$interrupt" = disk:full ]; then
      mount -t tmpfs -o size=32m xpersif_kb "$disk"
    else
      truncate -s 64M "$work/$name.img" && mkfs.ext4 -q -F "$work/$name.img"
      mount -o loop,errors=remount-ro "$work/$name.img" "$disk"
    fi
    db="$disk/knowledge.db"
  fi
  XPERSIF_NEW_MASTER=1 source "$repo/scripts/env.sh"
  set -u
  roslaunch -p "${ROS_MASTER_URI##*:}" xpersif xpersif.launch world:="$world" database:="$db" \
    run_dir:="$work/$name" snapshot:=false trace_file:="${TRACE:+$work/$name.trace}" >"$work/$name.launch.log" 2>&1 &
  launch=$!
  xpersif wait --timeout 180 /xpersif/loop_model >/dev/null || { tail -20 "$work/$name.launch.log"; exit 1; }
  local started=$(date +%s)
  if [ "$interrupt" = resume ]; then
    xpersif run "${campaign[@]}" >"$work/$name.run1.log" 2>&1 &
    local runner=$!
    until [ "$(stored "$db")" -ge "$stop_after" ] || ! kill -0 "$runner" 2>/dev/null; do sleep 0.2; done
    xpersif stop >/dev/null
    wait "$runner" || true  # a stopped run ends unsuccessfully
    echo "determinism: $name: stopped: $(tail -1 "$work/$name.run1.log") ($(stored "$db") stored)"
    xpersif run "${campaign[@]}" --resume | tail -1
  elif [[ "$interrupt" == disk:* ]]; then
    xpersif run "${campaign[@]}" >"$work/$name.run1.log" 2>&1 &
    local runner=$!
    until [ "$(stored "$db")" -ge "$stop_after" ] || ! kill -0 "$runner" 2>/dev/null; do sleep 0.2; done
    if [ "$interrupt" = disk:full ]; then
      dd if=/dev/zero of="$disk/filler" bs=1M 2>/dev/null || true  # until not a byte is left
    else  # an I/O error as a failing disk gives one: ext4 turns read-only under the open database
      echo 1 >"/sys/fs/ext4/$(basename "$(findmnt -no SOURCE "$disk")")/trigger_fs_error"
    fi
    echo "$name $interrupt" >>"$work/interruptions"
    if wait "$runner"; then
      echo "determinism: $name: the run succeeded although its knowledge base could not store"
      exit 1
    fi
    local said
    said=$(tail -1 "$work/$name.run1.log")
    echo "determinism: $name: ${interrupt#disk:} after $(stored "$db") stored; the client said: $said"
    grep -q "the knowledge base did not store" <<<"$said" ||
      { echo "determinism: $name: the run did not say that its knowledge base could not store"; exit 1; }
    if [ "$interrupt" = disk:full ]; then
      rm "$disk/filler"  # room again: the same system goes on
    else
      # A read-only disk stays so: the system stops, the knowledge base is copied to a good disk, and the
      # system starts again on the copy, as someone would do it.
      stop_launch "$name"
      cp "$db" "$work/$name.db"
      [ -f "$db-wal" ] && cp "$db-wal" "$work/$name.db-wal"
      db="$work/$name.db"
      roslaunch -p "${ROS_MASTER_URI##*:}" xpersif xpersif.launch world:="$world" database:="$db" \
        run_dir:="$work/$name" snapshot:=false >>"$work/$name.launch.log" 2>&1 &
      launch=$!
      xpersif wait --timeout 180 /xpersif/loop_model >/dev/null || { tail -20 "$work/$name.launch.log"; exit 1; }
    fi
    /usr/bin/python3 -c 'import sqlite3,sys; r=sqlite3.connect(sys.argv[1]).execute("PRAGMA integrity_check").fetchone()[0]; sys.exit(r != "ok" and print(sys.argv[1] + ": " + r) is None)' "$db" ||
      { echo "determinism: $name: the knowledge base is damaged"; exit 1; }
    xpersif run "${campaign[@]}" --resume | tail -1
  elif [ -n "$interrupt" ]; then  # kill:, stop:, battery: or system
    xpersif run "${campaign[@]}" >"$work/$name.run1.log" 2>&1 &
    local runner=$!
    [[ "$interrupt" == battery:* ]] && stop_after=0
    until [ "$(stored "$db")" -ge "$stop_after" ] || ! kill -0 "$runner" 2>/dev/null; do sleep 0.2; done
    if [ "$interrupt" = system ]; then
      # Every process that talks to this take's master, and the master and roslaunch themselves.
      local pids="$launch" pid
      for pid in $(pgrep -f "ros|nodelet|xpersif" || true); do
        [ "$pid" = "$$" ] || [ "$pid" = "$runner" ] && continue  # the client must notice by itself
        tr '\0' '\n' <"/proc/$pid/environ" 2>/dev/null | grep -x "ROS_MASTER_URI=${ROS_MASTER_URI%/}/\?" >/dev/null && pids="$pids $pid"
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
      echo "determinism: $name: killed the whole system ($(echo $pids | wc -w) processes) after $(stored "$db") experiments"
      sleep 1
      roslaunch -p "${ROS_MASTER_URI##*:}" xpersif xpersif.launch world:="$world" database:="$db" \
        run_dir:="$work/$name" snapshot:=false trace_file:="${TRACE:+$work/$name.trace2}" >>"$work/$name.launch.log" 2>&1 &
      launch=$!
      xpersif wait --timeout 180 /xpersif/loop_model >/dev/null || { tail -20 "$work/$name.launch.log"; exit 1; }
      xpersif run "${campaign[@]}" --resume | tail -1
    else
      if [[ "$interrupt" == disk:* ]]; then
        disk_fails "$name" "${interrupt#disk:}" "$runner"
      elif [[ "$interrupt" == battery:* ]]; then
        # The seeded moments of this take: after K stored experiments (goal pushes count), D s later.
        local k d spec
        while read -r k d spec; do
          until [ "$(stored "$db")" -ge "$k" ] || ! kill -0 "$runner" 2>/dev/null; do sleep 0.1; done
          kill -0 "$runner" 2>/dev/null || break
          pause_before "$d" "${spec#kill:}"
          interrupt "$name" "$spec"
        done < <(battery_plan "${interrupt#battery:}")
      else
        interrupt "$name" "$interrupt"
      fi
      wait "$runner" || { cat "$work/$name.run1.log"; launch_trouble "$name"; exit 1; }
      tail -1 "$work/$name.run1.log"
    fi
  else
    xpersif run "${campaign[@]}" | tail -1
  fi
  echo "determinism: $name campaign took $(($(date +%s) - started)) s"
  stop_launch "$name"
  if [ -n "$disk" ]; then  # the knowledge base where the comparison looks for it
    [ "$db" = "$work/$name.db" ] || cp "$db" "$work/$name.db"
    umount "$disk"
  fi
}

takes="second resumed stopped_sim_manager goal_sim_manager system"  # the single kills: the crash battery
take first
for name in ${ONLY:-$takes}; do
  case $name in
    second) take second ;;
    resumed) take resumed resume ;;
    system) take system system ;;
    goal_sim_manager) take goal_sim_manager kill:sim_manager 7 ;;  # mid-goal: its first push is stored
    sim_host) take sim_host kill:sim_manager+embodiment_manager ;;  # both at once, as multi_host.sh does
    stopped_sim_manager)  # SIGSTOPped longer than the heartbeat timeout: reported, and the run goes on
      take stopped_sim_manager stop:sim_manager
      grep -q "xpersim sent no status" "$work/stopped_sim_manager.launch.log" ||
        { echo "determinism: stopped_sim_manager: LOOPMODEL did not report the stopped simulator"; exit 1; } ;;
    disk_full) take disk_full disk:full ;;
    read_only) take read_only disk:readonly ;;
    crash*) take "$name" "battery:${name#crash}" ;;  # the crash battery (test/crash_battery.sh)
    *) take "$name" "kill:$name" ;;
  esac
done
failed=0 compared=0
for other in ${ONLY:-$takes}; do
  echo "determinism: first against $other:"
  compared=$((compared + 1))
  if ! /usr/bin/python3 "$repo/scripts/compare_kb.py" "$work/first.db" "$work/$other.db"; then
    failed=$((failed + 1))
    # A participant dropped from the lockstep clock (it reported too late) changes what the physics did.
    grep -h "did not report tick" "$work/first.launch.log" "$work/$other.launch.log" 2>/dev/null | sed 's/^/determinism: /' || true
    # What DESIGNOFEXPERIMENTS chose from (the scene, the stream, curiosity) in both takes, where they part.
    for take_name in first "$other"; do
      echo "determinism: $take_name's designs:"
      grep -aoh "designed run .*" "$work/$take_name.launch.log" 2>/dev/null | head -8 | cut -c1-600 | sed 's/^/  /' || true
    done
  fi
done
if [ -s "$work/interruptions" ]; then
  echo "determinism: $(wc -l <"$work/interruptions") interruptions in $(cut -d' ' -f1 "$work/interruptions" | sort -u | wc -l) takes:" \
    "$(cut -d' ' -f2 "$work/interruptions" | sort | uniq -c | awk '{printf "%s%s x%s", (NR>1?", ":""), $2, $1}')"
fi
[ -s "$work/hung_shutdowns" ] && echo "determinism: roslaunch hung on SIGINT after: $(tr '\n' ' ' <"$work/hung_shutdowns")"
echo "$((compared - failed)) passed, $failed failed"
[ "$failed" -eq 0 ]
