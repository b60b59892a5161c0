"""The fused estimator's compiled row helpers against their numpy equivalents."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sideslip.methods import fused_engine as eng
from sideslip.methods.fused import AUX_KEYS, _node_weights
from sideslip.models.fused_process import ICX, ICY, IMU, IPSI, ISG, ISR, IVX, IVY, NX_CORE
from sideslip.vehicle import G


def test_block_means_equal_reduceat_over_each_nodes_rows() -> None:
    """On evenly spaced rows the rectangle rule's time-weighted mean is the rows' mean, and
    the columns after ``n_inputs`` (the gap fills' increments) are the rows' mean anyway."""
    rng = np.random.default_rng(0)
    cols = tuple(rng.normal(size=103) for _ in range(3))
    t = 0.01 * np.arange(103.0)
    idx = np.array([0, 5, 10, 11, 40, 100])
    counts = np.diff(np.append(idx, 103))
    for n_inputs in (0, 2):
        U = eng.block_means(idx, cols, t, n_inputs, False)
        for c, col in enumerate(cols):
            np.testing.assert_allclose(U[:, c], np.add.reduceat(col, idx) / counts, rtol=1e-12)


def test_trapezoidal_node_inputs_integrate_a_sampled_ramp_exactly() -> None:
    """The trapezoidal rule's mean over [t[idx[j]], t[idx[j+1]]]: for a ramp sampled at its
    instants, the ramp's value at the interval's middle, evenly spaced or not (the rectangle
    rule's mean sits half a row earlier); the last node (no row after it) keeps its rows'
    mean."""
    rng = np.random.default_rng(3)
    for t in (0.01 * np.arange(103.0), np.cumsum(rng.uniform(0.005, 0.03, 103))):
        ramp = 0.3 + 2.0 * t
        idx = np.array([0, 5, 10, 11, 40, 100])
        U = eng.block_means(idx, (ramp,), t, 1, True)
        mid = 0.3 + 2.0 * 0.5 * (t[idx[:-1]] + t[idx[1:]])
        np.testing.assert_allclose(U[:-1, 0], mid, rtol=1e-12)
        np.testing.assert_allclose(U[-1, 0], ramp[100:].mean(), rtol=1e-12)
    rect = eng.block_means(idx, (ramp,), t, 1, False)
    assert np.all(rect[:-1, 0] < U[:-1, 0])


def test_a_pause_inside_a_node_step_counts_for_its_duration() -> None:
    """Rows 10 ms apart but one 2 s step (a pause of the logger): the node step over it takes
    the sample before the pause for 2 s of its 2.04 s (rectangle rule), or the mean of the
    samples on both sides (trapezoidal), not one fifth of the step as a row mean would."""
    t = np.concatenate([0.01 * np.arange(8), 2.07 + 0.01 * np.arange(8)])
    col = np.where(t < 1.0, 1.0, 3.0)
    idx = np.array([0, 5, 10, 15])  # node 1 spans rows 5..10: the pause is t[7] -> t[8]
    rect = eng.block_means(idx, (col,), t, 1, False)
    trap = eng.block_means(idx, (col,), t, 1, True)
    span = t[10] - t[5]
    np.testing.assert_allclose(rect[1, 0], (1.0 * (t[8] - t[5]) + 3.0 * (t[10] - t[8])) / span, rtol=1e-12)
    np.testing.assert_allclose(trap[1, 0], (1.0 * (t[7] - t[5]) + 2.0 * 2.0 + 3.0 * (t[10] - t[8])) / span, rtol=1e-12)
    assert rect[1, 0] < 1.05 and 1.9 < trap[1, 0] < 2.1


def test_node_interpolation_equals_np_interp_including_the_ends() -> None:
    rng = np.random.default_rng(1)
    tn = np.cumsum(rng.uniform(0.01, 0.1, 50))
    t = np.linspace(tn[0] - 0.2, tn[-1] + 0.2, 997)  # rows before the first and after the last node
    nodes = {"a": rng.normal(size=50), ("var", 3): rng.uniform(size=50)}
    j, w = _node_weights(t, tn)
    rows = eng.interp_rows(j, w, np.stack(list(nodes.values())))
    for row, v in zip(rows, nodes.values(), strict=True):
        # the fraction is float32: at most ~6e-8 of one node step's change
        np.testing.assert_allclose(row, np.interp(t, tn, v), rtol=0, atol=1e-7 * np.ptp(v))


def test_row_outputs_equal_the_numpy_formulas() -> None:
    """beta, its 1-sigma (atan2 gradient, inflation, tyre term, relaxation lag: the slip less
    the slip through a first-order lag of relax / |v_x| seconds), bank/roll/pitch and the
    Euler yaw rate, row by row."""
    rng = np.random.default_rng(2)
    n = 400
    t = np.cumsum(rng.uniform(0.005, 0.02, n))
    vx = np.concatenate([np.full(20, 0.2), rng.uniform(5, 30, n - 20)])  # standstill first
    vy = rng.normal(0, 0.5, n)
    var_vx, var_vy = rng.uniform(1e-4, 1e-2, n), rng.uniform(1e-4, 1e-2, n)
    cvv = 0.3 * np.sqrt(var_vx * var_vy)
    infl = rng.uniform(1, 3, n)
    bg, cy, cx, sg = rng.normal(0, 0.01, n), rng.normal(0, 0.5, n), rng.normal(0, 0.3, n), rng.normal(0, 0.01, n)
    wz, wy, fy = rng.normal(0, 0.3, n), rng.normal(0, 0.05, n), rng.normal(0, 3, n)
    s_r, var_sr = rng.uniform(0.1, 1.5, n), rng.uniform(0, 0.05, n)
    k_phi, l_r, rel, floor, relax = 0.005, 1.4, 0.2, 0.01, 1.0
    # every row its own node (j = i, w = 0): the state terms enter as they are
    aux = {("var", IVX): var_vx, ("var", IVY): var_vy, "cvv": cvv, "inflation": infl, ICY: cy,
           ICX: cx, ISG: sg, ISR: s_r, ("var", ISR): var_sr}  # fmt: skip
    nodes = np.stack([aux[k] for k in AUX_KEYS])
    beta, beta_std, r, roll, bank, pitch = eng.row_outputs(
        t, vx, vy, bg, wz, wy, fy, np.arange(n), np.zeros(n), nodes,
        k_phi, l_r, True, rel, floor, relax, math.radians(30.0), math.radians(5.0),
    )  # fmt: skip
    moving = np.abs(vx) > 0.5
    s2 = vx**2 + vy**2
    jx, jy = -vy / s2, vx / s2
    vb = (jx**2 * var_vx + jy**2 * var_vy + 2 * jx * jy * cvv) * infl
    alpha = -(vy - l_r * (wz - bg)) / np.maximum(np.abs(vx), 1.0)
    vb += (rel * alpha) ** 2 + floor**2
    vb += (np.sqrt(var_sr) / np.maximum(s_r, 0.2) * alpha) ** 2
    relaxed = alpha.copy()
    for i in range(1, n):
        k = 1.0 - np.exp(-(t[i] - t[i - 1]) * np.maximum(abs(vx[i]), 1.0) / relax)
        relaxed[i] = relaxed[i - 1] + k * (alpha[i] - relaxed[i - 1])
    vb += (alpha - relaxed) ** 2
    std_ref = np.where(moving, np.minimum(np.sqrt(vb), math.radians(30.0)), math.radians(5.0))
    np.testing.assert_allclose(beta, np.where(moving, np.arctan2(vy, np.abs(vx)), 0.0), rtol=1e-12)
    np.testing.assert_allclose(beta_std, std_ref, rtol=1e-10)
    bank_ref = np.arcsin(np.clip(cy / G, -0.6, 0.6))
    pitch_ref = np.arcsin(np.clip(-cx / G, -0.6, 0.6))
    roll_ref = bank_ref + k_phi * fy
    r_ref = ((wz - bg) * (1 - sg) * np.cos(roll_ref) + wy * np.sin(roll_ref)) / np.cos(pitch_ref)
    np.testing.assert_allclose(bank, bank_ref, rtol=1e-12)
    np.testing.assert_allclose(roll, roll_ref, rtol=1e-12)
    np.testing.assert_allclose(pitch, pitch_ref, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(r, r_ref, rtol=1e-12, atol=1e-15)


def test_blocked_smoother_equals_one_block(monkeypatch) -> None:
    """The backward pass in blocks (gains of the next block on a second thread) gives the
    same smoothed states as one block over the whole drive: block edges are handled exactly."""
    from sideslip.methods.registry import run_method
    from sideslip.simulate import simulate
    from sideslip.vehicle import load_vehicle

    drive = simulate("step_steer", seed=0)
    vehicle = load_vehicle(drive.meta["vehicle"])
    one = run_method("fused", drive, vehicle)
    monkeypatch.setattr(eng, "SMOOTHER_CHUNK", 37)  # many blocks, an odd size
    blocked = run_method("fused", drive, vehicle)
    for name in ("beta", "beta_std", "vx", "r"):
        np.testing.assert_allclose(blocked.series[name], one.series[name], rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("holes", [False, True, "no ax"])
@pytest.mark.parametrize("gnss", [True, False])
@pytest.mark.parametrize("method", ["fused", "fused_filter"])
def test_long_drive_rebuilding_the_row_inputs_gives_the_same_estimate(
    monkeypatch, method: str, gnss: bool, holes: bool | str
) -> None:
    """On a long drive ``fuse`` frees the per-row IMU inputs during the node pass and rebuilds
    them afterwards (memory, issue 17): the outputs and params equal the held-inputs path
    bit for bit (the threshold lowered below this drive's length), with and without GNSS
    (whose absence changes the smoother's force low-pass), with 0.5 s holes in a_y and w_z
    (filled through the kinematics, fused._lateral_fill: the rebuild must fill them alike), and
    without an ax column (the speed's rate stands in, fused._speed_rate: the rebuild too)."""
    from sideslip.drive import Drive
    from sideslip.methods import fused
    from sideslip.methods.registry import run_method
    from sideslip.simulate import simulate
    from sideslip.vehicle import load_vehicle

    drive = simulate("dlc_bank", seed=0)
    kept = {k: v for k, v in drive.data.items() if gnss or not k.startswith("gnss_")}
    if holes == "no ax":
        del kept["ax"]
    elif holes:
        for name, start in (("ay", 800), ("wz", 1500), ("ay", 2300)):
            col = np.array(kept[name], dtype=float)
            col[start : start + 50] = np.nan
            kept[name] = col
    drive = Drive(drive.t, kept, drive.meta, drive.path)
    vehicle = load_vehicle(drive.meta["vehicle"])
    held = run_method(method, drive, vehicle)
    monkeypatch.setattr(fused, "LONG_DRIVE_ROWS", len(drive) // 2)
    rebuilt = run_method(method, drive, vehicle)
    assert held.series.keys() == rebuilt.series.keys()
    for name, values in held.series.items():
        np.testing.assert_array_equal(rebuilt.series[name], values, err_msg=name)
    assert rebuilt.params == held.params


def test_the_estimate_carries_each_cues_nis_and_it_exposes_a_faulty_receiver() -> None:
    """Per-cue NIS on the estimate, at the node rows only (a node every ~5th row plus every
    GNSS epoch).  A receiver whose Doppler is 1 m/s off east makes that cue's mean NIS grow many
    times over the clean drive's (measured: 3.9 clean; a 1 m/s bias against a 0.1 m/s sigma
    is ~100 in NIS where the robust weights let it through); the wheel speeds barely move."""
    from dataclasses import replace

    from sideslip.methods.registry import run_method
    from sideslip.simulate import simulate
    from sideslip.vehicle import load_vehicle

    drive = simulate("urban_highway", seed=0, duration_s=120.0)
    vehicle = load_vehicle(drive.meta["vehicle"])
    clean = run_method("fused", drive, vehicle)
    assert {"wheel_speed_nis", "rear_axle_nis", "gnss_velocity_nis", "gnss_position_nis"} <= set(clean.innovations)
    v = clean.innovations["wheel_speed_nis"]
    assert v.shape == (len(drive),)
    assert 0.1 * len(drive) < np.isfinite(v).sum() < 0.5 * len(drive)
    data = dict(drive.data)
    burst = (drive.t > 40.0) & (drive.t < 60.0)
    data["gnss_ve"] = np.asarray(drive["gnss_ve"]) + np.where(burst, 1.5, 0.0)
    faulty = run_method("fused", replace(drive, data=data), vehicle)
    m_clean = float(np.nanmean(clean.innovations["gnss_velocity_nis"][burst]))
    m_faulty = float(np.nanmean(faulty.innovations["gnss_velocity_nis"][burst]))
    assert m_faulty > 3.0 * m_clean


def _check_config() -> np.ndarray:
    cfg = np.zeros(eng.N_CFG)
    cfg[eng.C_ACCEL_VRW] = 0.1
    cfg[eng.C_VCHECK_ACCEL] = 0.1
    cfg[eng.C_VCHECK_GATE] = 9.21
    cfg[eng.C_VCHECK_TAU] = 2.0
    return cfg


def _new_check() -> np.ndarray:
    """The engine's own fresh check state: a hand-made array once lacked the two road-roll
    entries the check reads (numba does not bound-check), and the spike test then failed
    whenever the memory past its end held a large number."""
    return eng.new_doppler_check()


def test_doppler_check_passes_agreeing_epochs_and_inflates_a_lone_spike_only_there() -> None:
    """Epochs that agree with the inertial anchor are taken as they are (factor 1); a lone
    epoch 1 m/s off (20 sigma of a 0.05 m/s receiver) gets the variance of its distance,
    1 + 0.5 * 1^2 / 0.05^2 = 201, and leaves nothing behind: the next epoch is factor 1."""
    cfg, chk, var_g = _check_config(), _new_check(), 0.05**2
    factors = [eng._doppler_check(chk, 0.1 * k, 20.0, 0.0, var_g, 0.0, cfg) for k in range(5)]
    assert factors == [1.0] * 5
    assert eng._doppler_check(chk, 0.5, 20.0, 1.0, var_g, 0.0, cfg) == pytest.approx(201.0)
    assert eng._doppler_check(chk, 0.6, 20.0, 0.0, var_g, 0.0, cfg) == 1.0


def test_doppler_check_keeps_a_burst_suspect_after_it_seems_to_end() -> None:
    """Three epochs 0.5 m/s off in a row (a multipath burst) are each inflated; after the
    second the excess 0.5 * 0.5^2 = 0.125 m^2/s^2 stays on the receiver, fading with tau 2 s:
    the first epoch back on the anchor 0.1 s later carries 1 + 0.125 e^-0.05 / 0.0025."""
    cfg, chk, var_g = _check_config(), _new_check(), 0.05**2
    for k in range(3):
        assert eng._doppler_check(chk, 0.1 * k, 20.0, 0.0, var_g, 0.0, cfg) == 1.0
    inflated = [eng._doppler_check(chk, 0.3 + 0.1 * k, 20.0, 0.5, var_g, 0.0, cfg) for k in range(3)]
    assert all(f > 50.0 for f in inflated)
    after = eng._doppler_check(chk, 0.6, 20.0, 0.0, var_g, 0.0, cfg)
    assert after == pytest.approx(1.0 + 0.125 * math.exp(-0.1 / 2.0) / var_g, rel=1e-9)
    later = eng._doppler_check(chk, 6.5, 20.0, 0.0, var_g, 0.0, cfg)
    assert 1.0 < later < 1.0 + 0.125 * math.exp(-5.0 / 2.0) / var_g + 1e-9


def test_doppler_check_widens_with_the_roll_the_model_does_not_carry() -> None:
    """On a bank ramp the body rolls and the velocity the accelerometers carry drifts by
    g sin(roll change) per second: 0.1 rad of unmodelled roll over 1 s admits a 0.8 m/s
    departure that the check alone (0.1 m/s^2, 0.1 m/s/sqrt(s): sigma 0.15 m/s) rejects."""
    cfg, var_g = _check_config(), 0.05**2
    for roll_since_anchor, expected in ((0.0, False), (0.1, True)):
        chk = _new_check()
        eng._doppler_check(chk, 0.0, 20.0, 0.0, var_g, 0.0, cfg)
        chk[7] = roll_since_anchor
        f = eng._doppler_check(chk, 1.0, 20.0, 0.8, var_g, 0.0, cfg)
        assert (f == 1.0) is expected


def test_relaxation_lag_is_tau_times_the_slip_rate_on_a_ramp_and_ignores_row_noise() -> None:
    """The relaxation term of beta_std: on a slip ramp (a turn-in) the tyre's force lags the
    slip by relaxation / v seconds, so the relation reads a slip short by tau * d alpha / dt
    (analytic: 1 m at 10 m/s, 0.02 rad/s -> 0.002 rad once the lag has settled; the discrete
    lag over 10 ms rows: 0.0002 rad per row times e^-0.1 / (1 - e^-0.1)); white noise
    in the row slip (the yaw gyro's, 0.001 rad per 100 Hz row at l_r r / v) stays at its own
    size, where a row-by-row derivative made it 1 m / 10 m/s * 0.001 rad * 100 Hz * sqrt(2)
    ~ 0.014 rad."""
    n = 1000
    t = np.arange(n) * 0.01
    vx = np.full(n, 10.0)
    l_r, relax = 1.5, 1.0
    aux = np.zeros((len(AUX_KEYS), n))
    aux[AUX_KEYS.index("inflation")] = 1.0
    aux[AUX_KEYS.index(ISR)] = 1.0

    def lag_std(wz: np.ndarray) -> np.ndarray:
        z = np.zeros(n)
        out = eng.row_outputs(
            t, vx, z, z, wz, z, z, np.arange(n), np.zeros(n), aux,
            0.0, l_r, False, 0.0, 0.0, relax, math.radians(30.0), math.radians(5.0),
        )  # fmt: skip
        return out[1]

    # alpha = l_r wz / v_x = 0.02 t rad: wz a ramp
    ramp = lag_std(0.02 * t * 10.0 / l_r)
    np.testing.assert_allclose(ramp[200:], 0.0002 * math.exp(-0.1) / (1.0 - math.exp(-0.1)), rtol=1e-6)
    np.testing.assert_allclose(ramp[200:], 0.1 * 0.02, rtol=0.05)
    noise = np.random.default_rng(0).normal(0.0, 0.001 * 10.0 / l_r, n)
    rms = np.sqrt(np.mean(lag_std(noise) ** 2))
    assert 0.0008 < rms < 0.0012


def test_a_heading_beyond_the_linear_range_is_turned_onto_the_doppler_course() -> None:
    """Analytic case: a state at 20 m/s with 2 deg of sideslip, its heading 40 deg off the
    truth.  With a heading sigma of 54 deg (a logger's pause) the Doppler epoch turns the
    heading so that the state's velocity over ground has the Doppler's course: the heading
    ends at the true one to float precision (the slip is the truth's), the covariance is
    unchanged.  With a heading sigma of 10 deg (inside the linear range) or below the speed
    floor nothing moves."""
    beta = math.radians(2.0)
    psi_true = math.radians(30.0)
    x = np.zeros(len(eng.VAR_STATES) + 20)
    x[IVX], x[IVY] = 20.0 * math.cos(beta), 20.0 * math.sin(beta)
    course = psi_true + beta
    y_e, y_n = 20.0 * math.cos(course), 20.0 * math.sin(course)
    for sigma_deg, speed, turned in ((54.0, 20.0, True), (10.0, 20.0, False), (54.0, 0.5, False)):
        xs = x.copy()
        xs[IPSI] = psi_true + math.radians(40.0)
        P = np.eye(xs.size)
        P[IPSI, IPSI] = math.radians(sigma_deg) ** 2
        P0 = P.copy()
        k = speed / 20.0
        assert eng._align_heading(xs, P, k * y_e, k * y_n, 1.0) is turned
        expected = psi_true if turned else psi_true + math.radians(40.0)
        assert abs(xs[IPSI] - expected) < 1e-12
        np.testing.assert_array_equal(P, P0)


def test_a_rear_slip_past_full_sliding_against_a_small_force_maps_back_onto_the_brush_curve() -> None:
    """Analytic case: a car at 20 m/s, no yaw rate, whose state says a rear slip of 2.5 x the
    brush curve's full sliding while the measured rear force is 0.3 of the axle's limit.
    The target v_y puts the rear slip where the model's own forward curve
    (``models.axle_force.fiala_force``) gives that force, to float precision.  A force over half
    the limit, or a state slip inside 1.2 x full sliding, is no contradiction (NaN); nor is
    another curve shape."""
    from sideslip.models.axle_force import fiala_force
    from sideslip.models.fused_measurements import A_CR, A_LR, A_NR, A_SHAPE

    axle = np.array([1.2, 1.4, 60.0, 70.0, 0.54 * G, 0.46 * G, 0.0])
    lim = axle[A_NR]
    z_sl = 3.0 * lim / axle[A_CR]
    x = np.zeros(NX_CORE)
    x[IVX], x[ISR], x[IMU] = 20.0, 1.0, 1.0
    u = np.zeros(11)
    dr = np.zeros(NX_CORE)
    x[IVY] = 2.5 * z_sl * 20.0  # rear slip z = -(v_y - l_r r) / v_x = -2.5 z_sl
    vy = eng._rear_slip_target(x, u, -0.3 * lim, axle, 0.0, dr)
    z = -(vy - axle[A_LR] * 0.0) / 20.0
    assert -z_sl < z < 0.0
    assert abs(fiala_force(z, axle[A_CR], lim)[0] - (-0.3 * lim)) < 1e-9
    assert math.isnan(eng._rear_slip_target(x, u, -0.6 * lim, axle, 0.0, dr))
    x[IVY] = 1.1 * z_sl * 20.0
    assert math.isnan(eng._rear_slip_target(x, u, -0.3 * lim, axle, 0.0, dr))
    x[IVY] = 2.5 * z_sl * 20.0
    axle[A_SHAPE] = 1.3
    assert math.isnan(eng._rear_slip_target(x, u, -0.3 * lim, axle, 0.0, dr))


def test_a_stiffness_scale_past_its_bound_is_projected_back_with_its_correlated_states() -> None:
    """Analytic case of the P^-1-weighted estimate projection: a rear scale at 0.3 (below
    SCALE_MIN 0.5) correlated with v_y (covariance 0.02, scale variance 0.04) moves to 0.5,
    and v_y by 0.02 / 0.04 x 0.2 = 0.1 m/s, as a measurement of the scale at the bound would
    move them; an uncorrelated state stays, the covariance is kept.  A front scale of 2.6
    goes to SCALE_MAX; scales inside the bounds do not move."""
    from sideslip.models.fused_measurements import SCALE_MAX, SCALE_MIN
    from sideslip.models.fused_process import ISF

    x = np.zeros(NX_CORE)
    x[IVX], x[IVY], x[ISR], x[ISF] = 30.0, 0.4, 0.3, 2.6
    P = np.eye(NX_CORE) * 0.01
    P[ISR, ISR], P[ISF, ISF] = 0.04, 0.09
    P[IVY, ISR] = P[ISR, IVY] = 0.02
    P0 = P.copy()
    eng._project_scales(x, P)
    assert x[ISR] == SCALE_MIN and x[ISF] == SCALE_MAX
    assert abs(x[IVY] - (0.4 + 0.02 / 0.04 * (SCALE_MIN - 0.3))) < 1e-12
    assert x[IVX] == 30.0
    np.testing.assert_array_equal(P, P0)
    inside = x.copy()
    inside[ISR], inside[ISF] = 0.8, 1.7
    moved = inside.copy()
    eng._project_scales(moved, P)
    np.testing.assert_array_equal(moved, inside)
