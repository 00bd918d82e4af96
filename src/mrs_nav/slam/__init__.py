"""SLAM-lite: occupancy grid mapping and scan-to-map matching (a gmapping substitute)."""

from mrs_nav.slam.config import SlamConfig
from mrs_nav.slam.grid import LogOddsGrid
from mrs_nav.slam.keyframes import ProcessedScan
from mrs_nav.slam.scan import LaserScanData, split_beams
from mrs_nav.slam.slam import Slam

__all__ = ["LaserScanData", "LogOddsGrid", "ProcessedScan", "Slam", "SlamConfig", "split_beams"]
