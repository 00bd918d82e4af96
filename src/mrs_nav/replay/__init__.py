"""Offline replay of recorded bags through the core algorithms (no ROS master)."""
