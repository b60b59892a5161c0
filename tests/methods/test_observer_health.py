"""Health of the methods without a covariance (observer_health) and its gap term."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.methods.observer_health import blocked_consistency, stale_health
from sideslip.methods.registry import run_method
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive
from tests.methods.robust_drives import with_sensor_gaps

MINE = ("obs_bicycle", "obs_kinematic", "obs_modified", "obs_modified_nocomp", "roll_index",
        "roll_dfc", "kinematic_integration", "doppler_slip", "doppler_slip_noroll")


def test_stale_health_rises_over_a_gap_and_ignores_the_normal_rate() -> None:
    t = np.arange(0.0, 10.0, 0.01)
    fresh = (np.arange(t.size) % 2 == 0) & ~((t > 3.0) & (t < 6.0))  # 50 Hz, 3 s hole
    h = stale_health(t, fresh)
    assert np.all(h[t < 3.0] == 0.0)  # every other row fresh: the normal rate, no gap
    # 0.5 s into the hole, past the 0.1 s normal-gap allowance: 0.5 x (0.5 - 0.1) / 1 s
    assert h[np.searchsorted(t, 3.5)] == pytest.approx(0.5 * (0.5 - 0.1), abs=0.01)
    assert np.all(h[(t > 4.2) & (t < 6.0)] == 0.5)
    assert np.all(h[t > 6.1] == 0.0)


def test_blocked_consistency_flags_a_burst_of_large_residuals() -> None:
    # chi^2(1) NIS everywhere, ten times larger for 3 s: the burst (and only about it) flagged
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 60.0, 0.01)
    z = rng.standard_normal(t.size)
    z[(t > 30) & (t < 33)] *= np.sqrt(10.0)
    health, inflation, summary = blocked_consistency(t, z * z, np.ones(t.size), 2.0, False)
    burst = (t > 30.5) & (t < 32.5)
    quiet = (t < 25) | (t > 38)
    assert np.all(health[burst] > 0) and np.mean(inflation[burst]) > 5.0
    assert np.mean(health[quiet] > 0) < 0.02
    assert 0.0 < summary["flagged_share"] < 0.15


def test_every_method_flags_held_sensor_samples_and_stays_finite() -> None:
    # three 1.5 s holes in the IMU and wheel speeds and a 20 s GNSS outage (robust_drives):
    # outputs finite, health in [0, 1], and at least 0.5 once a hole has lasted 1.2 s
    drive = with_sensor_gaps(sim_drive("demo"))
    vehicle = load_vehicle("midsize_sedan")
    imu = np.isfinite(drive["wz"])
    last = np.maximum.accumulate(np.where(imu, np.arange(imu.size), 0))
    deep = (~imu) & (drive.t - drive.t[last] > 1.2) & (drive["ref_vx"] > 6.0)
    assert deep.sum() > 20
    for m in MINE:
        est = run_method(m, drive, vehicle)
        h = est["health"]
        assert np.all(np.isfinite(h)) and h.min() >= 0.0 and h.max() <= 1.0, m
        assert np.all(h[deep] >= 0.5 - 1e-9), m
        assert "health" in est.params, m


# numpy forms of the compiled passes, as they were written before compiling them
def _stale_reference(t: np.ndarray, fresh: np.ndarray, full_s: float = 1.0,
                     level: float = 0.5) -> np.ndarray:
    rows = np.flatnonzero(fresh)
    if rows.size == 0:
        return np.full(t.size, level)
    last = np.full(t.size, -1, dtype=np.intp)
    last[rows] = rows
    np.maximum.accumulate(last, out=last)
    since = np.where(last >= 0, t - t[np.maximum(last, 0)], t - t[0] + full_s)
    normal = max(2.0 * float(np.median(np.diff(t[rows]))) if rows.size > 1 else 0.0, 0.1)
    return np.asarray(level * np.clip((since - normal) / full_s, 0.0, 1.0))


def _block_reference(t: np.ndarray, nis: np.ndarray, dof: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    block = np.floor((t - t[0]) / 0.25).astype(np.intp)
    uniq, inv = np.unique(block, return_inverse=True)
    ok = np.isfinite(nis) & (dof > 0)
    sum_nis = np.bincount(inv, weights=np.where(ok, nis, 0.0), minlength=uniq.size)
    sum_dof = np.bincount(inv, weights=np.where(ok, dof, 0.0), minlength=uniq.size)
    t_block = np.bincount(inv, weights=t, minlength=uniq.size) / np.bincount(inv)
    return inv, sum_nis, sum_dof, t_block


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compiled_stale_health_equals_its_numpy_form(seed: int) -> None:
    # jittered 100 Hz stamps, random dropouts and two long holes, a first fresh row late
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.009, 0.011, 5000))
    fresh = rng.random(t.size) > 0.3
    fresh[:37] = False
    fresh[1000:1400] = False
    fresh[3000:3090] = False
    for full_s, level in ((1.0, 0.5), (3.0, 0.5), (0.5, 1.0)):
        np.testing.assert_array_equal(stale_health(t, fresh, full_s, level),
                                      _stale_reference(t, fresh, full_s, level))
    one = np.zeros(t.size, dtype=bool)
    one[10] = True  # a single fresh row: the 0.1 s allowance
    np.testing.assert_array_equal(stale_health(t, one), _stale_reference(t, one))
    assert np.all(stale_health(t, np.zeros(t.size, dtype=bool)) == 0.5)


def test_compiled_block_sums_equal_the_sorted_bincount() -> None:
    from sideslip.methods.observer_health import _block_sums_nb

    rng = np.random.default_rng(3)
    t = 100.0 + np.cumsum(rng.uniform(0.005, 0.03, 4000))
    nis = rng.chisquare(2, t.size)
    nis[rng.random(t.size) < 0.2] = np.nan
    dof = rng.integers(0, 3, t.size).astype(float)
    inv, s_nis, s_dof, t_b, ordered = _block_sums_nb(t, nis, dof, 0.25)
    assert ordered
    for got, ref in zip((inv, s_nis, s_dof, t_b), _block_reference(t, nis, dof), strict=True):
        np.testing.assert_array_equal(got, ref)
    # unsorted stamps: reported, and blocked_consistency falls back to sorting the blocks
    t_shuffled = t.copy()
    t_shuffled[[10, 2000]] = t_shuffled[[2000, 10]]
    assert not _block_sums_nb(t_shuffled, nis, dof, 0.25)[-1]
    health, _, _ = blocked_consistency(t_shuffled, nis, dof, 2.0, True)
    assert health.shape == t.shape and np.all(np.isfinite(health))
