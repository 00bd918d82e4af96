#!/usr/bin/env bash
# Idempotent set-up for a Debian 12 machine: Debian's ROS 1 and friends from apt, then a venv made from
# /usr/bin/python3 with --system-site-packages (so it sees rospy, tf2, ode) holding the pinned pip packages.
# A second run only checks and returns. MRS_NAV_ROS2=1 also makes the ROS 2 venv (tools/install_ros2.sh).
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
venv=${VENV:-$here/.venv}
stamp=$venv/.mrs_nav-installed

apt_packages=(
  ros-core rosbash rospack-tools python3-rosbag python3-rostest librostest-dev catkin python3-catkin-pkg cmake g++
  python3-tf2-ros python3-tf python3-tf2-geometry-msgs
  python3-std-msgs python3-std-srvs python3-geometry-msgs python3-nav-msgs python3-sensor-msgs
  python3-visualization-msgs python3-tf2-msgs ros-robot-state-publisher
  python3-actionlib python3-actionlib-msgs python3-move-base-msgs
  python3-pyode python3-numpy python3-scipy python3-yaml python3-venv python3-pip
  xvfb xdotool imagemagick tmux  # tmux: the keyboard teleop tested in a real terminal
  openssl  # certificates for the Zenoh bridge's TLS tests and bench
  libsdformat-dev pkg-config
)
if [ "${MRS_NAV_RVIZ:-0}" = 1 ]; then apt_packages+=(rviz); fi

missing=()
for p in "${apt_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "install: apt packages missing: ${missing[*]}"
  sudo_cmd=()
  if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
  "${sudo_cmd[@]}" apt-get update -q
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

reqs=$here/requirements.txt
want=$(sha256sum "$reqs" "$here/pyproject.toml" "$here/setup.py" | sha256sum | cut -d' ' -f1)
if [ "${MRS_NAV_ROS2:-0}" = 1 ]; then bash "$here/tools/install_ros2.sh"; fi
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ] && [ -x "$venv/bin/mrs-nav" ]; then
  exit 0
fi
if [ ! -x "$venv/bin/python" ]; then
  echo "install: creating venv $venv from /usr/bin/python3 (--system-site-packages)"
  /usr/bin/python3 -m venv --system-site-packages "$venv"
fi
"$venv/bin/python" -m pip install -q --disable-pip-version-check -r "$reqs"
# --no-build-isolation: setup.py needs nothing but setuptools, and the venv already has it.
"$venv/bin/python" -m pip install -q --disable-pip-version-check --no-deps --no-build-isolation -e "$here"
echo "$want" > "$stamp"
echo "install: ready ($venv)"
