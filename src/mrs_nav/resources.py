"""Where the package's own files live: worlds, maps and configs beside the Python package in the checkout.

The catkin package is the checkout itself (``package.xml`` at its top), so the folders roslaunch users
touch (``worlds/``, ``maps/``, ``config/``) are found from this file's place in ``src/mrs_nav/``.
"""

from pathlib import Path

CHECKOUT = Path(__file__).resolve().parents[2]
WORLDS_DIR = CHECKOUT / "worlds"
MAPS_DIR = CHECKOUT / "maps"
CONFIG_DIR = CHECKOUT / "config"
