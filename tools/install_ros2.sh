#!/usr/bin/env bash
# Idempotent set-up of the ROS 2 venv for ros2_bridge's ROS 2 half (tools/install.sh runs it when MRS_NAV_ROS2=1):
# ROS 2 Jazzy's Python runtime from its PyPI wheels (requirements-ros2.txt) in a venv made from /usr/bin/python3
# WITHOUT --system-site-packages, so Debian's ROS 1 message packages cannot shadow the wheels' ones.
# The venv holds no copy of mrs_nav: the bridge starts its ROS 2 half with the package's own folder on PYTHONPATH.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
venv=${VENV_ROS2:-$here/.venv-ros2}
stamp=$venv/.mrs_nav-ros2-installed
reqs=$here/requirements-ros2.txt
want=$(sha256sum "$reqs" | cut -d' ' -f1)
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ] && [ -x "$venv/bin/python" ]; then
  exit 0
fi
if [ ! -x "$venv/bin/python" ]; then
  echo "install: creating the ROS 2 venv $venv from /usr/bin/python3 (no system site packages)"
  /usr/bin/python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install -q --disable-pip-version-check -r "$reqs"
# Check what the bridge needs, in a child without the ROS 1 environment of this shell.
env -u PYTHONPATH -u _ROS_WHEELS_BOOTSTRAP_COMPLETE "$venv/bin/python" -c \
  'import rclpy, nav_msgs.msg, sensor_msgs.msg, geometry_msgs.msg, rclpy.action'
echo "$want" > "$stamp"
echo "install: ROS 2 venv ready ($venv)"
