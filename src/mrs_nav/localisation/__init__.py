"""Particle-filter localisation on a known map (an AMCL substitute, no ROS): motion model, likelihood field,
KLD-adaptive resampling and random-particle recovery."""

from mrs_nav.localisation.config import LocalisationConfig
from mrs_nav.localisation.filter import BeamScan, ParticleFilter, PoseEstimate, kld_limit, sample_motion
from mrs_nav.localisation.likelihood_field import LikelihoodField

__all__ = [
    "BeamScan",
    "LikelihoodField",
    "LocalisationConfig",
    "ParticleFilter",
    "PoseEstimate",
    "kld_limit",
    "sample_motion",
]
