"""The fused estimator on every sensor subset: no GNSS, GNSS positions only (with a latency and
a lever arm the vehicle file does not state), and the real Stanford Revs lap (no GNSS)."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.drive import Drive, drive_from_columns
from sideslip.evaluate import metrics
from sideslip.methods.registry import all_methods, run_method, why_not
from sideslip.simulate import simulate
from sideslip.simulate.scenarios import SCENARIOS
from sideslip.simulate.sensors import SensorConfig
from sideslip.vehicle import Vehicle, load_vehicle
from tests.conftest import sim_drive
from tests.helpers import SHARED_DATA
from tests.methods.test_fused import beta_rmse_all, two_sigma_share

OURS = {"fused", "fused_filter"}
REVS = SHARED_DATA / "revs_250lm_20140222" / "20140222_01_01_03_250lm"


def _without_gnss(drive: Drive) -> Drive:
    cols = {"t": drive.t, **{k: v for k, v in drive.data.items() if not k.startswith("gnss_")}}
    return drive_from_columns(cols, dict(drive.meta))


@pytest.mark.parametrize("scenario", ["slalom_low_mu", "race_lap", "banked_turn", "dlc_bank"])
def test_without_gnss_fused_runs_and_matches_the_best_paper_method(scenario):
    """IMU + wheel speeds + steering only: fused runs, lists its cues, gives no heading or
    position (not observable), and is within 10 % of the best paper method the same columns
    allow, or better (measured: slalom on mu 0.25 0.018 vs fg_batch 0.087; race_lap 0.086 vs
    0.63; banked_turn 0.007 vs 0.051 and dlc_bank 0.031 vs 0.110 since the roll gyro drives
    the bank, were 0.41 and 0.12).  Still behind on cr_circle (seeds 0-3: 0.25 vs
    obs_modified_nocomp 0.081: its steady slip rests on a rear stiffness the circle's entry
    cannot pin without GNSS); step_steer's seed-0 1.22x is one draw (seeds 0-3: 0.017 vs
    fg_batch 0.026; benchmarks/results/no_gnss.md); fused's front-axle relation is left off
    by default (see FusedSettings.front_axle)."""
    drive = _without_gnss(sim_drive(scenario))
    vehicle = load_vehicle(drive.meta["vehicle"])
    assert why_not(all_methods()["fused"], drive, vehicle) is None
    est = run_method("fused", drive, vehicle)
    assert "gnss_doppler" not in est.params["cues"] and "gnss_position" not in est.params["cues"]
    assert "yaw" not in est.series and "e" not in est.series
    rmse = beta_rmse_all(drive, vehicle)
    others = {k: v for k, v in rmse.items() if k not in OURS}
    best = min(others, key=others.get)
    assert rmse["fused"] <= 1.1 * others[best], (rmse["fused"], best, others[best])


def _positions_only(scenario: str = "dlc_bank", lever_x_m: float = 0.5) -> Drive:
    """A 20 Hz receiver without Doppler, 50 ms late, its antenna ``lever_x_m`` ahead of where the
    vehicle file says (default: 0.5 m, on the double lane change with bank)."""
    cfg = (
        SensorConfig()
        .with_overrides(SCENARIOS[scenario].sensor_overrides)
        .with_overrides(
            {"gnss_rate_hz": 20.0, "gnss_doppler": False, "gnss_latency_s": 0.05, "gnss_lever_offset_x": lever_x_m}
        )
    )
    return simulate(scenario, seed=0, config=cfg)


def _positions_only_dlc() -> Drive:
    return _positions_only("dlc_bank")


def test_positions_only_gnss_with_latency_and_unstated_lever_arm():
    """fused uses the positions (cue listed) and keeps >= 85 % of errors inside 2 sigma
    (measured 1.00) although the latency and lever arm are in no file."""
    drive = _positions_only_dlc()
    assert "gnss_ve" not in drive and "gnss_e" in drive
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, vehicle)
    assert "gnss_position" in est.params["cues"] and "gnss_doppler" not in est.params["cues"]
    assert "tyres carry the slip" in est.params["assumed"]["gnss_positions_only"]
    assert "not identified" in est.params["assumed"]["gnss_latency_lever"]
    assert two_sigma_share(drive, est) >= 0.85


def test_positions_only_gnss_fused_within_10_percent_of_the_best_method():
    """Issue 15 point 4 on positions-only GNSS (20 Hz, 50 ms late, lever arm 0.5 m off): fused
    within 10 % of the best other method, or better (measured 0.035 deg against fg_batch
    0.110; 0.089 before the tyres carried the slip in arcs, 0.139 before the smoother's 0.05 s
    force low-pass)."""
    drive = _positions_only_dlc()
    vehicle = load_vehicle(drive.meta["vehicle"])
    rmse = beta_rmse_all(drive, vehicle)
    others = {k: v for k, v in rmse.items() if k not in OURS}
    best = min(others, key=others.get)
    assert rmse["fused"] <= 1.1 * others[best], (rmse["fused"], best, others[best])


@pytest.mark.parametrize("lever_x_m", [0.5, -0.5])
@pytest.mark.parametrize("soft", [False, True])
def test_positions_only_on_a_banked_track_the_arc_does_not_teach_a_wrong_stiffness(soft, lever_x_m):
    """The steady 8 deg banked arc with fixes only (20 Hz, 50 ms late, antenna 0.5 m ahead of or
    behind where the file says): on an arc a course error draws the same track as an
    along-track offset of the fixes, so a stiffness learned there took that offset for slip
    (rear scale 0.36 +- 0.01 with the right file, beta RMSE 0.93 deg, 52 % inside 2 sigma;
    1.02 deg with the 30 %-soft file).  With the tyres carrying the slip in arcs and the
    offset one draw per 20 s of fixes: measured 0.027 / 0.065 deg (right file, antenna ahead /
    behind), 0.186 / 0.239 (soft), 100 % inside 2 sigma.  The same drive without GNSS scores
    0.052 (right) and 0.241 (soft): in an arc the fixes cannot tell the slip from the antenna's
    offset, so the bounds are that tyres-only figure rounded up, 0.08 / 0.26 deg (a fifth of
    the failure's); 2-sigma share 0.90 (issue 15's floor)."""
    drive = _positions_only("banked_track_turn", lever_x_m)
    vehicle = load_vehicle(drive.meta["vehicle"])
    if soft:
        vehicle = vehicle.with_changes(cf=0.7 * vehicle.cf, cr=0.7 * vehicle.cr)
    est = run_method("fused", drive, vehicle)
    rmse = metrics(drive, est.series)["beta_rmse_deg"]
    assert rmse <= (0.26 if soft else 0.08), rmse
    assert two_sigma_share(drive, est) >= 0.90
    filt = run_method("fused_filter", drive, vehicle)  # was 1.99 deg, 56 % inside 2 sigma
    assert metrics(drive, filt.series)["beta_rmse_deg"] <= 0.35 and two_sigma_share(drive, filt) >= 0.90


def _revs() -> tuple[Drive, Vehicle]:
    from sideslip.io.revs import convert_revs

    return convert_revs(REVS), load_vehicle("revs_250lm")


def _revs_at_20_hz() -> tuple[Drive, Vehicle]:
    """The Revs lap with every fifth row kept (a 20 Hz logger sampling, not averaging); skips
    where the real data is absent."""
    if not REVS.exists():
        pytest.skip(f"real data absent: {REVS} (../shared/data is not shipped with the repo)")
    drive, vehicle = _revs()
    every_fifth = slice(None, None, 5)
    cols = {"t": drive.t[every_fifth], **{k: v[every_fifth] for k, v in drive.data.items()}}
    return drive_from_columns(cols, dict(drive.meta)), vehicle


@pytest.mark.realdata
def test_revs_lap_without_gnss_beats_the_papers_factor_graph():
    """The real Ferrari 250 LM lap (beta to 5.5 deg, |a_y| to 16.6 m/s^2, no GNSS): the paper's
    factor graph reports 0.57 deg, beta = 0 scores 1.69.  fused (IMU yaw rate, a_y, INS speed;
    the vehicle file's tyres, brush model with mu and stiffness identified) must meet issue
    15's 0.45 deg and beat every registered method that can run here (measured 0.30 deg vs
    fg_batch 0.56, obs_bicycle 0.60), with >= 90 % of errors inside 2 sigma (measured 0.96)."""
    if not REVS.exists():
        pytest.skip(f"real data absent: {REVS} (../shared/data is not shipped with the repo)")
    drive, vehicle = _revs()
    est = run_method("fused", drive, vehicle)
    rmse = metrics(drive, est.series)["beta_rmse_deg"]
    assert rmse <= 0.45
    others = {k: v for k, v in beta_rmse_all(drive, vehicle).items() if k not in OURS}
    assert rmse < min(others.values()), others
    assert two_sigma_share(drive, est) >= 0.90


@pytest.mark.realdata
@pytest.mark.parametrize("start_s", [225.0, 450.0])
def test_revs_clip_starting_at_speed_lets_the_causal_filter_learn_its_stiffness_again(start_s: float):
    """30 s of the Revs lap cut from 225 s (braking at 40 m/s) or 450 s (mid-corner), run
    as a drive of its own: no standstill, every state at its prior.  The causal filter's
    first rear-axle updates, with v_y still its prior's, took the rear stiffness scale below
    its bound 0.5 within the first second; the relation's Jacobian is 0 beyond the bound, so
    the scale stayed there for the whole clip (mu rose to 2.2 to match) and beta RMSE was
    1.50 / 1.59 deg.  The scale is now projected back onto the bound and learns again
    (measured 0.85 / 0.88 at the end, beta 0.645 / 0.629 deg).  Bounds: beta RMSE <= 0.9 deg
    (the clips' median for this filter is 0.52, the stuck scale's 1.5), the scale above its
    bound at the end, >= 90 % inside 2 sigma (measured 1.00)."""
    if not REVS.exists():
        pytest.skip(f"real data absent: {REVS} (../shared/data is not shipped with the repo)")
    drive, vehicle = _revs()
    rel = drive.t - drive.t[0]
    keep = (rel >= start_s) & (rel < start_s + 30.0)
    clip = drive_from_columns({"t": drive.t[keep], **{k: v[keep] for k, v in drive.data.items()}}, dict(drive.meta))
    est = run_method("fused_filter", clip, vehicle)
    assert metrics(clip, est.series)["beta_rmse_deg"] <= 0.9
    assert est.params["rear_stiffness_scale"] > 0.6
    assert two_sigma_share(clip, est) >= 0.90


@pytest.mark.realdata
def test_revs_lap_logged_at_20_hz_takes_the_files_stiffness_not_the_noises():
    """The same lap with every fifth row kept (a 20 Hz logger sampling, not averaging): the
    car's vibration, 0.84 m/s^2 per sample, folds into the band of the tyre forces.  Learned
    through that noise the rear stiffness collapsed (about 0.3 x the file's asked, held at
    0.5; beta RMSE 1.38 deg, where fg_batch keeps 0.57): errors in variables.  Now the
    smoother runs again with the file's stiffness where the scale falls below half through a
    noisy force, its velocity random walk is at least the accelerometer's white noise, and
    its zero-phase force low-pass takes half the single pass's time constant.
    Bounds: better than fg_batch on the same table (measured 0.41 deg against 0.57), >= 90 %
    inside 2 sigma (measured 0.97), and the params say why."""
    logged, vehicle = _revs_at_20_hz()
    est = run_method("fused", logged, vehicle)
    rmse = metrics(logged, est.series)["beta_rmse_deg"]
    fg = metrics(logged, run_method("fg_batch", logged, vehicle).series)["beta_rmse_deg"]
    assert rmse < fg, (rmse, fg)
    assert two_sigma_share(logged, est) >= 0.90
    assert est.params["rear_stiffness_scale"] == 1.0
    assert est.params["rear_stiffness_scale_note"].startswith("not learned")


@pytest.mark.realdata
def test_revs_lap_with_an_imu_slower_than_its_table_reads_as_the_same_imu_in_its_own_table():
    """The lap at 100 Hz with the IMU's samples kept on every fifth row only (a 20 Hz IMU in a
    table the 100 Hz speed and steering set, NaN between its samples, as the contract
    allows).  The accelerometer's noise is read from its own samples at their own spacing;
    before, the rows between were read as samples (1/25 of the noise's variance) and as
    gaps, and beta RMSE was 1.31 deg against 0.41 from the 20 Hz table (measured 0.405 now).
    Bound: the 20 Hz table's test bound (fg_batch on the same rows, 0.56), >= 90 % inside
    2 sigma (measured 0.98)."""
    if not REVS.exists():
        pytest.skip(f"real data absent: {REVS} (../shared/data is not shipped with the repo)")
    drive, vehicle = _revs()
    data = dict(drive.data)
    between = np.ones(len(drive), dtype=bool)
    between[::5] = False
    for name in ("ax", "ay", "wz"):
        col = drive[name].copy()
        col[between] = np.nan
        data[name] = col
    slow = Drive(drive.t, data, drive.meta, drive.path)
    est = run_method("fused", slow, vehicle)
    rmse = metrics(slow, est.series)["beta_rmse_deg"]
    fg = metrics(slow, run_method("fg_batch", slow, vehicle).series)["beta_rmse_deg"]
    assert rmse < fg, (rmse, fg)
    assert two_sigma_share(slow, est) >= 0.90


@pytest.mark.realdata
def test_revs_lap_at_100_hz_with_a_file_twice_too_stiff_keeps_the_bound():
    """The lap at 100 Hz with the file's cornering stiffnesses doubled asks for 0.35 x the
    file's rear stiffness through the car's noisy force.  A 100 Hz accelerometer keeps the
    car's vibration above the force's low-pass (the right file learns 0.94 x), so this is a
    file too stiff, not the 20 Hz log's flattening: the scale is held at the bound, 0.5
    (measured 0.233 deg, 96 % inside 2 sigma; with the file's stiffness, as before, 0.92).
    Bounds: fused_filter's 0.34 on the same file, and >= 90 % inside 2 sigma."""
    if not REVS.exists():
        pytest.skip(f"real data absent: {REVS} (../shared/data is not shipped with the repo)")
    drive, vehicle = _revs()
    stiff = vehicle.with_changes(cf=2.0 * vehicle.cf, cr=2.0 * vehicle.cr)
    est = run_method("fused", drive, stiff)
    assert est.params["rear_stiffness_scale"] == 0.5
    assert est.params["rear_stiffness_scale_note"].startswith("held at 0.5")
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.34
    assert two_sigma_share(drive, est) >= 0.90


@pytest.mark.realdata
def test_revs_lap_at_20_hz_with_a_file_twice_too_stiff_says_so_in_beta_std():
    """The lap logged at 20 Hz (every fifth row) with the file's stiffnesses doubled: the
    scale asked below half is there as likely the aliased vibration's flattening as the file
    (the right file asks 0.35-0.49 x at 20 Hz), so the fallback takes the file's stiffness,
    and the difference between the file's and the bound's beta joins beta_std: 84 % inside
    2 sigma without it, 94 % with it (measured).  Bounds: >= 90 %, a spread above 0.1 deg,
    and the estimate no worse than the file's alone (0.95)."""
    logged, vehicle = _revs_at_20_hz()
    stiff = vehicle.with_changes(cf=2.0 * vehicle.cf, cr=2.0 * vehicle.cr)
    est = run_method("fused", logged, stiff)
    assert est.params["rear_stiffness_scale_note"].startswith("not learned")
    assert est.params["beta_std_stiffness_fallback_deg"] > 0.1
    assert two_sigma_share(logged, est) >= 0.90
    assert metrics(logged, est.series)["beta_rmse_deg"] < 0.95


def test_a_file_far_too_stiff_on_a_clean_drive_keeps_the_bound():
    """The fallback above is for noise, not for a file that is far off: race_lap without GNSS
    with the file's cornering stiffness 2.5 x the car's asks for a scale below 0.5 through a
    clean force (the simulator's accelerometer, 0.05 m/s^2), so the scale is held at 0.5 as
    before (measured beta RMSE 0.275 deg; falling back to the file's stiffness there gives
    0.854).  Bound: 0.35 deg, the held scale, and its note."""
    drive = _without_gnss(sim_drive("race_lap"))
    vehicle = load_vehicle(drive.meta["vehicle"])
    vehicle = vehicle.with_changes(cf=2.5 * vehicle.cf, cr=2.5 * vehicle.cr)
    est = run_method("fused", drive, vehicle)
    assert est.params["rear_stiffness_scale"] == 0.5
    assert est.params["rear_stiffness_scale_note"].startswith("held at 0.5")
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.35


def test_without_gnss_the_roll_gyro_carries_the_bank_not_the_yaw_gyro_bias():
    """banked_turn (straight, a 25 deg banked turn, straight) without GNSS: the road bank
    changes only as the body rolls, so the roll gyro drives the offset c_y and the yaw gyro's
    bias stays at its true 0.0015 rad/s (before: 0.083 rad/s, a 10 deg bank read on the flat
    road and beta RMSE 0.41 deg).  Bounds: the bias within 0.0025 rad/s (the simulated MEMS
    turn-on bias is 0.0035 rad/s per axis: an estimate that does not beat its spread has
    learned nothing; measured 0.0020 here, 0.0005-0.0023 on seeds 1-3), the bank on the 25 deg
    part within 1.5 deg, beta RMSE below fg_batch's 0.051 deg on the same columns (measured
    0.007)."""
    import numpy as np

    drive = _without_gnss(sim_drive("banked_turn"))
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, vehicle)
    true_bias = drive.meta["truth_sensor"]["gyro_bias_mean"][2]
    assert abs(est.params["gyro_bias_rad_s"] - true_bias) < 0.0025
    steep = drive["ref_bank"] > np.radians(24.0)
    assert steep.sum() > 100
    assert np.max(np.abs(np.degrees(est["bank"][steep] - drive["ref_bank"][steep]))) < 1.5
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.051


def _piece_without_gnss(scenario: str, start_s: float, length_s: float) -> Drive:
    """``length_s`` of the scenario's drive from ``start_s``, its GNSS columns removed: a clip
    that starts at speed, with no standstill and every state at its prior."""
    whole = _without_gnss(sim_drive(scenario))
    rel = whole.t - whole.t[0]
    keep = (rel >= start_s) & (rel < start_s + length_s)
    return drive_from_columns({"t": whole.t[keep], **{k: v[keep] for k, v in whole.data.items()}}, dict(whole.meta))


def test_without_gnss_a_piece_of_stop_and_go_driving_takes_its_gyro_zero_from_the_steering():
    """urban_course from 110 s for 20 s without GNSS: no standstill and no heading reference,
    so the smoother's own gyro bias took up the lateral accelerometer's offset over the speed
    (0.021 rad/s against the simulator's -0.005; beta RMSE 0.202 deg, inside its sigma).  The
    steering relation (sideslip.calibrate.steer_yaw, speed 5-14 m/s) gives the zero to 0.002
    +- 0.005 rad/s and is the bias state's prior: measured beta RMSE 0.022 deg and the bias
    0.0012 off.  Bounds: beta below 0.08 (fg_batch on the same columns 0.049) and the bias
    within 0.01 rad/s (half the offset the smoother took alone)."""
    piece = _piece_without_gnss("urban_course", 110.0, 20.0)
    vehicle = load_vehicle(piece.meta["vehicle"])
    est = run_method("fused", piece, vehicle)
    true_bias = piece.meta["truth_sensor"]["gyro_bias_mean"][2]
    assert "steering" in est.params["assumed"]["gyro_bias_prior"]
    assert abs(est.params["gyro_bias_rad_s"] - true_bias) < 0.01
    assert metrics(piece, est.series)["beta_rmse_deg"] < 0.08
    assert two_sigma_share(piece, est) >= 0.9


def test_without_gnss_the_causal_filter_takes_the_steering_zero_only_as_a_whole_drive_calibration():
    """The same piece of urban_course: fused_filter takes the steering's zero as its gyro-bias
    prior, a calibration of the gyro read from the whole drive like the roll gyro's bias;
    strictly on-line (whole_drive_calibration off) it keeps the settings' prior.  Measured beta
    RMSE 0.307 -> 0.025 deg with it (the bias 0.0012 off against 0.021); bounds 0.1 deg and
    0.01 rad/s."""
    piece = _piece_without_gnss("urban_course", 110.0, 20.0)
    vehicle = load_vehicle(piece.meta["vehicle"])
    true_bias = piece.meta["truth_sensor"]["gyro_bias_mean"][2]
    est = run_method("fused_filter", piece, vehicle)
    assert "steering" in est.params["assumed"]["gyro_bias_prior"]
    assert abs(est.params["gyro_bias_rad_s"] - true_bias) < 0.01
    assert metrics(piece, est.series)["beta_rmse_deg"] < 0.1
    online = run_method("fused_filter", piece, vehicle, {"whole_drive_calibration": False})
    assert "gyro_bias_prior" not in online.params["assumed"]


def test_without_gnss_a_drive_starting_on_a_bank_is_not_confidently_wrong():
    """dlc_bank from 10 s without GNSS, at one speed (22 m/s), starting on its 16 deg bank: the
    smoother reads the bank's 2.7 m/s^2 as a gyro bias of -0.11 rad/s (no level reference in
    the piece; the offset's prior is 0.5 m/s^2), beta 0.47 deg off with 10 % of its errors
    inside 2 sigma.  The steering's zero, -0.009 +- 0.029 rad/s (the steering sensor's offset
    over L / v at one speed), is too wide to be the prior (FusedSettings.
    steer_gyro_prior_max_sigma; the prior stays the settings' and says why), but disagrees
    with the smoother's bias beyond both sigmas, and beta_std carries that disagreement as
    l_r db / v: measured 100 % inside 2 sigma.  Bound: 90 %, with the disagreement's part
    above 0.2 deg (l_r 0.1 / 22 rad is 0.37 deg).  The causal filter ends at the same bias
    (-0.110 +- 0.023 rad/s) and is tested row by row with its bias and sigma at that row:
    58 % inside 2 sigma without the term, 100 % with it (bound 90 % again)."""
    piece = _piece_without_gnss("dlc_bank", 10.0, 20.0)
    vehicle = load_vehicle(piece.meta["vehicle"])
    est = run_method("fused", piece, vehicle)
    assert "wider than" in est.params["assumed"]["gyro_bias_prior"]
    assert est.params["beta_std_gyro_zero_disagreement_deg"] > 0.2
    assert two_sigma_share(piece, est) >= 0.9
    causal = run_method("fused_filter", piece, vehicle)
    assert causal.params["beta_std_gyro_zero_disagreement_deg"] > 0.2
    assert two_sigma_share(piece, causal) >= 0.9


def test_without_gnss_cues_that_agree_leave_beta_std_alone():
    """banked_turn without GNSS (level start, the roll gyro carries the bank): the smoother's
    bias and the steering's zero agree within their sigmas, so no disagreement term; nor for
    the causal filter, whose bias agrees with the zero on every row."""
    drive = _without_gnss(sim_drive("banked_turn"))
    for method in ("fused", "fused_filter"):
        est = run_method(method, drive, load_vehicle(drive.meta["vehicle"]))
        assert "gyro_bias_steering_rad_s" in est.params
        assert "beta_std_gyro_zero_disagreement_deg" not in est.params


def test_without_gnss_the_gyro_scale_is_held_and_urban_turns_stay_right():
    """Without a heading or speed reference the gyro and (smoother) wheel-speed scale factors
    are not identified (held at 1): on urban_course (578 s, low-speed 90 deg turns) free
    scales took up the tyre relations' errors (gyro 5.6 % against 0.08 % true, wheels -1.3 %
    against 0.02 %; beta RMSE 0.14 deg, errors of 8 % of beta in every turn).  Bound: the
    best paper method on the same columns, kf_linear 0.060 deg (measured 0.051)."""
    drive = _without_gnss(sim_drive("urban_course"))
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, vehicle)
    assert est.params["gyro_scale"] == pytest.approx(1.0, abs=1e-4)  # its held 1-sigma
    assert est.params["wheel_speed_scale"] == pytest.approx(1.0, abs=1e-4)
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.060


def test_without_gnss_the_smoother_is_not_worse_than_its_filter_on_a_step_steer():
    """step_steer without GNSS: the smoother learns the rear stiffness from the turn-in (the
    steady turn cannot tell v_y from the stiffness); with axle forces that lag the state
    (a causal low-pass) and no yaw-acceleration term it read the lag as a soft tyre (scale
    0.90 against 1.06 implied by the truth) and scored 0.129 deg against its filter's 0.066.
    With the zero-phase low-pass and the moment balance: 0.019.  Bounds: not worse than the
    filter, and within twice fg_batch's 0.016 deg on the same columns."""
    drive = _without_gnss(sim_drive("step_steer"))
    vehicle = load_vehicle(drive.meta["vehicle"])
    smooth = metrics(drive, run_method("fused", drive, vehicle).series)["beta_rmse_deg"]
    causal = metrics(drive, run_method("fused_filter", drive, vehicle).series)["beta_rmse_deg"]
    assert smooth <= causal
    assert smooth < 2 * 0.016



def test_the_causal_filters_force_lag_is_inside_its_beta_std_in_transients():
    """race_lap without GNSS: fused_filter reads the axle forces through a causal low-pass
    (0.15 s), so in every turn-in and exit its slip lags the truth by about that time times
    the slip's rate (up to 1 deg at 6 deg/s).  beta_std carried the tyres' relaxation lag
    only: where the true beta changes faster than 2 deg/s, 86 % of the errors were inside
    2 sigma (seeds 0 / 1: 0.855 / 0.862; 0.80 / 0.75 above 5 deg/s), 93 % over the lap.  With
    the low-pass's time constant added to the lag: 0.973 / 0.971, and 0.985 over the lap.
    Bound: issue 15's 90 % on the transients alone."""
    import numpy as np

    drive = _without_gnss(sim_drive("race_lap"))
    est = run_method("fused_filter", drive, load_vehicle(drive.meta["vehicle"]))
    beta_rate = np.abs(np.gradient(np.degrees(drive["ref_beta"]), drive.t))
    fast = (drive["ref_vx"] > 5.0) & (beta_rate > 2.0)
    assert fast.sum() > 500
    err = np.abs(est["beta"] - drive["ref_beta"])[fast]
    assert np.mean(err < 2.0 * est["beta_std"][fast]) >= 0.90

def test_positions_only_latency_is_used_where_speed_changes_reveal_it() -> None:
    """urban_course, 20 Hz fixes 0.15 s late (antenna where the file says): without the
    latency the fixes' along-track offset in every turn reads as slip (measured beta RMSE 0.42
    deg; 0.28 since that offset counts as correlated over a second of fixes); with the latency
    identified from the fixes' speed, 0.032.  Since the offset counts once per 20 s of fixes
    (FusedSettings.gnss_offset_span_s) the unidentified latency costs less: 0.063 without it,
    0.030 with it.  Bounds: 0.1 deg, and without it at least 1.6x (measured 2.1x)."""
    from tests.test_gnss_latency import positions_drive

    drive = positions_drive("urban_course", 0.15)
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, vehicle)
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.1
    assert est.params["gnss_latency_s"] == pytest.approx(0.15, abs=0.05)
    off = run_method("fused", drive, vehicle, settings={"identify_gnss_latency": False})
    on_rmse = metrics(drive, est.series)["beta_rmse_deg"]
    assert metrics(drive, off.series)["beta_rmse_deg"] > 1.6 * on_rmse


def test_positions_only_the_lateral_lever_arm_is_identified_and_used() -> None:
    """urban_course, 20 Hz fixes 50 ms late, the antenna 0.5 m ahead of and 0.5 m left of where
    the file says (on the centreline): the fit of the fixes' speed against the wheels gives the
    lateral lever arm (its speed in turns), used with the file's 0 as prior: measured 0.484 m
    (posterior sigma 0.11 m); the bound is 2 of its sigmas.  The params say what was used."""
    from tests.test_gnss_latency import positions_drive

    drive = positions_drive("urban_course", 0.05, 0.5, 0.5)
    est = run_method("fused", drive, load_vehicle(drive.meta["vehicle"]))
    p = est.params
    assert p["gnss_lever_arm_y_m_sigma"] < 0.2
    assert abs(p["gnss_lever_arm_y_m"] - 0.5) < 2.0 * p["gnss_lever_arm_y_m_sigma"]
    assert p["gnss_lever_arm_y_identified_m"] == pytest.approx(0.5, abs=0.3)
    assert "lateral lever arm from the same fit" in p["assumed"]["gnss_latency_lever"]


@pytest.mark.parametrize("method", ["fused", "fused_filter"])
def test_an_unrevealed_latency_widens_beta_std_instead_of_hiding(method: str) -> None:
    """two_turns_gyro_sf at constant speed with fixes 0.15 s late: no speed change reveals the
    latency and in the turns it is the same as slip, so beta is off (measured 0.73 deg); its
    sigma carries what a latency one prior sigma later changes in beta (before: 64 % inside
    2 sigma)."""
    from tests.test_gnss_latency import positions_drive

    drive = positions_drive("two_turns_gyro_sf", 0.15)
    est = run_method(method, drive, load_vehicle(drive.meta["vehicle"]))
    assert two_sigma_share(drive, est) >= 0.9


@pytest.mark.parametrize("method", ["fused", "fused_filter"])
def test_the_latency_part_of_beta_std_is_what_the_latency_changes_not_r_times_its_sigma(method: str) -> None:
    """step_steer (the simulator's nonlinear truth, 80 km/h to 4.2 m/s^2) with issue 15's
    receiver: where the tyres carry the slip through the arc a latency barely moves beta, and r
    times the latency's prior sigma made beta_std uselessly wide (median 1.11 / 1.22 deg against
    a beta RMSE of 0.040 / 0.078).  Re-running the estimator with the fixes one sigma later
    measures what the latency does: median 0.31 / 0.59 deg, 100 % inside 2 sigma (on the
    latency grid of benchmarks/gnss_latency.py, 0-0.15 s x antenna +-0.5 m, six scenarios: at
    least 97 %).  Bounds: median under 0.8 deg, 2 sigma share at least 0.9 (issue 15)."""
    import numpy as np

    drive = _positions_only("step_steer")
    est = run_method(method, drive, load_vehicle(drive.meta["vehicle"]))
    moving = np.hypot(drive["ref_vx"], drive["ref_vy"]) > 5.0
    assert np.degrees(np.median(est.series["beta_std"][moving])) < 0.8
    assert two_sigma_share(drive, est) >= 0.9


def test_positions_only_an_unknown_latency_is_one_offset_not_white_noise() -> None:
    """race_lap with issue 15's receiver (20 Hz positions, 50 ms late, antenna 0.5 m ahead of
    the file's): the latency and lever arm the drive cannot identify shift the fixes along the
    track by one offset for many fixes.  Counted as white at every fix, the hundreds of fixes in
    a turn pinned that offset to centimetres and bent the slip to explain it (beta RMSE 0.166
    deg); counted once per second of fixes along the track, 0.094 (suite mean 0.090 -> 0.078,
    30 % soft file 0.121 -> 0.120); once per 20 s of fixes (FusedSettings.gnss_offset_span_s),
    0.088.  Bounds: 0.13 deg, and 2 sigma share at least 0.9."""
    drive = _positions_only("race_lap")
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, vehicle)
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.13
    assert two_sigma_share(drive, est) >= 0.9


def test_positions_only_an_antenna_behind_the_file_is_not_taken_for_slip() -> None:
    """two_turns_gyro_sf (0.2 rad/s turns at about 10 m/s) with the fixes 50 ms late and the
    antenna 0.5 m behind where the file says: in a steady arc the latency reads as a slip of
    -tau r (-0.57 deg) and the antenna as -l_x r / v (-0.29 deg), the same sign, so nothing
    cancels.  With the offset counted once per second of fixes the smoother bent beta by most
    of it: 0.304 deg RMSE (2026-12-05 default); once per 20 s of fixes, 0.135 (without GNSS
    0.041: the tyres alone).  Bound 0.2 deg: under a quarter of the 0.86 deg offset in the arcs,
    and clear of the 1 s figure; 2 sigma share at least 0.9 (issue 15's floor)."""
    drive = _positions_only("two_turns_gyro_sf", -0.5)
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, vehicle)
    assert metrics(drive, est.series)["beta_rmse_deg"] < 0.2
    assert two_sigma_share(drive, est) >= 0.9


@pytest.mark.parametrize("method", ["fused", "fused_filter"])
def test_a_late_doppler_is_taken_at_its_measurement_time(method: str) -> None:
    """demo with every GNSS epoch 100 ms late (a logger that stamps on arrival): before the
    Doppler latency was identified fused scored 0.287 deg with 63 % inside 2 sigma and
    fused_filter 0.266 deg (the Doppler course lags the heading by r tau, read as slip).
    With it, as on time (0.022 / 0.041 deg on time; measured 0.022 / 0.043): within 2x the
    on-time values and 2 sigma >= 0.9.  On time the fit (0.000 +- 0.010 s) is not applied."""
    from tests.test_gnss_latency import doppler_drive

    late = doppler_drive("demo", 0.1)
    vehicle = load_vehicle(late.meta["vehicle"])
    est = run_method(method, late, vehicle)
    bound = {"fused": 0.044, "fused_filter": 0.082}[method]
    assert metrics(late, est.series)["beta_rmse_deg"] < bound
    assert two_sigma_share(late, est) >= 0.9
    assert est.params["gnss_doppler_latency_s"] == pytest.approx(0.1, abs=0.02)
    on_time = run_method(method, doppler_drive("demo", 0.0), vehicle)
    assert on_time.params["gnss_doppler_latency_s"] == 0.0


@pytest.mark.parametrize("shape", [0.0, -1.0, 1.3])
def test_every_axle_curve_reaches_the_engine_and_stays_honest(shape: float) -> None:
    """The simulated race lap without GNSS (the tyres carry beta; truth: the simulator's Magic
    Formula with load transfer, none of the three curves).  Each curve (brush, Dugoff,
    simplified Magic Formula) reaches the axle relations: its beta RMSE differs from the
    brush's by more than 0.005 deg (measured 0.086 / 0.063 / 0.075 deg), stays under 0.12 deg,
    and keeps >= 90 % of its errors inside 2 sigma."""
    drive = _without_gnss(sim_drive("race_lap"))
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, vehicle, {"axle_curve_shape": shape})
    assert est.params["settings"]["axle_curve_shape"] == shape
    rmse = metrics(drive, est.series)["beta_rmse_deg"]
    assert rmse < 0.12
    assert two_sigma_share(drive, est) >= 0.90
    if shape != 0.0:
        brush = run_method("fused", drive, vehicle)
        assert abs(rmse - metrics(drive, brush.series)["beta_rmse_deg"]) > 0.005


def test_the_causal_yaw_rate_update_reads_a_slower_gyros_own_samples():
    """The causal filter's yaw-rate update at a node is the mean of the gyro's samples among
    the node step's rows.  A 20 Hz gyro in a 100 Hz table (a sample on every fifth row, the
    rows between holding it): the held rows made the update 0.8 x the previous sample plus
    0.2 x the current one, 40 ms late.  Now the sample itself (to rounding); a step without a
    sample takes the node's own (held) row, and a gyro on every row keeps the rows' mean."""
    from sideslip.methods.fused import _node_inputs
    from sideslip.models.fused_process import U_WZ

    t = np.arange(0.0, 10.0, 0.01)
    sample = np.zeros(t.size, dtype=bool)
    sample[::5] = True
    wz_true = np.sin(2.0 * np.pi * 0.5 * t)
    held = wz_true[np.flatnonzero(sample)[np.cumsum(sample) - 1]]
    inputs = tuple(held if k == U_WZ else np.zeros(t.size) for k in range(7))
    q_gap = [np.zeros(t.size)] * 4
    idx = np.arange(0, t.size, 5)
    U = _node_inputs(t, idx, inputs, q_gap, False, 5, causal=True, wz_samples=sample)
    np.testing.assert_allclose(U[1, :, U_WZ], wz_true[idx], atol=1e-12)
    every_row = _node_inputs(t, idx, inputs, q_gap, False, 5, causal=True)
    first = np.maximum(idx - 4, 0)
    rows_mean = np.array([held[a : b + 1].mean() for a, b in zip(first, idx, strict=True)])
    np.testing.assert_allclose(every_row[1, :, U_WZ], rows_mean, atol=1e-12)


def _without_ax(drive: Drive) -> Drive:
    cols = {"t": drive.t, **{k: v for k, v in drive.data.items() if k != "ax"}}
    return drive_from_columns(cols, dict(drive.meta))


@pytest.mark.parametrize("receiver", ["doppler", "none"])
def test_without_ax_the_speeds_rate_is_the_longitudinal_input(receiver: str) -> None:
    """A drive without an ``ax`` column (a yaw-rate / lateral sensor cluster on CAN; the
    contract asks only for ``wz`` and ``ay``), the race lap braking at 10 m/s^2: the
    longitudinal input was 0, taken as exact, and beta RMSE was fused 0.52 / fused_filter
    1.10 deg with Doppler, 1.10 / 19.1 without GNSS (42 % inside 2 sigma).  With the speed's
    rate as the input: 0.076 / 0.189 and 0.083 / 0.282 (with ax: 0.028 / 0.171 and 0.085 /
    0.319).  Bounds: fused 0.15 deg (the with-ax error plus the rate's lag in the braking
    zones, about 0.05), fused_filter 0.8, each with >= 90 % inside 2 sigma; params say what
    stood in for ax."""
    drive = _without_ax(sim_drive("race_lap"))
    if receiver == "none":
        drive = _without_gnss(drive)
    vehicle = load_vehicle(drive.meta["vehicle"])
    for method, bound in (("fused", 0.15), ("fused_filter", 0.8)):
        est = run_method(method, drive, vehicle)
        assert metrics(drive, est.series)["beta_rmse_deg"] <= bound, method
        assert two_sigma_share(drive, est) >= 0.90, method
        assert "imu (no ax: the speed's rate for it)" in est.params["cues"]


@pytest.mark.realdata
def test_revs_lap_without_ax_keeps_the_causal_filter_on_the_lap() -> None:
    """The real lap with its ax column removed: fused_filter scored 23.4 deg (35 % inside 2
    sigma) with a longitudinal input of 0 through 16 m/s^2 braking; with the speed's rate
    0.453 (0.98), fused 0.246 (with ax: 0.378 and 0.245).  Bounds: fused_filter under
    fg_batch's 0.56 on the same lap, fused the issue's 0.45; >= 90 % inside 2 sigma."""
    if not REVS.exists():
        pytest.skip(f"real data absent: {REVS} (../shared/data is not shipped with the repo)")
    drive, vehicle = _revs()
    drive = _without_ax(drive)
    for method, bound in (("fused", 0.45), ("fused_filter", 0.56)):
        est = run_method(method, drive, vehicle)
        assert metrics(drive, est.series)["beta_rmse_deg"] <= bound, method
        assert two_sigma_share(drive, est) >= 0.90, method


def test_without_ax_the_speeds_rate_is_v_x_rate_not_the_specific_force() -> None:
    """The speed's rate is v_x' itself, the specific force a_x = v_x' - r v_y: with it as the
    input the process model's r v_y term counted r v_y twice, v_x's prediction missed by it in
    every turn and the wheel updates put part of that into v_y.  urban_course (90 deg turns
    at town speed) without ax and GNSS: fused 0.130 / fused_filter 0.095 deg with the term,
    0.060 / 0.052 without it (with ax: 0.054 / 0.087).  Bound: 0.09 deg for both (the
    with-ax error plus half of it), >= 90 % inside 2 sigma."""
    drive = _without_gnss(_without_ax(sim_drive("urban_course")))
    vehicle = load_vehicle(drive.meta["vehicle"])
    for method in ("fused", "fused_filter"):
        est = run_method(method, drive, vehicle)
        assert metrics(drive, est.series)["beta_rmse_deg"] <= 0.09, method
        assert two_sigma_share(drive, est) >= 0.90, method
