"""The brush (Fiala) axle-force model against its closed-form properties."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sideslip.models.axle_force import (
    axle_lateral_force,
    dugoff_force,
    fiala_force,
    lateral_force,
    magic_force,
    sliding_slip_angle,
)

C, F = 60.0, 5.0  # m/s^2 per unit tan(alpha), m/s^2: a rear axle of a mid-size car on dry road


def test_linear_at_small_slip_and_saturated_beyond_sliding():
    """Pacejka 2012 eq 3.14: slope C at zero slip; F_y = mu F_z from alpha_sl = atan(3F/C) on,
    with both signs (odd function)."""
    z = 1e-5
    assert fiala_force(z, C, F)[0] == pytest.approx(C * z, rel=1e-4)
    a_sl = sliding_slip_angle(C, F)
    for alpha in (a_sl, 1.2 * a_sl, 0.5):
        assert fiala_force(math.tan(alpha), C, F)[0] == pytest.approx(F)
        assert fiala_force(-math.tan(alpha), C, F)[0] == pytest.approx(-F)
    assert lateral_force(np.array([-0.3, 0.3]), C, F) == pytest.approx([-F, F])


def test_slope_is_c_times_one_minus_utilisation_squared():
    """dF/dz = C (1 - |z| / z_sl)^2 (module docstring), checked at half the sliding slip."""
    z_sl = 3 * F / C
    assert fiala_force(0.5 * z_sl, C, F)[1] == pytest.approx(C * 0.25)


@pytest.mark.parametrize("z", [-0.3, -0.2, -0.05, 0.01, 0.1, 0.2, 0.24])
def test_derivatives_match_central_differences(z):
    """The three analytic partials against central differences (step 1e-6; the curve is C^1,
    so the error is O(step^2) relative, well inside 1e-6)."""
    _, dz, dc, df = fiala_force(z, C, F)
    h = 1e-6
    assert dz == pytest.approx(
        (fiala_force(z + h, C, F)[0] - fiala_force(z - h, C, F)[0]) / (2 * h), rel=1e-5, abs=1e-6
    )
    assert dc == pytest.approx(
        (fiala_force(z, C + h, F)[0] - fiala_force(z, C - h, F)[0]) / (2 * h), rel=1e-5, abs=1e-6
    )
    assert df == pytest.approx(
        (fiala_force(z, C, F + h)[0] - fiala_force(z, C, F - h)[0]) / (2 * h), rel=1e-5, abs=1e-6
    )


def test_magic_curve_is_linear_at_zero_holds_its_peak_and_has_exact_derivatives() -> None:
    """Simplified Magic Formula (S = 1.3): slope C at zero slip, the force limit F held from
    the peak on (never falling: one slip per force), more linear than the brush curve at
    moderate use (secant at a quarter of the brush's sliding slip: 0.98 against 0.92), and
    the analytic derivatives equal central differences."""
    s = 1.3
    assert magic_force(1e-6, C, F, s)[0] == pytest.approx(C * 1e-6, rel=1e-6)
    z_peak = math.tan(0.5 * math.pi / s) * s * F / C
    for z in (z_peak * 1.0001, 2 * z_peak, 10 * z_peak):
        assert magic_force(z, C, F, s)[0] == pytest.approx(F)
        assert magic_force(-z, C, F, s)[0] == pytest.approx(-F)
    z = 0.25 * 3 * F / C
    assert magic_force(z, C, F, s)[0] / (C * z) > fiala_force(z, C, F)[0] / (C * z) + 0.04
    h = 1e-7
    for z in (-0.3 * z_peak, 0.1 * z_peak, 0.7 * z_peak):
        _, dz, dc, df = magic_force(z, C, F, s)
        assert dz == pytest.approx((magic_force(z + h, C, F, s)[0] - magic_force(z - h, C, F, s)[0]) / (2 * h), rel=1e-5)
        assert dc == pytest.approx((magic_force(z, C + h, F, s)[0] - magic_force(z, C - h, F, s)[0]) / (2 * h), rel=1e-5)
        assert df == pytest.approx((magic_force(z, C, F + h, s)[0] - magic_force(z, C, F - h, s)[0]) / (2 * h), rel=1e-5)


def test_dugoff_curve_is_linear_to_half_the_limit_then_approaches_it() -> None:
    """Dugoff 1970: F = C z up to |z| = F / (2 C) (exactly linear there, where the brush
    curve's secant is already 1 - u + u^2 / 3 = 0.84 at u = 1/6 of its sliding slip),
    F - F^2 / (4 C |z|) beyond (at 10x the knee: 0.95 F), odd, C1 at the knee, and the
    analytic derivatives equal central differences on both branches."""
    knee = F / (2 * C)
    for z in (1e-6, 0.5 * knee, knee):
        assert dugoff_force(z, C, F)[0] == pytest.approx(C * z, rel=1e-12)
        assert dugoff_force(-z, C, F)[0] == pytest.approx(-C * z, rel=1e-12)
    assert fiala_force(knee, C, F)[0] < 0.85 * C * knee  # brush: already curved at the knee
    assert dugoff_force(10 * knee, C, F)[0] == pytest.approx(0.95 * F)
    h = 1e-7
    assert dugoff_force(knee + h, C, F)[1] == pytest.approx(C, rel=1e-5)  # slope continuous
    for z in (-3 * knee, -0.4 * knee, 0.7 * knee, 1.5 * knee, 8 * knee):
        _, dz, dc, df = dugoff_force(z, C, F)
        assert dz == pytest.approx((dugoff_force(z + h, C, F)[0] - dugoff_force(z - h, C, F)[0]) / (2 * h), rel=1e-5)
        assert dc == pytest.approx((dugoff_force(z, C + h, F)[0] - dugoff_force(z, C - h, F)[0]) / (2 * h), rel=1e-5, abs=1e-9)
        assert df == pytest.approx((dugoff_force(z, C, F + h)[0] - dugoff_force(z, C, F - h)[0]) / (2 * h), rel=1e-5, abs=1e-9)


def test_axle_curve_dispatches_on_the_shape() -> None:
    z = 0.4 * F / C
    assert axle_lateral_force(z, C, F, 0.0) == fiala_force(z, C, F)
    assert axle_lateral_force(z, C, F, 1.3) == magic_force(z, C, F, 1.3)
    assert axle_lateral_force(3 * z, C, F, -1.0) == dugoff_force(3 * z, C, F)
