"""Self-check of seed 000's slip model against the GNSS Doppler sideslip, row by row.

The slip gain K is fitted once for the whole drive (eq 20), but the relation
``beta_r = -K G_y`` holds only while the tyres are linear and the road is what the model
assumes (for the no-roll variant: level).  GNSS Doppler measures the sideslip directly at every
fresh epoch (course minus heading, eq 20's left-hand side), so the method can check its own
output: the innovation

    nu_k = beta_r,Doppler,k - (beta_r,model,k + c),   S_k = sigma_course,k^2 + beta_std_k^2

(c: the fit's intercept, the constant heading residue; sigma_course = sigma_v / V from the
receiver) has NIS_k = nu_k^2 / S_k ~ chi^2(1) where the model holds.  The windowed NIS test of
:func:`sideslip.filters.consistency.nis_consistency` (2 s centred windows: the method is an
offline smoother) gives the per-row ``health`` and the variance inflation f; there
``beta_std^2`` becomes ``f beta_std^2 + (f - 1) sigma_course^2`` (the window's mean nu^2 minus
the course noise: the package's sqrt(f) on beta_std, plus the course noise's share of the
excess, which matters where sigma_course > beta_std).  Rows without fresh Doppler
(outages, below the speed gate) keep the model's 1-sigma; their health also reflects

* reversing: the method reports the forward-equivalent 0 there (health 1: not an estimate of
  atan2(v_y, v_x), which is about +-pi);
* standstill: beta = 0 is exact, health 0;
* IMU sensor gaps (held samples): :func:`~sideslip.methods.observer_health.stale_health`;
* GNSS outages: the heading and so the course are dead reckoned, health rises linearly to 0.5
  at ``OUTAGE_FULL_S`` s without a fresh epoch (beyond the receiver's normal epoch spacing) (the slip relation
  itself does not need GNSS, so never beyond 0.5).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sideslip.frames import wrap_angle
from sideslip.methods.observer_health import blocked_consistency, stale_health

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

WINDOW_S = 2.0  # s: NIS window (centred)
NIS_CAP = 16.0  # per-epoch NIS cap (4 sigma): robust to single multipath epochs
OUTAGE_FULL_S = 60.0  # s without a fresh Doppler epoch at which the outage term reaches 0.5


@dataclass(frozen=True)
class DopplerHealth:
    """Per-row ``beta_std`` (inflated), ``health`` (0 ... 1), the innovations, and a summary."""

    beta_std: FloatArray
    health: FloatArray
    innovation: FloatArray
    nis: FloatArray
    summary: dict[str, object]


def doppler_health(
    t: FloatArray,
    rows: IntArray,
    beta_doppler: FloatArray,
    beta_model: FloatArray,
    sigma_course: FloatArray,
    beta_std: FloatArray,
    forward: NDArray[np.bool_],
    reversing: NDArray[np.bool_],
    imu_fresh: NDArray[np.bool_] | None = None,
) -> DopplerHealth:
    """The self-check of the module docstring.

    ``rows``: drive rows of the Doppler epochs used (fresh, above the speed gate);
    ``beta_doppler``/``beta_model``/``sigma_course`` (rad) at those rows (the model including
    its intercept); ``beta_std`` (rad) the model's 1-sigma on every row; ``forward`` and
    ``reversing`` row masks.
    """
    n = t.size
    nu = np.full(n, np.nan)
    nis = np.full(n, np.nan)
    ok = forward[rows] & np.isfinite(beta_doppler) & np.isfinite(beta_model)
    r_ok = rows[ok]
    nu[r_ok] = wrap_angle(beta_doppler[ok] - beta_model[ok])
    s = sigma_course[ok] ** 2 + beta_std[r_ok] ** 2
    # one multipath epoch must not flag a window by itself: each epoch's NIS is capped at
    # NIS_CAP (a 4-sigma innovation), so a window is flagged by a run of large innovations
    nis[r_ok] = np.minimum(nu[r_ok] ** 2 / np.maximum(s, 1e-12), NIS_CAP)
    cons_health, inflation, summary = blocked_consistency(
        t, nis, np.where(np.isfinite(nis), 1.0, 0.0), WINDOW_S, causal=False)
    # mean nu^2 = inflation (sigma_c^2 + beta_std^2) in a flagged window, so the model's own
    # error variance there is inflation beta_std^2 + (inflation - 1) sigma_c^2 (the package's
    # sqrt(inflation) on beta_std alone would leave out the course noise's share)
    sc2 = float(np.median(sigma_course[ok] ** 2)) if ok.any() else 0.0
    std = np.sqrt(beta_std**2 * inflation + (inflation - 1.0) * sc2)
    fresh = np.zeros(n, dtype=bool)
    fresh[r_ok] = True
    outage = stale_health(t, fresh, full_s=OUTAGE_FULL_S, level=0.5)
    health = np.maximum(cons_health, np.where(forward, outage, 0.0))
    if imu_fresh is not None:  # held gyro/accelerometer samples (sensor gap)
        health = np.maximum(health, stale_health(t, imu_fresh))
    health = np.where(reversing, 1.0, health)
    summary.update(
        criterion="windowed NIS of the Doppler sideslip against the slip model (2 s, chi2 99 %)",
        innovations=int(ok.sum()),
        reversing_share=float(np.mean(reversing)) if n else 0.0,
        outage_note=f"health rises to 0.5 after {OUTAGE_FULL_S:g} s without fresh Doppler",
    )
    return DopplerHealth(std, np.clip(health, 0.0, 1.0), nu, nis, summary)


LAG_MAX_S = 1.0  # s: beyond any road car's lateral response
LAG_MIN_Z = 3.0  # the lag is applied only when 3 sigma from 0
LAG_BLOCK_S = 5.0  # s: jackknife blocks of the lag fit


@dataclass(frozen=True)
class SlipLag:
    """First-order lag of the slip relation (s), its 1-sigma, whether applied and why not."""

    tau_s: float
    tau_s_sigma: float
    applied: bool
    note: str

    def params(self) -> dict[str, object]:
        return {"slip_lag_s": self.tau_s, "slip_lag_s_sigma": self.tau_s_sigma,
                "slip_lag_applied": self.applied, "slip_lag_note": self.note}


def fit_slip_lag(t_rows: FloatArray, rate_term: FloatArray, innovation: FloatArray,
                 min_z: float = LAG_MIN_Z) -> SlipLag:
    """Lag tau of ``beta_r = -K (G_y - tau dG_y/dt)``, identified from the Doppler sideslip.

    Eqs 10-14 are the steady state of the single track; in a transient the sideslip lags
    the lateral acceleration (the yaw and lateral modes of the single track settle in a few
    tenths of a second).  To first order the missing part is ``tau K dG_y/dt``, so the
    Doppler innovation nu (rad) regressed on ``rate_term`` = K dG_y/dt (rad/s) through the
    origin gives tau (s).  1-sigma: the larger of the formal one (one independent sample per
    second) and the block jackknife's (``LAG_BLOCK_S`` blocks).  Applied only when
    tau > ``LAG_MIN_Z`` sigma and below ``LAG_MAX_S`` (a lag, not a lead; otherwise the
    steady-state relation is kept and the note says why).
    """
    from sideslip.methods.doppler_stats import (
        block_jackknife_sums_std,
        honest_std,
        ratio_of_sums,
        time_blocks,
    )

    ok = np.isfinite(rate_term) & np.isfinite(innovation)
    x, y, tt = rate_term[ok], innovation[ok], t_rows[ok]
    sxx = float(np.sum(x * x))
    if x.size < 20 or sxx <= 0:
        return SlipLag(0.0, float("inf"), False, "too few Doppler epochs in transients")
    tau = float(np.sum(x * y) / sxx)
    res = y - tau * x
    span = max(float(tt[-1] - tt[0]), 1e-6)
    corr = max(x.size / span, 1.0)
    formal = float(np.std(res)) / np.sqrt(sxx) * np.sqrt(corr)
    labels = time_blocks(tt, LAG_BLOCK_S)

    jack = block_jackknife_sums_std(labels, np.stack([x * y, x * x]), ratio_of_sums)
    sigma = honest_std(formal, max(int(np.unique(labels).size) - 1, 1), jack)
    if not np.isfinite(sigma) or tau < min_z * sigma:
        return SlipLag(tau, sigma, False,
                       f"lag {tau:.3f} +- {sigma:.2g} s not significant: steady-state relation kept")
    if tau > LAG_MAX_S:
        return SlipLag(tau, sigma, False, f"lag {tau:.3f} s implausible (> {LAG_MAX_S} s): not used")
    return SlipLag(tau, sigma, True, "")
