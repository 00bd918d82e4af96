"""Setup for catkin's catkin_python_setup() and for pip (whose metadata is in pyproject.toml).

catkin interrogates the arguments of this setup() call: it needs the packages, their folder, and the version,
which must equal package.xml's, so the version is read from there (the one place it is written).
"""

import xml.etree.ElementTree as ET
from pathlib import Path

from setuptools import find_packages, setup

version = ET.parse(Path(__file__).with_name("package.xml")).getroot().findtext("version")

setup(version=version, packages=find_packages("src"), package_dir={"": "src"})
