"""Seed 001 MKF: consistency with its own Riccati prediction, the paper's findings on the
simulator's nonlinear truth, robustness (standstill, outages, multipath, wrong vehicle file)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sideslip.drive import drive_from_columns
from sideslip.filters.kalman import steady_state
from sideslip.methods.kkf import kkf
from sideslip.methods.mkf import (
    MkfProblem,
    MkfSettings,
    mkf,
    residual_diagnostics,
    run_mkf,
    run_mkf_problem,
)
from sideslip.methods.registry import SPEED, all_methods, run_method
from sideslip.models.mkf_model import table_one_model
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive
from tests.methods.seed001_drives import (
    BLAZER,
    awkward_drive,
    beta_err_deg,
    linear_drive,
    raw_gyro_demo,
    rms,
    turns,
    yaw_err_deg,
)


@pytest.mark.parametrize("rate_hz", [5.0, 20.0])
def test_mkf_empirical_error_matches_riccati_prediction(rate_hz: float) -> None:
    """The filter's own linear model, simulated with its own noise: the empirical error must
    match the steady-state P from the DARE (a consistency check, the one place where testing
    on the filter's own model is right)."""
    m = table_one_model(BLAZER, rate_hz)
    ss = steady_state(m.F, m.H, m.Q, m.R)
    rng = np.random.default_rng(3)
    n = 12000
    t = np.arange(n) / rate_hz
    u = np.zeros((n, 2))
    u[:, 0] = 0.02 * np.sin(0.3 * t)
    Lq = np.linalg.cholesky(m.Q + 1e-18 * np.eye(4))
    x = np.zeros(4)
    X = np.empty((n, 4))
    for k in range(n):
        if k > 0:
            x = m.F @ x + m.G @ u[k - 1] + Lq @ rng.normal(size=4)
        X[k] = x
    gyro = X[:, 1] + X[:, 3] + rng.normal(size=n) * math.sqrt(m.R[0, 0])
    course = X[:, 0] + X[:, 2] + rng.normal(size=n) * math.sqrt(m.R[1, 1])
    prob = MkfProblem(
        Ad=m.F[None].copy(), Bd=m.G[None].copy(), Qd=m.Q[None].copy(),
        idx=np.zeros(n, dtype=np.intp), u=u, gyro=gyro, gyro_var=np.full(n, m.R[0, 0]),
        course=np.angle(np.exp(1j * course)), course_var=np.full(n, m.R[1, 1]),
        hr=np.zeros(n), zero_rate=np.zeros(n, dtype=bool), x0=np.zeros(4),
        P0=ss.P_prior.copy(), low=np.zeros(n, dtype=bool),
    )  # fmt: skip
    res = run_mkf_problem(prob)
    err = res.x - X
    err[:, 2] = np.angle(np.exp(1j * err[:, 2]))
    burn = 200
    # 12000 samples, error correlation time of a few samples: the RMS is known to ~2-3 %
    # (1-sigma); 10 % is > 3 sigma.  Also the filter's own P must have converged to the DARE.
    for i in (0, 1):
        emp = rms(err[burn:, i])
        pred = math.sqrt(ss.P_post[i, i])
        assert emp == pytest.approx(pred, rel=0.10), (i, emp, pred)
        assert res.var[-1, i] == pytest.approx(ss.P_post[i, i], rel=1e-6)
    # normalised innovations: unit variance and white
    diag = residual_diagnostics(res)
    for ch in ("gyro", "course"):
        assert diag[ch]["nis_mean"] == pytest.approx(1.0, abs=0.06)  # sd ~ sqrt(2/12000)
        assert diag[ch]["frac_autocorr_outside_95"] <= 0.25


# ------------------------------------------------------------------------------------------
# analytic behaviour on the linear drive
# ------------------------------------------------------------------------------------------
def test_mkf_tracks_linear_model_drive_and_its_std_covers_the_error() -> None:
    d = linear_drive(gyro_scale=0.0)
    est = mkf(d, BLAZER)
    err = est["beta"] - d["ref_beta"]
    # the data come from the filter's model with small noise: error well under 0.1 deg
    assert rms(err[200:]) < math.radians(0.1)
    # consistency: the 1-sigma bounds the error most of the time
    assert np.mean(np.abs(err[200:]) < 3 * est["beta_std"][200:]) > 0.95
    assert abs(est["gyro_bias"][-1] - 0.005) < math.radians(0.05)


@pytest.mark.parametrize("name", ["kkf", "mkf", "mkf_adaptive"])
def test_finite_and_sensible_on_standstill_reverse_outage_and_gaps(name: str) -> None:
    d = awkward_drive()
    est = run_method(all_methods()[name], d, BLAZER)  # checks shape and finiteness
    beta = est["beta"]
    assert np.all(np.abs(beta) < math.radians(10))
    # standing still at the start: no sideslip
    assert np.all(np.abs(beta[d.t < 4.5]) < math.radians(0.5))
    assert np.all(est["beta_std"] > 0)


def test_multipath_course_outlier_is_rejected() -> None:
    d = linear_drive(gyro_scale=0.0)
    rows = np.flatnonzero(np.isfinite(d["gnss_ve"]))
    k = int(rows[np.searchsorted(d.t[rows], 30.0)])  # inside the turn
    cols = {name: np.array(d[name]) for name in d.columns()}
    ang = math.radians(15.0)  # a 15 deg multipath glitch of the Doppler velocity direction
    ve, vn = cols["gnss_ve"][k], cols["gnss_vn"][k]
    cols["gnss_ve"][k] = ve * math.cos(ang) - vn * math.sin(ang)
    cols["gnss_vn"][k] = ve * math.sin(ang) + vn * math.cos(ang)
    bad = drive_from_columns(cols, dict(d.meta))
    for f in (kkf, mkf):
        err = np.abs(f(bad, BLAZER)["beta"] - bad["ref_beta"])[k : k + 20]
        # without the gate the KKF beta would be off by the full 15 deg at that sample
        assert err.max() < math.radians(0.5), f.__name__


def test_mkf_std_grows_in_gnss_outage() -> None:
    d = awkward_drive()
    est = mkf(d, BLAZER)
    # (from 2.5 s into the outage: until the 2 s NIS window has passed, the inflation of the
    # turn before it widens yaw_std)
    before = est["yaw_std"][np.searchsorted(d.t, 32.5)]
    late = est["yaw_std"][np.searchsorted(d.t, 37.9)]
    # without course the heading integrates the gyro: its variance grows at least by the
    # drive's white gyro noise (0.003 rad/s per 100 Hz sample) integrated over the 5.4 s,
    # sigma^2 dt T; the bias uncertainty adds to that
    assert late**2 - before**2 >= 0.003**2 * 0.01 * 5.4
    assert np.all(np.diff(est["yaw_std"][(d.t > 32.5) & (d.t < 37.95)]) >= 0)


def test_registry_declares_what_the_methods_read() -> None:
    methods = all_methods()
    assert methods["kkf"].columns == ("wz", SPEED, ("gnss_ve", "gnss_e"))
    assert "steer" in methods["mkf"].columns
    assert set(methods["mkf_adaptive"].vehicle_params) == {
        "mass", "yaw_inertia", "lf", "lr", "cf", "cr"
    }  # fmt: skip


def test_mkf_without_vehicle_stiffness_is_a_clear_error() -> None:
    from sideslip.errors import InputError

    d = linear_drive()
    bad = BLAZER.with_changes(cf=math.nan)
    with pytest.raises(InputError, match="parameter 'cf' is needed by method 'mkf'"):
        run_method(all_methods()["mkf"], d, bad)


# ------------------------------------------------------------------------------------------
# peer: FilterPy's KalmanFilter on the same problem
# ------------------------------------------------------------------------------------------
@pytest.mark.filterpy
def test_filterpy_peer_gives_the_same_beta() -> None:
    pytest.importorskip("filterpy")
    from sideslip.peers import filterpy_kf

    d = awkward_drive()
    ours = mkf(d, BLAZER)["beta"]
    theirs = filterpy_kf.run(d, BLAZER)
    assert np.max(np.abs(ours - theirs)) < 1e-6


def test_mkf_with_right_parameters_is_immune_to_gyro_scale_factor() -> None:
    d = sim_drive("two_turns_gyro_sf", 0)
    # the paper's experiment: its published (fixed) noise
    err = beta_err_deg(mkf(d, BLAZER, MkfSettings(preset="paper"))["beta"], d)
    kkf_err = beta_err_deg(kkf(d, BLAZER)["beta"], d)
    # nonlinear truth vs linear model at 0.42 g, plus steering sensor offset/scale: a few
    # hundredths of a degree of bias, well under the KKF's scale-factor error
    for a, b in turns(d):
        assert np.abs(err[a:b]).max() < 0.4
        assert np.abs(err[a:b]).max() < 0.25 * np.abs(kkf_err[a:b]).max()
    assert rms(err) < 0.15
    # the process noise identified from the drive (default) does at least as well overall
    # (measured 0.047 against 0.072 deg) and stays well under the KKF in every turn
    auto = beta_err_deg(mkf(d, BLAZER)["beta"], d)
    assert rms(auto) <= rms(err)
    for a, b in turns(d):
        assert np.abs(auto[a:b]).max() < 0.25 * np.abs(kkf_err[a:b]).max()


def test_mkf_with_wrong_vehicle_is_biased_and_residuals_coloured() -> None:
    d = sim_drive("two_turns_gyro_sf", 0)
    # the same (paper) noise for both files, so that their residual statistics compare; the
    # default identifies its noise per file and so partly absorbs the mismatch into Q
    paper = MkfSettings(preset="paper")
    right = mkf(d, BLAZER, paper)
    wrong_vehicle = load_vehicle("seed003_sedan")  # "the parameters of a different vehicle"
    wrong = mkf(d, wrong_vehicle, paper)
    rmse_right = rms(beta_err_deg(right["beta"], d))
    rmse_wrong = rms(beta_err_deg(wrong["beta"], d))
    assert rmse_wrong > 3 * rmse_right
    # residual diagnostics tell the files apart: the gyro residual is far more coloured
    # (sum of squared autocorrelations over 20 lags) and its normalised variance larger
    g_right = right.params["residuals"]["gyro"]
    g_wrong = wrong.params["residuals"]["gyro"]
    assert g_wrong["colour"] > 10 * g_right["colour"]
    assert g_wrong["nis_mean"] > 2 * g_right["nis_mean"]
    assert not g_wrong["white"]
    assert right.params["residuals"]["verdict"] == "consistent"
    assert wrong.params["residuals"]["verdict"].startswith("model mismatch")
    # with identified noise the colour still tells the files apart
    auto_right, auto_wrong = mkf(d, BLAZER), mkf(d, wrong_vehicle)
    assert auto_right.params["residuals"]["verdict"] == "consistent"
    assert auto_wrong.params["residuals"]["verdict"].startswith("model mismatch")


def test_bank_unaware_mkf_is_biased_on_banked_turn() -> None:
    d = sim_drive("banked_track_turn", 0)
    turning = np.abs(d["ref_r"]) > 0.1
    bank = d["ref_bank"]
    assert abs(np.degrees(bank[turning]).mean()) > 7  # the paper's 8 deg track
    paper = MkfSettings(preset="paper")  # the paper's fixed noise
    unaware = beta_err_deg(mkf(d, BLAZER, paper)["beta"], d)[turning].mean()
    known = beta_err_deg(run_mkf(d, BLAZER, bank=bank, settings=paper)["beta"], d)[turning].mean()
    # gravity along the bank, m g sin(8 deg), read by the model as a steer error: the
    # steady-state bank gain of the single-track model puts ~0.5 deg into beta
    assert abs(unaware) > 0.25
    assert abs(known) < 0.3 * abs(unaware)
    # the identified (larger) sideslip noise lets the GNSS course pull beta off the flat-road
    # model: the bank bias shrinks (measured 0.11 deg)
    auto = beta_err_deg(mkf(d, BLAZER)["beta"], d)[turning].mean()
    assert abs(auto) < 0.5 * abs(unaware)


# ------------------------------------------------------------------------------------------
# settings, identified noise, honest uncertainty (issue 14)
# ------------------------------------------------------------------------------------------
def test_mkf_settings_reject_bad_values_with_the_field_named() -> None:
    with pytest.raises(ValueError, match=r"MkfSettings.beta_psd_rad2_per_s = -1.0: expected"):
        MkfSettings(beta_psd_rad2_per_s=-1.0)
    with pytest.raises(ValueError, match=r"MkfSettings.v_gate_m_s = 0.0: expected > 0.1 m/s"):
        MkfSettings(v_gate_m_s=0.0)
    from sideslip.errors import InputError

    with pytest.raises(InputError, match="'exact': expected one of 'auto', 'paper', 'typical'"):
        run_method("mkf", linear_drive(), BLAZER, {"preset": "exact"})


def test_mkf_auto_preset_identifies_the_gyro_noise_of_the_drive() -> None:
    d = sim_drive("urban_course", 0)
    est = run_method("mkf", d, load_vehicle(d.meta["vehicle"]))
    noise = est.params["noise"]
    # the simulator's gyro: 0.1 deg/s white per 100 Hz sample (SensorConfig.gyro_noise_std);
    # the robust second-difference estimate over ~10^4 samples is good to a few percent, the
    # yaw-rate signal's own curvature adds < 3 %
    assert noise["gyro_sigma_source"].startswith("drive")
    assert math.degrees(noise["gyro_sigma_100hz_rad_s"]) == pytest.approx(0.1, rel=0.08)
    assert est.params["settings"]["preset"] == "auto"
    typical = run_method("mkf", d, load_vehicle(d.meta["vehicle"]), {"preset": "typical"})
    assert typical.params["noise"]["gyro_sigma_100hz_rad_s"] == pytest.approx(math.radians(0.3))


def test_mkf_innovations_and_nis_are_on_the_estimate() -> None:
    d = linear_drive()
    est = mkf(d, BLAZER)
    gnss_rows = np.isfinite(d["gnss_ve"])
    assert np.isfinite(est.innovations["course_nis"][gnss_rows][10:]).all()
    assert np.isnan(est.innovations["course_nis"][~gnss_rows]).all()
    # the data come from the filter's own linear model: no window is inconsistent (the
    # typical process noise is conservative here, mean gyro NIS below 1)
    assert np.nanmean(est.innovations["gyro_nis"][500:]) < 1.0
    assert not est.series["health"].any()
    assert est.params["health"]["flagged_share"] == 0.0


@pytest.mark.parametrize(("scenario", "factor"), [("cr_slalom", 0.7), ("cr_step_steer", 1.0),
                                                  ("dlc_bank", 1.0)])  # fmt: skip
def test_mkf_beta_std_covers_the_error_on_drives_it_was_not_tuned_on(scenario: str, factor: float) -> None:
    """CommonRoad's multi-body model (another vehicle model), a file 30 % off in cornering
    stiffness, a banked road: the share of beta errors inside 2 beta_std is >= 0.90 (0.95 for
    a calibrated Gaussian; before issue 14: 0.18, 0.23 and 0.32)."""
    d = sim_drive(scenario, 0)
    veh = load_vehicle(d.meta["vehicle"])
    veh = veh.with_changes(cf=factor * veh.cf, cr=factor * veh.cr)
    est = run_method("mkf", d, veh)
    fast = d["ref_vx"] > 5.0
    err = np.abs(est["beta"] - d["ref_beta"])[fast]
    assert np.mean(err < 2 * est["beta_std"][fast]) >= 0.90
    # and the band stays informative: its median below 0.5 deg on these 0.1-0.4 deg errors
    assert math.degrees(np.median(est["beta_std"][fast])) < 0.5


def test_mkf_health_flags_and_inflates_where_the_model_stops_fitting() -> None:
    """A steering signal three times too large (a wrong steering ratio in the file's
    conversion): in the turn the model's yaw rate disagrees with the gyro far beyond the
    innovation bound; those rows get health > 0 and a wider beta_std, the straights not."""
    d = linear_drive()
    cols = {name: np.array(d[name]) for name in d.columns()}
    cols["steer"] = 3.0 * cols["steer"]
    bad = drive_from_columns(cols, dict(d.meta))
    good, wrong = mkf(d, BLAZER), mkf(bad, BLAZER)
    turning = np.abs(d["ref_r"]) > 0.1
    assert wrong.series["health"][turning].mean() > 0.3
    assert not good.series["health"][turning].any()
    assert np.median(wrong["beta_std"][turning] / good["beta_std"][turning]) > 1.5
    assert wrong.params["health"]["n_flagged_spans"] >= 1


@pytest.mark.commonroad
def test_mkf_at_the_grip_limit_is_not_confidently_wrong() -> None:
    """cr_limit_slalom (CommonRoad's multi-body BMW on mu 0.6, beta to 5 deg): the linear
    tyres underpredict the slip by up to 4 deg, far more than the NIS-inflated covariance
    (0.68 of the errors inside 2 sigma before filters.excess).  The course innovations' power
    beyond S now enters beta_std: >= 0.90 inside 2 sigma (measured 1.00, seeds 0 and 1),
    while the straight before the slalom keeps its narrow band (median 2 sigma 0.30 deg)."""
    pytest.importorskip("vehiclemodels", reason="needs the optional commonroad extra")
    d = sim_drive("cr_limit_slalom", 0)
    est = run_method("mkf", d, load_vehicle(d.meta["vehicle"]))
    fast = d["ref_vx"] > 5.0
    err = np.abs(est["beta"] - d["ref_beta"])[fast]
    assert math.degrees(np.sqrt(np.mean(err**2))) > 1.0  # the model does fail here
    assert np.mean(err < 2 * est["beta_std"][fast]) >= 0.90
    straight = fast & (d.t > 1.0) & (d.t < 4.0)
    assert math.degrees(np.median(est["beta_std"][straight])) < 0.25


def _positions_only(scenario: str):
    """The scenario with issue 15's receiver: 20 Hz positions, no Doppler, 50 ms late, the
    antenna 0.5 m ahead of the file (the scenario's own sensor settings otherwise)."""
    from sideslip.simulate import SensorConfig, simulate
    from sideslip.simulate.run import _lookup

    receiver = {
        "gnss_rate_hz": 20.0,
        "gnss_doppler": False,
        "gnss_latency_s": 0.05,
        "gnss_lever_offset_x": 0.5,
    }
    config = SensorConfig().with_overrides(_lookup(scenario).sensor_overrides).with_overrides(receiver)
    return simulate(scenario, seed=0, config=config)


@pytest.mark.commonroad
def test_mkf_at_the_grip_limit_with_positions_only_is_not_confidently_wrong() -> None:
    """The same limit slalom with positions only: the course from fixes is noisier than
    Doppler's, and its misfit (course NIS 3-6 where beta is 3 deg off) had vanished in the
    window's mean NIS beside the 100 Hz gyro's (0.27 on average): 0.67 of the errors inside
    2 sigma.  With the course's own test as well: >= 0.90 (measured 0.96)."""
    pytest.importorskip("vehiclemodels", reason="needs the optional commonroad extra")
    d = _positions_only("cr_limit_slalom")
    est = run_method("mkf", d, load_vehicle(d.meta["vehicle"]))
    fast = d["ref_vx"] > 5.0
    err = np.abs(est["beta"] - d["ref_beta"])[fast]
    assert math.degrees(np.sqrt(np.mean(err**2))) > 1.0  # the linear model fails here
    assert np.mean(err < 2 * est["beta_std"][fast]) >= 0.90


def test_mkf_starts_its_bias_state_from_the_drives_gyro_zero() -> None:
    """A raw gyro (-4.8 deg/s drawn on demo seed 3): with ``zero_gyro`` the bias state starts
    at the drive's own zero (GNSS course windows and standstill) with its 1-sigma, so the
    heading holds from the start; from 0 +- 1 deg/s the filter is 2 deg off in the first 10 s
    while it learns (measured 0.71 against 1.98 deg)."""
    drive = raw_gyro_demo()
    vehicle = load_vehicle(drive.meta["vehicle"])
    early = (drive.t < 10.0) & (drive["ref_vx"] > 5.0)
    worst = {}
    for zero in (True, False):
        est = run_method(all_methods()["mkf"], drive, vehicle, MkfSettings(zero_gyro=zero))
        worst[zero] = float(np.max(yaw_err_deg(est["yaw"], drive)[early]))
        assert ("gyro_bias_start" in est.params) is zero
    assert worst[True] < 1.0
    assert worst[False] > 1.5
