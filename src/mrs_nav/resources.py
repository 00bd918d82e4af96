"""Where the package's own files live: worlds, maps and configs beside the Python package in the checkout.

The catkin package is the checkout itself (``package.xml`` at its top), so the folders roslaunch users
touch (``worlds/``, ``maps/``, ``config/``) are found from this file's place in ``src/mrs_nav/``.
"""

from pathlib import Path

CHECKOUT = Path(__file__).resolve().parents[2]
WORLDS_DIR = CHECKOUT / "worlds"
MAPS_DIR = CHECKOUT / "maps"
# An installed wheel (`mrs-nav monitor` alone) has no checkout around it: it carries the configs as mrs_nav/config
# (in the checkout a link to config/), so the bridge's defaults come from the same file either way.
CONFIG_DIR = CHECKOUT / "config" if (CHECKOUT / "config").is_dir() else Path(__file__).resolve().parent / "config"
