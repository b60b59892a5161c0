"""Model-error terms of the MKF's ``beta_std`` (:mod:`sideslip.methods.mkf`, issue 14) and its
per-row NIS: the road bank the flat-road single-track model ignores, through the model's
steady-state bank gain (seed 001 eq 1), with the bank's 1-sigma from the accelerometer's
gravity cue or a typical road bank.
"""

from __future__ import annotations

import numba
import numpy as np
import pandas as pd
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.models.mkf_model import V_GATE
from sideslip.models.single_track import continuous_arrays
from sideslip.signals import gravity_lateral_sin
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]


@numba.njit(cache=True)
def _nis_into(innov: NDArray, s: NDArray) -> None:  # pragma: no cover - compiled
    """``s <- innov^2 / s`` (the NIS), NaN where there was no update (in place: no temporaries)."""
    for k in range(s.size):
        nu = innov[k]
        s[k] = nu * nu / s[k] if np.isfinite(nu) and s[k] > 0.0 else np.nan


def bank_beta_gain(vehicle: Vehicle, speed: FloatArray) -> FloatArray:
    """Steady-state sideslip per unit road bank of the single-track model (rad/rad) at each
    row's speed: the bank column of -A^-1 B (seed 001 eq 1), on the drive's speeds rounded to
    0.1 m/s and interpolated; speeds below the model's gate take the gate's gain."""
    v = np.clip(np.abs(speed), V_GATE, None)
    grid = np.sort(pd.unique(np.round(v, 1)))  # = np.unique, hashed (no sort of every row)
    a2, b2, _, _ = continuous_arrays(vehicle, grid)
    gain = -np.linalg.solve(a2, b2)[:, 0, 1]
    return np.asarray(np.interp(v, grid, gain), dtype=float)


def bank_sigma(
    drive: Drive, speed: FloatArray, yaw_rate: FloatArray, floor_sigma: float, road_sigma: float
) -> tuple[FloatArray, str]:
    """1-sigma (as sin) of the road bank the flat-road model ignores, per row, and its source.

    With an accelerometer: hypot(``floor_sigma``, |g sin(roll + bank)| cue) from
    :func:`sideslip.signals.gravity_lateral_sin` (conservative in turns, where it also holds
    the suspension roll).  Without: ``road_sigma`` (typical crown and bank of public roads) on
    every row.  (``MkfSettings.bank_floor_sigma`` / ``road_bank_sigma``.)
    """
    cue = gravity_lateral_sin(drive, speed, yaw_rate)
    if cue is None:
        return np.full(drive.t.size, road_sigma), _bank_source(drive)
    return np.hypot(floor_sigma, cue, out=cue), _bank_source(drive)


def _bank_source(drive: Drive) -> str:
    """Where :func:`bank_sigma` takes the road bank from."""
    return "accelerometer cue (ay - V r) / g" if "ay" in drive else "typical road bank (no ay)"
