#!/usr/bin/env bash
# XPERSIF across three hosts, built on this machine from network namespaces (doc/hosts.md):
#   sim   10.213.7.1  XPERSim and the embodiment (sim_manager, embodiment_manager), reached over ssh
#   loop  10.213.7.2  the master, roslaunch, the knowledge base and the loop (kb_manager, loop_manager, LOOPMODEL)
#   view  10.213.7.3  a viewer (view.launch: progress_markers and telesim_view, headless), reached over ssh
# joined by a bridge in a fourth namespace. One roslaunch on `loop` starts everything through xpersif.launch's
# <machine> tags (sim_host:=, loop_host:=, view_host:=) and scripts/xpersif_env_loader; sshd (Debian's
# openssh-server) runs in `sim` and `view` with keys this test generates. Checks (test/multi_host_check.py):
# a short run's experiments are stored; tf reaches the viewer on `view`; the sim host's managers are killed
# (SIGKILL), LOOPMODEL notices within 2 s, roslaunch respawns them there, and the run completes; every
# listening socket in the namespaces is bound to that namespace's address (scripts/env.sh's bind library).
# Nothing outside the namespaces is touched except /run/sshd (sshd's privilege-separation directory), which
# is created if missing. Everything is removed on exit, also when the test fails.
# Usage: bash test/multi_host.sh [BUILD_DIR]   (as root; ctest runs it as `multi_host`)
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
fail() { echo "multi_host: FAIL: $*" >&2; exit 1; }

[[ $(id -u) -eq 0 ]] || fail "needs root (ip netns, veth, sshd); run it as root, as CI does"
for tool in ip ssh-keygen /usr/sbin/sshd ss; do
  command -v "$tool" >/dev/null || fail "$tool is missing: bash scripts/setup.sh installs openssh-server and iproute2"
done
/usr/bin/python3 -c 'import paramiko' 2>/dev/null || fail "python3-paramiko is missing (roslaunch's ssh): bash scripts/setup.sh"
[[ -f "$repo/build/devel/setup.bash" ]] || fail "$repo/build is not built: bash scripts/setup.sh"

tag="xph$$"                       # namespace names unique to this run

# Leftovers of an earlier run that was killed outright (SIGKILL, e.g. a ctest timeout: no trap runs): namespaces
# named after a process that no longer exists, with whatever still runs in them.
for ns in $(ip netns list | awk '/^xph[0-9]+(lan|sim|loop|view)( |$)/ { print $1 }'); do
  owner=${ns#xph}
  owner=${owner%%[a-z]*}
  kill -0 "$owner" 2>/dev/null && continue
  pids=$(ip netns pids "$ns" 2>/dev/null || true)
  [[ -z "$pids" ]] || kill -KILL $pids 2>/dev/null || true
  ip netns del "$ns" && echo "multi_host: removed $ns, left by an earlier run (process $owner is gone)"
done
declare -A addr=([sim]=10.213.7.1 [loop]=10.213.7.2 [view]=10.213.7.3)
hosts=(sim loop view)
tmp=$(mktemp -d /tmp/xpersif_multi_host.XXXXXX)
keep=/tmp/xpersif_multi_host_last   # the logs of the last run, kept for a look
launch_pid=""

namespaces() { echo "${tag}lan" "${tag}sim" "${tag}loop" "${tag}view"; }
cleanup() {
  local status=$?
  set +e
  [[ -n "$launch_pid" ]] && kill -INT "$launch_pid" 2>/dev/null && sleep 3
  for ns in $(namespaces); do
    ip netns list 2>/dev/null | grep -qw "^$ns" || continue
    pids=$(ip netns pids "$ns" 2>/dev/null)
    [[ -n "$pids" ]] && kill -TERM $pids 2>/dev/null
  done
  sleep 1
  for ns in $(namespaces); do
    ip netns list 2>/dev/null | grep -qw "^$ns" || continue
    pids=$(ip netns pids "$ns" 2>/dev/null)
    [[ -n "$pids" ]] && kill -KILL $pids 2>/dev/null
    ip netns del "$ns"
  done
  rm -rf "$keep" && mkdir -p "$keep" && cp -r "$tmp"/*.log "$tmp"/*.status "$tmp"/view "$tmp"/ros_home_* "$keep"/ 2>/dev/null
  [[ -f "$tmp/experiment/launch.log" ]] && cp "$tmp/experiment/launch.log" "$keep/experiment_launch.log"
  rm -rf "$tmp"
  left=$(ip netns list | grep -c "^$tag" || true)
  [[ "$left" == 0 ]] || echo "multi_host: $left namespaces of this test are still there" >&2
  echo "multi_host: cleaned up (namespaces, sshd, processes); logs in $keep"
  exit $status
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# --- the network: a bridge in ${tag}lan, one veth pair per host ------------------------------------------
ip netns add "${tag}lan"
ip -n "${tag}lan" link set lo up
ip -n "${tag}lan" link add br0 type bridge || fail "cannot create a bridge in a namespace (kernel bridge support)"
ip -n "${tag}lan" link set br0 up
for h in "${hosts[@]}"; do
  ip netns add "${tag}$h"
  ip -n "${tag}lan" link add "p_$h" type veth peer name eth0 netns "${tag}$h"
  ip -n "${tag}lan" link set "p_$h" master br0 up
  ip -n "${tag}$h" addr add "${addr[$h]}/24" dev eth0
  ip -n "${tag}$h" link set eth0 up
  ip -n "${tag}$h" link set lo up
done

# --- ssh: a client key for roslaunch (in a HOME of its own), a host key, sshd on sim and view -------------
mkdir -p "$tmp/home/.ssh" /run/sshd
chmod 700 "$tmp/home/.ssh"
ssh-keygen -q -t ed25519 -N '' -C xpersif-multi-host -f "$tmp/home/.ssh/id_ed25519"
ssh-keygen -q -t ed25519 -N '' -C xpersif-multi-host-host -f "$tmp/ssh_host_key"
cp "$tmp/home/.ssh/id_ed25519.pub" "$tmp/authorized_keys"
: >"$tmp/home/.ssh/known_hosts"
# sshd without PAM refuses a locked account (a password field starting with '!'), even for a key; with PAM it
# only asks PAM's account rules, which let a key in.
use_pam=no
[[ "$(getent shadow root | cut -d: -f2)" == '!'* ]] && use_pam=yes
for h in sim view; do
  echo "${addr[$h]} $(cut -d' ' -f1,2 "$tmp/ssh_host_key.pub")" >>"$tmp/home/.ssh/known_hosts"
  mkdir -p "$tmp/ros_home_$h"
  cat >"$tmp/sshd_$h.conf" <<EOF
ListenAddress ${addr[$h]}:22
HostKey $tmp/ssh_host_key
PidFile $tmp/sshd_$h.pid
AuthorizedKeysFile $tmp/authorized_keys
PermitRootLogin prohibit-password
PasswordAuthentication no
KbdInteractiveAuthentication no
UsePAM $use_pam
StrictModes no
SetEnv ROS_HOME=$tmp/ros_home_$h
EOF
  /usr/sbin/sshd -t -f "$tmp/sshd_$h.conf" || fail "sshd rejects its configuration $tmp/sshd_$h.conf"
  ip netns exec "${tag}$h" env -u LD_PRELOAD /usr/sbin/sshd -f "$tmp/sshd_$h.conf" -E "$tmp/sshd_$h.log"
done

# --- one roslaunch on loop -------------------------------------------------------------------------------
# A clean ROS environment: nothing of the caller's master, address or preload (test.sh sources env.sh).
clean_env=(env -u SSH_AUTH_SOCK -u ROS_MASTER_URI -u ROS_IP -u ROS_HOSTNAME -u XPERSIF_BIND_ADDRESS -u XPERSIF_BIND_ADDRESS_DERIVED -u LD_PRELOAD
           -u XPERSIF_NEW_MASTER HOME="$tmp/home" ROS_HOME="$tmp/ros_home_loop" ROS_IP="${addr[loop]}"
           ROS_MASTER_URI="http://${addr[loop]}:11311")
mkdir -p "$tmp/ros_home_loop" "$tmp/view" "$tmp/run"
cat >"$tmp/parameters.yaml" <<EOF
loop_model:
  heartbeat_timeout: 1.0
EOF
ip netns exec "${tag}loop" "${clean_env[@]}" bash -c "source '$repo/scripts/env.sh' && exec roslaunch -p 11311 \
    xpersif xpersif.launch sim_host:=${addr[sim]} loop_host:=${addr[loop]} view_host:=${addr[view]} \
    view_rviz:=false view_telesim:=true view_telesim_output_dir:='$tmp/view' \
    database:='$tmp/knowledge.db' run_dir:='$tmp/run' snapshot:=false parameters:='$tmp/parameters.yaml'" \
  >"$tmp/launch.log" 2>&1 &
launch_pid=$!

# --- the checks -------------------------------------------------------------------------------------------
# In the background and waited for, so that a signal to this script runs its trap at once.
ip netns exec "${tag}loop" "${clean_env[@]}" bash -c "source '$repo/scripts/env.sh' && exec /usr/bin/python3 \
    '$repo/test/multi_host_check.py' --sim-netns '${tag}sim' --view-netns '${tag}view' \
    --view-dir '$tmp/view' --experiments 4" &
wait $! || {
  echo "--- launch.log (last 60 lines)"; tail -60 "$tmp/launch.log"
  fail "the run across hosts failed (above)"
}

# Every listener in the namespaces is on its host's address: no wildcard, no other address.
for h in "${hosts[@]}"; do
  listeners=$(ip netns exec "${tag}$h" ss -ltnH | awk '{ print $4 }')
  [[ -n "$listeners" ]] || fail "nothing listens on $h"
  bad=$(grep -v "^${addr[$h]//./\\.}:" <<<"$listeners" || true)
  [[ -z "$bad" ]] || fail "on $h ($(ip netns exec "${tag}$h" ss -ltnpH | grep -F "$(head -1 <<<"$bad")")) a listener is not on ${addr[$h]}: $(echo $bad)"
  echo "multi_host: $h: $(wc -l <<<"$listeners") listeners, all on ${addr[$h]}"
done

# Stop roslaunch; telesim_view on view writes its tf statistics as it exits.
kill -INT "$launch_pid"
for _ in $(seq 60); do kill -0 "$launch_pid" 2>/dev/null || break; sleep 0.5; done
kill -0 "$launch_pid" 2>/dev/null && fail "roslaunch did not stop within 30 s of SIGINT"
launch_pid=""
csv="$tmp/view/telesim_view_inter_frame_ms.csv"
[[ -f "$csv" ]] || fail "telesim_view on view wrote no tf statistics ($csv)"
frames=$(($(wc -l <"$csv") - 1))
((frames >= 50)) || fail "telesim_view on view received only $frames tf frames"
ls "$tmp"/view/*_last.png >/dev/null 2>&1 || fail "telesim_view on view rendered no image"
echo "multi_host: tf reached the viewer on view: $frames inter-frame intervals, images in $keep/view"

# --- an experiment file across the same hosts (experiment.launch hosts:=, as run.sh --hosts passes it) --------
experiment() {  # experiment HOSTS RUN_DIR -> roslaunch's output in RUN_DIR.log, the outcome in RUN_DIR.status
  ip netns exec "${tag}loop" "${clean_env[@]}" bash -c "source '$repo/scripts/env.sh' && exec roslaunch -p 11311 \
      xpersif experiment.launch experiment:='$repo/experiments/short.yaml' run_dir:='$2' status_file:='$2.status' \
      hosts:='$1'" >"$2.log" 2>&1 &
  launch_pid=$!
  wait "$launch_pid" || true
  launch_pid=""
}
experiment "sim_host=${addr[sim]} world=/elsewhere.yaml" "$tmp/refused"
read -r code sentence <"$tmp/refused.status" || fail "experiment.launch wrote no outcome for a bad hosts:= ($tmp/refused.log)"
[[ "$code" == 2 && "$sentence" == *"'world=/elsewhere.yaml' is not NAME=VALUE"* ]] ||
  fail "experiment.launch with hosts:='... world=...' ended '$code $sentence', not refused (2)"
echo "multi_host: experiment.launch refuses a hosts:= argument that is not a host's: $sentence"
experiment "sim_host=${addr[sim]} loop_host=${addr[loop]}" "$tmp/experiment"
read -r code sentence <"$tmp/experiment.status" || fail "experiment.launch across hosts wrote no outcome ($tmp/experiment.log)"
[[ "$code" == 0 ]] || { tail -30 "$tmp/experiment/launch.log"; fail "experiments/short.yaml across hosts: $code $sentence"; }
grep -qF "[${addr[sim]}-0]: process[xpersif/sim_manager-1]: started" "$tmp/experiment/launch.log" ||
  fail "the experiment's sim_manager did not start on ${addr[sim]} (see $tmp/experiment/launch.log)"
[[ -f "$tmp/experiment/report.md" ]] || fail "experiments/short.yaml across hosts wrote no report"
echo "multi_host: experiments/short.yaml across hosts: $sentence"
echo "multi_host: PASS"
