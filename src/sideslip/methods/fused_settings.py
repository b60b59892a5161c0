"""Settings of the fused estimator (:mod:`sideslip.methods.fused`) and the choices they make
against the drive: the noise of every cue, the priors of the identified states, and the time
constant of the axle forces' low-pass, set by the drive's own accelerometer noise."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from sideslip.signals import sample_step

FloatArray = NDArray[np.float64]

__all__ = ["FusedSettings", "accel_noise_sigma", "force_noise_variance", "force_time_constant"]


@dataclass(frozen=True)
class FusedSettings:
    """Noise and options of the fused estimator (SI units).  ``*_sigma``: 1-sigma per sample;
    ``*_psd``: random-walk density per sqrt(s); ``*_tau_s``: time constants.  Defaults are
    for a MEMS IMU, automotive wheel speeds and a u-blox M8-class receiver."""

    step_s: float = 0.05  # s: node spacing (0: every row); inputs averaged between nodes
    # the prediction's inputs over a node step by the trapezoidal rule (half weights on the
    # step's two end rows: on time for samples taken at their instants) where GNSS Doppler
    # measures the velocities it integrates; else the rows' mean (rectangle rule), half a
    # row late.  Measured 2026-12-07, 16 scenarios x 3 files, fused beta RMSE mean with
    # Doppler (right / soft / rough file): at 100 Hz 0.041 / 0.049 / 0.052 -> 0.042 / 0.055
    # / 0.059 (race_lap 0.048 -> 0.033, step_steer 0.019 -> 0.039), at 20 Hz 0.148 / 0.127
    # / 0.123 -> 0.060 / 0.072 / 0.073 (race_lap 0.311 -> 0.037); fused_filter (right file,
    # benchmarks/results/log_rates.md) 0.109 -> 0.109 at 100 Hz, 0.116 -> 0.109 at 50 Hz,
    # 0.152 -> 0.102 at 20 Hz.  Without Doppler the tyres carry the slip and learn the
    # stiffness in the transients, where the half-row lag measured better (at 20 Hz, no
    # GNSS: 0.099 -> 0.115 with the trapezoid; positions only 0.070 -> 0.079), so it is kept
    # there; the comma2k19 minute and the Revs lap (both 100 Hz) are unchanged within 0.003
    trapezoid_with_doppler: bool = True
    accel_vrw_psd: float = 0.1  # m/s/sqrt(s): accelerometer noise, vibration, roll transients
    # with GNSS Doppler the velocity random walk is read from the drive: the value (a factor
    # of two apart, from accel_vrw_psd times min_factor to max_factor, never below the
    # accelerometer's own white noise) whose forward filter predicts the Doppler velocities
    # best (sideslip.methods.fused_vrw), for the causal filter too (a calibration read from
    # the whole drive, as its roll gain and Doppler latency: 16 drives x 3 files, fused_filter
    # mean 0.138 -> 0.110 deg with the roll gyro's bank below); accel_vrw_psd stays the prior
    # and the value without Doppler (positions answer a velocity error only through its
    # integral)
    identify_accel_vrw: bool = True
    accel_vrw_min_factor: float = 1.0 / 16.0
    accel_vrw_max_factor: float = 1.0
    accel_vrw_min_epochs: int = 50  # Doppler epochs the drive needs for it
    # where the roll gyro drives the bank (roll_gyro_bank_with_doppler), c_y's random walk is
    # left with what the roll gyro misses (its drift, the suspension roll model's error, the
    # accelerometer's drift): read from the drive the same way, halving cy_psd (down to
    # cy_psd_min_factor of it) while the Doppler velocities' likelihood improves
    identify_cy_psd: bool = True
    cy_psd_min_factor: float = 1.0 / 16.0
    gyro_arw_psd: float = 5e-4  # rad/sqrt(s): angle random walk (consumer MEMS 1e-4 ... 5e-4)
    gyro_standstill_sigma: float = 0.003  # rad/s per sample, the standstill yaw-rate update
    gyro_bias_psd: float = 2e-5  # rad/s/sqrt(s)
    cy_psd: float = 0.2  # m/s^2/sqrt(s): bank changes (5 deg over 50 m at 20 m/s)
    cx_psd: float = 0.1  # m/s^2/sqrt(s): grade changes
    wheel_scale_psd: float = 1e-5  # 1/sqrt(s)
    gyro_scale_psd: float = 1e-5  # 1/sqrt(s)
    # relative: users' files are 20-35 % off, compliance.  The prior's mean stays at the file's
    # value: centred instead where a first pass ends (a forward pass, or the smoother itself),
    # with Doppler, measured 2026-12-07: urban_highway 30 %-soft 0.033 -> 0.014 deg, banked_turn
    # 0.048 -> 0.031, but cr_step_steer 0.035 -> 0.090, cr_circle right 0.022 -> 0.043, mean
    # over 16 scenarios right / soft / rough 0.041 / 0.049 / 0.052 -> 0.045 / 0.050 / 0.050: the
    # learned scale carries the brush curve's model error too, and the data counted twice
    # follows it further
    stiffness_prior_sigma: float = 0.5
    stiffness_psd: float = 2e-3  # 1/sqrt(s): tyre temperature, wear, load
    # without GNSS Doppler, run once more with the rear stiffness's prior mean moved, and take
    # the sigma the share it keeps implies where larger than the smoother's (fused_stiffness;
    # one more pass of the estimator on such drives)
    stiffness_prior_check: bool = True
    # the smoother: where the rear scale it learned falls below SCALE_MIN through a force
    # noisier than force_sigma, run again with the file's stiffness, not learned (fused.fuse)
    stiffness_bound_fallback: bool = True
    # ... and only for an accelerometer sampled at most this fast (Hz): below it the car's
    # vibration (wheel, engine and road, 10-30 Hz) folds into the relation's band, as on the
    # Revs lap logged at 20 Hz (scale asked 0.35-0.49 with the file right); sampled faster it
    # stays above the force's low-pass (the same lap at 100 / 50 / 33 Hz learns 0.94 / 0.93 /
    # 0.88-0.91), so a scale asked below half there is a file more than twice too stiff, and
    # the bound stays (the lap at 100 Hz with cf, cr doubled: 0.92 deg on the file's
    # stiffness, 0.23 held at the bound)
    stiffness_fallback_max_rate_hz: float = 25.0
    # the causal filter: a stiffness scale an update took past SCALE_MIN / SCALE_MAX is moved
    # back onto the bound (with the states correlated with it; fused_engine._project_scales),
    # so that it can learn again.  The Revs lap cut into 30 s clips, fused_filter: the clip
    # from 225 s 1.50 -> 0.65 deg, from 450 s 1.59 -> 0.63 (the scale taken below 0.5 in the
    # first second, while v_y was its prior's, and held there); every other clip unchanged.
    # cr_limit_ramp seed 11 with a 5 s multipath burst and a 30 %-soft file, without the
    # Doppler check's hold on the tyres: 3.93 deg (29 % inside 2 sigma) -> 1.55 (92 %).
    # The smoother keeps the excursion: its fallback (above) reads it
    filter_project_scales: bool = True
    mu_prior: float = 1.0  # dry asphalt
    mu_prior_sigma: float = 0.35
    # mu's prior mean from the drive's own understeer angle where the drive used at least 90 %
    # of it (sideslip.calibrate.friction); its width stays mu_prior_sigma (the fit's own
    # 0.01-0.03 as the width: fused_filter on cr_limit_ramp seed 11, soft file, 5 s multipath
    # burst, 2.78 deg with 64 % inside 2 sigma).  Not the default: the fit decides the mu of
    # the axle that saturates, and the estimator has one mu, read by the rear axle's relation.
    # On CommonRoad's BMW limit ramp (front axle saturating) the rear took the front's mu well
    # (no GNSS, seeds 0-1: 0.317 -> 0.073 deg with the right file, 0.528 -> 0.100 with one
    # 30 % stiff; but 0.181 -> 0.204 and 0.221 -> 0.275 with the soft and rough files, whose
    # excess slip a mu too high had offset); on the front-heavy Ford Escort, a car no default
    # was measured on, the same ramp got worse (right file 0.164 -> 0.275 deg with Doppler,
    # 0.117 -> 0.145 without GNSS): with the front's mu its lightly loaded rear axle's slip is
    # over-predicted (plateau beta -0.67 deg with Doppler against the truth's -0.29 and -0.43
    # with the prior), and the drive, whose rear stayed below its limit, does not decide the
    # rear's own mu.  benchmarks/results/friction.md (b), (e)
    identify_mu: bool = False
    identify_mu_causal: bool = False  # the causal filter too (with identify_mu)
    # without GNSS the smoother's gyro-bias prior is the drive's own steering relation
    # (sideslip.calibrate.steer_yaw: its mean and 1-sigma in place of 0 +- 0.1 rad/s) where
    # that 1-sigma is at most steer_gyro_prior_max_sigma.  Without a heading reference a gyro
    # bias and a lateral offset (bank, accelerometer bias) over the speed read alike in the
    # kinematic relation; the steering tells them apart where the speed varies.  At one speed
    # the steering's zero is no narrower than v sigma(delta_0) / L (0.03 rad/s at 22 m/s),
    # wider than what the smoother gets on its own (1-sigma 0.018-0.022 rad/s), and carries the
    # steering sensor's offset whole: taken anyway it cost banked_turn 0.007 -> 0.020 deg (seeds
    # 0-3 alike), cr_limit_ramp 0.287 -> 0.331, one Revs clip 0.43 -> 0.68; hence the cap.  With
    # it, 20 s pieces without GNSS: urban_course mean 0.125 -> 0.079 deg, suburban_outages
    # 0.080 -> 0.061; urban_highway whole 0.016 -> 0.008; no whole drive worse.  The fit reads
    # the whole drive: the causal filter takes it with whole_drive_calibration, as it takes the
    # roll gyro's bias (no-GNSS 20 s clips, sim_clips.md: fused_filter mean 0.125 -> 0.094 deg;
    # every whole drive of no_gnss.md, unseen_vehicle.md and the real drives unchanged).
    # benchmarks/results/gyro_zero_steer.md
    steer_gyro_prior: bool = True
    steer_gyro_prior_max_sigma: float = 0.015  # rad/s
    mu_psd: float = 0.02  # 1/sqrt(s): patches of another surface
    latency_prior_sigma_s: float = 0.1  # s: receivers stamp fixes 0-200 ms late
    latency_psd: float = 1e-5  # s/sqrt(s)
    lever_prior_sigma_m: float = 0.5  # m: antenna positions users do not state
    lever_psd: float = 1e-5  # m/sqrt(s)
    wheel_sigma: float = 0.05  # m/s: noise and quantisation
    wheel_rel_sigma: float = 0.003  # fraction of the speed: wheel slip, rolling-radius changes
    # normalised longitudinal slip stiffness C_k / F_z of the wheels that give the speed
    # (Pacejka 2012, sec. 1.3: 15-20 for passenger-car tyres; the lower value, since the
    # speed wheels carry only part of the load): the wheel speed's slip sigma is a_x / (g C_k),
    # in corners with the cornering drag and the combined-slip compliance (fused_updates)
    wheel_slip_stiffness: float = 15.0
    gnss_vel_sigma: float = 0.1  # m/s, when the drive has no gnss_vel_std
    gnss_pos_sigma: float = 0.5  # m, white part, when the drive has no gnss_pos_std
    gnss_gm_sigma: float = 1.5  # m, correlated part of the position error per axis
    gnss_gm_tau_s: float = 60.0  # s, its correlation time
    force_sigma: float = 0.15  # m/s^2 floor on an axle relation's residual
    force_rel: float = 0.15  # relative error of the axle forces (load transfer, camber, lag)
    # tyre relaxation length: the axle relations take the force as instantaneous, real tyres
    # build it over about one relaxation length of travel (0.5-1.5 m for passenger-car tyres,
    # Pacejka 2012, sec. 7.2), so in transients the relation is wrong by about
    # relaxation_m / v_x * |d alpha_r / dt|, correlated over the transient, which the
    # covariance does not see; added to beta_std (measured over the comparison's scenarios:
    # 2-sigma share on slalom_low_mu 0.78 -> 0.91, cr_slalom 0.77 -> 0.98; estimate unchanged).
    # Taken as the slip less the slip through a first-order lag of relaxation_m / v_x (was
    # tau times a row-by-row derivative, which differentiated the yaw gyro's noise in the
    # slip: suburban_outages at 3-5 m/s median beta_std 0.47 deg against an RMSE of 0.024;
    # now 0.08.  Measured 2026-12-07 over the 16 scenarios x 3 receivers x 3 files: no
    # 2-sigma share of fused or fused_filter moved by more than 0.01; Revs lap 0.960 ->
    # 0.957 (fused_filter 0.963 -> 0.950), comma2k19 minute 0.987 -> 0.966).  The lag's time
    # constant also holds the force low-pass's where that is causal (force_tau_s, and
    # smoother_force_tau_s with GNSS): fused_filter on the race lap without GNSS, where beta
    # changes faster than 2 deg/s, 0.86 -> 0.97 inside 2 sigma (lowest share over the 16
    # scenarios x 3 receivers x 3 files 0.93 -> 0.98; Revs lap 0.956 -> 0.979; no estimate
    # moved)
    relaxation_m: float = 1.0
    axle_error_tau_s: float = 0.05  # s: correlation time of the axle relations' model error
    gate_chi2: float = 16.0  # NIS beyond which a wheel/axle update is down-weighted (Huber-type)
    gnss_gate_chi2: float = 16.0  # the same for GNSS (2 dof)
    gnss_reject_reset_s: float = 0.5  # s: after this long without an accepted epoch, accept
    standstill_speed: float = 0.05  # m/s
    # low-pass of the measured axle forces: it removes accelerometer noise, but its lag is
    # read by the axle relations as tyre slip in every transient, so it is as short as the
    # drive's noise allows: the time constant is the larger of the floor below and the one
    # that brings the drive's own accelerometer noise (per sample, from successive
    # differences) down to force_noise_sigma (smoother; the causal filter keeps its floor,
    # a whole-drive value would read the future).  The causal filter's floor is longer: it
    # has no later samples to average noise over (measured over the comparison with both
    # vehicle files: 0.05 s costs the filter 15-20 % in mean beta RMSE and the Revs lap
    # 0.44 -> 0.75 deg; 0.15 s costs the smoother 20 % and the Revs lap 0.27 -> 0.46 deg)
    force_tau_s: float = 0.15  # s: the causal filter's floor
    smoother_force_tau_s: float = 0.05  # s: the smoother's floor (tyre relaxation, 1 m at 20 m/s)
    force_noise_sigma: float = 0.3  # m/s^2: noise of the low-passed force the floor admits
    stiffness_curve_accel: float = 0.5  # m/s^2: an axle's stiffness learned beyond this force
    filter_steady_jerk_m_s3: float = 2.0  # m/s^3: the filter only while it changes slower
    mu_utilisation: float = 0.5  # mu learned only where an axle uses this share of mu F_z
    mu_floor_sigma: float = 0.05  # 1-sigma of the constraint mu >= |a| / g where violated
    adapt_tau_s: float = 1.0  # s: adaptive axle-noise time constant
    adapt_max: float = 400.0  # largest variance factor of the adaptive axle noise
    # smallest variance factor, with GNSS Doppler (without GNSS, and with positions alone, 1:
    # the tyres are then the only v_y cue in arcs and their innovations have no independent
    # reference; positions alone: mean beta RMSE over 14 scenarios 0.058 -> 0.057 deg with the
    # right file, 0.127 -> 0.114 with the soft one).  With GNSS Doppler
    # the axle relations' innovations are checked against an independent v_y, and
    # on gentle drives their NIS averages 0.04-0.05 (urban_highway, urban_course, demo): the
    # prior sigma force_sigma + force_rel |f| is ~4.5x too wide there, so the Doppler noise
    # (not the tyres) sets beta.  The drive's NIS identifies the relation's noise (the
    # adaptive factor follows it down as well as up), bounded so that the floor stays at
    # force_sigma / 2 = 0.075 m/s^2, above a MEMS accelerometer's turn-on offset (5 mg class,
    # which the relation cannot tell from tyre force).  Measured (beta RMSE deg, factor 1 ->
    # 0.25): urban_highway 0.035 -> 0.025, demo 0.022 -> 0.012, cr_circle 0.088 -> 0.026.
    # Not the default: that floor assumes the simulator's IMU.  On the real comma2k19 minute
    # (phone IMU in a RAV4, mount misalignment removed by estimate) 0.25 narrowed beta_std to
    # a median 0.064 deg and put 81 % of the errors inside 2 sigma, beta RMSE 0.0997 deg; at 1
    # (the floor stays at force_sigma, 15 mg: real accelerometer offsets and mounting errors)
    # 93 %, 0.0958; at 0.5, 87 %, 0.0978.  Simulated suite, right / 30 % soft file: 0.052 /
    # 0.062 at 0.25, 0.0545 / 0.0635 at 0.5, 0.0588 / 0.0656 at 1 (fused stays the best mean).
    # Again 2026-12-07 (with the accelerometer offset's sigma in beta_std): comma minute at
    # 0.25 / 0.5 / 1: 94.4 / 94.9 / 96.6 % inside 2 sigma, beta RMSE 0.095 / 0.094 / 0.092 deg
    # (demo 0.009 / - / 0.015): the real drive still prefers the floor
    adapt_min: float = 1.0
    # 1-sigma of a lateral accelerometer offset (m/s^2: a consumer MEMS turn-on bias of
    # 0.15 m/s^2 and g times a 1 deg mounting roll, 0.17 m/s^2, together 0.23, rounded up)
    # the drive cannot tell from tyre force: its slip offset enters beta_std where GNSS gives
    # the heading (fused.fuse; before only with adapt_min < 1, and a_y 0.25 m/s^2 high left
    # 13-14 % of beta errors outside 2 sigma on urban_highway and race_lap).  It was 0.15
    # (the bias alone) while the velocity random walk stayed at its wide prior, which
    # covered part of the offset by accident; with the random walk read from the drive
    # (identify_accel_vrw) the consumer-grade drives (1 deg mount, 0.15 m/s^2 bias, seed 11)
    # put 78 % (slalom_low_mu, offset drawn -0.42 m/s^2) and 88 % (race_lap) inside 2 sigma
    # at 0.15, 95 % and more at 0.25 (benchmarks/results/fused_accuracy.md)
    accel_offset_sigma: float = 0.25
    # the share of the drive's typical lateral offset (median of g sin(bank) with the
    # accelerometer's offset in it) that may be a tilted mount rather than road crossfall:
    # with equal priors on both (about 1.5 deg each), the tilt's posterior mean is half the
    # level (0: the offset's sigma is accel_offset_sigma alone)
    offset_level_share: float = 0.5
    # with GNSS Doppler, the lateral reading's offset from seed 000's heading closure in
    # curves (fused_accel_offset: doppler_slip's scan, with accel_offset_sigma as its prior),
    # taken out of the axle forces and the bank, its posterior sigma in beta_std, where the
    # scan decides it (five curves or more pinning it to 0.15 m/s^2).  Measured 2026-12-06:
    # urban_highway seeds 0-3 beta RMSE 0.024 / 0.027 / 0.025 / 0.019 -> 0.014 / 0.025 /
    # 0.018 / 0.016 deg (30 %-soft file 0.050 / 0.037 / 0.041 / 0.044 -> 0.033 / 0.037 /
    # 0.032 / 0.029), bank RMSE 0.29 / 0.31 / 0.30 / 0.19 -> 0.09 / 0.28 / 0.04 / 0.05 deg;
    # no other scenario of the comparison decides it (urban_course, rough file: 0.054 ->
    # 0.057).  Cost where the gyro shows five curves: one doppler_slip run (the 1 h bench
    # drive, whose curves do not decide it: 168k -> 117k samples/s, 137 -> 166 MB peak;
    # fused_filter 94k -> 82k, 151 -> 176 MB; bench.md)
    identify_accel_offset: bool = True
    axle_min_speed: float = 3.0  # m/s: below this the slip angles are ill-defined
    # below axle_min_speed (pulling away, parking, reversing) the rear axle's sideways
    # velocity v_y - l_r r stands in for the slip angle's relation: it is -|v_x| f_r / C_r
    # (the slip at the measured force), within low_speed_sigma (m/s: tyre lateral compliance,
    # uneven ground) plus the force's noise through the stiffness plus cg_sigma_m times the
    # yaw rate (a file's l_r that is off).  Without it nothing holds v_y at walking pace: a
    # drive that starts from rest put its first Doppler course error into v_y, the axle
    # relation then met a slip beyond the tyre's saturation (no gradient, gated as an
    # outlier), and the estimate kept beta 6 deg off all drive (tests/methods/robust_drives
    # parking drive: fused 5.8 deg, fused_filter 9.4 deg above 5 m/s)
    low_speed_axle: bool = True
    low_speed_sigma: float = 0.05
    cg_sigma_m: float = 0.1
    # use the steering angle (front-axle relation) when present.  Off: measured worse on
    # every Doppler drive but one (16 drives, right file, seed 0: mean 0.042 -> 0.193 deg;
    # step_steer 0.019 -> 0.789 and cr_step_steer 0.058 -> 0.916 with half the errors inside
    # 2 sigma: in a long steady turn the Doppler gives the course, not the slip, since the
    # heading drifts with the gyro bias, so the tyres set beta, and with both axles free in
    # stiffness v_y and the two scales slide together to the scales' lower bound; taking
    # the Doppler at full weight where the inertial check vouches for it changed nothing), and
    # without GNSS mixed (step_steer 0.019 -> 0.008, race_lap 0.086 -> 0.203,
    # fused_accuracy.md).  A tight stiffness prior (stiffness_prior_sigma 0.1) held
    # step_steer at 0.074
    front_axle: bool = False
    # the road bank changes as the body rolls: the roll gyro (less the suspension's roll
    # rate) drives c_y when the drive has wx, instead of c_y's random walk alone
    roll_gyro_bank: bool = True
    # ... in the smoother with GNSS Doppler too: the bank then follows the body's roll
    # instead of c_y's random walk, which in a steady turn let the Doppler's noise wander
    # into v_y (step_steer 0.029 -> 0.019 deg with cy_psd read from the drive,
    # benchmarks/results/fused_accuracy.md); the causal filter too (the roll gyro's bias,
    # the drive's mean roll rate, read from the whole drive as a calibration)
    roll_gyro_bank_with_doppler: bool = True
    # the roll gain from the roll gyro in the drive's lateral transients, weighted with the
    # file's m h / (k - m g h) as a 30 % prior (sideslip.methods.roll_gyro_gradient; read from
    # the whole drive, for the causal filter too, as a calibration of the car): a file whose
    # mass, CG height and roll stiffness double the roll misreads the tyres' force by 15 % at
    # the limit
    identify_roll_gradient: bool = True
    # the causal filter (fused_filter) reads the car's and the receiver's calibrations from
    # the whole drive, as the smoother does: the roll gain, the Doppler latency, the velocity
    # and bank random walks and the roll gyro's bias; its states stay causal.  False: strictly
    # on-line (the file's roll gain, the receiver's stamps, the prior noise, c_y a random
    # walk), and with Doppler and fixes the antenna the smoother's check_doppler_lever
    # finds (the smoother then runs first: fused_filter 248k -> 98k samples/s).  Measured,
    # 16 drives x 3 files with Doppler: fused_filter mean 0.138 -> 0.110 deg; with the
    # antenna 0.5 m ahead / behind (right file) 0.212 / 0.228 -> 0.157 / 0.152
    # (fused_accuracy.md)
    whole_drive_calibration: bool = True
    # without GNSS the smoother's axle forces are low-passed zero-phase and split with the
    # yaw acceleration (the transients are then the stiffness's only teacher; fused.fuse)
    tyres_only_transients: bool = True
    yaw_acceleration: bool = False  # split the axle forces with the yaw acceleration too
    # GNSS positions without Doppler: the smoother's tyres carry the slip in arcs as without
    # GNSS (stiffness learned where the lateral force changes; zero-phase forces; the roll
    # gyro drives the bank; beta_std with the relation's error), since on an arc the track
    # cannot tell a course error from an offset of the fixes (fused.fuse).  Measured, 14
    # scenarios, fixes at 20 Hz 50 ms late with the antenna 0.5 m off (mean beta RMSE, deg):
    # 0.155 -> 0.057 with the right file, 0.225 -> 0.114 with one 30 % soft (with adapt_min
    # at 1 there too); fused_filter 0.255 -> 0.109 and 0.273 -> 0.218
    positions_only_tyres: bool = True
    identify_gnss_calibration: bool = False  # latency and lever arm as states (positions only)
    # with Doppler too (opt-in): the antenna's lever-arm error (and the fixes' latency) as
    # states with the prior lever_prior_sigma_m, for a vehicle file whose antenna position is
    # not trusted.  An antenna 0.5 m ahead of / behind where the file says takes urban_course
    # (seed 0) from 0.037 to 0.178 / 0.401 deg beta RMSE, race_lap from 0.074 to 0.364 /
    # 0.251; with the states 0.062 / 0.079 and 0.046 / 0.044 (100 % inside 2 sigma).
    # Off by default: in steady turns r dl_x reads as v_y, and with the right file the 17
    # comparison drives' mean went 0.059 -> 0.124 (cr_circle 0.107 -> 0.883, step_steer
    # 0.034 -> 0.086)
    identify_doppler_lever: bool = False
    # with Doppler and fixes (smoother): the antenna's longitudinal lever arm checked against
    # the Doppler with the tyres switched off (sideslip.methods.fused_lever); the file's is
    # kept unless the drive puts the antenna more than doppler_lever_z sigmas from it (less
    # the node inputs' half-row timing) and, with the tyres, the moved antenna lowers the
    # Doppler's -2 log L by more than doppler_lever_z^2.  The 16 comparison drives x 3 files
    # with the antenna 0.5 m ahead / behind: beta mean 0.144 -> 0.105 / 0.193 -> 0.130 deg,
    # with it where the file says 0.0482 -> 0.0482 (fused_accuracy.md)
    check_doppler_lever: bool = True
    doppler_lever_z: float = 3.0
    # where that check finds the antenna off (tyre-free the kinematics see only the antenna's
    # place relative to the IMU), the smoother runs once more with the IMU moved by -dl_x
    # instead and takes whichever of the file's installation, the moved antenna and the
    # moved IMU the Doppler's likelihood with the tyres prefers (the IMU by more than
    # doppler_lever_z^2 over the file's; sideslip.methods.fused_lever.ImuAlternative)
    check_imu_lever: bool = True
    # with Doppler (smoother): the antenna's place from the turns slower than
    # box_speed_max_m_s, where the rear axle does not slide sideways (regressed against the
    # yaw rate beside a stiffness-free linear slip term; sideslip.methods.fused_box); a sensor
    # box the file misplaces moves antenna and IMU together, which the check above cannot see.
    # Moved where beyond doppler_lever_z jackknife sigmas over box_block_s blocks, judged with
    # box_min_blocks blocks of such turns at least; with check_doppler_lever only (the place
    # of antenna and IMU against each other is that check's)
    check_box_lever: bool = True
    box_speed_min_m_s: float = 2.0
    box_speed_max_m_s: float = 9.0
    box_accel_max_m_s2: float = 3.0
    box_block_s: float = 10.0
    box_min_blocks: int = 5
    # with Doppler (smoother) and no slow turns to judge the box by: the Doppler's -2 log L
    # with the tyres, the box (antenna and IMU together) moved by d along x, scored from 0
    # outwards in steps of box_profile_step_m while within doppler_lever_z^2 of the lowest
    # (at most box_profile_max_m out); moved to the minimum where that beats the file's place
    # by doppler_lever_z^2, else kept with the profile's doubt (the minimum's distance and
    # sigma, times |r| / v) in beta_std (sideslip.methods.fused_box_profile)
    profile_box_lever: bool = True
    box_profile_step_m: float = 0.5
    box_profile_max_m: float = 2.0
    # positions only: the receiver's latency from the fixes' speed against the wheels
    # (sideslip.gnss_latency; tyre-free, so slip cannot pass for delay), combined with the
    # prior N(0, latency_prior_sigma_s); the prior's noise stays on the positions.  The
    # smoother only (it reads the whole drive).  Measured (benchmarks/results/gnss_latency.md,
    # 20 Hz fixes 0 / 0.05 / 0.15 s late, antenna -0.5 / 0 / +0.5 m off): mean beta RMSE
    # 0.252 -> 0.150 deg; where an antenna ahead cancels the lateness (issue 15's receiver:
    # 50 ms late, 0.5 m ahead, i.e. no offset at 10 m/s) it costs: positions-only suite
    # 0.081 -> 0.090 (right file), 0.124 -> 0.121 (soft)
    identify_gnss_latency: bool = True
    # GNSS Doppler: its latency from the Doppler speed against the wheels (tyre-free,
    # sideslip.gnss_latency.identify_doppler_latency), applied where decisive and late
    # (fused._doppler_latency); the epochs are then taken at their stamp less it, by the
    # causal filter too (a calibration of the receiver, read from the whole drive)
    identify_doppler_latency: bool = True
    # 1-sigma (s) of the prior on a Doppler latency the drive does not decide (few speed
    # changes and few turns): a logger that stamps the receiver's messages on arrival is
    # 50-100 ms late; r times the latency's rms about 0 (this prior with the drive's fits,
    # fused._doppler_latency) enters beta_std.  0.03 s left step_steer 100 ms late with 20 %
    # of its errors inside 2 sigma (doppler_latency.md)
    doppler_latency_prior_sigma_s: float = 0.05
    # where those fits leave the latency open (not applied, not decisive that it is on time),
    # the smoother profiles it with the tyres: the Doppler's -2 log L with the epochs taken tau
    # before their stamps, over the fits' estimate +- latency_profile_sigmas sigma in steps of
    # latency_profile_step_s (at most latency_profile_points runs before the extension and the
    # refinement), and takes the minimum where it beats the stamps by doppler_lever_z^2 and
    # every installation the antenna check proposes (sideslip.methods.fused_latency).
    # Measured: doppler_latency.md (the late cells the fits left open) and fused_accuracy.md
    profile_doppler_latency: bool = True
    latency_profile_sigmas: float = 2.5
    latency_profile_step_s: float = 0.05
    latency_profile_points: int = 5
    # positions only: how long one unidentified latency / lever-arm offset of the fixes lasts
    # for the noise model (its variance times the fixes in this span, at least one: a span
    # shorter than the fix interval counts it as white).  The offset is the receiver's and the
    # antenna's, the same for the whole drive; 20 s lets a turn's fixes carry it once.
    # Measured (benchmarks/results/positions_offset_span.md: 20 Hz fixes 50 ms late with the
    # antenna 0.5 m ahead / behind / at the file, or 150 ms late; 16 scenarios; mean over the
    # four receivers of the mean beta RMSE, deg): 1 s -> 20 s right file 0.099 -> 0.079,
    # 30 %-soft 0.168 -> 0.152, rough 0.164 -> 0.143; worst receiver 0.136 -> 0.087 (right),
    # 0.227 -> 0.168 (soft), 0.220 -> 0.158 (rough).  Where the antenna ahead cancels the
    # lateness (issue 15's receiver) the fixes are nearly unbiased and a wrong file loses
    # their pull: soft 0.120 -> 0.139, rough 0.119 -> 0.130.  Longer spans approach the
    # tyres alone (40 s: 0.077 / 0.151 / 0.140; 100-400 s flat), where the fixes correct
    # only a gross tyre error
    gnss_offset_span_s: float = 20.0
    health_window_s: float = 2.0  # s: window of the consistency test
    # the axle curve of the tyre relations (models.axle_force): 0, the brush (Fiala) curve; a
    # value > 1, the simplified Magic Formula with that shape factor (1.3: Pacejka's typical
    # lateral value), more linear at moderate utilisation.  Measured with S = 1.3 (mean beta
    # RMSE over the 16 simulated scenarios, right / 30 %-soft file, deg): Doppler 0.052 /
    # 0.063 -> 0.053 / 0.061; positions only 0.081 / 0.124 -> 0.086 / 0.113; no GNSS
    # 0.077 / 0.146 -> 0.078 / 0.131; Revs lap 0.245 -> 0.232; but on CommonRoad's tyres
    # with the right file cr_step_steer 0.020 -> 0.031 and cr_limit_ramp 0.31 -> 0.41 without
    # GNSS, and the causal filter's 2-sigma share 0.96 -> 0.88 (cr_limit_ramp): not the default.
    # -1: Dugoff's curve (linear to half the limit, then F - F^2 / (4 C z)), measured
    # 2026-12-06 over the same 16 scenarios at seed 0 (right / soft / rough file): Doppler
    # 0.042 / 0.050 / 0.053 -> 0.047 / 0.051 / 0.055; positions only 0.073 / 0.139 / 0.130 ->
    # 0.089 / 0.117 / 0.111; no GNSS 0.077 / 0.146 / 0.139 -> 0.090 / 0.127 / 0.122; Revs lap
    # 0.245 -> 0.209 (comma minute 0.092 either); it needs more slip than the brush near the
    # limit (at 90 % of it 2.5 F / C against 1.6), and CommonRoad's limit ramp without GNSS
    # went 0.309 -> 0.579, step_steer 0.019 -> 0.072: not the default either.
    # S = 1.3 again on 2026-12-07 (brush -> MF, mean beta RMSE, deg; no 2-sigma share moved):
    # the 16 scenarios, right / soft / rough file, Doppler 0.041 / 0.049 / 0.052 -> 0.043 /
    # 0.049 / 0.052, positions only 0.073 / 0.139 / 0.130 -> 0.077 / 0.123 / 0.116, no GNSS
    # 0.077 / 0.146 / 0.139 -> 0.078 / 0.131 / 0.125; CommonRoad's Escort and Vanagon (seed 7,
    # five manoeuvres), right / rough file: no GNSS 0.129 / 0.217 -> 0.133 / 0.187, positions
    # 0.119 / 0.188 -> 0.121 / 0.162, Doppler 0.125 / 0.146 -> 0.107 / 0.148; Revs lap 0.245 ->
    # 0.232; but at the limit (CommonRoad limit ramp, seeds 1-6) the brush was better on every
    # seed: Doppler 0.098 -> 0.115, no GNSS 0.328 -> 0.435 (right file).  More linear at
    # moderate utilisation fits all three truths (the simulator's, CommonRoad's, the Revs
    # car's) better, the brush fits CommonRoad's limit better: the brush stays the default
    axle_curve_shape: float = 0.0
    # a drive without an ax column: the speed's rate low-passed with this time constant (s)
    # is the longitudinal input (fused._speed_rate; the process model then drops its r v_y
    # term, fused_engine.C_AX_SPEED_RATE).  Measured 0.05 / 0.1 / 0.2 s (beta RMSE deg,
    # fused / fused_filter, ax removed): Revs lap 0.246 / 0.450, 0.246 / 0.453, 0.246 / 0.458
    # (with its ax 0.245 / 0.378; with the input 0 as before 0.415 / 23.4); race lap with
    # Doppler 0.073 / 0.188, 0.076 / 0.189, 0.093 / 0.289; without GNSS 0.084 / 0.287, 0.083 /
    # 0.282, 0.083 / 0.286; urban_course without GNSS 0.061 / 0.065, 0.060 / 0.052, 0.060 /
    # 0.066.  0.1 s is five samples of a 50 Hz wheel speed
    ax_from_speed_tau_s: float = 0.1
    # GNSS Doppler against the inertial propagation (fused_engine._doppler_check): an epoch
    # that disagrees with the velocity the accelerometers carried forward from the last
    # agreeing epoch has its variance grown to cover the disagreement; after two or more in a
    # row (a multipath burst) the excess stays on the next epochs for doppler_check_tau_s.
    # Multipath bursts (runs of moderately wrong epochs that agree with each other) pass a
    # per-epoch gate; a wrong tyre model leaves GNSS and IMU in agreement and is not flagged.
    # Measured (mean beta RMSE over seeds 0-3, deg, off -> on): cr_limit_slalom 0.51 -> 0.19,
    # cr_limit_ramp 0.64 -> 0.12 (seed 1: 2.13 deg with 17 % inside 2 sigma -> 0.14, 97 %);
    # the 14 scenarios of compare_methods.md: mean 0.036 -> 0.035 (right file), 0.046 -> 0.046
    doppler_check: bool = True
    doppler_check_accel_sigma: float = 0.1  # m/s^2: drift of the carried velocity (10 mg class)
    doppler_check_chi2: float = 9.21  # chi^2 (2 dof, 99 %) of the check
    doppler_check_tau_s: float = 2.0  # s: multipath persists while the reflecting geometry lasts
    doppler_check_bank_tau_s: float = 2.0  # s: c_y's lag after a bank change the check allows for
    # while the check rejects a run of Doppler epochs (two or more in a row), the tyres learn
    # nothing: their stiffness and mu are consider parameters of the axle relations.  A long
    # burst (5 s on cr_limit_ramp seed 11) outlasts the check, whose inertial anchor drifts
    # until it admits the burst's middle; learned during the first limit ramp, its course
    # error became a rear axle at 0.5x the file's and kept beta 2 deg off after the burst.
    # Measured (beta RMSE deg / share inside 2 sigma, off -> on): that drive with the file
    # 30 % soft 2.02 / 0.21 -> 0.34 / 0.95 (fused_filter 1.99 / 0.80 -> 1.31 / 0.94); the
    # CommonRoad limit ramp and slalom, seeds 1-12, right and rough files: mean 0.185 ->
    # 0.152, lowest share 0.64 -> 0.98 (fused_filter 0.510 -> 0.442, 0.31 -> 0.97); the
    # 16-scenario comparison (three files): no beta cell moved by more than 0.003 deg
    doppler_check_holds_tyres: bool = True
    # the smoother looks at the Doppler once more against its smoothed track: epochs beyond
    # doppler_burst_gate x the drive's own residual scale, in runs of doppler_burst_min_run
    # or more, are a burst the forward check let in; they get their distance as sigma and
    # the smoother runs again (sideslip.methods.fused_bursts; benchmarks/results/
    # fused_accuracy.md, session 27)
    doppler_burst_check: bool = True
    doppler_burst_gate: float = 3.5  # per-axis scales: 2-D chi^2 at 99.8 %
    doppler_burst_min_run: int = 2

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool):
                continue
            if f.name == "axle_curve_shape":
                if not (math.isfinite(value) and (value == 0.0 or value == -1.0 or value > 1.0)):
                    raise ValueError(
                        f"FusedSettings.axle_curve_shape = {value!r}: expected 0 (brush curve), -1 "
                        "(Dugoff curve) or a Magic Formula shape factor > 1"
                    )
                continue
            zero_ok = f.name in ("step_s", "offset_level_share")
            ok = math.isfinite(value) and (value >= 0 if zero_ok else value > 0)
            if not ok:
                expected = ">= 0" if zero_ok else "> 0"
                raise ValueError(f"FusedSettings.{f.name} = {value!r}: expected a finite number {expected}")
        if self.offset_level_share > 1.0:
            raise ValueError(f"FusedSettings.offset_level_share = {self.offset_level_share!r}: expected <= 1")
        if self.adapt_max < 1.0:
            raise ValueError(f"FusedSettings.adapt_max = {self.adapt_max!r}: expected >= 1")
        if self.accel_vrw_min_factor > 1.0:
            raise ValueError(
                f"FusedSettings.accel_vrw_min_factor = {self.accel_vrw_min_factor!r}: expected <= 1"
            )
        if self.cy_psd_min_factor > 1.0:
            raise ValueError(f"FusedSettings.cy_psd_min_factor = {self.cy_psd_min_factor!r}: expected <= 1")
        if self.accel_vrw_max_factor < 1.0:
            raise ValueError(
                f"FusedSettings.accel_vrw_max_factor = {self.accel_vrw_max_factor!r}: expected >= 1"
            )


def accel_noise_sigma(ay: FloatArray) -> float:
    """White-noise sigma (m/s^2 per sample) of an accelerometer channel from its successive
    differences (robust: 1.4826 MAD / sqrt(2); driving changes little between samples)."""
    d = np.diff(ay[np.isfinite(ay)])
    if d.size < 10:
        return 0.0
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / math.sqrt(2.0))


def force_time_constant(
    t: FloatArray, ay: FloatArray, floor_s: float, nz: FusedSettings, zero_phase: bool = False
) -> float:
    """Time constant (s) of the axle forces' low-pass: ``floor_s``, or longer where the drive's
    accelerometer noise sigma_a needs it: a first-order low-pass of white noise at step dt
    leaves sigma_a sqrt(dt / (2 tau)), run forwards and backwards (``zero_phase``: the squared
    gain twice, whose integral is half the single pass's) sigma_a sqrt(dt / (4 tau)), brought
    down to ``nz.force_noise_sigma``.  ``ay``: the samples (NaN between them), dt their own
    spacing (:func:`sample_step`)."""
    if t.size < 3:
        return floor_s
    dt = sample_step(t, ay)
    sig = accel_noise_sigma(ay)
    passes = 4.0 if zero_phase else 2.0
    return max(floor_s, dt * sig**2 / (passes * nz.force_noise_sigma**2))


def force_noise_variance(
    t: FloatArray, ay: FloatArray, tau_s: float, nz: FusedSettings, causal: bool
) -> FloatArray:
    """Per-row variance (m/s^2 squared, quoted per ``axle_error_tau_s`` like the axle
    relations' own) that the drive's accelerometer noise leaves in the axle forces after the
    low-pass of time constant ``tau_s``: sigma_a^2 dt / (2 tau), correlated over tau, so
    times tau / axle_error_tau_s.  sigma_a from successive differences: over the whole drive
    (robust, :func:`accel_noise_sigma`) off-line; for the causal filter the running mean of
    the squared differences up to each row (a simulated MEMS unit adds almost nothing; a
    real car's vibration, 0.85 m/s^2 per sample on the Revs lap, doubles the 0.15 floor).
    ``ay``: the samples (NaN between them), dt their own spacing (:func:`sample_step`); the
    causal mean is over the differences of successive samples at most 1.5 spacings apart."""
    n = t.size
    if n < 3:
        return np.zeros(n)
    dt = sample_step(t, ay)
    scale = dt / (2.0 * tau_s) * max(tau_s / nz.axle_error_tau_s, 1.0)
    if not causal:
        return np.full(n, accel_noise_sigma(ay) ** 2 * scale)
    rows = np.flatnonzero(np.isfinite(ay))
    d2 = np.zeros(n)
    counted = np.zeros(n)
    if rows.size > 1:
        close = np.diff(t[rows]) <= 1.5 * dt
        d2[rows[1:]] = np.where(close, np.diff(ay[rows]) ** 2, 0.0)
        counted[rows[1:]] = close
    running = np.cumsum(d2) / np.maximum(np.cumsum(counted), 1.0)
    return np.asarray(0.5 * running * scale, dtype=float)
