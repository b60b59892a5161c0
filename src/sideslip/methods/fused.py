"""Fused sideslip estimator: one error-aware filter/smoother over every sensor the drive has.

None of the five papers combines their strengths; this method does, in one extended Kalman
filter (``fused_filter``, causal) and its Rauch-Tung-Striebel smoother (``fused``, off-line,
the toolkit's best estimate).  It runs on any sensor subset that has a z gyro, a lateral
accelerometer and a speed: GNSS Doppler and/or positions (any rate) are used when present,
the steering angle when present; with no GNSS at all (e.g. the Stanford Revs lap) the tyres
alone carry the sideslip.  ``params["cues"]`` lists what a run used.

State (15, or 18 with GNSS positions; :mod:`sideslip.models.fused_process`):
position e, n; yaw psi; body velocity v_x, v_y; gyro bias b_g; lateral / longitudinal
specific-force offsets c_y (bank + accelerometer bias), c_x (grade + bias); wheel-speed
scale s_w; gyro scale error s_g; GNSS Gauss-Markov position error p_e, p_n; front / rear axle
stiffness scales s_f, s_r; friction coefficient mu; and with positions the GNSS latency tau and
the antenna lever-arm error dl_x, dl_y.  Process model: planar kinematics with the IMU as
input (seed 000 eq 3 for the Euler yaw rate, seed 001's gyro scale factor, seed 003 eq 43's
suspension roll in the accelerometer).  Without GNSS nothing but the tyres tells the offset
c_y from the gyro bias times v_x, so the roll gyro (when the drive has wx) drives c_y: the road
bank changes only as the body rolls (seed 003: roll = suspension roll + bank), and c_y's random
walk is left with the accelerometer's drift (banked_turn without GNSS: gyro bias 0.083 rad/s
and beta RMSE 0.41 deg with the random walk alone, 0.0015 rad/s and 0.012 deg with the roll
gyro, 0.007 with the changes below).  The smoother with GNSS Doppler takes the roll gyro's
bank too, with c_y's remaining random walk read from the drive (below), and so does the
causal filter; with GNSS positions only, the same as without GNSS.
Without GNSS the gyro scale factor is held at 1 (it is identified against the GNSS course,
seed 001), in the smoother the wheel-speed scale too (identified against the GNSS speed, seed
004).

Measurements (:mod:`sideslip.models.fused_measurements`): wheel speed ``s_w v_x``;
standstill (v = 0, r = 0); the rear and front axle force relations of the brush tyre model
(Fiala 1954 / Pacejka 2012 sec. 3.2, :mod:`sideslip.models.axle_force`) with the effective
stiffness and mu as slowly varying states (with ``identify_mu``, mu's prior mean from the
drive's own understeer angle where the drive reached its limit,
:mod:`sideslip.calibrate.friction`), the axle forces
measured by the accelerometer and the yaw acceleration through the single-track force/moment
balance (seed 003 eqs 1-2); GNSS
Doppler at the antenna (omega x lever), each epoch at its stamp less the Doppler latency
where the drive decides it (``_doppler_latency``); GNSS positions at the antenna with
Gauss-Markov error, the fix's age and the receiver latency.  Below ``axle_min_speed`` and in
reverse the rear axle's sideways velocity stands in for its slip relation.  Where the tyres
leave what the brush curve describes, an adaptive factor inflates the axle relations'
variance until their normalised innovations average 1 again (time constant ``adapt_tau_s``).

Robustness: every cue but standstill goes through a Huber-type update (variance times
d2 / gate beyond ``gate_chi2``, :mod:`sideslip.filters.kalman`).  A per-epoch gate does not
catch a multipath burst (a run of moderately wrong epochs that agree with each other), so
each Doppler epoch is also checked against the velocity the accelerometers carried forward
from the last epoch that agreed with them (``doppler_check``; the tyres play no part in it, so
a wrong tyre model is not taken for a bad receiver): a disagreeing epoch gets the variance of
its disagreement, and after a run of them the excess stays for ``doppler_check_tau_s``;
after a bank change (roll gyro less the suspension's roll, ``doppler_check_bank_tau_s``) the
check allows for the offset state's lag behind the road.  With positions but no Doppler, an
unidentified latency and lever arm are one along-track (l_y: cross-track) offset for about
``gnss_offset_span_s`` of fixes, not white noise at every fix.
Consistency between cues: the windowed NIS of the axle and GNSS innovations
(``sideslip.filters.consistency``) flags spans where the cues disagree beyond their sigma;
there ``beta_std`` grows by the square root of the inflation and ``health`` (0 good ... 1
unusable) says so; ``params["health"]`` lists the spans.

The suspension's roll gain (the accelerometer tilts with the body, so the tyres' force is
a_y less g times the roll) comes from the roll gyro in the drive's lateral transients,
weighted with the one the file's mass, CG height and roll stiffness give
(:mod:`sideslip.methods.roll_gyro_gradient`; ``params["roll_gradient_source"]``).

Noise the drive sets or the physics sizes (:mod:`sideslip.methods.fused_settings`): the axle
forces' low-pass is short (its lag is read as tyre slip in every transient: 0.05 s for the
smoother, raised where the drive's accelerometer noise needs it; 0.15 s for the causal
filter, which has no later samples to average; without GNSS, where the transients alone teach
the stiffness, the smoother's is zero-phase and the forces are split with the yaw
acceleration too), and the noise it leaves, from the drive's
own accelerometer (running estimate in the filter), enters the axle relations' variance; the
wheel speed's sigma carries the longitudinal slip
a_x / (g C_k) of braking and driving wheels, in corners with the front axle's cornering drag
and the combined-slip growth of the compliance (:mod:`sideslip.methods.fused_updates`); a
stiffness the causal filter withholds in a
transient is a consider parameter of the axle relation (Schmidt-Kalman: its variance and
cross-covariances kept, its gain zero).  ``beta_std`` adds what
the covariance's white updates cannot carry: the learned stiffness's remaining relative
uncertainty times the rear slip, the lag of the force the relations read (the tyres'
relaxation, and the measured force's causal low-pass: in the causal filter's turn-ins the
slip trails the truth by its 0.15 s), and, where nothing but the tyres
pins the slip (no GNSS; and for the causal filter in every corner, where GNSS cannot tell
slip from a gyro scale error before the turn is complete), the relation's relative error;
with GNSS positions but no Doppler, the change of beta when the whole estimator runs again
with the fixes one latency sigma later (a latency turns the fixes' course by r tau in every
turn, and how much of that reaches beta depends on how far the tyres carry the slip there).

Slow loggers: a table that samples a vibrating car's accelerometer at 10-50 Hz folds the
vibration into the band of the tyre forces.  The smoother's body-velocity random walk is then
at least the accelerometer's own white noise (sigma_a sqrt(dt), from the drive's successive
differences), and where the rear stiffness it learns falls below half the file's through a
force noisier than the relation's floor, from an accelerometer sampled at most 25 Hz (errors
in variables flatten the learned slope: the tyre reads soft) it runs again with the file's
stiffness, not learned, its prior sigma and its difference from the bound's estimate in
``beta_std`` (``stiffness_bound_fallback``, ``stiffness_fallback_max_rate_hz``); without GNSS
the force's zero-phase low-pass needs half the single pass's time constant for the same noise
(Revs lap at 20 Hz 1.41 -> 0.41 deg with the three, benchmarks/results/real_log_rates.md).

Multipath bursts the forward Doppler check lets in (its inertial anchor drifts until it admits
a long burst's middle) stand out from the smoothed track: the smoother looks at each Doppler
epoch's distance from it against the drive's own residual scale, takes the runs beyond the
gate again with their distance as sigma and runs once more (``doppler_burst_check``,
:mod:`sideslip.methods.fused_bursts`; CommonRoad limit ramps with two unseen cars, seed 7,
0.35 / 0.50 -> 0.18 / 0.14 deg).

With GNSS Doppler the smoother reads the body velocity's random walk (everything the planar
kinematics miss: accelerometer noise and vibration, roll transients, pitch and heave) from the
drive: the value, searched down from the prior ``accel_vrw_psd`` a factor of two at a time,
whose forward filter predicts the Doppler velocities best (``identify_accel_vrw``,
:mod:`sideslip.methods.fused_vrw`; ``params["assumed"]["accel_vrw"]`` gives the evidence),
and then, where the roll gyro drives the bank, c_y's random walk the same way
(``identify_cy_psd``, ``params["assumed"]["cy_psd"]``).  The causal filter does the same:
its states stay causal, its two noise levels are read from the whole drive, as are its roll
gain and Doppler latency (calibrations of the car and the receiver;
``whole_drive_calibration=false`` keeps it strictly causal).
``beta_std`` then carries the slip offset of an ``accel_offset_sigma`` accelerometer offset,
which the random walk, white, does not.  Where five curves or more decide it, the offset
itself comes out of the axle forces and the bank (``identify_accel_offset``,
:mod:`sideslip.methods.fused_accel_offset`: seed 000's heading closure in curves, which
tells a reading's offset from a road's crossfall through the yaw gyro's tilt), and its
posterior sigma replaces the prior's in ``beta_std``.  Without GNSS the gyro-bias prior is the
drive's steering relation (``steer_gyro_prior``, :mod:`sideslip.calibrate.steer_yaw`; the
causal filter's with ``whole_drive_calibration``) where that is narrow enough; where it is
not, and the estimate's bias disagrees with it beyond both sigmas (the causal filter's
row by row), ``beta_std`` carries the disagreement as the slip ``l_r db / v`` it makes.
With Doppler and fixes the smoother also checks the file's antenna position (``check_doppler_lever``,
:mod:`sideslip.methods.fused_lever`): an antenna ``dl_x`` ahead of where the file says adds
``r dl_x`` to the Doppler's lateral velocity, which reads as slip; a pass without the tyres
finds ``dl_x``, and the antenna is moved only where that pass puts it beyond
``doppler_lever_z`` sigmas (less the part the node inputs' half-row timing accounts for, where
they have one) and the filter with the tyres predicts the Doppler better with it moved
(``params["assumed"]["gnss_lever_x"]``).  Tyre-free the pass sees only the antenna's place
relative to the IMU, so where it finds an offset the smoother also runs with the antenna
moved and with the IMU moved the other way (``check_imu_lever``, ``ImuAlternative``), and the
Doppler's likelihood with the tyres picks the installation; the ones not picked add their
beta, by their likelihood weight, to ``beta_std`` (``params["assumed"]["imu_lever_x"]``).
A sensor box the file misplaces moves antenna and IMU together, which neither check sees; in
the turns slower than ``box_speed_max_m_s`` the rear axle barely slides sideways, and there the
Doppler puts the antenna against the rear axle (``check_box_lever``,
:mod:`sideslip.methods.fused_box`, ``params["assumed"]["box_x"]``).  Without such turns (a
race lap, a highway) the Doppler's likelihood with the tyres profiles the box's place
(``profile_box_lever``, :mod:`sideslip.methods.fused_box_profile`): moved to the minimum where
that beats the file's place by the gate on a drive without multipath bursts, otherwise kept
with the profile's doubt, ``hypot(sigma, d_min) |r| / v``, in ``beta_std``
(``params["box_x_tyres_*"]``).
A Doppler latency the tyre-free fits leave open (a short drive of a few turns at one speed)
is profiled with the tyres (``profile_doppler_latency``, :mod:`sideslip.methods.fused_latency`):
tyre-free a Doppler ``tau`` late reads in turns as an antenna ``v tau`` behind, so the late
Doppler is one more explanation beside the installations, taken where its ``-2 log L`` beats
the stamps' by the gate and every installation (``params["gnss_doppler_latency_tyres_*"]``);
where an installation scores within the gate of it, that one's beta counts in full in
``beta_std``.
The causal filter, with ``whole_drive_calibration``, runs the smoother first and takes the
antenna, the IMU, the box or the Doppler latency its checks found.

Holes in the IMU inputs and pauses of the logger (rows missing; :mod:`sideslip.methods.input_gaps`):
the smoother interpolates across a hole, the causal filter holds the last sample, a pause's
step is the sample before it held, and the fill's error, the drive's own change of the
signal over the gap's span, is one excursion over the gap in the heading's and the
velocities' process noise (and in the axle relations' variance, for the lateral
reading; the bank's, for the roll gyro where it drives the bank).

Discretisation and cost: both step on nodes every ``step_s`` and at every GNSS epoch (inputs
averaged in between; the smoother's states linearly interpolated back to every row, the
filter's propagated from its latest node with each row's own sample).  With GNSS Doppler the
average is the trapezoidal rule's (``trapezoid_with_doppler``), otherwise the rows' mean,
which runs half a row late; the causal filter's updates read only rows up to their node.
Memory: the filtered state and the float32 upper triangle of each node's covariance; linear
in the drive's length.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from sideslip import gnss
from sideslip.calibrate.friction import drive_friction
from sideslip.calibrate.result import Fitted
from sideslip.calibrate.steer_yaw import steer_gyro_zero
from sideslip.doppler_timing import (
    DECISIVE_SIGMA_S,
    DopplerTiming,
    antenna_geometry,
    choose_doppler_latency,
    doppler_fit,
)  # fmt: skip
from sideslip.drive import LONG_DRIVE_ROWS, Drive
from sideslip.estimate import Estimate
from sideslip.filters.consistency import nis_consistency
from sideslip.gnss_latency import LatencyEstimate, identify_latency
from sideslip.imu_lever import specific_force_at_cg
from sideslip.methods import fused_engine as eng
from sideslip.methods.fused_accel_offset import AccelOffset, lateral_accel_offset
from sideslip.methods.fused_box import antenna_from_slow_turns
from sideslip.methods.fused_box_profile import BoxProfile, profile_box
from sideslip.methods.fused_bursts import burst_epochs
from sideslip.methods.fused_latency import LatencyProfile, profile_latency
from sideslip.methods.fused_lever import (
    ImuAlternative,
    check_lever,
    imu_moved,
    likelihood_weights,
    without_tyres,
)  # fmt: skip
from sideslip.methods.fused_settings import (
    FusedSettings,
    accel_noise_sigma,
    force_noise_variance,
    force_time_constant,
)
from sideslip.methods.fused_stiffness import PRIOR_SHIFT as STIFFNESS_PRIOR_SHIFT
from sideslip.methods.fused_stiffness import model_form_params, prior_share, rear_secant
from sideslip.methods.fused_vrw import NoiseChoice, search_accel_vrw, search_noise_scale
from sideslip.methods.input_gaps import REGULAR_SPACING, causal_between_samples, fill_input, gap_increments
from sideslip.methods.input_gaps import Filled as FillResult
from sideslip.methods.registry import SPEED, register
from sideslip.methods.roll_gyro_gradient import identify_roll_gradient_from_gyro
from sideslip.models.fused_measurements import A_CR, A_LR, SCALE_MAX, SCALE_MIN
from sideslip.models.fused_process import (
    IBG,
    ICX,
    ICY,
    IE,
    ILX,
    ILY,
    IMU,
    IN,
    IPSI,
    ISF,
    ISG,
    ISR,
    ISW,
    ITAU,
    IVX,
    IVY,
    NX_CORE,
    NX_GNSS_CAL,
    U_WZ,
    f_rows,
    suspension_factor,
)
from sideslip.signals import gnss_course, hold, sample_step, speed_raw, speed_source, vehicle_speed
from sideslip.typical import slip_gain_k, understeer_gradient
from sideslip.vehicle import G, Vehicle

FloatArray = NDArray[np.float64]
# relative 1-sigma of a vehicle file's roll gain m h / (k - m g h) as the prior of the drive's
# own (users' CG heights and roll stiffnesses are guesses: 30 % each is rough_file's error)
ROLL_FILE_REL_SIGMA = 0.3


def _hold(drive: Drive, name: str, fill: float = 0.0) -> FloatArray:
    """Column ``name`` with gaps held at the last sample (an input, not a measurement)."""
    n = len(drive)
    if name not in drive:
        return np.full(n, fill)
    v = drive[name].copy()
    bad = ~np.isfinite(v)
    if bad.any():
        idx = np.where(~bad, np.arange(n), 0)
        np.maximum.accumulate(idx, out=idx)
        v = np.where(bad, v[idx], v)
        v[~np.isfinite(v)] = fill
    return v


def _imu(drive: Drive, name: str, smooth: bool) -> FillResult:
    """IMU column ``name`` with its gaps filled (interpolated by the smoother, held by the
    causal filter) and the fill's error (:mod:`sideslip.methods.input_gaps`); a column the
    drive lacks is 0 with no error (the caller knows it is absent)."""
    values = drive[name] if name in drive else np.full(len(drive), np.nan)
    return fill_input(drive.t, values, interpolate=smooth)


def _yaw_rate_input(drive: Drive, smooth: bool, speed: FloatArray, min_speed: float) -> FillResult:
    """The yaw gyro with its gaps filled (:func:`_imu`); in the causal filter, a row of a gap
    at speed where the lateral accelerometer reads takes a_y / v instead of the last sample
    (the path's yaw rate, wrong by the sideslip's rate and the gyro's bias) where that is
    the better guess: where the held sample's sigma exceeds the root mean square of
    w_z - a_y / v over the second before the gap (at the limit the two part; not below the
    drive's whole root mean square).  A held rate in a corner's turn-in drove v_y by v times
    its error (race lap without GNSS, a 0.5 s hole: beta 5-12 deg off for 7 s)."""
    filled = _imu(drive, "wz", smooth)
    if not filled.sigma.any() or "ay" not in drive:
        return filled
    if smooth:
        return _yaw_rate_fill_smooth(drive, filled, speed, min_speed)
    t = drive.t
    wz_raw = drive["wz"]
    gap = ~np.isfinite(wz_raw)
    fast = np.abs(speed) > min_speed
    path = np.where(fast, drive["ay"] / np.where(fast, speed, 1.0), np.nan)
    miss = wz_raw - path
    ok = np.isfinite(miss)
    if ok.sum() < 10:
        return filled
    floor = float(np.sqrt(np.mean(miss[ok] ** 2)))
    # the mismatch's mean square over the second before each row, from valid rows only
    cum_sq = np.concatenate(([0.0], np.cumsum(np.where(ok, miss, 0.0) ** 2)))
    cum_n = np.concatenate(([0], np.cumsum(ok)))
    # each gap's start, and per row the start of the gap it lies in (vectorised: a gyro at
    # half the table's rate has a one-row gap every other row)
    starts = np.flatnonzero(gap & ~np.concatenate(([False], gap[:-1])))
    if starts.size == 0:  # a pause of the logger (rows missing) leaves no row to fill
        return filled
    lo = np.searchsorted(t, t[starts] - 1.0)
    count = cum_n[starts] - cum_n[lo]
    local = np.sqrt(np.where(count > 0, (cum_sq[starts] - cum_sq[lo]) / np.maximum(count, 1), np.inf))
    sig_start = np.maximum(local, floor)
    run = np.cumsum(gap & ~np.concatenate(([False], gap[:-1]))) - 1
    sig_path = np.where(gap, sig_start[np.maximum(run, 0)], np.inf)
    better = gap & np.isfinite(path) & (filled.sigma > sig_path)
    values = np.where(better, path, filled.values)
    sigma = np.where(better, sig_path, filled.sigma)
    return FillResult(values, sigma, filled.gap_s)


def _yaw_rate_fill_smooth(
    drive: Drive, filled: FillResult, speed: FloatArray, min_speed: float
) -> FillResult:
    """The smoother's yaw-rate gaps at speed: (a_y - the residual a_y - v w_z interpolated
    across the gap) / v where the lateral accelerometer has its sample and that fill's
    1-sigma (the residual's over v) is below the interpolated rate's.  In a slalom the yaw
    rate reverses within a 0.5 s hole while v_y's rate stays small: cr_limit_slalom without
    GNSS, 0.5 s holes in w_z, a_y and a_x: fused 1.17 -> 0.33 deg (beta 5 deg off for 2 s
    after a hole in w_z with the rate interpolated)."""
    wz_raw, ay_raw = drive["wz"], drive["ay"]
    fast = np.abs(speed) > min_speed
    gap = ~np.isfinite(wz_raw) & np.isfinite(ay_raw) & fast
    if not gap.any():
        return filled
    lat = fill_input(drive.t, ay_raw - speed * wz_raw, interpolate=True)
    v = np.where(fast, np.abs(speed), 1.0)
    path = (ay_raw - lat.values) / np.where(fast, speed, 1.0)
    sig_path = lat.sigma / v
    better = gap & (filled.sigma > sig_path)
    values = np.where(better, path, filled.values)
    sigma = np.where(better, sig_path, filled.sigma)
    return FillResult(values, sigma, filled.gap_s)


def _accel_at_cg(
    drive: Drive, vehicle: Vehicle, wx: FloatArray, wy: FloatArray, wz: FloatArray, causal: bool,
    ax: FloatArray, ay: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """The accelerometer's x and y specific force (m/s^2, gaps filled: ``ax``, ``ay``) moved
    from the IMU's place in the vehicle file (``imu_xyz``) to the CG, where the kinematics
    and the axle force balance hold (:mod:`sideslip.imu_lever`; a phone 1.2 m ahead of the
    CG read r' l_x as tyre force in every transient: race_lap 0.048 -> 0.654 deg, 59 %
    inside 2 sigma, before the move).  A drive without ``ax`` keeps its ``ax`` input (the
    speed's rate, :func:`_speed_rate`, is not read at the IMU's place)."""
    ax_cg, ay_cg = specific_force_at_cg(drive.t, ax, ay, wx, wy, wz, vehicle.imu_xyz, causal=causal)
    return (ax_cg if _has_ax(drive) else ax), ay_cg


def _low_pass(t: FloatArray, x: FloatArray, tau: float) -> FloatArray:
    """Causal first-order low-pass (time constant ``tau`` s), exact for any step."""
    from scipy.signal import lfilter

    dt = np.diff(t, prepend=t[0])
    if np.allclose(dt[1:], dt[1] if dt.size > 1 else 0.0, rtol=1e-6, atol=1e-9) and dt.size > 1:
        a = 1.0 - math.exp(-dt[1] / tau)
        y, _ = lfilter([a], [1.0, a - 1.0], x, zi=[(1.0 - a) * x[0]])
        return np.asarray(y, dtype=float)
    y = np.empty_like(x)
    y[0] = x[0]
    for k in range(1, x.size):  # pragma: no cover - irregular time bases are rare
        a = 1.0 - math.exp(-dt[k] / tau)
        y[k] = y[k - 1] + a * (x[k] - y[k - 1])
    return y


def _zero_phase_low_pass(t: FloatArray, x: FloatArray, tau: float) -> FloatArray:
    """:func:`_low_pass` forwards, then backwards over the result: no lag (off-line only)."""
    y = _low_pass(t, x, tau)
    back = _low_pass(t[-1] - t[::-1], np.ascontiguousarray(y[::-1]), tau)
    return np.ascontiguousarray(back[::-1])


def _backward_rate(t: FloatArray, x: FloatArray) -> FloatArray:
    """Causal derivative (x_k - x_{k-1}) / (t_k - t_{k-1}), 0 at the first row."""
    rate = np.zeros_like(x)
    if x.size > 1:
        rate[1:] = np.diff(x) / np.diff(t)
    return rate


def roll_gain(vehicle: Vehicle) -> float:
    """k_phi = m h / (k - m g h), rad per m/s^2 (steady suspension roll), 0 if unknown."""
    if vehicle.missing(["mass", "cg_height", "roll_axis_height", "roll_stiffness"]):
        return 0.0
    h = vehicle.cg_height - vehicle.roll_axis_height
    denom = vehicle.roll_stiffness - vehicle.mass * G * h
    return vehicle.mass * h / denom if denom > 0 else 0.0


def _drive_roll_gain(
    drive: Drive, vehicle: Vehicle, k_phi_file: float, wx: FloatArray, ay: FloatArray
) -> tuple[float, dict[str, Any]]:
    """The roll gain k_phi (rad per m/s^2) from the roll gyro in the drive's lateral transients
    (:mod:`sideslip.methods.roll_gyro_gradient`) with the file's as its prior (relative
    1-sigma ``ROLL_FILE_REL_SIGMA``), with the params saying which was used.  It reads the
    whole drive before either pass runs: the causal filter is then causal in its states but
    not in this one vehicle parameter, a calibration of the car
    (``FusedSettings.identify_roll_gradient = False`` keeps it strictly causal).  The
    identified gradient G = m h / k per measured a_y becomes k_phi = G / (1 - g G), the file's
    relation.  Measured with a file whose mass, CG height and roll stiffness are 15 % / 30 % /
    -30 % off (roll gain x 2.1) and Doppler GNSS, CommonRoad limit slalom: fused 1.68 -> 0.27
    deg (75 % -> 100 % inside 2 sigma), fused_filter 3.18 -> 0.44 (83 % -> 99 %).  Taking the
    drive's value only where it contradicted the file by 3 sigma kept the right file's k_phi
    0.0168 there against the drive's 0.0162: beta RMSE 0.172 deg; 0.134 with the two
    weighted, 0.102 with the drive's alone (the limit slalom is that sensitive; the other 15
    scenarios of the comparison do not inform it or agree with the file)."""
    if not np.isfinite(wx).any():
        return k_phi_file, {}
    # a file without the roll model (no roll stiffness, CG or roll-axis height) leaves the
    # drive's own gradient unopposed
    file_g = k_phi_file / (1.0 + G * k_phi_file) if k_phi_file > 0.0 else math.nan
    speed = np.abs(vehicle_speed(drive))
    drive_g = identify_roll_gradient_from_gyro(drive.t, wx, ay, np.nan_to_num(speed))
    used = drive_g.combined(file_g, ROLL_FILE_REL_SIGMA)
    if not used.applied:
        source = "vehicle file" if k_phi_file > 0.0 else "none (the file has no roll model)"
    else:
        source = "drive and vehicle file" if k_phi_file > 0.0 else "identified"
    params = {
        "roll_gradient_source": source,
        "roll_gradient_identified_rad_per_m_s2": drive_g.value if math.isfinite(drive_g.value) else None,
        "roll_gradient_identified_sigma": drive_g.sigma if math.isfinite(drive_g.sigma) else None,
        "roll_gradient_file_rad_per_m_s2": file_g if math.isfinite(file_g) else None,
        "roll_gradient_used_rad_per_m_s2": used.value if used.applied else None,
        "roll_gradient_note": used.note,
    }
    if not used.applied:
        return k_phi_file, params
    return used.value / (1.0 - G * used.value), params


def axle_geometry(vehicle: Vehicle) -> tuple[FloatArray, float, dict[str, str]]:
    """``[l_f, l_r, C_f/m, C_r/m, g l_r/L, g l_f/L]``, ``I_z/m`` (m^2) and notes on what was
    assumed where the vehicle file lacks a value."""
    notes: dict[str, str] = {}
    lf, lr = float(vehicle.lf), float(vehicle.lr)
    wb = lf + lr
    if not vehicle.missing(["mass", "cr"]):
        cr_m = vehicle.cr / vehicle.mass
    else:
        k, note = slip_gain_k(vehicle)
        cr_m = lf / (wb * k)  # K = m l_f / (L C_r)
        notes["rear_stiffness"] = note
    if not vehicle.missing(["mass", "cf"]):
        cf_m = vehicle.cf / vehicle.mass
    else:
        kus, note = understeer_gradient(vehicle)
        cf_m = lr / max(wb * kus + lf / cr_m, 1e-6)  # K_us = (m / L)(l_r / C_f - l_f / C_r)
        notes["front_stiffness"] = note
    if not vehicle.missing(["mass", "yaw_inertia"]):
        iz_m = vehicle.yaw_inertia / vehicle.mass
    else:
        iz_m = lf * lr  # dynamic index k^2 / (l_f l_r) = 1 (Milliken & Milliken 1995, ch. 5)
        notes["yaw_inertia"] = "assumed I_z = m l_f l_r (dynamic index 1); the vehicle file gives none"
    geom = np.array([lf, lr, cf_m, cr_m, G * lr / wb, G * lf / wb])
    return geom, iz_m, notes


def _window_mean(v: FloatArray, idx: NDArray[np.intp]) -> FloatArray:
    """Mean of the finite samples of ``v`` in rows (idx[j-1], idx[j]] (NaN where none)."""
    ok = np.isfinite(v)
    cs = np.concatenate(([0.0], np.cumsum(np.where(ok, v, 0.0))))
    cn = np.concatenate(([0], np.cumsum(ok)))
    lo = np.concatenate(([0], idx[:-1] + 1))
    hi = idx + 1
    s, c = cs[hi] - cs[lo], cn[hi] - cn[lo]
    return np.where(c > 0, s / np.maximum(c, 1), np.nan)


def _gnss(drive: Drive, nz: FusedSettings, doppler_latency_s: float = 0.0) -> dict[str, Any]:
    """The GNSS samples of the drive from the GNSS layer (:mod:`sideslip.gnss`): ``rows``, the
    rows with a fix and/or a Doppler velocity, and at those rows ``gnss_e/n`` with their
    1-sigma ``pstd`` (the white part of the error, at least 0.2 m: the Gauss-Markov states
    carry the slow part) and ``gnss_ve/vn`` with ``vstd`` (at least 0.02 m/s), NaN where the
    epoch lacks that measurement; ``has_pos`` / ``has_vel``.  With ``doppler_latency_s`` every
    epoch (Doppler and fix: one receiver, one time tag) sits at the row nearest its stamp less
    that latency, so that fixes and velocities stay on the same rows (nodes)."""
    pos = gnss.position_samples(drive, nz.gnss_pos_sigma, 0.2)
    vel = gnss.doppler_samples(drive, nz.gnss_vel_sigma, 0.02)
    if doppler_latency_s != 0.0 and vel.rows.size:
        t = drive.t

        def earlier(rows: NDArray[np.intp]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
            when = t[rows] - doppler_latency_s
            at = np.clip(np.searchsorted(t, when), 1, t.size - 1)
            at = np.where(when - t[at - 1] < t[at] - when, at - 1, at)
            return np.unique(at, return_index=True)

        rows_v, first = earlier(vel.rows)
        vel = gnss.VelocitySamples(rows_v, vel.ve[first], vel.vn[first], vel.sigma[first], vel.source)
        if pos.rows.size:
            rows_p, first = earlier(pos.rows)
            pos = gnss.PositionSamples(rows_p, pos.e[first], pos.n[first], pos.sigma[first])
    rows = np.union1d(pos.rows, vel.rows)
    out: dict[str, Any] = {"rows": rows, "has_pos": pos.rows.size > 0, "has_vel": vel.rows.size > 0}
    for names, smp in ((("gnss_e", "gnss_n", "pstd"), (pos.e, pos.n, pos.sigma)),
                       (("gnss_ve", "gnss_vn", "vstd"), (vel.ve, vel.vn, vel.sigma))):  # fmt: skip
        at = np.searchsorted(rows, pos.rows if names[0] == "gnss_e" else vel.rows)
        for name, values in zip(names, smp, strict=True):
            col = np.full(rows.size, np.nan)
            col[at] = values
            out[name] = col
    return out


def _doppler_latency(
    drive: Drive, nz: FusedSettings, params: dict[str, Any],
    geometry: tuple[float, float, float] = (0.0, 0.0, 0.0), timing: DopplerTiming | None = None,
) -> tuple[float, float]:
    """The GNSS Doppler's latency (s) the epochs are taken with, and the 1-sigma of what may
    remain: the tyre-free fits of :func:`sideslip.gnss_latency.identify_doppler_latency` (speed
    against the wheels, course rate against the lateral accelerometer; ``geometry`` the antenna
    ahead of and above the IMU and the CG's distance to the rear axle, m), applied where they
    decide it (:func:`sideslip.doppler_timing.choose_doppler_latency`, with the prior
    N(0, ``doppler_latency_prior_sigma_s``) where they do not: slalom_low_mu 100 ms late reads
    +0.095 +- 0.016 s, kept at 0 before 2026-12-07 with sigma 0.088 s, now applied).  ``(0,
    0)`` when switched off.  ``timing``: the epochs' timing decided elsewhere (the tyres'
    profile of a latency the fits leave open, :mod:`sideslip.methods.fused_latency`), taken
    instead of the fits' choice.

    A Doppler velocity stamped tau late lags the heading by r tau, which in a turn reads as
    sideslip: 50 ms cost step_steer 0.034 -> 0.445 deg beta RMSE with 19 % inside 2 sigma,
    urban_course 0.037 -> 0.336 (fused_accuracy.md)."""
    if not nz.identify_doppler_latency or "gnss_ve" not in drive:
        return 0.0, 0.0
    est = doppler_fit(drive, geometry)
    if timing is None:
        timing = choose_doppler_latency(est, nz.doppler_latency_prior_sigma_s)
    params["gnss_doppler_latency_note"] = timing.note
    if est is None:
        return timing.latency_s, timing.sigma_s
    params["gnss_doppler_latency_identified_s"] = est.latency_s
    params["gnss_doppler_latency_identified_sigma_s"] = est.sigma_s
    fits = {"speed": (est.speed_s, est.speed_sigma_s), "lateral": (est.lateral_s, est.lateral_sigma_s)}
    for key, (value, sigma) in fits.items():
        if math.isfinite(value) and math.isfinite(sigma):  # [latency, 1-sigma] of each fit
            params[f"gnss_doppler_latency_{key}_fit_s"] = [value, sigma]
    params["gnss_doppler_latency_s"] = timing.latency_s
    return timing.latency_s, timing.sigma_s


def _initial_state(drive: Drive, vw: FloatArray, nx: int, nz: FusedSettings) -> tuple[FloatArray, FloatArray]:
    x0 = np.zeros(nx)
    rows, course, _ = gnss_course(drive, min_speed=3.0)
    x0[IPSI] = course[0] if rows.size else 0.0
    if "gnss_ve" not in drive and "gnss_e" in drive and "gnss_n" in drive:
        # a course over 10 m of fixes, not the first two (gnss.course_from_fixes)
        fixes = gnss.course_from_fixes(drive)
        x0[IPSI] = fixes[0] if fixes is not None else x0[IPSI]
    if "gnss_e" in drive and "gnss_n" in drive:
        ok = np.flatnonzero(np.isfinite(drive["gnss_e"]) & np.isfinite(drive["gnss_n"]))
        if ok.size:
            x0[IE], x0[IN] = drive["gnss_e"][ok[0]], drive["gnss_n"][ok[0]]
    first_v = vw[np.isfinite(vw)]
    x0[IVX] = float(first_v[0]) if first_v.size else 0.0
    x0[ISW] = 1.0
    x0[ISF] = x0[ISR] = 1.0
    x0[IMU] = nz.mu_prior
    # gyro bias prior 0.1 rad/s (5.7 deg/s): raw phone gyros carry several deg/s (comma2k19: 3.9)
    sig = np.zeros(nx)
    sig[:NX_CORE] = [
        10.0, 10.0, math.radians(10.0), 1.0, 0.5, 0.1, 0.5, 0.5, 0.02, 0.02, 1.5, 1.5,
        nz.stiffness_prior_sigma, nz.stiffness_prior_sigma, nz.mu_prior_sigma,
    ]  # fmt: skip
    if nx > NX_CORE:
        sig[ITAU] = nz.latency_prior_sigma_s
        sig[ILX] = sig[ILY] = nz.lever_prior_sigma_m
    return x0, np.diag(sig**2)


def _filled_inputs(
    drive: Drive, smooth: bool, v_held: FloatArray, min_speed: float, ax_tau_s: float
) -> dict[str, FillResult]:
    """The IMU inputs with their gaps filled (:func:`_imu`, :func:`_yaw_rate_input`,
    :func:`_lateral_fill`) and ``"lat"``, the lateral kinematic residual a_y - v w_z with its
    gaps (v_y's input error in a gap: the fills of a_y and w_z err together,
    sideslip.models.fused_process.U_QLAT); a drive without ``ax`` gets the speed's rate
    (:func:`_speed_rate`, time constant ``ax_tau_s``).  One function for the node pass and a
    long drive's rebuilt rows, so both read the same bits."""
    filled = {c: _imu(drive, c, smooth) for c in ("wx", "wy", "ax", "ay")}
    if not _has_ax(drive):
        filled["ax"] = filled["ax"]._replace(values=_speed_rate(drive, smooth, ax_tau_s))
    filled["wz"] = _yaw_rate_input(drive, smooth, v_held, min_speed)
    if filled["ay"].sigma.any() or filled["wz"].sigma.any():
        filled["lat"] = fill_input(drive.t, drive["ay"] - v_held * drive["wz"], interpolate=smooth)
        filled["ay"] = _lateral_fill(drive["ay"], drive["wz"], filled["ay"], filled["lat"], v_held)
    else:  # no gap in either: none in their difference
        filled["lat"] = filled["ay"]
    return filled


def _has_ax(drive: Drive) -> bool:
    """Whether the drive has a longitudinal accelerometer with at least one sample."""
    return "ax" in drive and bool(np.isfinite(drive["ax"]).any())


def _speed_rate(drive: Drive, smooth: bool, tau: float) -> FloatArray:
    """The speed's rate of change (m/s^2) on every row, the longitudinal input of a drive
    without ``ax`` (a yaw-rate / lateral-acceleration sensor cluster, common on CAN): the
    speed samples (:func:`sideslip.signals.speed_raw`) interpolated (smoother) or held (causal
    filter), differenced, and low-passed with time constant ``tau`` s (zero-phase off-line,
    causal in the filter; the low-pass of a held staircase's differences keeps its integral,
    the speed).  It is v_x' itself, not the specific force a_x = v_x' - r v_y + g sin(pitch)
    an accelerometer reads: the process model drops its r v_y term for it
    (``fused_engine.C_AX_SPEED_RATE``), and the grade's part is left to the state's
    longitudinal offset c_x, as an accelerometer's bias is.  Rows before the first speed
    sample hold that sample (no step from 0).  Without it the input was 0, which the process model took as
    exact: the Revs lap without its ax column, fused_filter 23.4 deg RMSE (35 % inside 2 sigma),
    the race lap with Doppler, fused 0.52 deg (FusedSettings.ax_from_speed_tau_s)."""
    raw = speed_raw(drive)
    t = drive.t
    if raw is None or np.isfinite(raw).sum() < 2:
        return np.zeros(t.size)
    ok = np.isfinite(raw)
    if smooth:
        v = np.interp(t, t[ok], raw[ok])
        return _zero_phase_low_pass(t, _backward_rate(t, v), tau)
    v = hold(raw, t, fill=float(raw[ok][0]))[0]
    return _low_pass(t, _backward_rate(t, v), tau)


def _lateral_fill(
    ay_raw: FloatArray, wz_raw: FloatArray, ay: FillResult, lat: FillResult, v: FloatArray
) -> FillResult:
    """The lateral accelerometer's gaps filled through the kinematic relation a_y = v_dot_y +
    v_x r where the yaw gyro has its sample: the residual a_y - v w_z (``lat``: held by the
    causal filter, interpolated by the smoother, as v_y's gap noise reads it) plus the speed
    times the measured yaw rate; where the gyro has a gap too, a_y's own fill.  In a slalom a_y
    reverses within half a second while the residual (v_y's rate) stays small, so holding a_y
    itself fed v_y the whole swing: cr_limit_slalom without GNSS with 0.5 s holes in a_y, w_z
    and a_x, fused_filter's v_y ran to -9.5 m/s in one hole (beta RMSE 12.0 -> 0.65 deg).  A
    race car's turn-in can hold 8 m/s^2 in the residual for a few tenths of a second, which a
    held residual keeps (race lap without GNSS, the same holes: fused_filter 0.365 -> 0.599;
    a window mean of it instead: 0.41 there but 1.19 on the slalom).  The fill's 1-sigma is the
    residual's."""
    gap = ~np.isfinite(ay_raw) & np.isfinite(wz_raw)
    values, sigma = ay.values.copy(), ay.sigma.copy()
    values[gap] = lat.values[gap] + v[gap] * wz_raw[gap]
    sigma[gap] = lat.sigma[gap]
    return FillResult(values, sigma, ay.gap_s)


def _steer_gyro_prior(
    zero: Fitted, x0: FloatArray, P0: FloatArray, notes: dict[str, str], max_sigma: float
) -> None:
    """The gyro-bias state's prior from the drive's steering relation ``zero``
    (:func:`sideslip.calibrate.steer_yaw.steer_gyro_zero`, FusedSettings.steer_gyro_prior)
    where its 1-sigma is at most ``max_sigma`` (rad/s), in place; ``notes["gyro_bias_prior"]``
    says what was taken or why not."""
    if not zero.informed:
        notes["gyro_bias_prior"] = f"0 +- {math.sqrt(P0[IBG, IBG]):g} rad/s (settings): {zero.note}"
        return
    if zero.sigma > max_sigma:
        notes["gyro_bias_prior"] = (
            f"0 +- {math.sqrt(P0[IBG, IBG]):g} rad/s (settings): the steering's zero {zero.value:.4f} +- "
            f"{zero.sigma:.4f} rad/s is wider than FusedSettings.steer_gyro_prior_max_sigma"
        )
        return
    x0[IBG] = zero.value
    P0[IBG, IBG] = min(zero.sigma, math.sqrt(P0[IBG, IBG])) ** 2
    notes["gyro_bias_prior"] = (
        f"{zero.value:.4f} +- {math.sqrt(P0[IBG, IBG]):.4f} rad/s from the drive's steering ({zero.source})"
    )


def _gyro_zero_disagreement(
    series: dict[str, FloatArray],
    params: dict[str, Any],
    zero: Fitted,
    lr: float,
    min_speed: float,
    bias_rows: tuple[FloatArray, FloatArray] | None = None,
) -> None:
    """Widen ``beta_std`` where the estimate's gyro bias and the steering's zero ``zero``
    disagree beyond both 1-sigmas (a consistency test between cues, issue 15 point 3).
    ``bias_rows``: the causal filter's bias and its 1-sigma on every row (each row tested
    against the zero with what the filter knew then); None: the smoother's one bias and
    sigma of the params.

    Without GNSS the smoother reads the bias from the kinematic relation, where a lateral
    offset over the speed (a bank the drive starts on, an accelerometer bias) reads the same;
    the steering tells them apart but at one speed only to v sigma(delta_0) / L, too wide to be
    the prior (FusedSettings.steer_gyro_prior_max_sigma).  A bias error db enters the rear
    slip as l_r db / v; the disagreement beyond the two sigmas (as the calibration widens a
    fit by its halves' spread, :func:`sideslip.calibrate.fit.halves_sigma`) is taken as that
    db.  dlc_bank from 10 s (16 deg bank at the start, no GNSS): smoother -0.11 rad/s, steering
    -0.009 +- 0.029.  The causal filter on that clip ends at -0.110 +- 0.023 rad/s too, and
    its beta at 0.43 deg RMSE had 58 % of its errors inside 2 sigma, 100 % with this term."""
    params["gyro_bias_steering_rad_s"] = [zero.value, zero.sigma]
    if bias_rows is None:
        b, b_sigma = float(params["gyro_bias_rad_s"]), float(params["gyro_bias_rad_s_sigma"])
        excess = np.asarray((b - zero.value) ** 2 - b_sigma**2 - zero.sigma**2)
    else:
        excess = (bias_rows[0] - zero.value) ** 2 - bias_rows[1] ** 2 - zero.sigma**2
    if not (excess > 0.0).any():
        return
    slip = lr * np.sqrt(np.maximum(excess, 0.0)) / np.maximum(np.abs(series["vx"]), min_speed)
    series["beta_std"] = np.hypot(series["beta_std"], slip)
    params["beta_std_gyro_zero_disagreement_deg"] = float(np.degrees(np.sqrt(np.mean(slip**2))))


def _process_psd(nx: int, nz: FusedSettings) -> FloatArray:
    q = np.zeros(nx)
    q[IBG] = nz.gyro_bias_psd**2
    q[ICY] = nz.cy_psd**2
    q[ICX] = nz.cx_psd**2
    q[ISW] = nz.wheel_scale_psd**2
    q[ISG] = nz.gyro_scale_psd**2
    # q[IPE], q[IPN]: the exact Gauss-Markov variance per step, in the engine
    q[IE] = q[IN] = 1e-4
    q[ISF] = q[ISR] = nz.stiffness_psd**2
    q[IMU] = nz.mu_psd**2
    if nx > NX_CORE:
        q[ITAU] = nz.latency_psd**2
        q[ILX] = q[ILY] = nz.lever_psd**2
    return q


def _config(
    nz: FusedSettings, k_phi: float, calibrate: bool, has_vel: bool, fix_rate_hz: float = 1.0
) -> FloatArray:
    cfg = np.zeros(eng.N_CFG)
    cfg[eng.C_WHEEL_SIGMA] = nz.wheel_sigma
    cfg[eng.C_STILL_SPEED] = nz.standstill_speed
    cfg[eng.C_GYRO_NOISE] = nz.gyro_standstill_sigma
    cfg[eng.C_ACCEL_VRW] = nz.accel_vrw_psd
    cfg[eng.C_GYRO_ARW] = nz.gyro_arw_psd
    cfg[eng.C_GM_TAU] = nz.gnss_gm_tau_s
    cfg[eng.C_GM_SIGMA] = nz.gnss_gm_sigma
    cfg[eng.C_GATE] = nz.gate_chi2
    cfg[eng.C_GATE_GNSS] = nz.gnss_gate_chi2
    cfg[eng.C_GNSS_RESET] = nz.gnss_reject_reset_s
    cfg[eng.C_AXLE_TAU] = nz.axle_error_tau_s
    cfg[eng.C_WHEEL_REL] = nz.wheel_rel_sigma
    cfg[eng.C_WHEEL_SLIP_STIFFNESS] = nz.wheel_slip_stiffness
    if not calibrate and not has_vel:  # positions only, calibration not identified
        cfg[eng.C_POS_LEVER] = nz.lever_prior_sigma_m
        cfg[eng.C_POS_LATENCY] = nz.latency_prior_sigma_s
        cfg[eng.C_POS_BIAS_FIXES] = max(1.0, fix_rate_hz * nz.gnss_offset_span_s)
    cfg[eng.C_FORCE_SIGMA] = nz.force_sigma
    cfg[eng.C_FORCE_REL] = nz.force_rel
    cfg[eng.C_ADAPT_TAU] = nz.adapt_tau_s
    cfg[eng.C_AXLE_MIN_SPEED] = nz.axle_min_speed
    cfg[eng.C_LOW_SPEED_SIGMA] = nz.low_speed_sigma if nz.low_speed_axle else 0.0
    cfg[eng.C_CG_SIGMA] = nz.cg_sigma_m
    cfg[eng.C_K_PHI] = k_phi
    cfg[eng.C_STIFF_CURVE] = nz.stiffness_curve_accel
    cfg[eng.C_ADAPT_MAX] = nz.adapt_max
    cfg[eng.C_MU_UTIL] = nz.mu_utilisation
    cfg[eng.C_MU_FLOOR_SIGMA] = nz.mu_floor_sigma
    cfg[eng.C_VCHECK_ACCEL] = nz.doppler_check_accel_sigma if nz.doppler_check else 0.0
    cfg[eng.C_VCHECK_GATE] = nz.doppler_check_chi2
    cfg[eng.C_VCHECK_TAU] = nz.doppler_check_tau_s
    cfg[eng.C_VCHECK_RAMP_TAU] = nz.doppler_check_bank_tau_s
    cfg[eng.C_SUSPECT_HOLD] = 1.0 if nz.doppler_check_holds_tyres else 0.0
    return cfg


def _accel_offset(
    drive: Drive, vehicle: Vehicle, nz: FusedSettings, smooth: bool, has_vel: bool,
    smoother: Estimate | None,
) -> AccelOffset:  # fmt: skip
    """The lateral reading's offset for the axle forces (:mod:`.fused_accel_offset`): with
    GNSS Doppler and ``identify_accel_offset``; the causal filter only with
    ``whole_drive_calibration`` (a calibration read from the whole drive), and from the
    smoother's run where it has one."""
    prior = nz.accel_offset_sigma
    if not nz.identify_accel_offset:
        return AccelOffset(0.0, prior, False, "off (FusedSettings.identify_accel_offset)")
    if not has_vel:
        return AccelOffset(0.0, prior, False, "no GNSS Doppler: the curves' heading closure is not measured")
    if not smooth and not nz.whole_drive_calibration:
        return AccelOffset(0.0, prior, False, "causal without whole_drive_calibration")
    if smoother is not None and "accel_offset_y_m_s2" in smoother.params:
        p = smoother.params
        scan = p["accel_offset_y_scan_m_s2"]
        return AccelOffset(
            float(p["accel_offset_y_m_s2"]), float(p["accel_offset_y_m_s2_sigma"]),
            bool(p["accel_offset_y_informed"]), str(p["accel_offset_y_note"]),
            None if scan is None else (float(scan[0]), float(scan[1])),
        )  # fmt: skip
    return lateral_accel_offset(drive, vehicle, prior)


def fuse(drive: Drive, vehicle: Vehicle, smooth: bool, settings: FusedSettings | None = None) -> Estimate:
    """Run the fused EKF (and RTS smoother when ``smooth``); see the module docstring."""
    nz = settings or FusedSettings()
    if smooth:
        return _checked_smoother(drive, vehicle, nz).est
    # the causal filter takes the installation (antenna, IMU, both) the smoother's checks find
    # (a calibration read from the whole drive, as its noise levels are): the checks need the
    # smoother's later samples, so the smoother runs first
    if not (
        nz.whole_drive_calibration and nz.check_doppler_lever
        and not nz.identify_doppler_lever and "gnss_ve" in drive and "gnss_e" in drive
    ):  # fmt: skip
        return _fuse(drive, vehicle, False, nz)
    smoother_lever, spread, timing = _checked_smoother(drive, vehicle, nz)
    p = smoother_lever.params
    box = float(p.get("box_x_applied_m") or 0.0)
    imu_x = float(p.get("imu_lever_x_applied_m") or 0.0) + float(p.get("box_imu_x_m") or 0.0)
    vehicle = imu_moved(vehicle, imu_x)
    if box:
        x, y, z = (float(c) for c in vehicle.gnss_xyz)
        vehicle = dataclasses.replace(vehicle, gnss_xyz=(x + box, y, z))
    est = _fuse(drive, vehicle, False, nz, smoother_lever, doppler_timing=timing)
    if spread is not None:
        series = {**est.series, "beta_std": np.hypot(est.series["beta_std"], spread)}
        est = dataclasses.replace(est, series=series)
    return est


class _Checked(NamedTuple):
    """The smoother's estimate after its checks; the slip (rad per row) their doubt adds to
    ``beta_std`` (None: nothing); the Doppler timing they took (None: the tyre-free fits')."""

    est: Estimate
    spread: FloatArray | None
    timing: DopplerTiming | None


def _checked_smoother(drive: Drive, vehicle: Vehicle, nz: FusedSettings) -> _Checked:
    """The smoother on the installation and the Doppler timing its checks settle on; and the
    slip (rad per row) that the checks' doubt adds to ``beta_std`` (None: nothing added).

    First the antenna against the IMU, and the Doppler's latency where the tyre-free fits
    leave it open (:func:`_imu_checked`), then both together from the slow turns
    (:mod:`sideslip.methods.fused_box`): where those put the antenna beyond the gate,
    antenna and IMU move by it and the smoother runs once more (its antenna pass off:
    the place of the two against each other is the first check's), and the slow turns'
    sigma joins ``beta_std`` as ``sigma r / v``.  Without slow turns the tyres' profile of the
    box (:func:`_box_profile`) moves the two the same way where it decides, and otherwise its
    doubt joins ``beta_std`` the same way."""
    est, spread, timing = _imu_checked(drive, vehicle, nz)
    if not (nz.check_box_lever and nz.check_doppler_lever):
        # the box check moves antenna and IMU as the relative check left them: without that
        # check their place against each other is not known
        return _Checked(est, spread, timing)
    # the installation the checks settled on, and the relative offset none of them took
    p = est.params
    imu_x = float(p.get("imu_lever_x_applied_m") or 0.0)
    ant_x = float(p.get("gnss_lever_x_applied_m") or 0.0)
    settled = imu_moved(vehicle, imu_x)
    x, y, z = (float(c) for c in settled.gnss_xyz)
    settled = dataclasses.replace(settled, gnss_xyz=(x + ant_x, y, z))
    unresolved = 0.0
    if p.get("gnss_lever_x_neg2ll") is not None and not (imu_x or ant_x):
        unresolved = float(p["gnss_lever_x_tyre_free_m"])
    box = antenna_from_slow_turns(
        drive, settled, est, nz.box_speed_min_m_s, nz.box_speed_max_m_s, nz.box_accel_max_m_s2,
        nz.box_block_s, nz.box_min_blocks, nz.doppler_lever_z,
        float(p.get("gnss_doppler_latency_s") or 0.0),
    )  # fmt: skip
    extra: dict[str, Any] = box.params()
    note = box.note()
    # no slow turns: the Doppler with the tyres profiles the box (fused_box_profile)
    bursts = int(p.get("gnss_doppler_burst_epochs") or 0)
    # the profile keeps between antenna and IMU the offset the tyre-free pass read where no
    # check moved either, beyond the pass's gate or not (fused_box_profile.profile_box)
    pair = unresolved
    read = p.get("gnss_lever_x_tyre_free_m")
    if read is not None and math.isfinite(float(read)) and not (imu_x or ant_x):
        pair = float(read)
    profile = None
    if not math.isfinite(box.sigma_m):
        profile = _box_profile(drive, settled, nz, timing, bursts, pair)
    if profile is not None:
        extra.update(profile.params())
        note = f"{note}; {profile.note()}"
    if box.applied or (profile is not None and profile.applied):
        # the antenna by d; the IMU by d less the relative offset the tyre-free pass found
        # (the slow turns) or read (the profile) and no check took: antenna and IMU keep the
        # place against each other the pass saw, as the profile scored them
        if box.applied:
            d, sigma_m, imu_d = box.d_m, box.sigma_m, box.d_m - unresolved
        else:
            assert profile is not None
            d, sigma_m, imu_d = profile.d_m, profile.spread_m, profile.d_m - pair
        x, y, z = (float(c) for c in settled.gnss_xyz)
        moved = imu_moved(dataclasses.replace(settled, gnss_xyz=(x + d, y, z)), imu_d)
        nz_box = dataclasses.replace(nz, check_doppler_lever=False)
        est = _fuse(drive, moved, True, nz_box, doppler_timing=timing)
        extra["box_x_applied_m"] = d
        extra["box_imu_x_m"] = imu_d
        # the place is known to its sigma: r sigma / v of slip
        slip = _box_slip(est, sigma_m, nz)
        spread = slip if spread is None else np.hypot(spread, slip)
        series = {**est.series, "beta_std": np.hypot(est.series["beta_std"], spread)}
        est = dataclasses.replace(est, series=series)
    elif profile is not None and profile.spread_m > 0.0:
        # kept where the file says, as doubtful as the profile leaves it (est's beta_std
        # already carries the first checks' spread)
        slip = _box_slip(est, profile.spread_m, nz)
        spread = slip if spread is None else np.hypot(spread, slip)
        series = {**est.series, "beta_std": np.hypot(est.series["beta_std"], slip)}
        est = dataclasses.replace(est, series=series)
    # the first checks' findings stay in the params (the run above had them switched off)
    kept = ("gnss_lever_x_", "imu_lever_x_", "gnss_doppler_latency_tyres_")
    params = {**est.params, **{k: v for k, v in p.items() if k.startswith(kept)}}
    params.update(extra)
    first = {k: p["assumed"][k] for k in ("gnss_lever_x", "imu_lever_x") if k in p["assumed"]}
    params["assumed"] = {**est.params["assumed"], **first, "box_x": note}
    return _Checked(dataclasses.replace(est, params=params), spread, timing)


def _box_slip(est: Estimate, sigma_m: float, nz: FusedSettings) -> FloatArray:
    """The slip (rad per row) of a box place known to ``sigma_m``: ``sigma r / v``."""
    return sigma_m * np.abs(est.series["r"]) / np.maximum(np.abs(est.series["vx"]), nz.axle_min_speed)


def _box_profile(
    drive: Drive,
    vehicle: Vehicle,
    nz: FusedSettings,
    timing: DopplerTiming | None,
    bursts: int,
    pair: float,
) -> BoxProfile | None:
    """The tyres' profile of the box's place (:mod:`sideslip.methods.fused_box_profile`):
    the antenna of ``vehicle`` (the installation the first checks settled on) moved by ``d``
    and its IMU by ``d - pair`` (the antenna's offset from the IMU that the tyre-free pass
    read and no check took), each place scored by a smoother run that stops at its
    Doppler ``-2 log L``, with the Doppler's checks off as in :func:`_latency_profile`
    (``bursts``: the epochs the file's run found in multipath bursts, which then score too);
    None where switched off or the drive has no Doppler to score."""
    if not nz.profile_box_lever or "gnss_ve" not in drive:
        return None
    nz_score = dataclasses.replace(nz, check_doppler_lever=False, doppler_check=False)

    def score(d: float, imu_d: float) -> float:
        x, y, z = (float(c) for c in vehicle.gnss_xyz)
        moved = imu_moved(dataclasses.replace(vehicle, gnss_xyz=(x + d, y, z)), imu_d)
        run = _fuse(drive, moved, True, nz_score, score_doppler=True, doppler_timing=timing, score_only=True)
        return float(run.params.get("gnss_doppler_neg2ll", math.nan))

    at_file = score(0.0, 0.0)
    if not math.isfinite(at_file):
        return None
    return profile_box(
        lambda d: score(d, d - pair), at_file, nz.box_profile_step_m, nz.box_profile_max_m,
        nz.doppler_lever_z, bursts, None if pair == 0.0 else score(0.0, -pair),
    )  # fmt: skip


def _latency_left_open(drive: Drive, vehicle: Vehicle, nz: FusedSettings) -> LatencyEstimate | None:
    """The tyre-free fit of the Doppler's latency where it leaves the latency open (not
    applied, and not decisive that it is on time: :func:`choose_doppler_latency`), so that the
    tyres' profile is asked (``profile_doppler_latency``); None otherwise."""
    if not (nz.profile_doppler_latency and nz.identify_doppler_latency and "gnss_ve" in drive):
        return None
    fit = doppler_fit(drive, antenna_geometry(vehicle))
    timing = choose_doppler_latency(fit, nz.doppler_latency_prior_sigma_s)
    if fit is None or timing.latency_s != 0.0 or fit.sigma_s <= DECISIVE_SIGMA_S:
        return None
    return fit


def _latency_profile(
    drive: Drive, vehicle: Vehicle, nz: FusedSettings, fit: LatencyEstimate
) -> LatencyProfile | None:
    """The tyres' profile of the Doppler's latency (:mod:`sideslip.methods.fused_latency`):
    each latency, the stamps' too, scored by a smoother run that stops at its Doppler
    ``-2 log L`` (the antenna check off: the file's installation).  The Doppler's own check
    against the inertial propagation is off in these runs: it lets different epochs in at
    different latencies, and their ``-2 log L`` are then not of the same data (urban_highway
    seed 2, on time, with 108 multipath epochs: 141 lower at 31 ms with the check, rising
    from the stamps without it)."""
    nz_score = dataclasses.replace(nz, check_doppler_lever=False, doppler_check=False)

    def score(tau: float) -> float:
        timing = DopplerTiming(tau, 0.0, "scored by the tyres' profile", fit)
        run = _fuse(
            drive, vehicle, True, nz_score, score_doppler=True, doppler_timing=timing, score_only=True
        )
        return float(run.params["gnss_doppler_neg2ll"])

    return profile_latency(
        score, score(0.0), fit, nz.latency_profile_sigmas, nz.latency_profile_step_s,
        nz.latency_profile_points, nz.doppler_lever_z,
    )  # fmt: skip


def _imu_checked(drive: Drive, vehicle: Vehicle, nz: FusedSettings) -> _Checked:
    """The smoother with its antenna check, the IMU alternative and a late Doppler.

    Where the smoother's tyre-free check put the antenna off the file's by ``dl_x``
    (:mod:`sideslip.methods.fused_lever`), the kinematics have said only that the antenna
    sits ``dl_x`` further ahead *of the IMU* than the file says: the IMU ``dl_x`` behind its
    file place explains the same.  The smoother is run twice more, with the antenna moved in
    the file and with the IMU moved (each with the noise it identifies itself, as the file's
    installation had), and their Doppler likelihoods with the tyres decide
    (:class:`sideslip.methods.fused_lever.ImuAlternative`).

    Where the tyre-free fits leave the Doppler's latency open (:func:`_latency_left_open`),
    the tyres' profile of it (:func:`_latency_profile`) is one more explanation: tyre-free,
    a Doppler ``tau`` late reads in turns as an antenna ``v tau`` behind.  Where it lowers the
    Doppler's ``-2 log L`` below the stamps' by the gate and beats every installation, the
    epochs are taken at that latency with the file's installation."""
    open_fit = _latency_left_open(drive, vehicle, nz)
    est = _fuse(drive, vehicle, True, nz, score_doppler=open_fit is not None)
    p = est.params
    pair = p.get("gnss_lever_x_neg2ll")
    profile = None
    late: Estimate | None = None
    if open_fit is not None and "gnss_doppler_neg2ll" in p:
        profile = _latency_profile(drive, vehicle, nz, open_fit)
        if profile is not None and profile.found:
            late = _fuse(drive, vehicle, True, nz, score_doppler=True, doppler_timing=profile.timing())
    gate = nz.doppler_lever_z**2
    runs: dict[str, Estimate]
    if nz.check_imu_lever and pair is not None:
        dl = float(p["gnss_lever_x_tyre_free_m"])
        x, y, z = (float(c) for c in vehicle.gnss_xyz)
        moved = dataclasses.replace(vehicle, gnss_xyz=(x + dl, y, z))
        antenna = _fuse(drive, moved, True, nz, score_doppler=True)
        alt = _fuse(drive, imu_moved(vehicle, -dl), True, nz, score_doppler=True)
        verdict = ImuAlternative(
            dl, float(pair[0]), float(antenna.params["gnss_doppler_neg2ll"]),
            float(alt.params["gnss_doppler_neg2ll"]), bool(p["gnss_lever_x_applied_m"]),
            nz.doppler_lever_z,
            math.inf if late is None else float(late.params["gnss_doppler_neg2ll"]),
        )  # fmt: skip
        # the estimate of each installation: the check's own run stands for the one it settled on
        runs = {"imu": alt, "antenna": est if verdict.antenna_applied else antenna, "file": est}
        if late is not None:
            runs["latency"] = late
        name, weights = verdict.chosen, verdict.weights()
        neg2ll = {"imu": verdict.neg2ll_imu, "antenna": verdict.neg2ll_antenna, "file": verdict.neg2ll_file}
        neg2ll["latency"] = verdict.neg2ll_latency
        extra: dict[str, Any] = verdict.params()
        notes = {"imu_lever_x": verdict.note()}
        del antenna, alt
    elif late is not None:
        # the file's installation (or the antenna the check moved) against the Doppler late
        n_est, n_late = float(p["gnss_doppler_neg2ll"]), float(late.params["gnss_doppler_neg2ll"])
        n_file = float(pair[0]) if pair is not None else n_est
        name = "latency" if (n_file - n_late > gate and n_late < n_est) else "file"
        runs = {"file": est, "latency": late}
        neg2ll = {"file": n_est, "latency": n_late}
        weights = likelihood_weights(neg2ll)
        extra, notes = {}, {}
    else:
        if profile is not None:
            est = dataclasses.replace(est, params={**p, **profile.params()})
        return _Checked(est, None, None)
    chosen = runs[name]
    beta = chosen.series["beta"]
    spread_sq = np.zeros_like(beta)
    for key, weight in weights.items():
        if key != name and runs[key] is not chosen:
            # a late Doppler against an installation: where the two are within the gate of
            # each other the tyres have not told them apart (imu:two_turns_gyro_sf, the IMU
            # 1 m ahead: the Doppler 36 ms late scored 5.5 below it), and the other's beta
            # counts in full; otherwise by its likelihood weight
            close = "latency" in (key, name) and neg2ll[key] - neg2ll[name] <= gate
            spread_sq += (1.0 if close else weight) * np.square(runs[key].series["beta"] - beta)
    del runs, est, late
    spread = np.sqrt(spread_sq)
    params = {**chosen.params, **extra}
    if profile is not None:
        params.update(profile.params())
        params["gnss_doppler_latency_tyres_weight"] = float(weights.get("latency", 0.0))
    params["assumed"] = {**chosen.params["assumed"], **notes}
    series = {**chosen.series, "beta_std": np.hypot(chosen.series["beta_std"], spread)}
    timing = profile.timing() if (profile is not None and name == "latency") else None
    return _Checked(dataclasses.replace(chosen, series=series, params=params), spread, timing)


def _fuse(
    drive: Drive,
    vehicle: Vehicle,
    smooth: bool,
    nz: FusedSettings,
    smoother_lever: Estimate | None = None,
    score_doppler: bool = False,
    doppler_timing: DopplerTiming | None = None,
    score_only: bool = False,
) -> Estimate:
    """:func:`fuse` with its settings; the causal filter with ``smoother_lever``, the
    smoother's estimate whose antenna check it takes; ``score_doppler``: the smoother
    reports the Doppler's ``-2 log L`` with the tyres at its final antenna
    (``params["gnss_doppler_neg2ll"]``), and with ``score_only`` returns as soon as it has it
    (an estimate without series); ``doppler_timing``: the Doppler epochs' timing decided
    by the caller (:func:`_doppler_latency`)."""
    if not smooth and not nz.whole_drive_calibration:
        # strictly on-line: the file's roll gain, the receiver's stamps, the prior noise and
        # c_y a random walk (the roll gyro's bias would need the whole drive)
        nz = dataclasses.replace(
            nz, identify_roll_gradient=False, identify_doppler_latency=False,
            identify_accel_vrw=False, roll_gyro_bank_with_doppler=False, identify_mu_causal=False,
        )  # fmt: skip
    t = drive.t
    n = len(drive)
    raw = speed_raw(drive)
    # signed: a drive whose wheel speeds carry the sign reverses correctly; one with magnitudes
    # only is taken as driving forwards (GNSS then disagrees, and the Huber weights limit harm)
    vw = np.full(n, np.nan) if raw is None else raw
    v_held = hold(vw, t)[0] if raw is not None else np.zeros(n)
    filled = _filled_inputs(drive, smooth, v_held, nz.axle_min_speed, nz.ax_from_speed_tau_s)
    wz, wx, wy = filled["wz"].values, filled["wx"].values, filled["wy"].values
    ax, ay = _accel_at_cg(
        drive, vehicle, wx, wy, wz, not smooth, filled["ax"].values, filled["ay"].values
    )
    # on a long drive the per-row IMU inputs are rebuilt after the node pass (the same
    # arithmetic, so the same bits) instead of held through it: 5 x 8 bytes a row less at the
    # pass's peak (the filtered covariances), a few ms per hour of drive
    rebuild = n > LONG_DRIVE_ROWS
    dop_params: dict[str, Any] = {}
    # the antenna ahead of and above the IMU, and the rear axle behind the CG (m)
    geometry = antenna_geometry(vehicle)
    doppler_latency = _doppler_latency(drive, nz, dop_params, geometry, doppler_timing)
    gn = _gnss(drive, nz, doppler_latency[0])
    has_pos, has_vel = bool(gn["has_pos"]), bool(gn["has_vel"])
    # latency and lever arm as states: on positions-only drives with identify_gnss_calibration;
    # with Doppler only with identify_doppler_lever (in steady turns r dl_x is
    # indistinguishable from v_y, so by default the file's lever arm is used)
    calibrate = has_pos and (nz.identify_doppler_lever if has_vel else nz.identify_gnss_calibration)
    nx = NX_CORE + (NX_GNSS_CAL if calibrate else 0)
    k_phi = roll_gain(vehicle)
    roll_params: dict[str, Any] = {}
    if nz.identify_roll_gradient:
        k_phi, roll_params = _drive_roll_gain(drive, vehicle, k_phi, wx, ay)
    geom, iz_m, notes = axle_geometry(vehicle)
    use_mu_fit = nz.identify_mu and (smooth or nz.identify_mu_causal)
    mu_fit = drive_friction(drive, vehicle, k_phi, nz.axle_curve_shape) if use_mu_fit else None
    axle = np.append(geom, nz.axle_curve_shape)  # the engine's axle vector (A_SHAPE last)
    # where the tyres alone carry the slip (no GNSS) the smoother learns the stiffness from
    # the transients, and there the axle forces must not lag the state: zero-phase low-pass
    # (forward and backward: no lag, it has the later samples) and the moment balance with the
    # yaw acceleration (without it the rear force leads the rear slip at turn-in).  Measured
    # without GNSS: step_steer 0.100 -> 0.019 deg, race_lap 0.115 -> 0.086, Revs lap 0.30 ->
    # 0.24; with GNSS (v_y measured) the same costs 4 % in the comparison's mean, so it is
    # left off there.  GNSS positions without Doppler measure v_y only in transients: on an
    # arc a constant error of the course draws the same track as a constant along-track offset
    # of the fixes (their latency, an antenna lever arm the file does not state, the slow
    # Gauss-Markov error), so there the tyres carry the slip as they do without GNSS
    # (``positions_only_tyres``; below, in the stiffness's learning, the bank and beta_std)
    tyres_carry = not has_vel and (not has_pos or nz.positions_only_tyres)
    tyres_only = smooth and tyres_carry and nz.tyres_only_transients
    # axle forces per mass from the force and moment balance (seed 003 eqs 1-2)
    # the causal filter keeps its floor (a time constant from the whole drive's noise would
    # read the future); the smoother's is raised where the drive's noise needs it, half as
    # much where its low-pass runs both ways (the noise passes it twice: Revs lap sampled at
    # 50 / 20 / 10 Hz, beta RMSE 0.388 / 0.467 / 0.619 -> 0.278 / 0.407 / 0.522 deg)
    # the accelerometer's noise from its own samples at their own spacing (the fills between
    # the samples of an IMU slower than the table are not samples: a 20 Hz IMU in a 100 Hz
    # table read 1/25 of its noise variance, the Revs lap 1.31 deg against 0.41 from a 20 Hz
    # table)
    ay_samples = np.where(np.isfinite(drive["ay"]), ay, np.nan)
    tau_f = (
        force_time_constant(t, ay_samples, nz.smoother_force_tau_s, nz, zero_phase=tyres_only)
        if smooth
        else nz.force_tau_s
    )
    # the smallest velocity random walk the drive can have: its accelerometer's white noise
    vrw_floor = accel_noise_sigma(ay_samples) * math.sqrt(sample_step(t, ay_samples)) if n > 1 else 0.0
    force_var = force_noise_variance(t, ay_samples, tau_f, nz, causal=not smooth)
    force_noise = float(np.sqrt(np.median(force_var))) if n else 0.0  # m/s^2, per relation
    imu_step = sample_step(t, ay_samples) if n > 1 else 0.0
    imu_rate_hz = 1.0 / imu_step if imu_step > 0 else math.inf
    # a gap's fill of the lateral reading is one error over the whole gap, in every axle
    # relation inside it: its variance quoted per axle_error_tau_s like the relations' own
    fa = filled["ay"]
    if fa.sigma.any():
        force_var = force_var + fa.sigma**2 * np.maximum(fa.gap_s / nz.axle_error_tau_s, 1.0)
    # and a gap's yaw rate is in the rear slip (v_y - l_r r) / v_x: C_r l_r / v_x times its
    # error in force (race lap without GNSS, eight 0.5 s holes in the gyro: fused_filter
    # 2.05 deg with 89 % inside 2 sigma without it)
    fw = filled["wz"]
    if fw.sigma.any():
        slip_force = geom[A_CR] * geom[A_LR] / np.maximum(np.abs(v_held), nz.axle_min_speed) * fw.sigma
        force_var = force_var + slip_force**2 * np.maximum(fw.gap_s / nz.axle_error_tau_s, 1.0)
    del v_held
    if has_pos and not has_vel:
        if tyres_carry:
            notes["gnss_positions_only"] = (
                "no Doppler: in arcs the tyres carry the slip (a course error and an along-track "
                "offset of the fixes draw the same track); the stiffness is learned where the "
                "lateral force changes" + ("" if smooth else " and in quasi-steady cornering")
            )
        if not calibrate:
            notes["gnss_latency_lever"] = (
                f"not identified: position noise of {nz.latency_prior_sigma_s:g} s x speed and "
                f"{nz.lever_prior_sigma_m:g} m (FusedSettings.identify_gnss_calibration)"
            )
    # the receiver's latency from the fixes' speed against the wheels (tyre-free:
    # sideslip.gnss_latency): each fix is taken at its stamp less the latency the estimate and
    # the prior N(0, latency_prior_sigma_s) give together (0 where the drive does not inform
    # it); the position noise keeps the prior's v x latency_prior_sigma_s, which also covers
    # an antenna the file misplaces along x (on an arc the same as a latency of -l_x / v).
    # Measured over 20 Hz fixes 0-0.15 s late with the antenna -0.5 / 0 / +0.5 m off
    # (benchmarks/results/gnss_latency.md): mean beta RMSE 0.252 -> 0.174 deg
    # (off-line only: the whole drive's speed would read the future in the causal filter)
    latency = None
    if smooth and has_pos and not has_vel and not calibrate and nz.identify_gnss_latency:
        latency = identify_latency(drive)
        if latency is not None:
            notes["gnss_latency_lever"] = (
                f"latency {latency.latency_s:.3f} +- {latency.sigma_s:.3f} s from the fixes' speed "
                f"against the wheels, used as {latency.posterior_mean(nz.latency_prior_sigma_s):.3f} s "
                f"(with the prior 0 +- {nz.latency_prior_sigma_s:g} s); lateral lever arm from the "
                "same fit (the antenna's speed in turns), used with the file's value as prior; "
                f"longitudinal lever arm not identified (tyre-free it is the slip's kinematic "
                f"part): {nz.lever_prior_sigma_m:g} m and {nz.latency_prior_sigma_s:g} s x speed "
                "of position noise"
            )
    lp = _zero_phase_low_pass if tyres_only else _low_pass
    # the reading's offset the tyres do not carry (bias, mounting roll): from the curves'
    # heading closure where the drive decides it (fused_accel_offset), else 0 and the prior
    offset_y = _accel_offset(drive, vehicle, nz, smooth, has_vel, smoother_lever)
    params_offset = offset_y.params()
    fy_lp = lp(t, (ay - offset_y.value) * suspension_factor(k_phi), tau_f)
    r_dot = _backward_rate(t, wz)
    r_dot_lp = lp(t, r_dot, tau_f) if (nz.yaw_acceleration or tyres_only) else np.zeros(n)
    wb = geom[0] + geom[1]
    f_front = (geom[1] * fy_lp + iz_m * r_dot_lp) / wb
    f_rear = (geom[0] * fy_lp - iz_m * r_dot_lp) / wb
    # the causal filter learns the stiffness in quasi-steady cornering only (the lateral force
    # changing slower than filter_steady_jerk_m_s3); the smoother sees both sides of a
    # transient and learns everywhere, except from positions alone: on an arc they cannot
    # tell the slip from an offset of the fixes (above), and a stiffness learned there takes
    # that offset for tyre slip (banked_track_turn, 20 Hz fixes 50 ms late, antenna 0.5 m off:
    # rear stiffness scale 0.36 +- 0.01 against a right file, beta RMSE 0.93 deg, 52 % inside
    # 2 sigma), so it learns where the lateral force changes, where the track answers a change
    # of slip within a second
    jerk = _low_pass(t, _backward_rate(t, fy_lp), tau_f)
    steady = np.abs(jerk) < nz.filter_steady_jerk_m_s3
    if smooth:
        steady = ~steady if (tyres_carry and has_pos) else np.ones(n, dtype=bool)
    # the friction the road must at least have to transmit the measured acceleration
    mu_floor = np.hypot(_low_pass(t, ax, tau_f), fy_lp) / G
    use_front = bool(nz.front_axle and "steer" in drive and np.isfinite(drive["steer"]).any())
    delta = _hold(drive, "steer") if use_front else np.full(n, np.nan)
    if not use_front:
        f_front = np.full(n, np.nan)
    # nodes: every stride-th row, every GNSS epoch (so that fixes and Doppler velocities are
    # applied at their own time) and, for the smoother, the last row
    stride = max(1, round(nz.step_s / drive.dt_median)) if nz.step_s > 0 and n > 1 else 1
    g_rows = gn["rows"]
    idx = np.arange(0, n, stride)
    if stride > 1:
        idx = np.union1d(np.append(idx, [n - 1]) if smooth else idx, g_rows)
    elif idx[-1] != n - 1:
        idx = np.append(idx, n - 1)
    tn = t[idx]
    # the road's bank rate (input of c_y) without GNSS: the roll gyro less the suspension's
    # roll rate k_phi f_y'; the roll gyro's bias is the drive's mean roll rate (the body ends
    # a drive about as level as it starts: 1 deg over 60 s is 3e-4 rad/s), for the causal
    # filter too, as a calibration read from the whole drive (with 0 there, c_y's random walk
    # left to carry the ramp g b_x: cr_limit_ramp seed 11, 5 s multipath burst, file 30 %
    # soft, fused_filter with Doppler 3.63 deg with 60 % inside 2 sigma; with the mean 1.31,
    # 94 %).  With GNSS Doppler both take
    # it too (FusedSettings.roll_gyro_bank_with_doppler) and read c_y's remaining random
    # walk from the drive (_identify_noise); drives without wx keep c_y a random walk
    has_wx = "wx" in drive and bool(np.isfinite(drive["wx"]).any())
    has_wx = has_wx and nz.roll_gyro_bank and (tyres_carry or nz.roll_gyro_bank_with_doppler)
    bx = float(np.mean(wx)) if has_wx and (smooth or nz.whole_drive_calibration) else 0.0
    road_roll = (wx - bx - k_phi * _backward_rate(t, fy_lp)) if has_wx else np.zeros(n)
    # process noise of the inputs' gap fills (zero without gaps; the roll gyro's only where
    # it drives the bank; v_y's only where GNSS Doppler measures it: where the tyres carry
    # the slip, v_y after a gap is read again from the brush relation, linearised at the
    # predicted v_y, and the gap's variance let that point leave the curve's linear range
    # (race lap, three 2 s pauses of the logger, no GNSS: beta RMSE 0.30 -> 5.98 deg with it;
    # with Doppler, eight 0.5 s holes (seed 5): fused_filter 1.31 deg with 75 % inside 2 sigma
    # without it, 0.39 deg with 96 %)): each row's increment belongs to the interval ending there,
    # so moved one row back its block sum is the node step's, then per second of that step
    no_gap = np.zeros(n)
    q_gap = [
        np.append(gap_increments(t, filled[c].sigma)[1:], 0.0)
        if filled[c].sigma.any() and (c != "wx" or has_wx) and (c != "lat" or has_vel) else no_gap
        for c in ("wz", "wx", "ax", "lat")
    ]  # fmt: skip
    # propagation by the trapezoidal rule where GNSS Doppler measures the velocities it
    # integrates (FusedSettings.trapezoid_with_doppler)
    trapezoid = has_vel and nz.trapezoid_with_doppler
    inputs = (wz, wx, wy, ax, ay, fy_lp, road_roll)
    predict = None
    if not smooth and imu_step > REGULAR_SPACING * drive.dt_median:
        # the causal filter with an IMU slower than its table: the rows between two samples
        # hold the earlier one, which the prediction's block mean reads up to a sample spacing
        # late; between two samples whose later one is in by the node that closes the step, the
        # prediction reads them interpolated, as it reads an IMU on every row (race_lap with a
        # 20 Hz IMU in its 100 Hz table: fused_filter 0.316 deg against 0.113 from the 20 Hz
        # table, the trapezoid rule over the held rows weighting the later sample 0.1, not 0.5)
        imu_rows = np.flatnonzero(np.isfinite(drive["ay"]) & np.isfinite(drive["wz"]))
        between = [
            causal_between_samples(t, imu_rows, col, idx, REGULAR_SPACING * imu_step)
            for col in (wz, wx, wy, ax, ay)
        ]
        predict = (*between, fy_lp, road_roll)
        del between
    U = _node_inputs(
        t, idx, inputs, q_gap, trapezoid, stride, causal=not smooth, wz_samples=np.isfinite(drive["wz"]),
        predict=predict,
    )  # fmt: skip
    del inputs, predict
    del road_roll, q_gap, filled
    vw_n = vw[idx] if stride == 1 else _window_mean(vw, idx)
    g_node = np.searchsorted(idx, g_rows, side="left").astype(np.int64)
    tau_fix, tau_sigma = 0.0, nz.latency_prior_sigma_s  # the latency fixes are taken with, s
    if latency is not None:
        tau_fix = latency.posterior_mean(nz.latency_prior_sigma_s)
        tau_sigma = latency.posterior_sigma(nz.latency_prior_sigma_s)
    g_age = tn[g_node] - t[g_rows] + tau_fix
    x0, P0 = _initial_state(drive, vw, nx, nz)
    if mu_fit is not None and mu_fit.informed:
        # the drive's own friction (sideslip.calibrate.friction) as mu's prior
        # as the prior's mean; its width stays the settings' (FusedSettings.identify_mu)
        x0[IMU] = mu_fit.value
        notes["mu_prior"] = (
            f"{mu_fit.value:.2f} (fit +- {mu_fit.sigma:.2f}) +- {nz.mu_prior_sigma:g} from the drive's "
            f"{mu_fit.source}"
        )
    else:
        if mu_fit is not None:
            why = mu_fit.note
        elif not nz.identify_mu:
            why = "FusedSettings.identify_mu is off"
        else:
            why = "the causal filter keeps the settings' mu (FusedSettings.identify_mu_causal)"
        notes["mu_prior"] = f"{nz.mu_prior:g} +- {nz.mu_prior_sigma:g} (settings): {why}"
    steer_zero = None  # the steering's gyro zero, for beta_std's disagreement term
    if (smooth or nz.whole_drive_calibration) and nz.steer_gyro_prior and not (has_pos or has_vel):
        # a calibration of the gyro read from the whole drive, which the causal filter takes
        # as it takes the roll gyro's bias (FusedSettings.whole_drive_calibration)
        zero = steer_gyro_zero(drive, vehicle)
        _steer_gyro_prior(zero, x0, P0, notes, nz.steer_gyro_prior_max_sigma)
        steer_zero = zero
    q = _process_psd(nx, nz)
    if not (has_pos or has_vel):
        # the gyro's scale factor is identified against a heading reference, the GNSS course
        # (seed 001), the wheel-speed scale against the GNSS speed (seed 004); without GNSS
        # the tyre relations see a gyro scale error only as r v_x, the same as the offset c_y,
        # and at low speed a speed scale error as slip (alpha_r is there a small difference of
        # v_y and l_r r), so the scale states take up the tyre model's errors instead
        # (urban_course: gyro scale 5.6 % against 0.08 % true, wheel scale -1.3 % against
        # 0.02 %: beta errors of 8 % of beta in every low-speed turn).  The gyro scale is held
        # at 1 (Revs lap: smoother 0.28 -> 0.24 deg, filter 0.45 -> 0.37), the wheel scale in
        # the smoother (urban_course 0.074 -> 0.051 deg; Revs 0.242 -> 0.245): the causal
        # filter keeps it free (Revs 0.36 free, 0.46 held; urban 0.076 free, 0.059 held).
        # A 1e-4 sigma keeps the smoother's prediction well conditioned
        P0[ISG, ISG] = 1e-8
        q[ISG] = 0.0
        if smooth:
            P0[ISW, ISW] = 1e-8
            q[ISW] = 0.0
    lever = np.array(vehicle.gnss_xyz, dtype=float)
    lever_params: dict[str, Any] = {}
    if smoother_lever is not None and "gnss_lever_x" in smoother_lever.params["assumed"]:
        moved = float(smoother_lever.params.get("gnss_lever_x_applied_m") or 0.0)
        lever[0] += moved
        notes["gnss_lever_x"] = "the smoother's check, " + smoother_lever.params["assumed"]["gnss_lever_x"]
        lever_params = {
            k: v
            for k, v in smoother_lever.params.items()
            if k.startswith(("gnss_lever_x_", "imu_lever_x_", "box_x_", "box_imu_x_"))
        }
    for check in ("imu_lever_x", "box_x"):
        if smoother_lever is not None and check in smoother_lever.params["assumed"]:
            notes[check] = "the smoother's check, " + smoother_lever.params["assumed"][check]
    del smoother_lever
    if latency is not None:
        # the antenna's lateral lever arm from the same tyre-free fit (sideslip.gnss_latency),
        # with the file's value as the prior's mean
        lever[1] = latency.lever_y_posterior(lever[1], nz.lever_prior_sigma_m)[0]
    if idx.size == n:  # every row a node (a 20 Hz table, or step_s 0): no copies
        node_inputs = (f_front, f_rear, delta, mu_floor, steady, force_var)
    else:
        node_inputs = (f_front[idx], f_rear[idx], delta[idx], mu_floor[idx], steady[idx], force_var[idx])
    # the per-row node inputs are no longer needed: free them before the filter runs
    del f_front, f_rear, delta, mu_floor, steady, force_var, jerk, r_dot, r_dot_lp, vw, raw, wx
    if smooth or rebuild:  # the smoother's outputs interpolate the nodes: no row ax, ay
        del ax, ay
    if rebuild:
        del wz, wy, fy_lp
    fix_t = t[g_rows[np.isfinite(gn["gnss_e"])]] if has_pos else t[:0]
    fix_rate = 1.0 / float(np.median(np.diff(fix_t))) if fix_t.size > 1 else 1.0
    cfg = _config(nz, k_phi, calibrate, has_vel, fix_rate)
    cfg[eng.C_SCALE_PROJECT] = 1.0 if (nz.filter_project_scales and not smooth) else 0.0
    cfg[eng.C_AX_SPEED_RATE] = 0.0 if _has_ax(drive) else 1.0
    # the smoother's body velocity random walk is at least the accelerometer's own white noise
    # (on a 100 Hz log well below the prior; a 20 Hz log of a vibrating car folds its
    # vibration into the band: Revs lap sampled at 20 Hz, 0.84 m/s^2 per sample, 0.19
    # m/s/sqrt(s); with the file's stiffness and the single pass's force time constant beta
    # RMSE 0.99 -> 0.47 deg); with GNSS Doppler
    # the drive's value is searched from there (_identify_noise).  Not the causal filter's:
    # the same lap 0.77 -> 1.55 deg with it
    if smooth:
        cfg[eng.C_ACCEL_VRW] = max(nz.accel_vrw_psd, vrw_floor)
    # the axle noise identified from the innovations may fall below its prior only where GNSS
    # gives v_y independently of the tyres (FusedSettings.adapt_min): not where the tyres
    # carry the slip (no GNSS; positions alone, whose arcs agree with any slip the tyres say)
    cfg[eng.C_ADAPT_MIN] = 1.0 if tyres_carry else nz.adapt_min
    before = (tn, U, vw_n, *node_inputs, g_node)
    after = (gn["gnss_e"], gn["gnss_n"], gn["pstd"], gn["gnss_ve"], gn["gnss_vn"], gn["vstd"],
             x0, P0, q, f_rows(nx), axle, lever, cfg, smooth)  # fmt: skip
    if has_vel and nz.identify_accel_vrw and g_node.size >= nz.accel_vrw_min_epochs:
        for name, choice in _identify_noise(before, g_age, after, nz, vrw_floor, has_wx):
            notes[name] = choice.note()
    lever_check = None
    if smooth and has_vel and has_pos and not calibrate and nz.check_doppler_lever:
        # the antenna where the file says, unless the Doppler contradicts it tyre-free
        # (sideslip.methods.fused_lever) and the moved antenna predicts the Doppler better
        # with the tyres too: a misplaced antenna's r dl_x reads as slip
        lever_check = check_lever(
            before, g_age, without_tyres(after), nz.lever_prior_sigma_m, nz.lever_psd,
            nz.latency_prior_sigma_s, nz.latency_psd, nz.doppler_lever_z, drive.dt_median,
            lagged=not trapezoid,
        )  # fmt: skip
        if lever_check.found:
            file_x = float(lever[0])
            neg2ll = _doppler_neg2ll(before, g_age, after, (file_x, file_x + lever_check.dl_x_m))
            lever_check = dataclasses.replace(
                lever_check, gain=neg2ll[0] - neg2ll[1], neg2ll=(neg2ll[0], neg2ll[1])
            )
        notes["gnss_lever_x"] = lever_check.note()
        if lever_check.applied:
            lever[0] += lever_check.dl_x_m
    doppler_score = None
    if score_doppler and has_vel:
        doppler_score = _doppler_neg2ll(before, g_age, after, (float(lever[0]),))[0]
        if score_only:
            return Estimate("fused", t, {}, {"gnss_doppler_neg2ll": doppler_score})
    xs, var, var_last, cov_vxvy, nis, counts = eng.run_nodes(*before, g_age, *after)
    if smooth and has_vel and nz.doppler_burst_check:
        # a multipath burst the forward check let in stands out from the smoothed track
        # (sideslip.methods.fused_bursts): its epochs once more with their distance as sigma
        residual = eng.doppler_residuals(xs, U, g_node, gn["gnss_ve"], gn["gnss_vn"], lever, cfg)
        burst = burst_epochs(residual, gn["vstd"], nz.doppler_burst_gate, nz.doppler_burst_min_run)
        dop_params["gnss_doppler_burst_epochs"] = int(burst.sum())
        if burst.any():
            vstd = gn["vstd"].copy()
            vstd[burst] = np.maximum(vstd[burst], residual[burst] / math.sqrt(2.0))
            after = (*after[:5], vstd, *after[6:])
            del xs, var, var_last, cov_vxvy, nis, counts  # not held through the second pass
            xs, var, var_last, cov_vxvy, nis, counts = eng.run_nodes(*before, g_age, *after)
            notes["gnss_doppler_bursts"] = (
                f"{int(burst.sum())} Doppler epochs in runs beyond {nz.doppler_burst_gate:g} x the "
                "drive's residual scale from the smoothed track: taken with their distance as "
                "sigma (FusedSettings.doppler_burst_check)"
            )
    stiffness_fallback = None
    fallback_spread = None  # rad per node: beta with the file's stiffness against the bound's
    wanted = float(np.median(xs[:, ISR]))
    noisy = force_noise > nz.force_sigma
    aliased = imu_rate_hz <= nz.stiffness_fallback_max_rate_hz
    if smooth and nz.stiffness_bound_fallback and wanted < SCALE_MIN and noisy and aliased:
        # the rear relation asked for a stiffness below half the file's while the force it
        # reads carries more of the accelerometer's noise than the relation's own floor:
        # errors in variables (the slip the noise moves through the velocity's integration
        # is regressed on the same noise in the force) flatten the learned slope, the tyre
        # reads soft (the Revs lap logged at 20 Hz, every fifth row: 0.84 m/s^2 of aliased
        # vibration per sample, scale asked about 0.3 x, beta RMSE 1.37 deg, 0.41 with the
        # file's; comma2k19 minute at 20 Hz 0.40 x, 0.115 -> 0.099 deg).  Run again with the file's
        # stiffness, not learned; its prior sigma stays in beta_std
        # (fused_stiffness.model_form_params).  A clean drive that asks for less than half
        # keeps the bound (a file more than twice too stiff)
        cfg_fixed = cfg.copy()
        cfg_fixed[eng.C_STIFF_CURVE] = math.inf
        after = (*after[:12], cfg_fixed, after[13])
        beta_held = _node_beta(xs)
        xs, var, var_last, cov_vxvy, nis, counts = eng.run_nodes(*before, g_age, *after)
        # the drive cannot say which of the two is right: a 20 Hz log's noise flattens the
        # slope (the file right), or the file is twice too stiff (the bound right: the Revs
        # lap with cf, cr doubled asks 0.35 x at 100 Hz as at 20 Hz with the file right,
        # and read 0.92 deg with 84 % inside 2 sigma on the file's).  Their difference joins
        # beta_std
        fallback_spread = np.abs(_node_beta(xs) - beta_held)
        del beta_held
        stiffness_fallback = (
            f"not learned: the rear axle's relation asked for {wanted:.3g} x the file's stiffness, "
            f"below {SCALE_MIN:g}, through a force {force_noise:.2f} m/s^2 noisy (above the "
            f"relation's {nz.force_sigma:g}; FusedSettings.stiffness_bound_fallback): the file's "
            "stiffness with the prior's sigma"
        )
    prior_check = None  # (share of a moved prior the rear scale keeps, the prior's sigma)
    if tyres_carry and nz.stiffness_prior_check:
        # without Doppler the drive may not inform the rear stiffness at all: run once more
        # with its prior mean moved (sideslip.methods.fused_stiffness)
        x0_moved = x0.copy()
        x0_moved[ISR] += STIFFNESS_PRIOR_SHIFT
        xs_moved = eng.run_nodes(*before, g_age, *after[:6], x0_moved, *after[7:])[0]
        pick = np.median if smooth else (lambda a: a[-1])
        held = [float(pick(np.clip(a[:, ISR], SCALE_MIN, SCALE_MAX))) for a in (xs, xs_moved)]
        prior_check = (prior_share(*held), nz.stiffness_prior_sigma)
        del xs_moved
    latency_beta = None  # |d beta| at the nodes for a latency one sigma later (positions only)
    if has_pos and not has_vel and not calibrate:
        # an unknown latency turns the fixes' course by r tau through a turn: an error
        # correlated over the turn that the fixes' white position noise does not carry, and
        # that the stiffness learned in the transients takes along into the arc.  How much of
        # it reaches beta depends on how far the estimate follows the fixes there (in a steady
        # turn the tyres may carry the slip, in a transient the fixes), so the whole estimator
        # is run again with the fixes taken one latency sigma later and the change of beta is
        # that part of beta_std (first-order propagation through the estimator; one more
        # pass, on positions-only drives only)
        xs_late = eng.run_nodes(*before, g_age + tau_sigma, *after)[0]
        latency_beta = np.abs(
            np.arctan2(xs_late[:, IVY], np.abs(xs_late[:, IVX]) + 1e-3)
            - np.arctan2(xs[:, IVY], np.abs(xs[:, IVX]) + 1e-3)
        )
        del xs_late
    del U, gn, node_inputs, before, after
    # consistency between cues: windowed NIS of the axle and GNSS innovations
    chan = nis[:, [eng.K_REAR, eng.K_FRONT, eng.K_GNSS_VEL, eng.K_GNSS_POS]]
    dof_per = np.array([1.0, 1.0, 2.0, 2.0])
    dof = np.where(np.isfinite(chan), dof_per, 0.0).sum(axis=1)
    nis_sum = np.where(np.isfinite(chan), chan, 0.0).sum(axis=1)
    cons = nis_consistency(tn, nis_sum, dof, window_s=nz.health_window_s, causal=not smooth)
    del chan, dof, nis_sum
    nis = nis.astype(np.float32)  # kept for the innovation diagnostics, which are float32
    # series output on every row (position only with fixes, yaw only with GNSS: without
    # them neither is observable); the others (AUX_KEYS) enter the row outputs from the nodes
    keep = [IVX, IVY, IBG] + ([IPSI] if has_pos or has_vel else []) + ([IE, IN] if has_pos else [])
    vc = eng.VAR_COLUMN
    # 1-sigma of yaw and position at the nodes, interpolated as such (no per-row variances);
    # each table is one stacked array (the compiled row passes read it whole), the dicts views
    # the causal filter's gyro bias sigma on every row, for the test against the steering
    bias_std = [("std", IBG)] if not smooth and steer_zero is not None and steer_zero.informed else []
    node_keys = [*keep, *(("std", i) for i in keep if i in (IE, IN, IPSI)), *bias_std, "health"]
    node_vals = np.empty((len(node_keys), tn.size))
    for m, key in enumerate(node_keys):
        if key == "health":
            node_vals[m] = cons.health
        elif isinstance(key, tuple):
            np.sqrt(np.maximum(var[:, vc[key[1]]], 0.0), out=node_vals[m])
        else:
            node_vals[m] = xs[:, key]
    nodes: dict[Any, FloatArray] = dict(zip(node_keys, node_vals, strict=True))
    aux_nodes = np.empty((len(AUX_KEYS), tn.size))
    for m, key in enumerate(AUX_KEYS):
        if key == "cvv":
            aux_nodes[m] = cov_vxvy
        elif key == "inflation":
            aux_nodes[m] = cons.inflation
        elif isinstance(key, tuple):
            aux_nodes[m] = var[:, vc[key[1]]]
        else:
            aux_nodes[m] = xs[:, key]
    aux: dict[Any, FloatArray] = dict(zip(AUX_KEYS, aux_nodes, strict=True))
    node_params = _node_params(vehicle, smooth, xs, var[:, vc[IMU]], var_last, counts, cons, tn, k_phi, notes)
    node_params.update(roll_params)
    node_params.update(dop_params)
    if lever_check is not None:
        node_params.update(lever_check.params())
    node_params.update(lever_params)
    if doppler_score is not None:
        node_params["gnss_doppler_neg2ll"] = doppler_score
    del xs, var, cov_vxvy  # the row outputs need only the columns copied above
    if rebuild:
        speed_rows = speed_raw(drive)
        v_rows = hold(speed_rows, t)[0] if speed_rows is not None else np.zeros(n)
        again = _filled_inputs(drive, smooth, v_rows, nz.axle_min_speed, nz.ax_from_speed_tau_s)
        del speed_rows, v_rows
        wz, wy, wx_row = again["wz"].values, again["wy"].values, again["wx"].values
        ax_row, ay_row = again["ax"].values, again["ay"].values
        ax, ay = _accel_at_cg(drive, vehicle, wx_row, wy, wz, not smooth, ax_row, ay_row)
        del again
        fy_lp = lp(t, (ay - offset_y.value) * suspension_factor(k_phi), tau_f)  # as above
        if smooth:
            del ax, ay
    if smooth:  # linear interpolation of the smoothed nodes
        j, w = _node_weights(t, tn)
        rows = dict(zip(nodes, eng.interp_rows(j, w, node_vals), strict=True))
    else:  # causal: the last node, propagated to the row with the row's IMU sample
        j = (np.searchsorted(idx, np.arange(n), side="right") - 1).clip(0).astype(np.int32)
        w = np.zeros(n, dtype=np.float32)
        coupling = 1.0 if _has_ax(drive) else 0.0
        rows = _propagate_causal(t, tn, j, node_keys, node_vals, aux, wz, wy, ax, ay, fy_lp, k_phi, coupling)
        del ax, ay
    del nodes, node_vals, aux  # the row outputs hold what the series need
    # the causal low-pass delays the force the relations read by about its time constant
    force_lag_s = 0.0 if tyres_only else tau_f
    est = _estimate(
        drive, vehicle, smooth, nz, rows, (j, w, aux_nodes), node_params, k_phi, fy_lp, wz, wy,
        has_pos, has_vel, use_front, tyres_carry, force_lag_s,
    )  # fmt: skip
    params = dict(est.params)
    series = dict(est.series)
    params.update(params_offset)
    if stiffness_fallback is not None:
        params["rear_stiffness_scale_note"] = stiffness_fallback
    if fallback_spread is not None:
        spread_rows = eng.interp_rows(j, w, fallback_spread[None, :])[0]
        series["beta_std"] = np.hypot(series["beta_std"], spread_rows)
        params["beta_std_stiffness_fallback_deg"] = float(np.degrees(np.sqrt(np.mean(spread_rows**2))))
    if offset_y.informed:
        # c_y holds g sin(bank) plus the reading's offset: the road's bank is the rest
        sin_bank = np.clip(np.sin(series["bank"]) - offset_y.value / G, -0.6, 0.6)
        bank_road = np.arcsin(sin_bank)
        series["roll"] = series["roll"] + (bank_road - series["bank"])
        series["bank"] = bank_road
    # the learned rear stiffness against a straight line through the estimate's own slip:
    # the difference is the tyre curve's part of its sigma (sideslip.methods.fused_stiffness)
    secant = rear_secant(
        t, series["beta"], series["r"], series["vx"], fy_lp, (geom[0], geom[1], iz_m, geom[3]),
        nz.stiffness_curve_accel,
    )  # fmt: skip
    sigma_formal = params["rear_stiffness_scale_sigma"]
    held_sigma = nz.stiffness_prior_sigma if "rear_stiffness_scale_note" in params else None
    scale = params["rear_stiffness_scale"]
    params.update(model_form_params(scale, sigma_formal, secant, prior_check, held_sigma))
    if not use_front:
        params["front_stiffness_scale_note"] = (
            "not identified: the front-axle relation is off (FusedSettings.front_axle, or no "
            "steering column); the scale and its sigma are the prior's"
        )
    if latency_beta is not None:
        # the latency's part of beta_std (above), on the rows as the nodes are
        lat_rows = eng.interp_rows(j, w, latency_beta[None, :])[0] if smooth else latency_beta[j]
        series["beta_std"] = np.hypot(est["beta_std"], lat_rows)
    if has_vel:
        # a Doppler epoch late by tau lags the heading by r tau, read as slip where the
        # Doppler sets beta: the latency's remaining sigma (the prior's, where the drive does
        # not decide it) times |r| enters beta_std (doppler_latency.md: at 50 / 100 ms late
        # and undecided, step_steer had 19 % of its errors inside 2 sigma without it), and so
        # does the inputs' own timing against the Doppler: the trapezoidal rule is on time
        # for samples taken at their instants, but a sample may stand for the interval
        # before it (an IMU's own averaging), half a row earlier (rectangle rule on a 20 Hz
        # race lap: 0.311 deg with 93.7 % inside 2 sigma without this term, 99.0 % with it)
        timing_s = math.hypot(doppler_latency[1], 0.5 * drive.dt_median)
        series["beta_std"] = np.hypot(series["beta_std"], np.abs(series["r"]) * timing_s)
    if steer_zero is not None and steer_zero.informed:
        bias_rows = None if smooth else (series["gyro_bias"], rows[("std", IBG)])
        _gyro_zero_disagreement(series, params, steer_zero, vehicle.lr, nz.axle_min_speed, bias_rows)
    if nz.accel_offset_sigma > 0.0 and not tyres_carry:
        # an accelerometer offset the drive cannot tell from tyre force (nor, with GNSS,
        # from bank; a mounting roll is one too: g times its angle) is a rear-axle force
        # m l_f / L b_y, which the rear relation turns into a slip offset of that over the
        # axle's stiffness, and through the heading into beta where GNSS Doppler sets it:
        # one offset for the whole drive, so the axle updates' white noise, averaged over
        # thousands of rows, does not carry it.  a_y 0.25 m/s^2 high (25 mg, or 1.5 deg of
        # mounting roll): share of beta errors inside 2 sigma 0.87 -> 1.00 on urban_highway,
        # 0.86 -> 0.99 on race_lap (a 1 deg mounting roll alone: race_lap 0.88 -> 1.00);
        # comma2k19 minute at adapt_min 0.25: 81 % -> 90 %
        scale = max(float(params.get("rear_stiffness_scale", 1.0)), SCALE_MIN)
        # the drive's typical lateral offset (c_y: g sin(bank) + the accelerometer's offset;
        # the median over the moving rows, where a banked curve is a passing part) is a
        # road's crossfall, which the tyres carry, or a tilted mount, which they do not; the
        # drive cannot tell which (a bank the drive starts on and a mount tilt read alike),
        # so the part of it a tilt may be (FusedSettings.offset_level_share) adds to the
        # offset's sigma.  IMU mounted 2 deg off at random (seed 1 of urban_course: roll
        # -2.8 deg): 86 % of beta errors inside 2 sigma -> 100 %
        moving = np.abs(series["vx"]) > nz.axle_min_speed
        level = G * abs(float(np.median(np.sin(series["bank"][moving])))) if moving.any() else 0.0
        sigma_offset = math.hypot(nz.accel_offset_sigma, nz.offset_level_share * level)
        if offset_y.informed:
            # the curves' heading closure told the offset (a tilted mount too) from the bank
            sigma_offset = offset_y.sigma
        offset = sigma_offset * vehicle.mass * vehicle.lf / vehicle.wheelbase / (vehicle.cr * scale)
        params["accel_offset_level_m_s2"] = level
        series["beta_std"] = np.hypot(series["beta_std"], offset)
        params["beta_std_accel_offset_deg"] = math.degrees(offset)
    if latency is not None:
        params.update(
            gnss_latency_s=latency.posterior_mean(nz.latency_prior_sigma_s),
            gnss_latency_identified_s=latency.latency_s,
            gnss_latency_identified_s_sigma=latency.sigma_s,
            gnss_latency_source="fixes' speed against the wheels (sideslip.gnss_latency), with the prior",
        )
        ly, ly_sigma = latency.lever_y_posterior(vehicle.gnss_xyz[1], nz.lever_prior_sigma_m)
        informed = math.isfinite(latency.lever_y_sigma_m)  # False: the drive did not turn
        params.update(
            gnss_lever_arm_y_m=ly,
            gnss_lever_arm_y_m_sigma=ly_sigma,
            gnss_lever_arm_y_identified_m=latency.lever_y_m if informed else None,
            gnss_lever_arm_y_identified_m_sigma=latency.lever_y_sigma_m if informed else None,
        )
    return Estimate(est.method, est.t, series, params, _innovations(n, idx, nis))


INNOVATION_CHANNELS = (
    ("wheel_speed_nis", eng.K_WHEEL),
    ("rear_axle_nis", eng.K_REAR),
    ("front_axle_nis", eng.K_FRONT),
    ("gnss_velocity_nis", eng.K_GNSS_VEL),
    ("gnss_position_nis", eng.K_GNSS_POS),
)


def _identify_noise(
    before: tuple[Any, ...], g_age: FloatArray, after: tuple[Any, ...], nz: FusedSettings,
    vrw_floor: float, bank_from_roll_gyro: bool,
) -> list[tuple[str, NoiseChoice]]:  # fmt: skip
    """The process noise whose forward filter predicts the drive's Doppler velocities best
    (:mod:`sideslip.methods.fused_vrw`), set in place in ``after``'s configuration and
    process-noise arrays: the velocity random walk, then, where the roll gyro drives the
    bank, the bank offset's random walk at that velocity random walk.  Two candidates at a
    time on two threads (the forward pass runs without the GIL), each with its own copies."""
    from concurrent.futures import ThreadPoolExecutor

    *head, q, rows, axle, lever, cfg, _ = after
    forward: Any = eng.forward_nodes  # compiled; the last of its outputs is doppler_ll

    def one(vrw: float, cy_psd: float) -> float:
        c, qc = cfg.copy(), q.copy()
        c[eng.C_ACCEL_VRW] = vrw
        qc[ICY] = cy_psd**2
        out = forward(*before, g_age, *head, qc, rows, axle, lever, c, False)
        return float(out[-1][0])

    def many(f: Any, values: Sequence[float]) -> list[float]:
        if len(values) == 1:
            return [f(values[0])]
        with ThreadPoolExecutor(max_workers=len(values)) as pool:
            return list(pool.map(f, values))

    cy_prior = math.sqrt(q[ICY])
    found = []
    vrw = search_accel_vrw(
        lambda vs: many(lambda v: one(v, cy_prior), vs),
        nz.accel_vrw_psd, vrw_floor, nz.accel_vrw_min_factor, nz.accel_vrw_max_factor,
    )  # fmt: skip
    cfg[eng.C_ACCEL_VRW] = vrw.value
    found.append(("accel_vrw", vrw))
    if bank_from_roll_gyro and nz.identify_cy_psd:
        cy = search_noise_scale(
            lambda vs: many(lambda v: one(vrw.value, v), vs),
            cy_prior, 0.0, nz.cy_psd_min_factor, 1.0, unit="m/s^2/sqrt(s)",
        )  # fmt: skip
        q[ICY] = cy.value**2
        found.append(("cy_psd", cy))
    return found


def _node_beta(xs: FloatArray) -> FloatArray:
    """Sideslip (rad) of the node states ``xs`` (N, nx); 0 where the node stands still."""
    vx, vy = xs[:, IVX], xs[:, IVY]
    moving = np.abs(vx) > 0.5
    return np.where(moving, np.arctan2(vy, np.maximum(np.abs(vx), 1e-3)), 0.0)


def _node_inputs(
    t: FloatArray,
    idx: NDArray[np.intp],
    inputs: tuple[FloatArray, ...],
    q_gap: list[FloatArray],
    trapezoid: bool,
    stride: int,
    causal: bool,
    wz_samples: NDArray[np.bool_] | None = None,
    predict: tuple[FloatArray, ...] | None = None,
) -> FloatArray:
    """The engine's node inputs ``U`` (2, N, m): ``U[0, j]`` drives the prediction from node j
    to j + 1, ``U[1, j]`` the updates at node j; columns ``inputs`` (U_WZ .. U_RR) then the
    gap fills' noise densities ``q_gap`` (U_QWZ ..).  ``predict``: other columns for the
    prediction's means (the causal filter's IMU interpolated between slower samples), the
    updates keep ``inputs``.

    Prediction: each input's mean over [t[idx[j]], t[idx[j+1]]] by the rectangle rule (an
    IMU sample at its instant stands for the interval after it, so the kinematics run half a
    row late) or with ``trapezoid`` by the trapezoidal rule (no lag for samples taken at
    their instants), weighted by time (:func:`sideslip.methods.fused_engine.block_means`).
    Updates at node j: the rectangle rule's mean for the smoother.  The causal filter's
    updates read no row after their node (the block mean had them read the step's later
    rows, a 40 ms look-ahead at 100 Hz): the node's own row, but for the yaw rate the mean of
    the ``stride`` rows ending there.  The rear slip (v_y - l_r r) / v_x the tyres' stiffness
    is learned against takes one gyro sample's noise as its own at walking pace, and a
    regressor's noise biases the slope it fits low (urban_course seed 0 without GNSS: rear
    scale 0.75 with the node's row, 0.86 with the mean; beta 0.133 -> 0.085 deg); the mean
    lags two rows (step_steer 0.142 -> 0.197), and over the comparison's 16 drives x 3
    receivers the two are within 0.007 deg of each other on every mean."""
    n = t.size
    N = idx.size
    means_of = inputs if predict is None else predict
    prop = eng.block_means(idx, (*means_of, *q_gap), t, len(inputs), trapezoid)
    rows_per_node = np.diff(np.append(idx, n))
    if any(q.any() for q in q_gap):
        # the gap columns: block sums of per-row increments, per second of the node step
        step_n = np.append(np.diff(t[idx]), np.inf)
        prop[:, len(inputs) :] *= (rows_per_node / np.where(step_n > 0.0, step_n, np.inf))[:, None]
    U = np.empty((2, N, prop.shape[1]))
    U[0] = prop
    if causal:
        U[1] = prop
        U[1, :, : len(inputs)] = np.column_stack([col[idx] for col in inputs])
        # the yaw rate as the mean of the gyro's samples among the step's rows that end at
        # the node (the rows between the samples of a gyro slower than the table hold the
        # previous one: a 20 Hz gyro in a 100 Hz table read 40 ms late, the Revs lap 1.90 deg
        # against 0.77 from a 20 Hz table); the node's own row where the step has none
        real = np.ones(t.size, dtype=bool) if wz_samples is None else wz_samples
        wz_sum = np.concatenate(([0.0], np.cumsum(np.where(real, inputs[U_WZ], 0.0))))
        count = np.concatenate(([0], np.cumsum(real)))
        first = np.maximum(idx - stride + 1, 0)
        k = count[idx + 1] - count[first]
        mean = (wz_sum[idx + 1] - wz_sum[first]) / np.maximum(k, 1)
        U[1, :, U_WZ] = np.where(k > 0, mean, inputs[U_WZ][idx])
    elif trapezoid:
        U[1] = eng.block_means(idx, (*inputs, *q_gap), t, len(inputs), False)
    else:
        U[1] = prop
    return U


def _doppler_neg2ll(
    before: tuple[Any, ...], g_age: FloatArray, after: tuple[Any, ...], lever_x: Sequence[float]
) -> list[float]:
    """``-2 log L`` of the Doppler innovations of the forward filter with ``after``'s noise for
    each antenna position ``lever_x`` (m ahead of the CG), on two threads."""
    from concurrent.futures import ThreadPoolExecutor

    *head, q, rows, axle, lever, cfg, _ = after
    forward: Any = eng.forward_nodes

    def one(x: float) -> float:
        arm = lever.copy()
        arm[0] = x
        return float(forward(*before, g_age, *head, q, rows, axle, arm, cfg, False)[-1][0])

    with ThreadPoolExecutor(max_workers=2) as pool:
        return list(pool.map(one, lever_x))


def _innovations(n: int, idx: NDArray[np.intp], nis: FloatArray) -> dict[str, Any]:
    """The NIS of each cue the run used (before robust down-weighting; chi^2 with 1 dof for
    the wheel speed and the axle relations, 2 for GNSS velocity and position; summed where a
    node took several GNSS epochs) at its node's row, NaN on other rows; float32 (diagnostics
    kept in memory, not written to the output table)."""
    out: dict[str, Any] = {}
    for name, k in INNOVATION_CHANNELS:
        if np.isfinite(nis[:, k]).any():
            col = np.full(n, np.nan, dtype=np.float32)
            col[idx] = nis[:, k]
            out[name] = col
    return out


# node series the row outputs read at node level (interpolated inside eng.row_outputs)
AUX_KEYS: tuple[Any, ...] = (("var", IVX), ("var", IVY), "cvv", "inflation", ICY, ICX, ISG, ISR, ("var", ISR))


def _node_weights(t: FloatArray, tn: FloatArray) -> tuple[NDArray[np.int32], NDArray[np.float32]]:
    """Row i between nodes ``j[i]`` and ``j[i] + 1`` at fraction ``w[i]`` (as ``np.interp``:
    held before the first and after the last node; int32 / float32: the fraction needs no more
    than single precision, 1e-7 of a 50 ms node step)."""
    j = np.clip(np.searchsorted(tn, t, side="right") - 1, 0, max(tn.size - 2, 0)).astype(np.int32)
    if tn.size > 1:
        w = np.clip((t - tn[j]) / (tn[j + 1] - tn[j]), 0.0, 1.0).astype(np.float32)
    else:
        w = np.zeros(t.size, dtype=np.float32)
    return j, w


def _propagate_causal(
    t: FloatArray,
    tn: FloatArray,
    j: NDArray[np.int32],
    keys: list[Any],
    node_vals: FloatArray,
    aux: dict[Any, FloatArray],
    wz: FloatArray,
    wy: FloatArray,
    ax: FloatArray,
    ay: FloatArray,
    fy_lp: FloatArray,
    k_phi: float,
    coupling: float = 1.0,
) -> dict[Any, FloatArray]:
    """Filter output on every row from the latest node at or before it: one Euler step of
    the process model over the (< one node step) gap with the row's own IMU sample, in one
    compiled pass (:func:`sideslip.methods.fused_engine.propagate_rows`; ``coupling`` 0 where
    ``ax`` is the speed's rate, ``fused_engine.C_AX_SPEED_RATE``); ``node_vals`` holds
    the node values of ``keys``, one row each."""
    pos = {k: i for i, k in enumerate(keys)}
    out = eng.propagate_rows(
        t, tn, j, node_vals, aux[ICY], aux[ICX], aux[ISG], wz, wy, ax, ay,
        fy_lp, k_phi, pos[IVX], pos[IVY], pos[IBG], pos.get(IPSI, -1), pos.get(IE, -1),
        pos.get(IN, -1), coupling,
    )  # fmt: skip
    rows = dict(zip(keys, out, strict=True))
    return rows


def _node_params(
    vehicle: Vehicle,
    smooth: bool,
    xs: FloatArray,
    var_mu: FloatArray,
    var_last: FloatArray,
    counts: NDArray[np.int64],
    cons: Any,
    tn: FloatArray,
    k_phi: float,
    notes: dict[str, str],
) -> dict[str, Any]:
    """The params :func:`fuse` reads off the node states ``xs``, mu's variance ``var_mu`` and
    the last node's variances ``var_last`` (calibration, stiffness, mu, update counts, health
    spans): the median over the drive for the smoother, the last node for the causal filter."""
    sd = np.sqrt(np.maximum(var_last, 0.0))  # the last node's 1-sigma
    pick = (lambda a: float(np.median(a))) if smooth else (lambda a: float(a[-1]))
    geom, _, _ = axle_geometry(vehicle)
    # the stiffness scales the axle relations use: held within SCALE_MIN .. SCALE_MAX
    used = {j: pick(np.clip(xs[:, j], SCALE_MIN, SCALE_MAX)) for j in (ISF, ISR)}
    params: dict[str, Any] = {
        "node_step_s": float(np.median(np.diff(tn))) if tn.size > 1 else 0.0,
        "wheel_speed_scale": pick(xs[:, ISW]),
        "wheel_speed_scale_factor": pick(xs[:, ISW]),  # the same (measured / true), older name
        "gyro_bias_rad_s": float(xs[-1, IBG]),
        "gyro_bias_rad_s_sigma": float(sd[IBG]),
        "gyro_scale": 1.0 / (1.0 - pick(xs[:, ISG])),
        "front_stiffness_scale": used[ISF],
        "front_stiffness_scale_sigma": float(sd[ISF]),
        "rear_stiffness_scale": used[ISR],
        "rear_stiffness_scale_sigma": float(sd[ISR]),
        "slip_gain_k_s2_m": float(geom[0] / ((geom[0] + geom[1]) * geom[3] * used[ISR])),
        "slip_gain_k_prior_s2_m": float(geom[0] / ((geom[0] + geom[1]) * geom[3])),
        "mu": pick(xs[:, IMU]),
        "mu_sigma": float(np.sqrt(max(np.median(var_mu), 0.0))),
        "roll_gain_rad_per_m_s2": k_phi,
        "gnss_updates_accepted": int(counts[0]),
        "gnss_updates_downweighted": int(counts[1]),
        "axle_updates_accepted": int(counts[2]),
        "axle_updates_downweighted": int(counts[3]),
        "health": cons.summary(tn),
        "assumed": notes,
    }
    for axle_name, j_state in (("front", ISF), ("rear", ISR)):
        wanted = pick(xs[:, j_state])
        if not SCALE_MIN <= wanted <= SCALE_MAX:
            # the relation kept asking for more (or less) slip than half .. twice the file's
            # stiffness gives: another cue (a misplaced antenna, a latency) or the file disagrees
            # with the tyres, and the consistency test and beta_std carry the disagreement
            params[f"{axle_name}_stiffness_scale_note"] = (
                f"held at {used[j_state]:g} x the file's: the {axle_name} axle's "
                f"relation asked for {wanted:.3g} x, beyond {SCALE_MIN:g}-{SCALE_MAX:g}; the tyres "
                "disagree with another cue (antenna position, latency) or with the vehicle file"
            )
    if xs.shape[1] > NX_CORE:
        lever = np.array(vehicle.gnss_xyz, dtype=float)
        params.update(
            gnss_latency_s=pick(xs[:, ITAU]),
            gnss_latency_s_sigma=float(sd[ITAU]),
            gnss_lever_arm_xy_m=[float(lever[0] + pick(xs[:, ILX])), float(lever[1] + pick(xs[:, ILY]))],
            gnss_lever_arm_xy_m_sigma=[float(sd[ILX]), float(sd[ILY])],
        )
    return params


def _estimate(
    drive: Drive,
    vehicle: Vehicle,
    smooth: bool,
    nz: FusedSettings,
    rows: dict[Any, FloatArray],
    aux: tuple[NDArray[np.int32], NDArray[np.float32], FloatArray],
    node_params: dict[str, Any],
    k_phi: float,
    fy_lp: FloatArray,
    wz: FloatArray,
    wy: FloatArray,
    has_pos: bool,
    has_vel: bool,
    use_front: bool,
    tyres_carry: bool,
    force_lag_s: float,
) -> Estimate:
    """Output series (from the per-row ``rows`` and, through ``aux = (j, w, node values of
    AUX_KEYS)``, the node-level terms of beta_std and the attitude) and params (the cues,
    then ``node_params`` of :func:`_node_params`) of :func:`fuse`."""
    t = drive.t
    vx, vy = rows[IVX], rows[IVY]
    geom_v, _, _ = axle_geometry(vehicle)
    # the tyre term (use_tyre): without GNSS (or with positions alone, in arcs: fuse) nothing
    # but the tyre relations pins v_y, and their error is correlated over whole corners: the
    # rear slip angle carries the relation's relative error.  The causal filter is in that
    # state in every corner: there the GNSS course rate is a_y / v whatever the gyro's scale,
    # so GNSS tells slip from a gyro scale error only once the turn is complete, which the
    # smoother sees and the filter has not yet.
    # The rear slip also scales with the learned stiffness: its remaining relative
    # uncertainty is an error of the slip correlated over the whole drive, which the
    # covariance's white updates do not carry (banked_turn, file 30 % soft: 2-sigma share
    # 0.89 -> 1.00)
    j, w, aux_nodes = aux
    beta, beta_std, r, roll, bank, pitch = eng.row_outputs(
        t, vx, vy, rows[IBG], wz, wy, fy_lp, j, w, aux_nodes, k_phi, geom_v[1],
        tyres_carry or not smooth, nz.force_rel, nz.force_sigma / geom_v[3],
        nz.relaxation_m, math.radians(30.0), math.radians(5.0), force_lag_s,
    )  # fmt: skip
    series = {
        "beta": beta, "beta_std": beta_std, "health": rows["health"], "r": r, "vx": vx,
        "vy": vy, "gyro_bias": rows[IBG], "roll": roll, "bank": bank, "pitch": pitch,
    }  # fmt: skip
    std = {i: rows[("std", i)] for i in (IE, IN, IPSI) if ("std", i) in rows}
    if has_pos or has_vel:  # without GNSS, heading and position are not observable
        series.update(yaw=rows[IPSI], yaw_std=std[IPSI])
    if has_pos:
        series.update(e=rows[IE], n=rows[IN], e_std=std[IE], n_std=std[IN])
    cues = ["imu" if _has_ax(drive) else "imu (no ax: the speed's rate for it)", speed_source(drive)]
    cues.append("rear axle (brush tyre model)")
    if use_front:
        cues.append("steer (front axle, brush tyre model)")
    if has_vel:
        cues.append("gnss_doppler")
    if has_pos:
        cues.append("gnss_position")
    params: dict[str, Any] = {"cues": cues, "smoothed": smooth, **node_params}
    return Estimate("fused" if smooth else "fused_filter", t, series, params)


# A z gyro, a lateral accelerometer and a speed suffice; GNSS, steering, ax, wx, wy are used
# when present (params["cues"]).
COLUMNS = ("wz", "ay", SPEED)
OPTIONAL = ("gnss_e", "gnss_n", "gnss_ve", "gnss_vn", "steer", "ax", "wx", "wy")
PAPER = "this toolkit (fuses seeds 000, 001, 003, 004 ideas; brush tyre model Pacejka 2012)"


@register(
    "fused",
    columns=COLUMNS,
    vehicle_params=("lf", "lr"),
    summary="EKF + RTS smoother: IMU, speed, steering, GNSS (any subset); brush-model axles, mu",
    paper=PAPER,
    settings=FusedSettings,
    accelerometer="own",
    optional=OPTIONAL,
)
def fused(drive: Drive, vehicle: Vehicle, settings: FusedSettings) -> Estimate:
    """Off-line best estimate: forward EKF and RTS smoother (see module docstring)."""
    return fuse(drive, vehicle, smooth=True, settings=settings)


@register(
    "fused_filter",
    columns=COLUMNS,
    vehicle_params=("lf", "lr"),
    summary="causal EKF of `fused` (real-time form)",
    paper=PAPER,
    settings=FusedSettings,
    accelerometer="own",
    optional=OPTIONAL,
)
def fused_filter(drive: Drive, vehicle: Vehicle, settings: FusedSettings) -> Estimate:
    """Causal form of :func:`fused`: the forward EKF only."""
    return fuse(drive, vehicle, smooth=False, settings=settings)
