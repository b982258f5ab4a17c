# Source me: the environment to run XPERSIF from this checkout (devel space, loopback networking).
# A master port is chosen at random unless ROS_MASTER_URI is already set. Loopback only unless ROS_IP (or
# ROS_HOSTNAME) is already set: then the master and the nodes use that address (README, "Security").
_xpersif_repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
set +u  # catkin's setup files read unset variables
# shellcheck disable=SC1091
source "$_xpersif_repo/build/devel/setup.bash"
[[ -n "${ROS_IP:-}" || -n "${ROS_HOSTNAME:-}" ]] || export ROS_IP=127.0.0.1
_xpersif_address=${ROS_HOSTNAME:-$ROS_IP}
# ROS scripts start with "#!/usr/bin/env python3"; they need the python that has ROS modules.
export PATH="/usr/bin:$PATH"
if [[ -z "${ROS_MASTER_URI:-}" || "${XPERSIF_NEW_MASTER:-0}" == 1 ]]; then
  _port=$(/usr/bin/python3 -c 'import socket, sys; s=socket.socket(); s.bind((sys.argv[1], 0)); print(s.getsockname()[1])' \
    "$_xpersif_address")
  export ROS_MASTER_URI="http://${_xpersif_address}:${_port}"
fi
export PATH="$_xpersif_repo/build/devel/lib/xpersif:$PATH"
