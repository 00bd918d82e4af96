"""A 360-degree planar laser scanner (the Burger's LDS) cast with ODE rays against the obstacles and other robots.

Every beam is an ODE ``GeomRay`` of length ``range_max`` in a space of its own; one ``ode.collide2`` call of
that space against each target space (the static obstacles, then every other robot's own space: never the
scanning robot's, whose chassis surrounds the scanner) finds all hits of a scan, and the contact depth of a ray
contact is the distance from the ray's origin. Beams leave the scanner horizontally at its mounting height.

Readings follow REP 117: ``+inf`` when nothing is within ``range_max``, ``-inf`` when the hit is closer than
``range_min`` (only possible when the robot is pressed against an obstacle). Finite readings get additive
Gaussian noise N(0, sigma^2) and are kept within [range_min, range_max]. The noise for all beams is drawn
every scan, hit or not, so the random stream does not depend on what the robot sees.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import ode

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.sim.ode_bindings import collide_spaces


@dataclass(frozen=True)
class LaserParams:
    """Beam layout (rad), range limits (m), rate (Hz), range noise (m) and mount (m, in base_footprint)."""

    beams: int = 360
    angle_min: float = 0.0
    range_min: float = 0.12
    range_max: float = 3.5
    rate: float = 5.0
    noise_sigma: float = 0.01
    mount_x: float = -0.032
    mount_y: float = 0.0
    mount_z: float = 0.182

    def __post_init__(self) -> None:
        if self.beams < 1:
            raise InvalidInputError(f"laser beams must be at least 1, got {self.beams}")
        if not 0.0 <= self.range_min < self.range_max < math.inf:
            raise InvalidInputError(f"laser ranges must satisfy 0 <= min < max, got {self.range_min}, {self.range_max}")
        if not (math.isfinite(self.rate) and self.rate > 0.0):
            raise InvalidInputError(f"laser rate must be positive, got {self.rate}")
        if not (math.isfinite(self.noise_sigma) and self.noise_sigma >= 0.0):
            raise InvalidInputError(f"laser noise sigma must be >= 0, got {self.noise_sigma}")

    @property
    def angle_increment(self) -> float:
        """Angle between beams (rad): the beams cover the full circle."""
        return 2.0 * math.pi / self.beams

    @property
    def angle_max(self) -> float:
        return self.angle_min + (self.beams - 1) * self.angle_increment

    def angles(self) -> FloatArray:
        """Beam angles in the scanner frame (rad), shape (beams,)."""
        return np.asarray(self.angle_min + np.arange(self.beams) * self.angle_increment, dtype=np.float64)


@dataclass(frozen=True, eq=False)
class Scan:
    """One laser scan taken at sim time ``stamp`` (s); ``ranges`` in metres, beam i at angle_min + i*increment."""

    stamp: float
    ranges: FloatArray
    params: LaserParams = field(repr=False)


class Laser:
    """Casts the scanner's beams against ODE spaces: the static obstacles and the other robots."""

    def __init__(self, targets: Sequence[Any], params: LaserParams, rng: np.random.Generator) -> None:
        self.params = params
        self._targets = tuple(targets)
        self._rng = rng
        self._space = ode.SimpleSpace()
        self._rays = [ode.GeomRay(self._space, params.range_max) for _ in range(params.beams)]
        self._index = {ray: i for i, ray in enumerate(self._rays)}
        self._angles = params.angles()
        self._hits = np.full(params.beams, np.inf)

    def _near(self, g1: Any, g2: Any) -> None:
        for contact in ode.collide(g1, g2):
            depth = contact.getContactGeomParams()[2]
            i = self._index.get(g1)
            if i is None:
                i = self._index[g2]
            self._hits[i] = min(self._hits[i], depth)

    def true_ranges(self, base: Pose2D) -> FloatArray:
        """Noise-free distances (m) to the nearest obstacle or other robot per beam, +inf beyond ``range_max``."""
        p = self.params
        scanner = base.compose(Pose2D(p.mount_x, p.mount_y, 0.0))
        origin = (scanner.x, scanner.y, p.mount_z)
        heading = self._angles + scanner.yaw
        for ray, c, s in zip(self._rays, np.cos(heading).tolist(), np.sin(heading).tolist(), strict=True):
            ray.set(origin, (c, s, 0.0))
        self._hits.fill(np.inf)
        for target in self._targets:
            collide_spaces(self._space, target, self._near)
        return self._hits.copy()

    def scan(self, base: Pose2D, stamp: float) -> Scan:
        """A noisy scan from the robot whose ``base_footprint`` is at ``base``, per REP 117."""
        p = self.params
        ranges = self.true_ranges(base)
        noise = self._rng.normal(0.0, p.noise_sigma, p.beams) if p.noise_sigma > 0.0 else np.zeros(p.beams)
        finite = np.isfinite(ranges)
        too_close = finite & (ranges < p.range_min)
        valid = finite & ~too_close
        ranges[valid] = np.clip(ranges[valid] + noise[valid], p.range_min, p.range_max)
        ranges[too_close] = -np.inf
        return Scan(stamp, ranges, p)
