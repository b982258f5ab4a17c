#!/usr/bin/env bash
# libxpersif_bind_address.so (src/tools/bind_address.cpp) and scripts/env.sh's use of it: wildcard binds go to
# XPERSIF_BIND_ADDRESS, specific binds are untouched, `any` and a bad value change nothing (the bad value
# with a sentence); env.sh derives the address from ROS_IP; a master and a roscpp nodelet manager started
# from env.sh listen on loopback only (xmlrpcpp alone would listen on every address).
# Usage: bash test/bind_address.sh [BUILD_DIR]   (no root, no network namespace; ctest `bind_address`)
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-$repo/build}
lib="$build/devel/lib/libxpersif_bind_address.so"
[[ -f "$lib" ]] || { echo "bind_address: FAIL: $lib is not built" >&2; exit 1; }
failures=0
check() {  # check WHAT EXPECTED ACTUAL
  if [[ "$2" == "$3" ]]; then echo "bind_address: ok: $1: $3"; else
    echo "bind_address: FAIL: $1: expected '$2', got '$3'" >&2; failures=$((failures + 1)); fi
}
probe=$(mktemp /tmp/xpersif_bind_probe.XXXXXX)
trap 'rm -f "$probe"' EXIT
cat >"$probe" <<'EOF'
import socket, sys
family = socket.AF_INET6 if sys.argv[1] == "6" else socket.AF_INET
s = socket.socket(family, socket.SOCK_STREAM)
s.bind((sys.argv[2], 0))
s.listen(1)
print(s.getsockname()[0])
EOF
clean=(env -u LD_PRELOAD -u XPERSIF_BIND_ADDRESS -u XPERSIF_BIND_ADDRESS_DERIVED -u ROS_IP -u ROS_HOSTNAME -u ROS_MASTER_URI)

check "IPv4 wildcard, no library" 0.0.0.0 "$("${clean[@]}" /usr/bin/python3 "$probe" 4 0.0.0.0)"
check "IPv4 wildcard" 127.0.0.2 "$("${clean[@]}" LD_PRELOAD="$lib" XPERSIF_BIND_ADDRESS=127.0.0.2 /usr/bin/python3 "$probe" 4 0.0.0.0)"
check "a specific address stays" 127.0.0.3 "$("${clean[@]}" LD_PRELOAD="$lib" XPERSIF_BIND_ADDRESS=127.0.0.2 /usr/bin/python3 "$probe" 4 127.0.0.3)"
check "any: unchanged" 0.0.0.0 "$("${clean[@]}" LD_PRELOAD="$lib" XPERSIF_BIND_ADDRESS=any /usr/bin/python3 "$probe" 4 0.0.0.0)"
if "${clean[@]}" /usr/bin/python3 -c 'import socket; socket.socket(socket.AF_INET6).bind(("::", 0))' 2>/dev/null; then
  check "IPv6 wildcard, IPv4 chosen" ::ffff:127.0.0.2 \
    "$("${clean[@]}" LD_PRELOAD="$lib" XPERSIF_BIND_ADDRESS=127.0.0.2 /usr/bin/python3 "$probe" 6 ::)"
  check "IPv4 wildcard, IPv6 chosen" 127.0.0.1 "$("${clean[@]}" LD_PRELOAD="$lib" XPERSIF_BIND_ADDRESS=::1 /usr/bin/python3 "$probe" 4 0.0.0.0)"
  check "IPv6 wildcard, IPv6 chosen" ::1 "$("${clean[@]}" LD_PRELOAD="$lib" XPERSIF_BIND_ADDRESS=::1 /usr/bin/python3 "$probe" 6 ::)"
else
  echo "bind_address: IPv6 is off on this machine; its cases are not run"
fi
err=$(mktemp)
out=$("${clean[@]}" LD_PRELOAD="$lib" XPERSIF_BIND_ADDRESS=my-host /usr/bin/python3 "$probe" 4 0.0.0.0 2>"$err")
check "a bad address: unchanged" 0.0.0.0 "$out"
check "a bad address: the sentence" 1 "$(grep -c "XPERSIF_BIND_ADDRESS is 'my-host', which is not an IPv4 or IPv6 address" "$err")"
rm -f "$err"

# env.sh: the address from ROS_IP, loopback by default, the library preloaded once.
check "env.sh default" "127.0.0.1 1" "$("${clean[@]}" bash -c "source '$repo/scripts/env.sh'; source '$repo/scripts/env.sh';
  echo \$XPERSIF_BIND_ADDRESS \$(tr : '\n' <<<\"\$LD_PRELOAD\" | grep -c libxpersif_bind_address)")"
check "env.sh with ROS_IP" "127.0.0.7 http://127.0.0.7:" "$("${clean[@]}" ROS_IP=127.0.0.7 bash -c "source '$repo/scripts/env.sh';
  echo \$XPERSIF_BIND_ADDRESS \${ROS_MASTER_URI%:*}:")"
check "env.sh with ROS_HOSTNAME" 127.0.0.1 "$("${clean[@]}" ROS_HOSTNAME=localhost bash -c "source '$repo/scripts/env.sh';
  echo \$XPERSIF_BIND_ADDRESS")"
check "env.sh again after ROS_IP changed" "127.0.0.8" "$("${clean[@]}" bash -c "source '$repo/scripts/env.sh';
  export ROS_IP=127.0.0.8; source '$repo/scripts/env.sh'; echo \$XPERSIF_BIND_ADDRESS")"
check "env.sh keeps a chosen XPERSIF_BIND_ADDRESS" "127.0.0.6" "$("${clean[@]}" XPERSIF_BIND_ADDRESS=127.0.0.6 bash -c \
  "source '$repo/scripts/env.sh'; export ROS_IP=127.0.0.8; source '$repo/scripts/env.sh'; echo \$XPERSIF_BIND_ADDRESS")"
check "env.sh with XPERSIF_BIND_ADDRESS=any" "any 0" "$("${clean[@]}" XPERSIF_BIND_ADDRESS=any bash -c "source '$repo/scripts/env.sh';
  echo \$XPERSIF_BIND_ADDRESS \$(tr : '\n' <<<\"\${LD_PRELOAD:-}\" | grep -c libxpersif_bind_address)")"

# A master and a roscpp nodelet manager from env.sh, loopback by default: every listener on 127.0.0.1 (without
# the library xmlrpcpp listens on 0.0.0.0). Another loopback address would not do: roscpp binds its TCPROS
# server to 127.0.0.1 itself whenever ROS_IP is a loopback address.
tmp=$(mktemp -d /tmp/xpersif_bind_address.XXXXXX)
pids=()
trap 'for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null; rm -rf "$tmp" "$probe"' EXIT
"${clean[@]}" ROS_HOME="$tmp" bash -c "source '$repo/scripts/env.sh'; echo \$ROS_MASTER_URI > '$tmp/uri';
  rosmaster --core -p \${ROS_MASTER_URI##*:} >'$tmp/master.log' 2>&1 & echo \$! > '$tmp/master.pid';
  sleep 2; exec rosrun nodelet nodelet manager __name:=bind_check >'$tmp/manager.log' 2>&1" &
pids+=($!)
manager_pid=""
for _ in $(seq 100); do
  manager_pid=$(pgrep -f "__name:=bind_check" | head -1 || true)
  [[ -n "$manager_pid" ]] && [[ $(ss -ltnpH | grep -c "pid=$manager_pid,") -ge 2 ]] && break
  sleep 0.2
done
master_pid=$(cat "$tmp/master.pid" 2>/dev/null || true)
pids+=("$master_pid" "$manager_pid")
for who in master manager; do
  pid=${who}_pid
  listeners=$(ss -ltnpH | grep "pid=${!pid}," | awk '{ print $4 }' | sed 's/:[0-9]*$//' | sort -u | tr '\n' ' ')
  check "the $who's listeners ($(ss -ltnpH | grep -c "pid=${!pid},") sockets)" "127.0.0.1 " "$listeners"
done

((failures == 0)) || { echo "bind_address: $failures checks failed" >&2; exit 1; }
echo "bind_address: PASS"
