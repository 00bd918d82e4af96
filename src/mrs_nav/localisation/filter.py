"""Monte Carlo localisation on a known map (Thrun et al., *Probabilistic Robotics*, ch. 8; Fox 2003 for KLD).

Each filter update (once the odometry has moved ``update_min_d`` or turned ``update_min_a`` since the last)

1. moves every particle by the odometry increment with sampled noise (:func:`sample_motion`; a motion that
   spans the thresholds k times, scans having been skipped, with the noise of k updates),
2. weights it by the likelihood field of the scan's beams (:class:`LikelihoodField`), in log space,
3. every ``resample_interval`` updates, resamples with the low-variance (systematic) sampler, keeping as many
   particles as the KLD bound asks for (between ``min_particles`` and ``max_particles``), and replaces a
   fraction ``max(0, 1 - w_fast / w_slow)`` of them with random poses in free space (Augmented MCL, table 8.3):
   ``w_fast`` and ``w_slow`` are fast and slow running averages of how well the scans fit, so a sudden fall
   (the robot was kidnapped) spreads particles over the map until one of them finds the true pose. Random
   poses lie in known free space only, and within ``recovery_radius`` of the estimate while it is confident:
   a passing misfit then searches nearby instead of inviting a look-alike elsewhere (issue 38),

4. takes the estimate from the dominant cluster (heaviest place, then heaviest heading there), never the mean
   of two, and calls it confident only when that cluster holds 90 % of the weight, is narrow and the scans
   still fit (:meth:`ParticleFilter.estimate`).

The fit of a scan is the per-beam geometric mean of the weighted average likelihood: it lies in (0, ~z_hit] and
does not depend on how many beams were used. All steps are numpy over the whole particle set.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from scipy.special import logsumexp
from scipy.stats import norm

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D, cos_sin, format_point, wrap_angle, wrap_angles
from mrs_nav.localisation.config import LocalisationConfig
from mrs_nav.localisation.global_match import GlobalMatch
from mrs_nav.localisation.likelihood_field import LikelihoodField
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.motion_model import OdometryNoise, decompose

_CLUSTER_RADIUS = 0.75  # m: particles this close to the heaviest bin's mean make the pose estimate
_CLUSTER_SECTOR = math.pi / 4.0  # rad: headings are grouped in sectors this wide to find the dominant heading
_CLUSTER_HEADING = math.pi / 3.0  # rad: particles this close to the dominant heading make the pose estimate
# A dominant cluster with less of the weight than this is not a confident estimate: the office's look-alike
# corridors keep two or more modes alive for a while after a global spread, and one that holds barely half of
# the weight is as likely the wrong one (the sharp model then locked global localisation onto it).
_CONFIDENT_SHARE = 0.9
_LOST_FIT = 0.5  # the fast average fit below this share of the slow one: the scans no longer fit the belief
# Odometry 10,000 km from its origin is a broken message (a tf of 1e300): the motion model's squares overflow.
MAX_ODOM_M = 1e7


@dataclass(frozen=True, eq=False)
class BeamScan:
    """One laser scan for the filter: ranges (m) at angles (rad, laser frame), limits, and the laser's mounting
    (its pose in the robot's base frame). Readings outside [range_min, range_max) or not finite are unused."""

    ranges: FloatArray
    angles: FloatArray
    range_min: float
    range_max: float
    mount: Pose2D = field(default_factory=lambda: Pose2D(0.0, 0.0, 0.0))

    def __post_init__(self) -> None:
        if self.ranges.shape != self.angles.shape or self.ranges.ndim != 1:
            raise InvalidInputError(f"scan has {self.ranges.shape} ranges for {self.angles.shape} angles")
        if not (math.isfinite(self.range_max) and 0.0 <= self.range_min < self.range_max):
            raise InvalidInputError(
                f"scan range limits must satisfy 0 <= min < max, got {self.range_min}, {self.range_max}"
            )


@dataclass(frozen=True)
class PoseEstimate:
    """The filter's pose (map frame) and its 3x3 covariance over (x m, y m, yaw rad)."""

    pose: Pose2D
    covariance: FloatArray
    share: float = 1.0  # weight of the particles in the dominant mode (1: all of them)
    confident: bool = True  # see ParticleFilter.estimate


def sample_motion(  # noqa: PLR0917
    particles: FloatArray,
    start: Pose2D,
    end: Pose2D,
    noise: OdometryNoise,
    rng: np.random.Generator,
    steps: float = 1.0,
) -> None:
    """Move ``(N, 3)`` particles in place by the odometry increment ``start -> end`` with sampled noise (that of a
    turn on the spot when it moved less than :data:`mrs_nav.motion_model.IN_PLACE_M`), as the sum of ``steps``
    (>= 1) equal increments: each variance of the model is quadratic in the motion, so it is divided by ``steps``."""
    rot1, trans, rot2 = decompose(start, end)
    n = len(particles)
    sd_rot1, sd_trans, sd_rot2 = (sd / math.sqrt(steps) for sd in noise.std_devs(rot1, trans, rot2))
    e = rng.standard_normal((3, n))
    heading = particles[:, 2] + rot1 + sd_rot1 * e[0]
    step = trans + sd_trans * e[1]
    particles[:, 0] += step * np.cos(heading)
    particles[:, 1] += step * np.sin(heading)
    particles[:, 2] = wrap_angles(heading + rot2 + sd_rot2 * e[2])


def kld_limit(bins: npt.NDArray[np.intp] | int, err: float, z: float, max_particles: int) -> npt.NDArray[np.float64]:
    """Particles needed for ``bins`` occupied histogram bins (Fox 2003, eq. 8; AMCL's ``pf_resample_limit``)."""
    k = np.asarray(bins, dtype=np.float64)
    a = 2.0 / (9.0 * np.maximum(k - 1.0, 1.0))
    n = (k - 1.0) / (2.0 * err) * (1.0 - a + np.sqrt(a) * z) ** 3
    return np.where(k <= 1.0, float(max_particles), np.ceil(n))


class ParticleFilter:
    """MCL with KLD-adaptive sample size and random-particle recovery on one map."""

    def __init__(self, grid: OccupancyGrid, config: LocalisationConfig | None = None) -> None:
        self.config = config or LocalisationConfig()
        self.grid = grid
        self._rng = np.random.default_rng(None if self.config.seed < 0 else self.config.seed)
        self._z = float(norm.ppf(self.config.kld_z))
        if grid.origin[2] != 0.0:
            raise InvalidInputError(f"localisation needs a map with an unrotated origin, got yaw {grid.origin[2]}")
        if not np.any(grid.occupied_mask):
            raise InvalidInputError("localisation needs a map with at least one occupied cell")
        self._free_cells = np.flatnonzero(grid.free_mask)
        if self._free_cells.size == 0:
            raise InvalidInputError("localisation needs a map with at least one free cell")
        self._fields: dict[float, LikelihoodField] = {}
        self._given = False  # the cloud is a given pose (set_pose) not yet confirmed or refuted by the scans
        self._match: GlobalMatch | None = None  # built on the first pose to check (the grid costs some MB)
        self._to_check = 0  # updates left in which a given pose is checked against the whole map
        self._misfits = 0  # consecutive checked updates whose scan fits elsewhere far better
        self._refuted = False
        self._last_odom: Pose2D | None = None
        self._updates = 0
        self._w_slow = 0.0
        self._w_fast = 0.0
        self.particles: FloatArray = np.zeros((0, 3))
        self._log_weights: FloatArray = np.zeros(0)
        c = self.config
        self.set_pose(
            Pose2D(c.initial_pose_x, c.initial_pose_y, c.initial_pose_a),
            np.diag([c.initial_cov_xx, c.initial_cov_yy, c.initial_cov_aa]),
        )

    # -- initialisation -----------------------------------------------------------------------------------------

    def set_pose(self, pose: Pose2D, covariance: npt.ArrayLike) -> None:
        """Restart from a Gaussian about ``pose`` (rviz's 2D Pose Estimate); ``covariance`` is 3x3 (x, y, yaw).

        A pose off the map, or a spread wider than the map (x, y) or than a full turn (yaw), raises
        InvalidInputError and keeps the current particles: such a cloud would lie mostly where no scan can be
        scored; to search the whole map, use :meth:`global_localisation`.
        """
        cov = np.asarray(covariance, dtype=np.float64)
        if cov.shape != (3, 3) or not np.all(np.isfinite(cov)) or np.any(np.diag(cov) < 0.0):
            raise InvalidInputError(
                f"initial pose covariance must be a finite 3x3 matrix with variances >= 0, "
                f"got {np.array2string(cov.ravel(), precision=3, separator=', ', max_line_width=1000, threshold=9)}"
            )
        xmin, ymin, xmax, ymax = self.grid.extent
        if not (xmin <= pose.x <= xmax and ymin <= pose.y <= ymax):
            raise InvalidInputError(
                f"initial pose {format_point(pose.x, pose.y)} m lies off the map "
                f"(x {xmin:.3g}..{xmax:.3g}, y {ymin:.3g}..{ymax:.3g} m)"
            )
        sd_x, sd_y, sd_yaw = np.sqrt(np.diag(cov))
        diagonal = math.hypot(xmax - xmin, ymax - ymin)
        if max(sd_x, sd_y) > diagonal or sd_yaw > 2.0 * math.pi:
            raise InvalidInputError(
                f"initial pose covariance: std devs ({sd_x:.3g} m, {sd_y:.3g} m, {sd_yaw:.3g} rad) exceed the map's "
                f"{diagonal:.3g} m diagonal or a full turn; use global localisation to search the whole map"
            )
        n = self.config.max_particles
        # A covariance that is not positive semi-definite (rviz sends diagonal ones) is used by its diagonal.
        try:
            draws = self._rng.multivariate_normal(np.zeros(3), cov, size=n, method="cholesky")
        except np.linalg.LinAlgError:
            draws = self._rng.standard_normal((n, 3)) * np.sqrt(np.diag(cov))
        particles = draws + np.array([pose.x, pose.y, pose.yaw])
        particles[:, 2] = wrap_angles(particles[:, 2])
        self._given = True
        self._reset(particles)
        self._to_check, self._refuted = self.config.refute_updates, False

    def global_localisation(self) -> None:
        """Spread ``max_particles`` uniformly over the map's free space (AMCL's ``global_localization``)."""
        self._given = False
        self._reset(self._random_poses(self.config.max_particles))

    def request_update(self) -> None:
        """Update with the next scan although the robot has not moved (AMCL's ``request_nomotion_update``): the
        particles are weighed against it, resampled when due, and the estimate recomputed."""
        self._force_update = True

    def _reset(self, particles: FloatArray) -> None:
        self.particles = particles
        self._log_weights = np.zeros(len(particles))
        self._estimate = self._compute_estimate()
        # The new cloud describes the robot as it is now: odometry before the next scan must not move it.
        self._last_odom = None
        self._force_update = True
        self._w_slow = self._w_fast = 0.0
        self._to_check = self._misfits = 0

    def _recovery_poses(self, count: int) -> FloatArray:
        """Random poses for recovery: within ``recovery_radius`` of a confident estimate (the robot slipped or
        the scans were odd for a while: a local search finds it without inviting a distant look-alike), over
        all the known free space once the estimate is not confident (the robot was kidnapped); never in
        unknown space, where a scan cannot be checked against the map."""
        radius, estimate = self.config.recovery_radius, self._estimate
        if radius <= 0.0 or not estimate.confident:
            return self._random_poses(count)
        g = self.grid
        row, col = np.divmod(self._free_cells, g.width)
        x = g.origin[0] + (col + 0.5) * g.resolution
        y = g.origin[1] + (row + 0.5) * g.resolution
        local = self._free_cells[np.hypot(x - estimate.pose.x, y - estimate.pose.y) <= radius]
        return self._random_poses(count, local if local.size else self._free_cells)

    def _random_poses(self, count: int, cells: npt.NDArray[np.intp] | None = None) -> FloatArray:
        """``(count, 3)`` poses uniform over ``cells`` (flat indices; default: every free cell) and headings."""
        g, rng = self.grid, self._rng
        row, col = np.divmod(rng.choice(self._free_cells if cells is None else cells, size=count), g.width)
        return np.column_stack(
            [
                g.origin[0] + (col + rng.random(count)) * g.resolution,
                g.origin[1] + (row + rng.random(count)) * g.resolution,
                rng.uniform(-math.pi, math.pi, count),
            ]
        )

    def _field(self, range_max: float) -> LikelihoodField:
        model = self._fields.get(range_max)
        if model is None:
            c = self.config
            model = LikelihoodField(
                self.grid,
                z_hit=c.laser_z_hit,
                z_rand=c.laser_z_rand,
                max_dist=c.laser_likelihood_max_dist,
                range_max=range_max,
            )
            self._fields = {range_max: model}  # one laser: keep the latest only
        return model

    def _sigma(self) -> float:
        """The hit spread (m) for the next scan: ``laser_sigma_hit`` while the estimate is confident,
        ``laser_sigma_max`` while it is not (global localisation, recovery). A particle cloud spread over the
        map rarely has a particle within ``laser_sigma_hit`` of the truth, and a sharp model then scores them
        all alike; the broad one ranks them by how close they are. Once one mode is confident (within
        ``confident_max_sd_xy``, e.g. after a 2D Pose Estimate) the sharp model is used: a broad one there
        cannot tell places along a corridor apart, and the cloud stayed 0.3 m wide through a spin in place."""
        return self.config.laser_sigma_hit if self._estimate.confident else self.config.laser_sigma_max

    # -- reading ------------------------------------------------------------------------------------------------

    @property
    def weights(self) -> FloatArray:
        """Normalised particle weights, shape ``(N,)``."""
        w = np.exp(self._log_weights - self._log_weights.max())
        return np.asarray(w / w.sum(), dtype=np.float64)

    @property
    def recovery_fraction(self) -> float:
        """Fraction of particles the next resampling replaces with random ones (0 while the fit holds)."""
        if self._w_slow <= 0.0:
            return 0.0
        return max(0.0, 1.0 - self._w_fast / self._w_slow)

    @property
    def refuted(self) -> bool:
        """Whether the last pose given by :meth:`set_pose` was refuted by the scans (they fit somewhere else in
        the map far better, :mod:`.global_match`): the filter then spread its particles over the map's free space
        as :meth:`global_localisation` does. Cleared by the next :meth:`set_pose`."""
        return self._refuted

    def estimate(self) -> PoseEstimate:
        """The pose estimate after the last update (or reset): the weighted mean and covariance of the dominant
        cluster, never the mean of two. It is ``confident`` when its standard deviations are within
        ``confident_max_sd_xy`` (widest axis) and ``confident_max_sd_yaw``, the scans still fit (the fast
        average fit is at least half of the slow one, i.e. :attr:`recovery_fraction` < 0.5), and either that
        cluster holds at least 90 % of the weight or the cloud is a pose given by :meth:`set_pose` (a 2D Pose
        Estimate, the initial pose) that the scans have neither confirmed nor refuted yet: the user's word
        stands until then, not a global search's first guess."""
        return self._estimate

    def _cluster(self, w: FloatArray) -> npt.NDArray[np.bool_]:
        """The particles of the dominant mode: near the heaviest 0.5 m cell's mean, and of them those near the
        heaviest heading sector's mean (a corridor seen both ways makes two modes at one place)."""
        p = self.particles
        _, inverse = np.unique(_bin_keys(p[:, :2], self.config.kld_bin_xy), return_inverse=True)
        heaviest = int(np.argmax(np.bincount(inverse, weights=w)))
        in_cell = inverse == heaviest
        centre = np.average(p[in_cell, :2], axis=0, weights=w[in_cell] + 1e-300)
        near = np.hypot(p[:, 0] - centre[0], p[:, 1] - centre[1]) <= _CLUSTER_RADIUS
        sectors = np.floor((p[:, 2] + math.pi) / _CLUSTER_SECTOR).astype(np.intp)
        sector = int(np.argmax(np.bincount(sectors[near], weights=w[near] + 1e-300)))
        in_sector = near & (sectors == sector)
        cos, sin = cos_sin(p[in_sector, 2])
        heading = math.atan2(float(w[in_sector] @ sin), float(w[in_sector] @ cos))
        cluster: npt.NDArray[np.bool_] = near & (np.abs(wrap_angles(p[:, 2] - heading)) <= _CLUSTER_HEADING)
        return cluster

    def _compute_estimate(self) -> PoseEstimate:
        """Weighted mean and covariance of the dominant cluster, and whether it is confident."""
        w = self.weights
        p = self.particles
        near = self._cluster(w)
        share = float(w[near].sum())
        wn = w[near] / share if share > 0.0 else np.full(int(near.sum()), 1.0 / near.sum())
        pn = p[near]
        cos, sin = cos_sin(pn[:, 2])
        mean_yaw = math.atan2(float(wn @ sin), float(wn @ cos))
        mean = np.array([wn @ pn[:, 0], wn @ pn[:, 1], mean_yaw])
        d = pn - mean
        d[:, 2] = wrap_angles(d[:, 2])
        cov = (d * wn[:, None]).T @ d
        c = self.config
        narrow = (
            float(np.linalg.eigvalsh(cov[:2, :2])[-1]) <= c.confident_max_sd_xy**2
            and float(cov[2, 2]) <= c.confident_max_sd_yaw**2
        )
        fits = self.recovery_fraction < 1.0 - _LOST_FIT
        confirmed = share >= _CONFIDENT_SHARE and narrow and fits
        # A given pose counts as confident until the scans confirm it (then the rule alone holds) or refute it.
        confident = confirmed or (self._given and narrow and fits)
        self._given &= fits and not confirmed
        if not confident:
            # The cluster's spread claims too much of a belief that is not in it: report the whole cloud's spread
            # about the estimate, which navigation reads (/amcl_pose) against its own bounds (issue 38: a global
            # spread whose heaviest mode held 42 % of the weight was reported 0.05 m wide, and a goal was taken
            # as reached by it 12 m from the robot).
            d = p - mean
            d[:, 2] = wrap_angles(d[:, 2])
            cov = (d * w[:, None]).T @ d
        return PoseEstimate(Pose2D(float(mean[0]), float(mean[1]), wrap_angle(mean_yaw)), cov, share, confident)

    # -- updating -----------------------------------------------------------------------------------------------

    def update(self, odom: Pose2D, scan: BeamScan) -> bool:
        """Feed the odometry pose (odom frame) at a scan's time and the scan; True if the filter was updated.

        The first call only records the odometry; later calls update once the robot has moved enough, or at
        once after :meth:`set_pose` / :meth:`global_localisation`.
        """
        c = self.config
        if not (abs(odom.x) <= MAX_ODOM_M and abs(odom.y) <= MAX_ODOM_M and math.isfinite(odom.yaw)):
            raise InvalidInputError(
                f"odometry pose {format_point(odom.x, odom.y)} is not within {MAX_ODOM_M:g} m of its origin"
            )
        if self._last_odom is None:
            self._last_odom = odom
            if not self._force_update:
                return False
        rot1, trans, rot2 = decompose(self._last_odom, odom)
        moved = abs(trans) >= c.update_min_d or abs(wrap_angle(odom.yaw - self._last_odom.yaw)) >= c.update_min_a
        if not (moved or self._force_update):
            return False
        if rot1 or trans or rot2:
            sample_motion(self.particles, self._last_odom, odom, c.odometry_noise, self._rng, self._steps(trans, odom))
        self._last_odom = odom
        self._force_update = False
        self._weigh(scan)
        self._updates += 1
        if self._updates % c.resample_interval == 0:
            self._resample()
        self._estimate = self._compute_estimate()
        if self._to_check:
            self._check_given_pose(scan)
        return True

    def _steps(self, trans: float, odom: Pose2D) -> float:
        """How many updates the motion since the last one stands for (at least 1): how many times it covers
        ``update_min_d`` or ``update_min_a``. The node takes only the scans it can (one arriving before the
        odometry of its stamp, or while the filter is busy, is skipped), and the noise of one update grows with the
        square of its motion: a 2.2 rad turn onto a goal's heading taken in one update spreads the cloud 0.31 rad,
        in the four the thresholds make 0.16. Drawn as that many updates, the spread does not depend on how many
        scans got through, as with AMCL, which queues scans until tf has their odometry."""
        c = self.config
        assert self._last_odom is not None
        turn = abs(wrap_angle(odom.yaw - self._last_odom.yaw))
        spans = [abs(trans) / c.update_min_d if c.update_min_d > 0.0 else 0.0]
        spans.append(turn / c.update_min_a if c.update_min_a > 0.0 else 0.0)
        return max(1.0, *spans)

    def _check_given_pose(self, scan: BeamScan) -> None:
        """One of the first ``refute_updates`` updates after :meth:`set_pose`: a scan that fits near the belief as
        well as anywhere ends the checks; ``refute_updates`` in a row that fit elsewhere by more than
        ``refute_margin`` refute the pose and start a global localisation. Until then the estimate is not
        confident: the user's word stands against one odd scan, not against the map."""
        c = self.config
        ex, ey = self._beams(scan)
        if ex.size == 0:
            return
        if self._match is None:
            self._match = GlobalMatch(self._field(scan.range_max), self._free_cells)
        margin = self._match.margin(self._estimate.pose, self.particles, ex, ey, c.refute_sigma)
        if margin <= c.refute_margin:
            self._to_check = self._misfits = 0
            return
        self._to_check -= 1
        self._misfits += 1
        if self._misfits >= c.refute_updates:
            self.global_localisation()
            self._refuted = True
        else:
            self._estimate = dataclasses.replace(self._estimate, confident=False)

    def _beams(self, scan: BeamScan) -> tuple[FloatArray, FloatArray]:
        """Endpoints (x, y) in the robot's base frame of up to ``laser_max_beams`` evenly spaced valid beams."""
        c = self.config
        lo = scan.range_min if c.laser_min_range < 0.0 else max(scan.range_min, c.laser_min_range)
        hi = scan.range_max if c.laser_max_range < 0.0 else min(scan.range_max, c.laser_max_range)
        step = (len(scan.ranges) - 1) / (c.laser_max_beams - 1) if len(scan.ranges) > 1 else 1.0
        picked = np.unique(np.rint(np.arange(c.laser_max_beams) * step).astype(np.intp))
        picked = picked[picked < len(scan.ranges)]
        r, a = scan.ranges[picked], scan.angles[picked]
        valid = np.isfinite(r) & (r >= lo) & (r < hi)
        r, a = r[valid], a[valid] + scan.mount.yaw
        m = scan.mount
        return m.x + r * np.cos(a), m.y + r * np.sin(a)

    def _weigh(self, scan: BeamScan) -> None:
        ex, ey = self._beams(scan)
        if ex.size == 0:
            return  # nothing seen: the motion update alone
        model = self._field(scan.range_max)
        p = self.particles
        c, s = (v[:, None] for v in cos_sin(p[:, 2]))
        xs = p[:, 0, None] + c * ex - s * ey
        ys = p[:, 1, None] + s * ex + c * ey
        prior = self._log_weights - logsumexp(self._log_weights)
        beams, fit_beams = model.log_likelihood(xs, ys, np.exp(prior), self._sigma(), self.config.laser_sigma_hit)
        log_p = beams.sum(axis=1) - model.pose_cost(p[:, 0], p[:, 1])
        fit = math.exp(float(logsumexp(prior + fit_beams.sum(axis=1))) / ex.size)
        self._log_weights = prior + self._temper(prior, log_p) * log_p
        cfg = self.config
        if self._w_slow <= 0.0:
            self._w_slow = self._w_fast = fit
        else:
            self._w_slow += cfg.recovery_alpha_slow * (fit - self._w_slow)
            self._w_fast += cfg.recovery_alpha_fast * (fit - self._w_fast)

    def _temper(self, prior: FloatArray, log_p: FloatArray) -> float:
        """The largest exponent in (0, 1] on the scan likelihood that keeps ``min_effective_fraction`` of the
        particles effective (Kish's ESS): beams are not independent, and a full-strength likelihood on a
        spread-out cloud would leave a handful of particles, none of them near the truth."""
        target = self.config.min_effective_fraction * len(log_p)

        def ess(beta: float) -> float:
            lw = prior + beta * log_p
            return math.exp(2.0 * float(logsumexp(lw)) - float(logsumexp(2.0 * lw)))

        if ess(1.0) >= target:
            return 1.0
        lo, hi = 0.0, 1.0
        for _ in range(30):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if ess(mid) >= target else (lo, mid)
        return lo

    def _resample(self) -> None:
        c = self.config
        n_max = c.max_particles
        cumulative = np.cumsum(self.weights)
        cumulative[-1] = 1.0
        positions = (self._rng.random() + np.arange(n_max)) / n_max
        drawn = self.particles[np.searchsorted(cumulative, positions)]
        # The systematic draws in random order, each replaced by a random pose with the recovery probability
        # (spread-out random poses fill new bins, so the KLD count grows with them), kept up to the first count
        # that covers its histogram bins.
        drawn = drawn[self._rng.permutation(n_max)]
        if c.recovery_alpha_slow > 0.0 and c.recovery_alpha_fast > 0.0 and self.recovery_fraction > 0.0:
            replace = np.flatnonzero(self._rng.random(n_max) < self.recovery_fraction)
            drawn[replace] = self._recovery_poses(replace.size)
        keys = _bin_keys(drawn, c.kld_bin_xy, c.kld_bin_yaw)
        _, first = np.unique(keys, return_index=True)
        new_bin = np.zeros(n_max)
        new_bin[first] = 1.0
        needed = kld_limit(np.cumsum(new_bin).astype(np.intp), c.kld_err, self._z, n_max)
        enough = np.flatnonzero(np.arange(1, n_max + 1) >= np.clip(needed, c.min_particles, n_max))
        count = int(enough[0]) + 1 if enough.size else n_max
        self.particles = drawn[:count].copy()
        self._log_weights = np.zeros(count)


def _bin_keys(poses: FloatArray, size_xy: float, size_yaw: float = 0.0) -> npt.NDArray[np.int64]:
    """One integer per pose naming its histogram bin: (x, y) cells of ``size_xy`` m, and ``size_yaw`` rad
    heading sectors unless that is 0. 21 bits per axis: a million bins each way."""
    cells = np.floor(poses[:, :2] / size_xy).astype(np.int64) + (1 << 20)
    keys = (cells[:, 0] << 21) | cells[:, 1]
    if size_yaw > 0.0:
        keys = (keys << 21) | (np.floor(poses[:, 2] / size_yaw).astype(np.int64) + (1 << 20))
    return np.asarray(keys, dtype=np.int64)
