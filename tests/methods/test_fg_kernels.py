"""The compiled per-row passes of the seed-002 graph against their plain numpy formulation."""

from __future__ import annotations

import numpy as np

from sideslip.methods.fg_kernels import chain_factors, one_sigma
from sideslip.models.single_track import continuous_arrays
from sideslip.vehicle import load_vehicle

VEHICLE = load_vehicle("ferrari_250lm")


def test_chain_factors_equal_the_numpy_formulation():
    rng = np.random.default_rng(2)
    n = 3000
    t = np.cumsum(rng.uniform(0.008, 0.012, n))
    t[1500:] += 1.0  # a time gap
    gap = np.diff(t) > 0.25
    speed = np.abs(20.0 * np.sin(np.linspace(0, 6, n))) + 0.5
    low = speed < 3.0
    delta = 0.05 * rng.normal(size=n)
    wz, ay = rng.normal(size=n), rng.normal(size=n)
    wz[100:200] = np.nan
    ay[300:350] = np.nan
    sig = np.array([1e-3, 1e-2, 1e-2, 0.5])
    # dynamics at a faster clamp than the a_y factor on the low-speed rows (as the graph does)
    v_dyn = np.maximum(speed, 5.0)
    A, B, _, _ = continuous_arrays(VEHICLE, v_dyn, v_min=3.0)
    _, _, C, D = continuous_arrays(VEHICLE, speed, v_min=3.0)
    model = np.array([VEHICLE.mass, VEHICLE.yaw_inertia, VEHICLE.lf, VEHICLE.lr, VEHICLE.cf,
                      VEHICLE.cr, 3.0])  # fmt: skip
    F, g, sq, Hu, zu, su = chain_factors(t, v_dyn, speed, model, delta, low, gap, wz, ay, sig,
                                         0.01, 10.0, 0.05, 0.05, 0.02)  # fmt: skip
    # numpy: the same factors as whole-array operations
    dt = np.diff(t)
    F_ref = np.eye(2)[None] + dt[:, None, None] * A[:-1]
    g_ref = dt[:, None] * B[:-1, :, 0] * delta[:-1, None]
    sq_ref = np.sqrt(dt / 0.01)[:, None] * sig[:2]
    sq_ref[low[:-1]] *= 10.0
    F_ref[gap], g_ref[gap], sq_ref[gap] = 0.0, 0.0, (0.05, 0.05)
    np.testing.assert_array_equal(F, F_ref)
    np.testing.assert_array_equal(g, g_ref)
    np.testing.assert_array_equal(sq, sq_ref)
    ok_wz, ok_ay = np.isfinite(wz), np.isfinite(ay) & ~low
    np.testing.assert_array_equal(Hu[:, 1], C[:, 1])
    np.testing.assert_array_equal(Hu[:, 0], np.tile([0.0, 1.0], (n, 1)))
    np.testing.assert_array_equal(zu[:, 0], np.where(ok_wz, wz, 0.0))
    np.testing.assert_array_equal(zu[:, 1], np.where(ok_ay, ay - D[:, 1, 0] * delta, 0.0))
    np.testing.assert_array_equal(su[:, 0], np.where(ok_wz, 1e-2, np.inf))
    np.testing.assert_array_equal(su[:, 1], np.where(ok_ay, 0.5, np.inf))
    np.testing.assert_array_equal(su[:, 2], np.where(low, 0.02, np.inf))
    assert gap.sum() == 1 and low.any() and ok_ay.sum() < n - 50


def test_one_sigma_is_the_inflated_variance_plus_the_stiffness_limit_and_offset_terms():
    rng = np.random.default_rng(4)
    n = 1000
    x = 0.02 * rng.normal(size=(n, 2))
    var = rng.uniform(-1e-9, 1e-4, size=(n, 2))  # tiny negative round-off is clipped
    inflation = rng.uniform(1.0, 3.0, n)
    health = rng.uniform(0.0, 1.0, n)
    delta, v = 0.03 * rng.normal(size=n), rng.uniform(3.0, 40.0, n)
    beta_std, r_std = one_sigma(
        x, var, inflation, delta, v, VEHICLE.lf, VEHICLE.lr, 0.3, health, 0.5, 0.002
    )
    alpha_f = delta - x[:, 0] - VEHICLE.lf * x[:, 1] / v
    alpha_r = VEHICLE.lr * x[:, 1] / v - x[:, 0]
    slip = np.maximum(abs(alpha_f), abs(alpha_r))
    rel2 = 0.3**2 + (0.5 * health) ** 2  # hypot(stiffness, health x limit) on the slip angle
    vb = np.maximum(var[:, 0], 0.0) * inflation + rel2 * slip**2 + 0.002**2
    np.testing.assert_allclose(beta_std, np.sqrt(vb), rtol=1e-13)
    np.testing.assert_allclose(r_std, np.sqrt(np.maximum(var[:, 1], 0.0) * inflation), rtol=1e-14)
    # no health given: the limit term is off whatever its setting
    b1, _ = one_sigma(x, var, inflation, delta, v, VEHICLE.lf, VEHICLE.lr, 0.3, np.zeros(0), 0.5, 0.0)
    np.testing.assert_allclose(
        b1, np.sqrt(np.maximum(var[:, 0], 0.0) * inflation + (0.3 * slip) ** 2), rtol=1e-13
    )
    # no inflation, no stiffness, limit or offset term: the plain 1-sigma
    b0, r0 = one_sigma(x, var, np.ones(0), delta, v, VEHICLE.lf, VEHICLE.lr, 0.0, health, 0.0, 0.0)
    np.testing.assert_array_equal(b0, np.sqrt(np.maximum(var[:, 0], 0.0)))
    np.testing.assert_array_equal(r0, np.sqrt(np.maximum(var[:, 1], 0.0)))
