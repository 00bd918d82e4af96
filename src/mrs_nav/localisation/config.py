"""Parameters of the particle filter, under AMCL's names where they mean the same thing.

Units: metres, radians, seconds. Defaults: ``config/localisation.yaml`` (:mod:`mrs_nav.config_files`), which the
localisation node reads too. The odometry alphas are those of AMCL's ``diff`` model (Thrun et al.,
*Probabilistic Robotics*, table 5.6): variances per squared motion, see :mod:`mrs_nav.motion_model`.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from mrs_nav.config_files import node_default
from mrs_nav.errors import InvalidInputError
from mrs_nav.motion_model import MAX_ALPHA, OdometryNoise

#: Particles at most: 10 times the default and 20 times AMCL's 5000. An update holds about 40 bytes per particle
#: and beam, so 100 000 particles at 60 beams take 0.7 s and 220 MB; far more would stall the node, not help it.
MAX_PARTICLES = 100_000
#: Beams per scan at most: one a tenth of a degree round a full turn, more than any 2-D laser gives (the LDS-01
#: has 360, a Hokuyo UTM-30LX 1081). Neighbouring beams are not independent, so AMCL's 30-60 already tell it all.
MAX_BEAMS = 3600
#: Particle-beam pairs one update scores at most (``max_particles * laser_max_beams``): about 400 MB and a second
#: of CPU; the default is 600 000.
MAX_BEAM_ENDPOINTS = 10_000_000

_default = functools.partial(node_default, "localisation")


@dataclass(frozen=True)
class LocalisationConfig:
    """Particle counts, KLD bounds, update gates, odometry noise, likelihood field and recovery rates (each
    field's unit, range and meaning: config/localisation.yaml)."""

    min_particles: int = _default("min_particles")
    max_particles: int = _default("max_particles")
    kld_err: float = _default("kld_err")
    kld_z: float = _default("kld_z")
    kld_bin_xy: float = _default("kld_bin_xy")
    kld_bin_yaw: float = _default("kld_bin_yaw")
    update_min_d: float = _default("update_min_d")
    update_min_a: float = _default("update_min_a")
    resample_interval: int = _default("resample_interval")
    odom_alpha1: float = _default("odom_alpha1")
    odom_alpha2: float = _default("odom_alpha2")
    odom_alpha3: float = _default("odom_alpha3")
    odom_alpha4: float = _default("odom_alpha4")
    laser_max_beams: int = _default("laser_max_beams")
    laser_z_hit: float = _default("laser_z_hit")
    laser_z_rand: float = _default("laser_z_rand")
    laser_sigma_hit: float = _default("laser_sigma_hit")
    laser_sigma_max: float = _default("laser_sigma_max")
    laser_likelihood_max_dist: float = _default("laser_likelihood_max_dist")
    laser_min_range: float = _default("laser_min_range")
    laser_max_range: float = _default("laser_max_range")
    min_effective_fraction: float = _default("min_effective_fraction")
    recovery_alpha_slow: float = _default("recovery_alpha_slow")
    recovery_alpha_fast: float = _default("recovery_alpha_fast")
    recovery_radius: float = _default("recovery_radius")
    refute_updates: int = _default("refute_updates")
    refute_margin: float = _default("refute_margin")
    refute_sigma: float = _default("refute_sigma")
    confident_max_sd_xy: float = _default("confident_max_sd_xy")
    confident_max_sd_yaw: float = _default("confident_max_sd_yaw")
    initial_pose_x: float = _default("initial_pose_x")
    initial_pose_y: float = _default("initial_pose_y")
    initial_pose_a: float = _default("initial_pose_a")
    initial_cov_xx: float = _default("initial_cov_xx")
    initial_cov_yy: float = _default("initial_cov_yy")
    initial_cov_aa: float = _default("initial_cov_aa")
    seed: int = _default("seed")

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
                raise InvalidInputError(f"{f.name}: must be a finite number, got {value!r}")
        if not 1 <= self.min_particles <= self.max_particles <= MAX_PARTICLES:
            raise InvalidInputError(
                f"min_particles/max_particles: need 1 <= min <= max <= {MAX_PARTICLES:,}, "
                f"got {self.min_particles}, {self.max_particles}"
            )
        if not 2 <= self.laser_max_beams <= MAX_BEAMS:
            raise InvalidInputError(f"laser_max_beams: must lie in [2, {MAX_BEAMS}], got {self.laser_max_beams}")
        if self.max_particles * self.laser_max_beams > MAX_BEAM_ENDPOINTS:
            raise InvalidInputError(
                f"max_particles * laser_max_beams: {self.max_particles} x {self.laser_max_beams} beam endpoints per "
                f"update exceed the limit of {MAX_BEAM_ENDPOINTS:,}; use fewer particles or beams"
            )
        for name in ("odom_alpha1", "odom_alpha2", "odom_alpha3", "odom_alpha4"):
            if not 0.0 <= getattr(self, name) <= MAX_ALPHA:
                raise InvalidInputError(f"{name}: must lie in [0, {MAX_ALPHA:g}], got {getattr(self, name):.3g}")
        for name in ("kld_err", "laser_sigma_hit", "laser_sigma_max", "refute_sigma"):
            if getattr(self, name) <= 0.0:
                raise InvalidInputError(f"{name}: must be > 0, got {getattr(self, name)}")
        for name, low, high in (
            # A bin key holds 21 bits of cells each way: 1 cm bins span +-10 km; finer ones overflow it.
            ("kld_bin_xy", 0.01, 100.0),
            ("kld_bin_yaw", 0.001, 2.0 * math.pi),
            # Distances are clipped there; AMCL's default is 2 m, and squares of far larger ones overflow.
            ("laser_likelihood_max_dist", 0.01, 100.0),
        ):
            if not low <= getattr(self, name) <= high:
                raise InvalidInputError(f"{name}: must lie in [{low:g}, {high:g}], got {getattr(self, name):.3g}")
        non_negative = (
            "update_min_d",
            "update_min_a",
            "laser_z_hit",
            "laser_z_rand",
            "initial_cov_xx",
            "initial_cov_yy",
            "initial_cov_aa",
            "recovery_radius",
            "refute_margin",
            "confident_max_sd_xy",
            "confident_max_sd_yaw",
        )
        for name in non_negative:
            if getattr(self, name) < 0.0:
                raise InvalidInputError(f"{name}: must be >= 0, got {getattr(self, name)}")
        if self.laser_z_hit + self.laser_z_rand <= 0.0:
            raise InvalidInputError("laser_z_hit + laser_z_rand: must be > 0")
        if not 0.0 <= self.min_effective_fraction <= 1.0:
            raise InvalidInputError(f"min_effective_fraction: must lie in [0, 1], got {self.min_effective_fraction}")
        if not 0.0 < self.kld_z < 1.0:
            raise InvalidInputError(f"kld_z: must lie in (0, 1), got {self.kld_z}")
        if not (0.0 <= self.recovery_alpha_slow <= 1.0 and 0.0 <= self.recovery_alpha_fast <= 1.0):
            raise InvalidInputError("recovery_alpha_slow/recovery_alpha_fast: must lie in [0, 1]")
        if self.refute_updates < 0:
            raise InvalidInputError(f"refute_updates: must be >= 0, got {self.refute_updates}")
        if self.resample_interval < 1:
            raise InvalidInputError(f"resample_interval: must be >= 1, got {self.resample_interval}")

    @property
    def odometry_noise(self) -> OdometryNoise:
        return OdometryNoise(self.odom_alpha1, self.odom_alpha2, self.odom_alpha3, self.odom_alpha4)

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> LocalisationConfig:
        """A config from parameter values by name (unknown names are an error); ints stay ints."""
        fields = {f.name: f for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - set(fields))
        if unknown:
            raise InvalidInputError(f"unknown localisation parameters: {', '.join(unknown)}")
        converted: dict[str, Any] = {}
        for name, value in values.items():
            default = fields[name].default
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise InvalidInputError(f"{name}: expected a number, got {value!r}")
            if isinstance(default, int):
                if not isinstance(value, int):
                    raise InvalidInputError(f"{name}: expected an integer, got {value!r}")
                converted[name] = value
            else:
                converted[name] = float(value)
        return cls(**converted)
