"""Schmidt-Kalman ("consider") update (Schmidt 1966, NASA TN D-3146; Simon 2006, *Optimal State
Estimation*, sec. 7.6): the gain of a consider state is set to zero, so the measurement does
not move it, but its uncertainty enters the innovation variance and its cross-covariances
with the other states are updated.  With the gain ``k`` altered, the covariance is the Joseph
product ``P - k (P h')' - (P h') k' + S k k'``, which holds for any gain (Simon 2006, eq 5.19).
Dropping the cross-covariances instead (adding ``h_c^2 P_cc`` to the measurement variance of
each update as if it were white) lets many updates average out an error that is in fact the
same in all of them: the filter grows overconfident in the states the relation does move.
"""

from __future__ import annotations

import math

import numba
from numpy.typing import NDArray

from sideslip.filters.kalman import (
    cross_covariance_nb,
    innovation_variance_nb,
    joseph_rank1_nb,
    robust_weight_nb,
)


@numba.njit(cache=True)
def scalar_consider_nb(
    x: NDArray, P: NDArray, innov: float, h: NDArray, r: float, keep: NDArray, work: NDArray
) -> float:
    """In place scalar update with the gain of state i multiplied by ``keep[i]`` (0: a
    consider state, 1: estimated) and the covariance by the Joseph product (module
    docstring); returns S = h P h' + r.  All ``keep`` 1 is the ordinary Kalman update
    (:func:`sideslip.filters.kalman.update_scalar_ws_nb`).  ``work`` at least (2, n); a
    non-positive S leaves x and P unchanged."""
    s = cross_covariance_nb(P, h, r, work)
    if not s > 0.0:
        return s
    for i in range(x.size):
        work[1, i] = work[0, i] / s * keep[i]
        x[i] += work[1, i] * innov
    joseph_rank1_nb(P, work, s)
    return s


@numba.njit(cache=True)
def robust_consider_nb(
    x: NDArray, P: NDArray, innov: float, h: NDArray, r: float, inflate_nis: float, keep: NDArray,
    work: NDArray,
) -> tuple[float, bool]:  # fmt: skip
    """Scalar consider update whose variance grows with its NIS beyond ``inflate_nis``
    (:func:`sideslip.filters.kalman.robust_weight_nb`); returns ``(NIS, taken at full weight)``."""
    s = innovation_variance_nb(P, h, r)
    if not s > 0.0:
        return math.nan, False
    nis = innov * innov / s
    w = robust_weight_nb(nis, math.inf, inflate_nis)
    scalar_consider_nb(x, P, innov, h, r / w, keep, work)
    return nis, w >= 1.0
