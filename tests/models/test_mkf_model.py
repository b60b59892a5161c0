"""The MKF model of seed 001: Table I from the discrete Riccati equation."""

from __future__ import annotations

import math

import pytest

from sideslip.models.mkf_model import table_one
from sideslip.vehicle import load_vehicle

BLAZER = load_vehicle("blazer_suv")


# ------------------------------------------------------------------------------------------
# Table I and the filter's consistency with its own Riccati prediction (item 5)
# ------------------------------------------------------------------------------------------
def test_table_one_rows_and_noise_scaling() -> None:
    rows = table_one(BLAZER)
    assert [r["rate_hz"] for r in rows] == [5.0, 20.0, 50.0, 100.0]
    for r in rows:
        f = math.sqrt(r["rate_hz"] / 100.0)
        assert r["sigma_gyro_deg_s"] == pytest.approx(0.3 * f)
        assert r["sigma_course_deg"] == pytest.approx(0.0382 * f)
        # a filter does better than its gyro: estimated r more certain than the measured one
        assert 0 < r["sigma_r_deg_s"] < r["sigma_gyro_deg_s"] * 1.3
        assert 0 < r["sigma_beta_deg"] < 0.5
