"""The suspension roll gradient identified from the drive (roll_gradient, used by roll_index)."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.methods.registry import run_method
from sideslip.methods.roll_gradient import identify_roll_gradient
from sideslip.simulate import simulate
from sideslip.vehicle import G, load_vehicle


def _rmse_deg(x: np.ndarray) -> float:
    return float(np.degrees(np.sqrt(np.mean(x**2))))


@pytest.fixture(scope="module")
def soft_step_steer():
    # the case: a soft car (roll stiffness 40 % of the preset's, roll gradient 2.5x)
    # on a flat road, estimated with the preset's (stiff) vehicle file
    preset = load_vehicle("seed003_sedan")
    soft = preset.with_changes(roll_stiffness=0.4 * preset.roll_stiffness)
    return simulate("step_steer", seed=0, vehicle=soft), preset, soft


def test_soft_car_on_a_flat_road_gradient_identified_and_roll_fixed(soft_step_steer) -> None:
    drive, preset, soft = soft_step_steer
    est = run_method("roll_index", drive, preset)
    p = est.params
    assert p["roll_gradient_source"] == "identified"
    # truth m h / k of the simulated car; 15 %: wheel-speed/gyro scale errors (0.5 % here)
    # and the steady-state relation's v_y' residue bias phi_ss by a few percent
    assert p["roll_gradient_rad_per_m_s2"] == pytest.approx(soft.static_roll_gain, rel=0.15)
    # its 1-sigma holds the truth (3 sigma: one run)
    assert abs(p["roll_gradient_rad_per_m_s2"] - soft.static_roll_gain) < 3 * p[
        "roll_gradient_rad_per_m_s2_sigma"]
    assert p["roll_gradient_rows"] > 100
    mv = drive["ref_vx"] > 5.0
    fixed = _rmse_deg((est["roll"] - drive["ref_roll"])[mv])
    off = run_method("roll_index", drive, preset, {"identify_roll_gradient": False})
    assert off.params["roll_gradient_source"] == "vehicle file"
    stale = _rmse_deg((off["roll"] - drive["ref_roll"])[mv])
    assert fixed < 0.5 < stale  # measured 0.28 vs 1.12 deg


def test_right_file_is_kept_when_the_drive_agrees() -> None:
    drive = simulate("step_steer", seed=0)
    est = run_method("roll_index", drive, load_vehicle("seed003_sedan"))
    assert est.params["roll_gradient_source"] == "vehicle file"
    assert "consistent with the drive" in est.params["roll_gradient_note"]


def test_analytic_flat_road_gradient_and_bank_at_the_ends() -> None:
    # phi_ss = bank + G a_y exactly, with a different bank in each of five curves (constant
    # through the curve, as at its straight ends): the slope is G, whatever the banks
    t = np.arange(0.0, 150.0, 0.01)
    ay = np.zeros_like(t)
    bank = np.zeros_like(t)
    for c, (start, level, b) in enumerate(((10, 3.0, 0.01), (40, -2.5, -0.02), (70, 4.0, 0.0),
                                           (100, -3.5, 0.015), (125, 2.0, -0.01))):  # fmt: skip
        on = (t >= start) & (t < start + 12)
        ay[on] = level * (1 + 0.1 * c)
        near = (t >= start - 5) & (t < start + 17)
        bank[near] = b
    g_true = 0.012
    phi = bank + g_true * ay
    res = identify_roll_gradient(t, ay, phi, np.ones(t.size, bool), np.ones(t.size, bool))
    assert res.applied and res.curves == 5
    assert res.value == pytest.approx(g_true, rel=1e-6)
    # the sensor-scale term bounds the 1-sigma from below (no false certainty)
    assert res.sigma >= np.hypot(0.01, 0.01) / G


def test_no_curves_keep_the_file_value_and_say_why() -> None:
    t = np.arange(0.0, 30.0, 0.01)
    z = np.zeros_like(t)
    res = identify_roll_gradient(t, z, z, np.ones(t.size, bool), np.ones(t.size, bool))
    assert not res.applied and "file value used" in res.note
    assert res.params(0.008)["roll_gradient_rad_per_m_s2"] == 0.008
