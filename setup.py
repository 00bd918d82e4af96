"""Setup for catkin's catkin_python_setup(); pip reads the metadata from pyproject.toml.

catkin interrogates the arguments of this setup() call, so the packages and their folder are named here.
"""

from setuptools import find_packages, setup

setup(packages=find_packages("src"), package_dir={"": "src"})
