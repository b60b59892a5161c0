"""Process noise of the seed-001 MKF identified from the drive (issue 14, ``preset="auto"``).

Seed 001 publishes sensor noise only (Table I), no process noise; typical model-error
densities (:class:`sideslip.models.mkf_model.MkfNoise`) are right for no particular car.  The
drive chooses two factors on them by maximum likelihood of the filter's innovations (the
prediction-error decomposition of the measurement likelihood, Schweppe 1965; its use to
identify Kalman-filter noise: Mehra, IEEE TAC 15(2), 1970), each scored on the channel that
measures what the density drives:

1. ``steer_yaw_factor`` on the steering-input and yaw-moment densities, by the gyro channel:
   the gyro measures r (+ bias) at every IMU row, so its one-step prediction errors are the
   direct cue of the yaw-rate process noise.  Grid :data:`STEER_YAW_GRID`, each scored by its
   best gyro likelihood over the sideslip grid (the two states are coupled).
2. ``beta_factor`` on the sideslip density, by the GNSS course channel (nu = psi + beta):
   the independent cue of the model's sideslip.  Grid :data:`BETA_GRID` at the chosen
   steering/yaw factor.  Model error is not white (it grows as the tyres leave their linear range), so a
   single likelihood maximum can be too confident: among the factors whose likelihood the
   drive does not reject against the best one (likelihood-ratio test, Wilks 1938:
   Delta(-2 ln L) <= :data:`LR_CHI2_95`, chi2 1 dof at 95 %) the largest is taken -- the most
   cautious sideslip noise the drive is consistent with.

-2 ln L = sum over updates of ln S + nu^2 / S (constants dropped).  Cost: one filter pass per
grid point (|STEER_YAW_GRID| x |BETA_GRID| = 12 passes of the numba loop, the discretised model
table shared, Q_d being linear in Q_c), linear in the drive's length; a tuning pass sums the
scores inside the compiled loop and keeps no per-row output
(:func:`sideslip.methods.mkf.mkf_scores`), so the memory is that of the problem.  The grids stop at
the largest factors checked on the simulator (a sideslip density beyond 30x typical let the
filter chase the course noise: beta_std no longer covered the error on the race lap).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

STEER_YAW_GRID = (0.01, 0.1, 1.0)
BETA_GRID = (1.0, 3.0, 10.0, 30.0)
LR_CHI2_95 = 3.84  # chi2(1 dof) 95 % quantile: likelihood-ratio confidence set of one factor


def neg2_log_likelihood(innov: FloatArray, s: FloatArray) -> tuple[float, int]:
    """-2 ln L of one channel's innovations (sum of ln S + nu^2 / S) and the update count."""
    ok = np.isfinite(innov) & np.isfinite(s) & (s > 0)
    if not ok.any():
        return 0.0, 0
    return float(np.sum(np.log(s[ok]) + innov[ok] ** 2 / s[ok])), int(ok.sum())


@dataclass(frozen=True)
class NoiseChoice:
    """Identified factors on the typical densities, with the scores that chose them."""

    steer_yaw_factor: float
    beta_factor: float
    steer_yaw_scores: dict[str, float]
    beta_scores: dict[str, float]
    gyro_updates: int
    course_updates: int

    def as_params(self) -> dict[str, Any]:
        return {
            "steer_yaw_factor": self.steer_yaw_factor,
            "beta_factor": self.beta_factor,
            "criterion": "max likelihood of the gyro innovations for the steering/yaw densities; "
            "for the sideslip density the largest factor whose GNSS-course innovation "
            f"likelihood is within chi2(1, 95 %) = {LR_CHI2_95} of the best (LR test)",
            "gyro_neg2_log_likelihood_by_factor": self.steer_yaw_scores,
            "course_neg2_log_likelihood_by_factor": self.beta_scores,
            "gyro_updates": self.gyro_updates,
            "course_updates": self.course_updates,
        }


def choose_noise(
    prob: Any,
    qd_of: Any,
    run: Any,
    tune_steer_yaw: bool = True,
    tune_beta: bool = True,
) -> NoiseChoice:
    """Pick the factors (module docstring).  ``prob``: an MKF problem (frozen dataclass with a
    ``Qd`` field); ``qd_of(steer_yaw_factor, beta_factor)`` the rescaled Q_d table; ``run`` one
    filter pass returning ``((gyro -2 ln L, gyro updates), (course -2 ln L, course updates))``
    (:func:`neg2_log_likelihood` of each channel, e.g. :func:`sideslip.methods.mkf.mkf_scores`,
    which keeps no per-row output).  A factor not tuned stays 1."""
    # each grid point is run once; only its scores are kept: memory stays one pass
    cache: dict[tuple[float, float], tuple[tuple[float, int], tuple[float, int]]] = {}

    def scores_of(fs: float, fb: float) -> tuple[tuple[float, int], tuple[float, int]]:
        if (fs, fb) not in cache:
            gyro, course = run(dataclasses.replace(prob, Qd=qd_of(fs, fb)))
            cache[(fs, fb)] = ((float(gyro[0]), int(gyro[1])), (float(course[0]), int(course[1])))
        return cache[(fs, fb)]

    fs_scores: dict[str, float] = {}
    fs, n_g = 1.0, 0
    if tune_steer_yaw:
        # the sideslip density also shapes the yaw-rate prediction (the states are coupled
        # through A), so the gyro score of each steering/yaw factor is its best over BETA_GRID
        best = np.inf
        for f in STEER_YAW_GRID:
            score = np.inf
            for fb_try in BETA_GRID if tune_beta else (1.0,):
                (s_try, n_g), _ = scores_of(f, fb_try)
                score = min(score, s_try)
            fs_scores[f"{f:g}"] = float(score)
            if n_g and score < best:
                best, fs = score, f
    fb_scores: dict[str, float] = {}
    fb, n_c = 1.0, 0
    if tune_beta:
        scores = []
        for f in BETA_GRID:
            _, (score, n_c) = scores_of(fs, f)
            fb_scores[f"{f:g}"] = score
            scores.append(score)
        if n_c:
            best_c = min(scores)
            fb = max(f for f, sc in zip(BETA_GRID, scores, strict=True) if sc - best_c <= LR_CHI2_95)
    return NoiseChoice(fs, fb, fs_scores, fb_scores, n_g, n_c)
