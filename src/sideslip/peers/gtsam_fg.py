"""Peer: the seed-002 factor graph built with GTSAM's linear factors, for cross-checks/speed.

The graph is the one of :func:`sideslip.methods.factor_graph.sideslip_graph` (with the sigmas
fg_batch resolves: a named preset, explicit values, or "auto" from the drive), laid out as in
the paper's Fig. 2/3: one scalar variable per beta_k (key 2k) and per r_k (key 2k+1);
two ternary dynamic factors per step (beta_{k+1}, beta_k, r_k) and (r_{k+1}, beta_k, r_k),
a unary yaw-rate factor on r_k, a binary lateral-acceleration factor on (beta_k, r_k), the
unary low-speed pseudo-measurement on beta_k, and two unary priors on the first step.  Each is
a ``gtsam.JacobianFactor`` with a ``noiseModel.Diagonal.Sigmas`` model; the linear system is
solved by ``GaussianFactorGraph.optimize()`` (multifrontal QR/Cholesky elimination), which is
the exact solution (one Gauss-Newton step) of this linear problem.

``run(drive, vehicle) -> beta`` (rad, N).  Needs the optional extra ``gtsam``: importing this
module raises ImportError without it (the benchmark then skips the peer).
"""

from __future__ import annotations

import gtsam
import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.methods.factor_graph import DEFAULT_SETTINGS, FactorGraphSettings, sideslip_graph
from sideslip.vehicle import Vehicle

PEER_FOR = ("fg_batch",)
NAME = "gtsam"


def _key_beta(k: int) -> int:
    return 2 * k


def _key_r(k: int) -> int:
    return 2 * k + 1


def build(
    drive: Drive, vehicle: Vehicle, settings: FactorGraphSettings = DEFAULT_SETTINGS
) -> tuple[gtsam.GaussianFactorGraph, int]:
    """The GTSAM factor graph of ``drive`` and its number of time steps."""
    graph = sideslip_graph(drive, vehicle, settings)
    n = graph.Hu.shape[0]
    fg = gtsam.GaussianFactorGraph()
    jac = gtsam.JacobianFactor
    sigmas = gtsam.noiseModel.Diagonal.Sigmas
    one = np.ones((1, 1))
    # priors on the first step (unary)
    fg.push_back(jac(_key_beta(0), one, np.array([graph.x0[0]]), sigmas(graph.sigma0[:1])))
    fg.push_back(jac(_key_r(0), one, np.array([graph.x0[1]]), sigmas(graph.sigma0[1:])))
    F, g, sq = graph.F, graph.g, graph.sigma_q
    Hu, zu, su = graph.Hu, graph.zu, graph.sigma_u
    finite = np.isfinite(su)
    for k in range(n):
        kb, kr = _key_beta(k), _key_r(k)
        if finite[k, 0]:  # yaw rate: unary on r_k
            fg.push_back(jac(kr, one * Hu[k, 0, 1], zu[k, 0:1], sigmas(su[k, 0:1])))
        if finite[k, 1]:  # lateral acceleration: binary on (beta_k, r_k)
            fg.push_back(
                jac(kb, one * Hu[k, 1, 0], kr, one * Hu[k, 1, 1], zu[k, 1:2], sigmas(su[k, 1:2]))
            )
        if finite[k, 2]:  # low-speed kinematic sideslip: unary on beta_k
            fg.push_back(jac(kb, one * Hu[k, 2, 0], zu[k, 2:3], sigmas(su[k, 2:3])))
        if k + 1 < n:  # dynamics: ternary x_{k+1}[c] - F_k[c] x_k = g_k[c]
            for c, key_next in ((0, _key_beta(k + 1)), (1, _key_r(k + 1))):
                a_beta = -one * F[k, c, 0]
                a_r = -one * F[k, c, 1]
                noise = sigmas(sq[k, c : c + 1])
                fg.push_back(jac(key_next, one, kb, a_beta, kr, a_r, g[k, c : c + 1], noise))
    return fg, n


def solve(fg: gtsam.GaussianFactorGraph, n: int) -> NDArray[np.float64]:
    """beta (rad) of the graph's solution (``optimize``: elimination with COLAMD ordering)."""
    solution = fg.optimize()
    return np.array([solution.at(_key_beta(k))[0] for k in range(n)])


def run(
    drive: Drive, vehicle: Vehicle, settings: FactorGraphSettings = DEFAULT_SETTINGS
) -> NDArray[np.float64]:
    """Sideslip beta (rad) of the batch graph solved by GTSAM."""
    return solve(*build(drive, vehicle, settings))
