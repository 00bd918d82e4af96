"""A 360-degree planar laser scanner (the Burger's LDS) cast against the 2-D cross-sections of the world.

Beams leave the scanner horizontally at its mounting height, so what a beam can hit is the cross-section of
the ODE world at that height (:meth:`mrs_nav.sim.physics.Physics.laser_sections`): oriented rectangles (the
upright boxes), circles (upright cylinders: the static ones and the other robots' chassis; spheres that reach
that height), never the scanning robot's own chassis, which surrounds the scanner. One compiled kernel casts
every beam against every section near enough to matter, as ODE's ray geoms did (same hits, without a Python
callback per ray and shape):

* ray ``o + t d`` (unit ``d``, ``0 <= t <= range_max``) against a rectangle of centre ``c``, heading ``psi`` and
  half sizes ``(hx, hy)``: in the rectangle's frame ``o' = R(-psi)(o - c)``, ``d' = R(-psi) d``, and per axis
  the slab ``|o'_k + t d'_k| <= h_k`` holds for ``t`` between ``(-h_k - o'_k) / d'_k`` and ``(h_k - o'_k) / d'_k``
  (all ``t`` if ``d'_k = 0`` and ``|o'_k| <= h_k``, none otherwise); the ray meets the rectangle on
  ``[lo, hi]`` = the intersection of both slabs' intervals, if ``lo <= hi``;
* against a circle of centre ``c`` and radius ``r``: ``|o - c + t d|^2 = r^2``, i.e. ``t = -b -+ sqrt(b^2 - q)``
  with ``b = (o - c).d`` and ``q = |o - c|^2 - r^2``, a hit if the discriminant is >= 0;
* the hit is the entry ``lo`` (or ``-b - sqrt``), or, from inside the shape, the exit ``hi`` (``-b + sqrt``),
  as ODE reports it; a beam's range is its nearest hit within ``[0, range_max]``, ``+inf`` if none.

Readings follow REP 117: ``+inf`` when nothing is within ``range_max``, ``-inf`` when the hit is closer than
``range_min`` (only possible when the robot is pressed against an obstacle). Finite readings get additive
Gaussian noise N(0, sigma^2) and are kept within [range_min, range_max]. The noise for all beams is drawn
every scan, hit or not, so the random stream does not depend on what the robot sees.
"""

# ruff: noqa: PLR0917

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np
from numba import types as nt

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D

_F = nt.float64
_F1 = nt.Array(_F, 1, "C")
_F2 = nt.Array(_F, 2, "C")


@dataclass(frozen=True, eq=False)
class Sections:
    """What a horizontal beam can hit at one height, world frame (m, rad): ``circles`` rows (x, y, radius),
    ``rects`` rows (x, y, yaw, half size x, half size y); both float64, C-contiguous."""

    circles: FloatArray
    rects: FloatArray

    @staticmethod
    def join(parts: list[Sections]) -> Sections:
        return Sections(
            np.ascontiguousarray(np.concatenate([p.circles for p in parts]), dtype=np.float64),
            np.ascontiguousarray(np.concatenate([p.rects for p in parts]), dtype=np.float64),
        )


@numba.njit(_F1(_F, _F, _F1, _F1, _F2, _F2, _F), cache=True)
def cast_rays(
    ox: float, oy: float, dx: FloatArray, dy: FloatArray, circles: FloatArray, rects: FloatArray, length: float
) -> FloatArray:
    """Nearest hit (m) along each ray ``(ox, oy) + t (dx[i], dy[i])``, ``0 <= t <= length``, ``+inf`` if none
    (the maths of the module docstring); shapes whose bounding circle lies beyond ``length`` are skipped."""
    ranges = np.full(dx.size, np.inf)
    for j in range(circles.shape[0]):
        qx, qy, r = ox - circles[j, 0], oy - circles[j, 1], circles[j, 2]
        q = qx * qx + qy * qy - r * r
        if math.sqrt(qx * qx + qy * qy) - r > length:
            continue
        for i in range(dx.size):
            b = qx * dx[i] + qy * dy[i]
            disc = b * b - q
            if disc < 0.0:
                continue
            root = math.sqrt(disc)
            t = -b - root
            if t < 0.0:
                t = -b + root
            if 0.0 <= t <= length and t < ranges[i]:
                ranges[i] = t
    for j in range(rects.shape[0]):
        cx, cy, yaw, hx, hy = rects[j, 0], rects[j, 1], rects[j, 2], rects[j, 3], rects[j, 4]
        if math.hypot(ox - cx, oy - cy) - math.hypot(hx, hy) > length:
            continue
        c, s = math.cos(yaw), math.sin(yaw)
        lx = c * (ox - cx) + s * (oy - cy)
        ly = -s * (ox - cx) + c * (oy - cy)
        for i in range(dx.size):
            ux = c * dx[i] + s * dy[i]
            uy = -s * dx[i] + c * dy[i]
            lo, hi = -np.inf, np.inf
            if ux != 0.0:
                k1, k2 = (-hx - lx) / ux, (hx - lx) / ux
                lo, hi = max(lo, min(k1, k2)), min(hi, max(k1, k2))
            elif abs(lx) > hx:
                continue
            if uy != 0.0:
                k1, k2 = (-hy - ly) / uy, (hy - ly) / uy
                lo, hi = max(lo, min(k1, k2)), min(hi, max(k1, k2))
            elif abs(ly) > hy:
                continue
            if lo > hi:
                continue
            t = lo if lo >= 0.0 else hi
            if 0.0 <= t <= length and t < ranges[i]:
                ranges[i] = t
    return ranges


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
    """Casts the scanner's beams against the cross-sections of the world at the scanner's height."""

    def __init__(self, params: LaserParams, rng: np.random.Generator) -> None:
        self.params = params
        self._rng = rng
        self._angles = params.angles()

    def true_ranges(self, base: Pose2D, sections: Sections) -> FloatArray:
        """Noise-free distances (m) to the nearest of ``sections`` per beam, +inf beyond ``range_max``."""
        p = self.params
        scanner = base.compose(Pose2D(p.mount_x, p.mount_y, 0.0))
        heading = self._angles + scanner.yaw
        return np.asarray(
            cast_rays(
                scanner.x, scanner.y, np.cos(heading), np.sin(heading), sections.circles, sections.rects, p.range_max
            )
        )

    def scan(self, base: Pose2D, stamp: float, sections: Sections) -> Scan:
        """A noisy scan from the robot whose ``base_footprint`` is at ``base``, per REP 117."""
        p = self.params
        ranges = self.true_ranges(base, sections)
        noise = self._rng.normal(0.0, p.noise_sigma, p.beams) if p.noise_sigma > 0.0 else np.zeros(p.beams)
        finite = np.isfinite(ranges)
        too_close = finite & (ranges < p.range_min)
        valid = finite & ~too_close
        ranges[valid] = np.clip(ranges[valid] + noise[valid], p.range_min, p.range_max)
        ranges[too_close] = -np.inf
        return Scan(stamp, ranges, p)
