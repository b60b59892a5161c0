"""The seed-002 factor graph's two solves -- its Kalman filter and its banded normal equations
(:mod:`sideslip.methods.factor_graph`) -- run on the graph's factor arrays alone, so a caller
can free the graph's sigmas first and each intermediate as soon as the next step no longer
needs it (issue #17: a 24 h, 100 Hz drive in 4 GB).  :func:`solve_batch` and
:func:`solve_kalman` take a whole graph; the ``*_parts`` functions give the same results, bit
for bit, on its factor arrays.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from sideslip.filters.banded import assemble_chain, selected_inverse, solve_chain
from sideslip.methods.fg_tuning import chain_kalman

if TYPE_CHECKING:
    from sideslip.methods.factor_graph import SideslipGraph

FloatArray = NDArray[np.float64]


def solve_batch(graph: SideslipGraph) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Batch solution: ``(x, var, cov)``: (N, 2) means and marginal variances and the (N,)
    beta-r covariance of each row; one banded Cholesky + selected inverse."""
    return solve_system(assemble_parts(factor_parts(graph), *graph.prior_information))


def solve_kalman(graph: SideslipGraph) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Kalman filter on the same factors: F, g, Q = diag(sigma_q^2), R = sigma_u^2, P0;
    ``(x, var, cov, innovation, S)`` (:func:`sideslip.methods.fg_tuning.chain_kalman`)."""
    return chain_kalman(
        graph.F, graph.g, graph.wq, graph.Hu, graph.zu, graph.wu, graph.x0,
        np.diag(graph.sigma0**2),
    )  # fmt: skip


def factor_parts(graph: SideslipGraph) -> list[FloatArray]:
    """``[F, g, wq, Hu, zu, wu]``: what the filter and the normal equations read of a graph."""
    return [graph.F, graph.g, graph.wq, graph.Hu, graph.zu, graph.wu]


def kalman_on_parts(p: list[FloatArray], x0: FloatArray, P0: FloatArray) -> tuple[FloatArray, ...]:
    """``(x, var, cov, innovation, S)``: :func:`~sideslip.methods.fg_tuning.chain_kalman` on
    :func:`factor_parts`."""
    return tuple(chain_kalman(p[0], p[1], p[2], p[3], p[4], p[5], x0, P0))


def innovations_on_parts(p: list[FloatArray], x0: FloatArray, P0: FloatArray
                         ) -> tuple[FloatArray, FloatArray]:
    """The filter's innovations and their variances for the gyro and a_y factors (N, 2), the
    two a consistency test reads (the filter's other outputs are dropped at once)."""
    _, _, _, nu, S = kalman_on_parts(p, x0, P0)
    return nu[:, :2].copy(), S[:, :2].copy()


def assemble_parts(p: list[FloatArray], lam0: FloatArray, eta0: FloatArray) -> list[FloatArray]:
    """The banded normal equations ``[ab, rhs]`` of :func:`factor_parts` (a list: see
    :func:`solve_system`)."""
    return list(assemble_chain(p[0], p[1], p[2], p[3], p[4], p[5], lam0, eta0))


def solve_system(system: list[FloatArray]) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(x, var, cov)`` from ``[ab, rhs]`` (one banded Cholesky + selected inverse), emptying
    the list so each array is freed as soon as the next step no longer needs it (80 B/row of
    normal equations)."""
    ab, rhs = system
    system.clear()
    x, cb = solve_chain(ab, rhs)
    del ab, rhs
    sb = selected_inverse(cb)
    del cb
    return x.reshape(-1, 2), sb[0].reshape(-1, 2), sb[1].reshape(-1, 2)[:, 0].copy()
