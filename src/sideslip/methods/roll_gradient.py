"""The suspension roll gradient identified from the drive (seed 003 eqs 43 and 46).

Seed 003's roll estimate needs the suspension roll gradient ``G_phi = m h / k`` (rad per m/s^2
of lateral specific force, eq 43), which users' vehicle files give roughly if at all: a soft
car with a stiff file's value misses the body roll by degrees.  The drive informs it where the
static bank relation holds (eq 46, steady state, v_y' ~ 0): the total roll is then

    phi_ss = asin((a_ym - r v_x) / g) = bank + G_phi a_ym              (eqs 43, 46)

Bank model: the road's bank is taken as constant through each curve and equal to its value on
the straights at the curve's ends (the mean phi_ss over ``END_S`` s of straight driving,
|a_ym| < ``STRAIGHT_AY``, on each side within ``END_SEARCH_S`` s; one side suffices).
``G_phi`` is then the least-squares slope through the origin of ``phi_ss - bank_curve`` on
``a_ym`` over the curves' steady rows (roll index flag f, no urgent steering, above the speed
gate, |a_ym| > ``MIN_AY``).

Honesty and guards (the value is used only when the drive supports it):

* the vehicle file's value is kept when the identified one agrees with it within ``FILE_Z``
  sigma (the drive does not contradict the file); the identified one replaces it otherwise;
* 1-sigma: a sensor-scale term ``SCALE_TERM`` (wheel-speed and gyro scale errors move
  r v_x, hence phi_ss, in proportion to a_y) in quadrature with the larger of the formal one
  (one independent sample per ``CORR_S``, t-scaled) and the jackknife over curves (over
  ``BLOCK_S`` blocks when fewer than four curves) -- a road whose superelevation differs from
  curve to curve shows up as a spread between curves;
* rejected (the vehicle file's value kept, reason in the params) with fewer than ``MIN_ROWS_S``
  seconds of steady curve rows, an a_ym span below ``MIN_SPAN``, a 1-sigma above
  ``MAX_REL_SIGMA`` of the value, or a value outside ``PLAUSIBLE`` (0.06-2.3 deg per m/s^2).

Limitation: superelevation designed in proportion to the curve's a_y (the same ratio in every
curve) cannot be told from body roll by this relation; it then shows as a larger gradient.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sideslip.methods.doppler_stats import (
    block_jackknife_sums_std,
    honest_std,
    ratio_of_sums,
    time_blocks,
)

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

STRAIGHT_AY = 0.3  # m/s^2: straight driving for the bank at a curve's ends
CURVE_AY = 1.0  # m/s^2: a curve
MIN_AY = 1.0  # m/s^2: rows used in the slope
END_S = 1.0  # s of straight driving averaged at each end
END_SEARCH_S = 10.0  # s searched for that straight driving
MIN_ROWS_S = 3.0  # s of usable steady curve rows
MIN_SPAN = 1.5  # m/s^2: span of |a_ym| over the rows used (5th to 95th percentile of a_ym)
MAX_REL_SIGMA = 0.25
PLAUSIBLE = (1e-3, 0.04)  # rad per m/s^2
# wheel-speed and gyro scale errors enter r v_x, so phi_ss carries (s_v + s_r) a_y / g: with
# 1 % each (rolling radius with pressure and wear; a MEMS gyro's sensitivity tolerance, +-1-3 %
# in consumer datasheets) a gradient error of
SCALE_TERM = float(np.hypot(0.01, 0.01)) / 9.80665  # rad per m/s^2 (1.4e-3)
FILE_Z = 3.0  # the file's value is kept unless the drive contradicts it by this many sigma
CORR_S = 1.0  # s
BLOCK_S = 5.0  # s


@dataclass(frozen=True)
class RollGradient:
    """Identified roll gradient (rad per m/s^2) and its 1-sigma, rows and curves used."""

    value: float
    sigma: float
    rows: int
    curves: int
    applied: bool
    note: str

    def validated(self, file_value: float) -> RollGradient:
        """Keep the file's value when the drive does not contradict it (within ``FILE_Z``
        sigma): the identification is then used only where the file is wrong."""
        if self.applied and np.isfinite(file_value) and abs(self.value - file_value) <= (
            FILE_Z * self.sigma
        ):
            return RollGradient(self.value, self.sigma, self.rows, self.curves, False,
                                f"file value {file_value:.4g} consistent with the drive "
                                f"({self.value:.4g} +- {self.sigma:.2g}): file value used")
        return self

    def combined(self, file_value: float, file_rel_sigma: float) -> RollGradient:
        """The drive's value and the file's (a prior of relative 1-sigma ``file_rel_sigma``)
        weighted by their precision; the drive's alone where the file has none, the file's
        where the drive does not inform it (not ``applied``)."""
        if not self.applied or not (np.isfinite(file_value) and file_value > 0.0):
            return self
        var_file = (file_rel_sigma * file_value) ** 2
        var = self.sigma**2
        value = (file_value * var + self.value * var_file) / (var + var_file)
        sigma = float(np.sqrt(var * var_file / (var + var_file)))
        return RollGradient(float(value), sigma, self.rows, self.curves, True,
                            f"drive {self.value:.4g} +- {self.sigma:.2g} with the file's "
                            f"{file_value:.4g} +- {file_rel_sigma:.0%}: {value:.4g}")

    def params(self, file_value: float) -> dict[str, object]:
        return {
            "roll_gradient_rad_per_m_s2": self.value if self.applied else file_value,
            "roll_gradient_rad_per_m_s2_sigma": self.sigma if self.applied else float("nan"),
            "roll_gradient_source": "identified" if self.applied else "vehicle file",
            "roll_gradient_identified_rad_per_m_s2": self.value,
            "roll_gradient_identified_sigma": self.sigma,
            "roll_gradient_file_rad_per_m_s2": file_value,
            "roll_gradient_rows": self.rows,
            "roll_gradient_curves": self.curves,
            "roll_gradient_note": self.note,
        }


def _runs(mask: BoolArray) -> list[tuple[int, int]]:
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return list(zip(starts.tolist(), stops.tolist(), strict=True))


def identify_roll_gradient(
    t: FloatArray, ay_m: FloatArray, phi_ss: FloatArray, steady: BoolArray, moving: BoolArray
) -> RollGradient:
    """The identification of the module docstring.  ``ay_m`` (m/s^2) and ``phi_ss`` (rad)
    low-passed on every row; ``steady`` rows where eq 46 holds; ``moving`` above the gate."""
    n = t.size
    if n < 10:
        return RollGradient(float("nan"), float("inf"), 0, 0, False, "drive too short")
    dt = float(np.median(np.diff(t)))
    straight = moving & (np.abs(ay_m) < STRAIGHT_AY)
    end_n = max(round(END_S / dt), 1)
    search = max(round(END_SEARCH_S / dt), 1)
    x_all: list[FloatArray] = []
    y_all: list[FloatArray] = []
    t_all: list[FloatArray] = []
    label: list[NDArray[np.intp]] = []
    for c, (a, b) in enumerate(_runs(moving & (np.abs(ay_m) > CURVE_AY))):
        ends = []
        before = np.flatnonzero(straight[max(a - search, 0):a])
        if before.size >= end_n:
            ends.append(float(np.mean(phi_ss[max(a - search, 0):a][before[-end_n:]])))
        after = np.flatnonzero(straight[b:min(b + search, n)])
        if after.size >= end_n:
            ends.append(float(np.mean(phi_ss[b:min(b + search, n)][after[:end_n]])))
        if not ends:
            continue
        use = np.arange(a, b)
        use = use[steady[use] & (np.abs(ay_m[use]) > MIN_AY)]
        if use.size == 0:
            continue
        x_all.append(ay_m[use])
        y_all.append(phi_ss[use] - float(np.mean(ends)))
        t_all.append(t[use])
        label.append(np.full(use.size, c, dtype=np.intp))
    if not x_all:
        return RollGradient(float("nan"), float("inf"), 0, 0, False,
                            "no steady curve with straight driving at an end: file value used")
    x = np.concatenate(x_all)
    y = np.concatenate(y_all)
    tt = np.concatenate(t_all)
    lab = np.concatenate(label)
    curves = int(np.unique(lab).size)
    sxx = float(np.sum(x * x))
    g = float(np.sum(x * y) / sxx)
    res = y - g * x
    corr = max(CORR_S / dt, 1.0)  # rows per independent sample
    formal = float(np.std(res)) / np.sqrt(sxx) * np.sqrt(corr)
    blocks: NDArray[np.intp] = lab if curves >= 4 else time_blocks(tt, BLOCK_S)

    n_blocks = int(np.unique(blocks).size)
    jack = block_jackknife_sums_std(blocks, np.stack([x * y, x * x]), ratio_of_sums)
    sigma = honest_std(formal, max(n_blocks - 1, 1), jack)
    sigma = float(np.hypot(sigma, SCALE_TERM))
    rows = int(x.size)
    span = float(np.percentile(x, 95) - np.percentile(x, 5))
    reason = ""
    if rows * dt < MIN_ROWS_S:
        reason = f"only {rows * dt:.1f} s of steady curve rows (< {MIN_ROWS_S} s)"
    elif span < MIN_SPAN and float(np.percentile(np.abs(x), 95)) < MIN_SPAN:
        reason = f"a_ym spans {span:.2f} m/s^2 (< {MIN_SPAN})"
    elif not np.isfinite(sigma) or sigma > MAX_REL_SIGMA * abs(g):
        reason = f"{g:.4g} +- {sigma:.2g} rad per m/s^2 too uncertain"
    elif not PLAUSIBLE[0] <= g <= PLAUSIBLE[1]:
        reason = f"{g:.4g} rad per m/s^2 outside the plausible {PLAUSIBLE}"
    if reason:
        return RollGradient(g, sigma, rows, curves, False, reason + ": file value used")
    return RollGradient(g, sigma, rows, curves, True, "")
