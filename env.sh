# Source this file to make a shell ready for roslaunch/rosrun/rostest mrs_nav ... and mrs-nav:
#   source env.sh      (after `make install`, `make test` or `make demo` has made the venv)
# It puts the venv (which sees Debian's rospy) first on PATH, so nodes' `#!/usr/bin/env python3` run in it,
# and adds this checkout to ROS_PACKAGE_PATH.
_mrs_nav_root=$(cd "$(dirname "${BASH_SOURCE[0]:-$0}")" && pwd)
export PATH="${VENV:-$_mrs_nav_root/.venv}/bin:$PATH"
case ":${ROS_PACKAGE_PATH:-}:" in
  *":$_mrs_nav_root:"*) ;;
  *) export ROS_PACKAGE_PATH="$_mrs_nav_root${ROS_PACKAGE_PATH:+:$ROS_PACKAGE_PATH}" ;;
esac
export ROS_PYTHON_VERSION=3
unset _mrs_nav_root
