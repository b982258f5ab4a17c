# Source me: the environment to run XPERSIF from this checkout (devel space, loopback networking).
# A master port is chosen at random unless ROS_MASTER_URI is already set.
_xpersif_repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
set +u  # catkin's setup files read unset variables
# shellcheck disable=SC1091
source "$_xpersif_repo/build/devel/setup.bash"
export ROS_IP=127.0.0.1
# ROS scripts start with "#!/usr/bin/env python3"; they need the python that has ROS modules.
export PATH="/usr/bin:$PATH"
if [[ -z "${ROS_MASTER_URI:-}" || "${XPERSIF_NEW_MASTER:-0}" == 1 ]]; then
  _port=$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
  export ROS_MASTER_URI="http://127.0.0.1:${_port}"
fi
export PATH="$_xpersif_repo/build/devel/lib/xpersif:$PATH"
