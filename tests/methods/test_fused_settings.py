"""The fused estimator's settings and what they choose against the drive."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.methods.fused import _low_pass, _zero_phase_low_pass
from sideslip.methods.fused_settings import FusedSettings, accel_noise_sigma, force_time_constant


def test_force_low_pass_is_as_short_as_the_accelerometer_noise_allows():
    """The axle forces' low-pass: the floor for a clean accelerometer; for a noisy one (a real
    car's vibration: the Revs lap reads about 0.85 m/s^2 per sample) the time constant whose
    first-order low-pass leaves force_noise_sigma of the noise, checked by filtering white
    noise (analytic sigma sqrt(dt / (2 tau)); 2 % tolerance: 40 000 samples)."""
    rng = np.random.default_rng(3)
    t = np.arange(40_000) * 0.01
    nz = FusedSettings()
    clean = 0.05 * rng.standard_normal(t.size)
    assert accel_noise_sigma(clean) == pytest.approx(0.05, rel=0.03)
    assert force_time_constant(t, clean, 0.05, nz) == 0.05
    noisy = 3.0 * rng.standard_normal(t.size)
    tau = force_time_constant(t, noisy, 0.05, nz)
    assert tau == pytest.approx(0.01 * 9.0 / (2 * nz.force_noise_sigma**2), rel=0.05)
    assert np.std(_low_pass(t, noisy, tau)[100:]) == pytest.approx(nz.force_noise_sigma, rel=0.05)


def test_a_zero_phase_low_pass_needs_half_the_time_constant():
    """Run forwards and backwards (the smoother without GNSS) white noise passes the low-pass
    twice and keeps sigma sqrt(dt / (4 tau)): the time constant that leaves force_noise_sigma
    is half the single pass's (with the single pass's, the Revs lap sampled at 20 Hz had its
    forces smoothed over 0.2 s each way; beta RMSE 0.467 -> 0.407 deg).  Checked by filtering
    white noise (5 % tolerance: 40 000 samples, tau 25 rows; measured 0.301 against 0.3, and
    0.214 with the single pass's tau)."""
    rng = np.random.default_rng(4)
    t = np.arange(40_000) * 0.01
    nz = FusedSettings()
    noisy = 3.0 * rng.standard_normal(t.size)
    single = force_time_constant(t, noisy, 0.05, nz)
    both = force_time_constant(t, noisy, 0.05, nz, zero_phase=True)
    assert both == pytest.approx(single / 2.0)
    assert np.std(_zero_phase_low_pass(t, noisy, both)[100:-100]) == pytest.approx(nz.force_noise_sigma, rel=0.05)


def test_a_bad_setting_is_one_clear_error():
    """Every numeric field must be finite and > 0 (step_s, offset_level_share >= 0); the message
    names it."""
    with pytest.raises(ValueError, match=r"FusedSettings.force_noise_sigma = 0.0: expected a finite number > 0"):
        FusedSettings(force_noise_sigma=0.0)
    with pytest.raises(ValueError, match=r"axle_curve_shape = 0.5: expected 0 \(brush curve\), -1 \(Dugoff curve\) or a Magic"):
        FusedSettings(axle_curve_shape=0.5)
    with pytest.raises(ValueError, match=r"FusedSettings.wheel_slip_stiffness = nan: expected"):
        FusedSettings(wheel_slip_stiffness=float("nan"))
    with pytest.raises(ValueError, match=r"offset_level_share = -0.1: expected a finite number >= 0"):
        FusedSettings(offset_level_share=-0.1)
    with pytest.raises(ValueError, match=r"FusedSettings.offset_level_share = 1.5: expected <= 1"):
        FusedSettings(offset_level_share=1.5)
    assert FusedSettings(offset_level_share=0.0).offset_level_share == 0.0


def test_force_noise_variance_is_the_drives_own_accelerometer_noise():
    """A clean simulated MEMS accelerometer (0.05 m/s^2 per sample at 100 Hz, low-passed at
    0.05 s) adds 0.05^2 dt / (2 tau) = 6e-5 (m/s^2)^2 to the axle relations; vibration of 0.85
    m/s^2 per sample (the Revs lap's) adds 0.072 (tau / axle_error_tau_s = 1), the 0.15 floor
    doubled in sigma.  The causal form (running mean of squared differences up to each row)
    converges to the same value and at row k uses rows up to k only (5 % tolerances: 40 000
    samples; the running mean over the first 1 000 rows)."""
    from sideslip.methods.fused_settings import force_noise_variance

    rng = np.random.default_rng(5)
    t = np.arange(40_000) * 0.01
    nz = FusedSettings()
    clean = force_noise_variance(t, 0.05 * rng.standard_normal(t.size), 0.05, nz, causal=False)
    assert clean == pytest.approx(np.full(t.size, 0.05**2 * 0.1), rel=0.05)
    ay = 0.85 * rng.standard_normal(t.size)
    offline = force_noise_variance(t, ay, 0.05, nz, causal=False)
    assert offline[0] == pytest.approx(0.85**2 * 0.1, rel=0.05)
    causal = force_noise_variance(t, ay, 0.05, nz, causal=True)
    assert causal[-1] == pytest.approx(0.85**2 * 0.1, rel=0.05)
    early = force_noise_variance(t[:1000], ay[:1000], 0.05, nz, causal=True)
    np.testing.assert_allclose(causal[:1000], early, rtol=1e-12)


def test_a_slower_accelerometer_is_read_at_its_own_sample_spacing():
    """The same 20 Hz samples of 0.85 m/s^2 vibration, as a 20 Hz table and as every fifth row
    of a 100 Hz table (NaN between): the same noise density sigma^2 x 0.05 s, so the same low
    pass and the same force noise (offline and causal).  Read at the table's 0.01 s step the
    variance was a fifth of it."""
    from sideslip.methods.fused_settings import force_noise_variance, sample_step

    rng = np.random.default_rng(3)
    t = np.arange(20_000) * 0.01
    ay = np.full(t.size, np.nan)
    ay[::5] = 0.85 * rng.standard_normal(t[::5].size)
    nz = FusedSettings()
    assert sample_step(t, ay) == pytest.approx(0.05) and sample_step(t[::5], ay[::5]) == pytest.approx(0.05)
    assert force_time_constant(t, ay, 0.05, nz) == pytest.approx(force_time_constant(t[::5], ay[::5], 0.05, nz))
    for causal in (False, True):
        in_100 = force_noise_variance(t, ay, 0.05, nz, causal=causal)
        in_20 = force_noise_variance(t[::5], ay[::5], 0.05, nz, causal=causal)
        assert in_100[-1] == pytest.approx(in_20[-1], rel=1e-9)
