# Source me: the environment to run XPERSIF from this checkout (devel space) or from an installed package,
# loopback networking by default.
# A master port is chosen at random unless ROS_MASTER_URI is already set (XPERSIF_NEW_MASTER=1: always).
# Addresses (doc/security.md and "Several hosts"): loopback only unless ROS_IP (or ROS_HOSTNAME) is already
# set; then the master and the nodes use that address. Every listener started from this shell binds to that
# address only (XPERSIF_BIND_ADDRESS, default: ROS_IP or ROS_HOSTNAME's address; `any` for every address),
# through the preloaded libxpersif_bind_address.so.
_xpersif_here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
_xpersif_repo=$(cd "$_xpersif_here/.." && pwd)
set +u  # catkin's setup files read unset variables
# catkin's setup sets ROS_MASTER_URI=http://localhost:11311 when it is unset (/etc/catkin/profile.d); what
# counts is whether the caller had set it.
_xpersif_master_uri=${ROS_MASTER_URI:-}
# A file sourced without arguments sees its caller's: catkin's setup.bash would hand them to _setup_util.py (a
# script run with --help printed that tool's usage, which the shell then ran). A function has arguments of its own.
_xpersif_source() {
  local file=$1
  shift
  # shellcheck disable=SC1090
  source "$file"
}
if [[ -f "$_xpersif_repo/build/devel/setup.bash" ]]; then
  _xpersif_source "$_xpersif_repo/build/devel/setup.bash"
  _xpersif_bin="$_xpersif_repo/build/devel/lib/xpersif"
elif [[ -f "$_xpersif_repo/package.xml" && -d "$_xpersif_repo/../../lib/xpersif" ]]; then
  # Installed (cmake --install): <prefix>/share/xpersif/scripts/env.sh. A workspace's install has a setup.bash
  # at <prefix>; the package installed alone has none, so the paths are set here.
  _xpersif_prefix=$(cd "$_xpersif_repo/../.." && pwd)
  if [[ -f "$_xpersif_prefix/setup.bash" ]]; then
    _xpersif_source "$_xpersif_prefix/setup.bash"
  else
    export CMAKE_PREFIX_PATH="$_xpersif_prefix${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}"
    export ROS_PACKAGE_PATH="$_xpersif_prefix/share${ROS_PACKAGE_PATH:+:$ROS_PACKAGE_PATH}"
    export LD_LIBRARY_PATH="$_xpersif_prefix/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
    export PYTHONPATH="$_xpersif_prefix/lib/python3/dist-packages${PYTHONPATH:+:$PYTHONPATH}"
  fi
  _xpersif_bin="$_xpersif_prefix/lib/xpersif"
else
  echo "scripts/env.sh: neither $_xpersif_repo/build/devel/setup.bash (a built checkout: run scripts/setup.sh)" \
       "nor an installed package around $_xpersif_repo" >&2
  return 1 2>/dev/null || exit 1
fi
[[ -n "${ROS_IP:-}" || -n "${ROS_HOSTNAME:-}" ]] || export ROS_IP=127.0.0.1
_xpersif_address=${ROS_HOSTNAME:-$ROS_IP}
# ROS scripts start with "#!/usr/bin/env python3"; they need the python that has ROS modules.
export PATH="/usr/bin:$PATH"
# Derived unless the caller chose it: a value this file derived earlier (XPERSIF_BIND_ADDRESS_DERIVED) follows a
# ROS_IP changed since.
if [[ -z "${XPERSIF_BIND_ADDRESS+x}" || "$XPERSIF_BIND_ADDRESS" == "${XPERSIF_BIND_ADDRESS_DERIVED:-}" ]]; then
  if [[ -n "${ROS_IP:-}" && -z "${ROS_HOSTNAME:-}" ]]; then
    XPERSIF_BIND_ADDRESS=$ROS_IP
  else
    XPERSIF_BIND_ADDRESS=$({ getent ahostsv4 "$_xpersif_address" || getent ahosts "$_xpersif_address"; } 2>/dev/null |
      awk 'NR == 1 { print $1 }')
    if [[ -z "$XPERSIF_BIND_ADDRESS" ]]; then
      echo "scripts/env.sh: ROS_HOSTNAME '$_xpersif_address' does not resolve; listeners bind every address" >&2
      XPERSIF_BIND_ADDRESS=any
    fi
  fi
  export XPERSIF_BIND_ADDRESS_DERIVED=$XPERSIF_BIND_ADDRESS
fi
export XPERSIF_BIND_ADDRESS
if [[ "$XPERSIF_BIND_ADDRESS" != any ]]; then
  _xpersif_preload=""
  for _xpersif_dir in ${CMAKE_PREFIX_PATH//:/ }; do
    if [[ -f "$_xpersif_dir/lib/libxpersif_bind_address.so" ]]; then
      _xpersif_preload="$_xpersif_dir/lib/libxpersif_bind_address.so"
      break
    fi
  done
  if [[ -z "$_xpersif_preload" ]]; then
    echo "scripts/env.sh: libxpersif_bind_address.so is not built; listeners bind every address" >&2
  elif [[ ":${LD_PRELOAD:-}:" != *":$_xpersif_preload:"* ]]; then
    export LD_PRELOAD="$_xpersif_preload${LD_PRELOAD:+:$LD_PRELOAD}"
  fi
fi
if [[ -n "$_xpersif_master_uri" ]]; then
  export ROS_MASTER_URI=$_xpersif_master_uri
fi
if [[ -z "$_xpersif_master_uri" || "${XPERSIF_NEW_MASTER:-0}" == 1 ]]; then
  _port=$(/usr/bin/python3 -c 'import socket, sys; s=socket.socket(); s.bind((sys.argv[1], 0)); print(s.getsockname()[1])' \
    "$_xpersif_address")
  export ROS_MASTER_URI="http://${_xpersif_address}:${_port}"
fi
export PATH="$_xpersif_bin:$PATH"
unset -f _xpersif_source
