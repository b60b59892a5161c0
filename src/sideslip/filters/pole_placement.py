"""Observer gains for 2-state systems by pole placement, and the exact step of a double-pole loop.

Everything here is vectorised over a leading axis (one 2x2 system per sample, e.g. per speed):
``A`` has shape (N, 2, 2).  Derivations (ours; seed 003's closed forms eqs 16-17 and 37 are
garbled by extraction, so they are re-derived here and checked against the paper's structure):

Single output ``y = x_2`` (seed 003 eqs 12-17, simple bicycle observer, C = [0, 1])
    A - K C = [[a11, a12 - k1], [a21, a22 - k2]]
    det(sI - (A - KC)) = s^2 - (a11 + a22 - k2) s + a11 (a22 - k2) - a21 (a12 - k1)
    Matching (s - p)^2 = s^2 - 2 p s + p^2 gives
        k2 = a11 + a22 - 2 p
        k1 = ((p - a11)^2 + a12 a21) / a21
    (x_1 is observable from x_2 only through a21; |a21| is floored, keeping its sign, and
    :func:`reachable_pole` moves the pole towards a11 when a21 is small.)

Two outputs ``y = C x`` with K12 fixed (seed 003 eqs 33-37, modified bicycle observer)
    K12 = a11 / c21 cancels the first column of row 1; for the single-track model this is
    K12 = 1/v_x (eq 36), and row 1 of A - KC becomes [0, e - K11] with e = a12 - K12 c22
    (e = -1 for the single-track model).  Row 2 is [a21 - K22 c21, a22 - K21 - K22 c22].
    Let q = a21 - K22 c21.  Then det(sI - (A - KC)) = s^2 - (a22 - K21 - K22 c22) s
    - (e - K11) q, and (s - p)^2 requires
        K21 = a22 - K22 c22 - 2 p,     K11 = e + p^2 / q.
    One gain is free.  The paper takes K22 = a22 / c22 (it cancels the model's own yaw
    damping), which gives q = cf cr L^2 / (I_z (cf lf - cr lr)) per axle (= 2 Cf Cr L^2 /
    (I_z (Cf lf - Cr lr)) per tyre: eq 37's K11 = I_z (lf Cf - lr Cr) p^2 / (2 Cf Cr L^2) - 1
    and K21 = -2p are reproduced).  That choice is singular for a neutral-steer vehicle
    (c22 -> 0); :func:`two_output_gain` therefore takes q as an argument and sets
    K22 = (a21 - q) / c21 (c21 = -(cf + cr)/m never vanishes).

Exact discretisation of a loop with a double pole
    If M (2x2) has the double eigenvalue p, then N = M - p I is nilpotent (N^2 = 0 by
    Cayley-Hamilton), so exp(M T) = e^{pT} (I + N T) exactly and
    int_0^T exp(M s) ds = phi1 I + phi2 N,  phi1 = (e^{pT} - 1)/p,
    phi2 = (e^{pT}(pT - 1) + 1)/p^2  (series used for small |pT|).
    This is exact whatever the size of the gains, so a stiff, speed-scheduled loop needs no
    sub-stepping.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]

MIN_COUPLING = 1e-6  # floor on |a21| (1/s^2 units of the caller) in the single-output design


def _signed_floor(x: FloatArray, floor: float) -> FloatArray:
    """x with |x| >= floor, keeping the sign (0 -> +floor)."""
    return np.where(x >= 0, np.maximum(x, floor), np.minimum(x, -floor))


def single_output_gain(A: ArrayLike, p: float | ArrayLike) -> FloatArray:
    """Gains K (N, 2) placing both poles of A - K [0, 1] at ``p`` (< 0), for each of N systems.

    ``A``: (N, 2, 2) or (2, 2).  ``p``: scalar or (N,).  See the module docstring for the
    derivation.  |a21| is floored at :data:`MIN_COUPLING` (x_1 unobservable when a21 = 0);
    for weakly coupled systems pass the pole from :func:`reachable_pole` instead.
    """
    a = np.asarray(A, dtype=float).reshape(-1, 2, 2)
    pole = np.broadcast_to(np.asarray(p, dtype=float), a.shape[:1])
    a11, a12, a21, a22 = a[:, 0, 0], a[:, 0, 1], a[:, 1, 0], a[:, 1, 1]
    a21 = _signed_floor(a21, MIN_COUPLING)
    K = np.empty((a.shape[0], 2))
    K[:, 1] = a11 + a22 - 2.0 * pole
    K[:, 0] = (pole - a11) ** 2 / a21 + a12
    return K


def reachable_pole(A: ArrayLike, p: float, coupling_ref: float | ArrayLike) -> FloatArray:
    """Double pole (N,) to ask of :func:`single_output_gain` when a21 may be tiny.

    With y = x_2, the gain on x_1 is k1 = (p - a11)^2 / a21 + a12: as a21 -> 0 (x_1 barely
    observable, e.g. a neutral-steer car for the bicycle observer) it explodes, and any error
    in a21 then puts a pole at 2p - a11, unstable when a11 < 2p.  The double pole
    p_eff = a11 + (p - a11) c, c = min(1, |a21| / coupling_ref), keeps k1 bounded
    (k1 -> a12 as a21 -> 0: x_1 then follows its own model pole a11, which is stable when
    a11 < 0) and equals ``p`` whenever |a21| >= coupling_ref (a scalar, or one per system).
    """
    a = np.asarray(A, dtype=float).reshape(-1, 2, 2)
    c = np.minimum(1.0, np.abs(a[:, 1, 0]) / np.asarray(coupling_ref, dtype=float))
    return np.asarray(a[:, 0, 0] + (p - a[:, 0, 0]) * c, dtype=float)


def two_output_gain(A: ArrayLike, C: ArrayLike, p: float | ArrayLike, q: float | ArrayLike
                    ) -> FloatArray:
    """Gains K (N, 2, 2) for y = C x with K12 = a11/c21, double pole at ``p``, coupling ``q``.

    ``A``, ``C``: (N, 2, 2).  ``q`` (nonzero, scalar or (N,)) is the (2,1) entry of A - K C;
    :func:`bicycle_coupling` gives seed 003's choice.  See the module docstring.
    """
    a = np.asarray(A, dtype=float).reshape(-1, 2, 2)
    c = np.asarray(C, dtype=float).reshape(-1, 2, 2)
    n = a.shape[0]
    pole = np.broadcast_to(np.asarray(p, dtype=float), (n,))
    qq = np.broadcast_to(np.asarray(q, dtype=float), (n,))
    a11, a12, a21, a22 = a[:, 0, 0], a[:, 0, 1], a[:, 1, 0], a[:, 1, 1]
    c21, c22 = c[:, 1, 0], c[:, 1, 1]
    K = np.empty((n, 2, 2))
    K[:, 0, 1] = a11 / c21
    K[:, 1, 1] = (a21 - qq) / c21
    e = a12 - K[:, 0, 1] * c22
    K[:, 1, 0] = a22 - K[:, 1, 1] * c22 - 2.0 * pole
    K[:, 0, 0] = e + pole**2 / qq
    return K


def bicycle_coupling(cf: float, cr: float, lf: float, lr: float, yaw_inertia: float,
                     min_fraction: float = 0.02) -> float:
    """Seed 003's coupling q = cf cr L^2 / (I_z (cf lf - cr lr)), 1/s^2 (cf, cr per axle).

    It follows from K22 = a22/c22 (eq 37).  Near neutral steer (|cf lf - cr lr| below
    ``min_fraction`` of cf lf + cr lr) the difference is floored, keeping its sign (an exactly
    neutral vehicle is taken as slightly understeering, q < 0), so q stays finite.
    """
    diff = cf * lf - cr * lr
    floor = min_fraction * (cf * lf + cr * lr)
    if abs(diff) < floor:
        diff = floor if diff > 0 else -floor
    return cf * cr * (lf + lr) ** 2 / (yaw_inertia * diff)


def closed_loop(A: ArrayLike, K: ArrayLike, C: ArrayLike) -> FloatArray:
    """A - K C for stacks of systems: A (N, 2, 2), K (N, 2, m), C (N, m, 2) or (m, 2)."""
    a = np.asarray(A, dtype=float).reshape(-1, 2, 2)
    k = np.asarray(K, dtype=float)
    k = k.reshape(a.shape[0], 2, -1)
    c = np.asarray(C, dtype=float)
    c = np.broadcast_to(c, (a.shape[0], *c.shape[-2:]))
    return a - k @ c


def double_pole_step(M: ArrayLike, p: float | ArrayLike, dt: float | ArrayLike
                     ) -> tuple[FloatArray, FloatArray]:
    """Exact (Phi, Gamma) of x' = M x + w over ``dt`` with w held, for M with double pole ``p``.

    Returns Phi = exp(M dt) and Gamma = int_0^dt exp(M s) ds, each (N, 2, 2).  Valid for any
    p <= 0 (p = 0 gives the pure integrator).  Exact only when M really has the double
    eigenvalue p, as the gains of this module make it.
    """
    m = np.asarray(M, dtype=float).reshape(-1, 2, 2)
    n = m.shape[0]
    pole = np.broadcast_to(np.asarray(p, dtype=float), (n,))
    h = np.broadcast_to(np.asarray(dt, dtype=float), (n,))
    z = pole * h
    ez = np.exp(z)
    small = np.abs(z) < 1e-4
    zs = np.where(small, 1.0, z)
    # phi1 = (e^z - 1)/z * h, phi2 = (e^z (z - 1) + 1)/z^2 * h^2 (series near z = 0)
    f1 = np.where(small, 1.0 + z / 2.0 + z**2 / 6.0, np.expm1(zs) / zs)
    f2 = np.where(small, 0.5 + z / 3.0 + z**2 / 8.0, (ez * (zs - 1.0) + 1.0) / zs**2)
    eye = np.eye(2)
    N_ = m - pole[:, None, None] * eye
    Phi = ez[:, None, None] * (eye + N_ * h[:, None, None])
    Gam = (f1 * h)[:, None, None] * eye + (f2 * h**2)[:, None, None] * N_
    return Phi, Gam
