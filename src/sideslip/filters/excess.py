"""The innovation power a filter's covariance does not explain, per row of a drive.

Where a filter's model stops fitting (tyres past their linear range, a wrong vehicle file),
its innovations ``nu_k`` grow beyond their predicted variance ``S_k``.  The windowed NIS test
(:mod:`sideslip.filters.consistency`) scales the state covariance by the ratio of the two,
which keeps a covariance that was small small: a filter whose sideslip variance is a tenth of
its course innovation's still reports a tenth of the error the innovations show.  The
estimate cannot be surer than the disagreement between its model and the measurement, so a
method whose innovation measures the sideslip directly (a GNSS course against the model's
``psi + beta``, a Doppler sideslip against a slip gain's) adds the excess

    max(0, sum nu_k^2 - sum S_k) / (number of innovations)

over a centred window (Bar-Shalom, Li, Kirubarajan, *Estimation with Applications to Tracking
and Navigation*, 2001, sec. 5.4: ``E[nu nu'] = S`` for a consistent filter; the excess is the
power the model misses) to the sideslip variance.  Inside the chi-square bound the excess is
noise, so only windows the NIS test flags add it.  Summed over bins first, as
:mod:`sideslip.filters.nis_windows`: O(N).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def excess_innovation_variance(
    t: ArrayLike,
    innov: ArrayLike,
    s: ArrayLike,
    flagged: ArrayLike,
    window_s: float = 2.0,
    bin_s: float = 0.1,
    causal: bool = False,
) -> FloatArray:
    """Per-row innovation variance beyond the filter's own ``S`` (innovation unit squared).

    ``t`` (N,) s, increasing; ``innov`` (N,) a scalar innovation per row (NaN: no update);
    ``s`` (N,) its predicted variance; ``flagged`` (N,) rows whose windowed NIS is beyond the
    chi-square bound (:class:`sideslip.filters.consistency.Consistency.flagged`), elsewhere 0;
    ``window_s`` the window (centred; trailing, this bin and those before, when ``causal``),
    ``bin_s`` the bin width (at most a tenth of the window).
    """
    t = np.asarray(t, dtype=float)
    nu = np.asarray(innov, dtype=float)
    var = np.asarray(s, dtype=float)
    flag = np.asarray(flagged, dtype=bool)
    if not (t.shape == nu.shape == var.shape == flag.shape):
        raise ValueError(
            f"t, innov, s and flagged must have one shape, got {t.shape}, {nu.shape}, "
            f"{var.shape}, {flag.shape}"
        )
    if window_s <= 0.0 or not np.isfinite(window_s):
        raise ValueError(f"window_s must be positive and finite, got {window_s!r}")
    if t.size == 0:
        return np.zeros(0)
    ok = np.isfinite(nu) & np.isfinite(var)
    width = min(bin_s, 0.1 * window_s)
    idx = np.floor((t - t[0]) / width).astype(np.int64)
    nb = int(idx[-1]) + 1
    power = np.bincount(idx, weights=np.where(ok, nu * nu - var, 0.0), minlength=nb)
    count = np.bincount(idx, weights=ok.astype(float), minlength=nb)
    half = max(1, round(0.5 * window_s / width))
    c_p = np.concatenate(([0.0], np.cumsum(power)))
    c_n = np.concatenate(([0.0], np.cumsum(count)))
    lo = np.clip(np.arange(nb) - (2 * half if causal else half), 0, nb)
    hi = np.clip(np.arange(nb) + (1 if causal else half + 1), 0, nb)
    n_win = c_n[hi] - c_n[lo]
    excess = np.where(n_win > 0, (c_p[hi] - c_p[lo]) / np.maximum(n_win, 1.0), 0.0)
    return np.where(flag, np.maximum(excess[idx], 0.0), 0.0)
