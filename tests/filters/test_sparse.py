"""The sparse / robust Kalman kernels against plain-numpy references."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.filters.kalman import update_joseph
from sideslip.filters.sparse import (
    pack_upper,
    predict_sparse,
    robust_pair,
    robust_scalar,
    rts_step,
    unpack_upper,
    update_scalar_sym,
)
from sideslip.models.fused_process import NX_CORE, f_rows, process


def _spd(n: int, rng: np.random.Generator) -> np.ndarray:
    a = rng.normal(size=(n, n))
    return a @ a.T / n + np.eye(n) * 0.1


def _transition(rng: np.random.Generator) -> np.ndarray:
    x = rng.normal(0, 0.1, NX_CORE)
    x[3] = 15.0
    return process(x, np.array([0.1, 0.0, 0.0, 0.2, 2.0, 2.0]), 0.05, 0.01, 60.0)[1]


def test_sparse_prediction_equals_dense():
    rng = np.random.default_rng(0)
    P, F, q = _spd(NX_CORE, rng), _transition(rng), rng.uniform(0, 1e-3, NX_CORE)
    Pn, tmp = np.zeros_like(P), np.zeros_like(P)
    predict_sparse(P, F, f_rows(NX_CORE), q, Pn, tmp)
    np.testing.assert_allclose(Pn, F @ P @ F.T + np.diag(q), rtol=1e-12, atol=1e-12)


def test_symmetric_scalar_update_equals_joseph_form():
    rng = np.random.default_rng(1)
    P, x = _spd(NX_CORE, rng), rng.normal(size=NX_CORE)
    h = rng.normal(size=NX_CORE)
    z, r = 0.7, 0.04
    x_ref, P_ref, _, S_ref = update_joseph(x, P, [z], h[None, :], [[r]])
    x2, P2 = x.copy(), P.copy()
    s = update_scalar_sym(x2, P2, z - h @ x, h, r, np.zeros(NX_CORE))
    assert s == pytest.approx(S_ref[0, 0])
    np.testing.assert_allclose(x2, x_ref, rtol=1e-10)
    np.testing.assert_allclose(P2, P_ref, rtol=1e-9, atol=1e-12)


def test_robust_updates_down_weight_outliers_only():
    """Inside the gate the Huber-type update is the plain update; a 10-sigma outlier moves the
    state by gate / d2 of the plain update's step (variance times d2 / gate)."""
    rng = np.random.default_rng(2)
    P, x = _spd(NX_CORE, rng), np.zeros(NX_CORE)
    h = np.zeros(NX_CORE)
    h[3] = 1.0
    r = 0.01
    s = P[3, 3] + r
    for sigmas, expect_ok in ((1.0, True), (10.0, False)):
        innov = sigmas * np.sqrt(s)
        x1, P1 = x.copy(), P.copy()
        d2, ok = robust_scalar(x1, P1, innov, h, r, 16.0, np.zeros(NX_CORE))
        assert d2 == pytest.approx(sigmas**2)
        assert ok is expect_ok
        r_eff = r if ok else r * d2 / 16.0
        assert x1[3] == pytest.approx(P[3, 3] / (P[3, 3] + r_eff) * innov)
    H = np.zeros((2, NX_CORE))
    H[0, 0] = H[1, 1] = 1.0
    x1, P1 = x.copy(), P.copy()
    d2, ok = robust_pair(x1, P1, H, 0.1, -0.1, r, 16.0, *(np.zeros(NX_CORE) for _ in range(3)))
    S = H @ P @ H.T + r * np.eye(2)
    assert d2 == pytest.approx(np.array([0.1, -0.1]) @ np.linalg.solve(S, [0.1, -0.1]))
    x_ref, _, _, _ = update_joseph(x, P, [0.1, -0.1], H, r * np.eye(2))
    np.testing.assert_allclose(x1, x_ref, atol=1e-12)


def test_packed_float32_storage_round_trips_to_single_precision():
    rng = np.random.default_rng(3)
    P = _spd(NX_CORE, rng)
    packed = np.zeros(NX_CORE * (NX_CORE + 1) // 2, dtype=np.float32)
    pack_upper(P, packed)
    out = np.zeros_like(P)
    unpack_upper(packed, out)
    np.testing.assert_allclose(out, P, rtol=1e-6)
    np.testing.assert_array_equal(out, out.T)


def test_rts_step_equals_the_textbook_smoother():
    """Simon 2006 eq 9.99 written densely with numpy."""
    rng = np.random.default_rng(4)
    P, F = _spd(NX_CORE, rng), _transition(rng)
    x = rng.normal(size=NX_CORE)
    Q = np.diag(rng.uniform(1e-4, 1e-3, NX_CORE))
    xn, Pn = F @ x, F @ P @ F.T + Q
    xs_next, Ps_next = xn + rng.normal(0, 0.1, NX_CORE), Pn * 0.5
    C = P @ F.T @ np.linalg.inv(Pn)
    x_ref = x + C @ (xs_next - xn)
    P_ref = P + C @ (Ps_next - Pn) @ C.T
    work = [np.zeros_like(P) for _ in range(4)]
    x2, P2 = x.copy(), P.copy()
    rts_step(x2, P2, xn, Pn, F, f_rows(NX_CORE), xs_next, Ps_next, *work)
    np.testing.assert_allclose(x2, x_ref, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(P2, P_ref, rtol=1e-7, atol=1e-10)
