"""Kernels of the seed-002 tuning and consistency (sideslip.methods.fg_tuning) against their
plain references: the side-by-side candidate pass against one run per candidate, the
innovations-only filter against the full graph filter, the compiled block sums against numpy."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.drive import drive_from_columns
from sideslip.methods.factor_graph import FactorGraphSettings, build_graph, graph_inputs, prepare
from sideslip.methods.fg_tuning import (
    AUTO_LATERAL_ACCELERATION,
    AUTO_MODEL_BETA,
    SIGMA_FIELDS,
    _block_nis,
    chain_innovations,
    chain_kalman,
    gyro_prediction_error,
    gyro_prediction_errors,
)
from sideslip.simulate import simulate
from sideslip.vehicle import load_vehicle


@pytest.fixture(scope="module")
def drive_and_vehicle():
    """40 s of the demo drive with a 1 s hole in the time stamps and a gyro gap."""
    base = simulate("demo", seed=4, duration_s=40.0)
    keep = np.ones(len(base), dtype=bool)
    keep[1500:1600] = False
    cols = {"t": base.t[keep], **{k: base[k][keep].copy() for k in base.data}}
    cols["wz"][2500:2600] = np.nan
    return drive_from_columns(cols, dict(base.meta)), load_vehicle(base.meta["vehicle"])


def _unit_graph(drive, vehicle):
    settings = FactorGraphSettings().with_sigmas(dict.fromkeys(SIGMA_FIELDS, 1.0))
    inputs = graph_inputs(drive, vehicle, settings)
    return inputs, build_graph(inputs, vehicle, settings)


def test_candidates_side_by_side_score_exactly_as_one_run_each(drive_and_vehicle):
    # The auto grid's filters share one pass over the rows; each candidate's arithmetic must be
    # that of its own run, so the scores (and hence the choice) are bit-identical.
    inputs, unit = _unit_graph(*drive_and_vehicle)
    gap, score = inputs.time_gap, ~inputs.low_speed
    assert gap.any()
    P0 = np.diag(unit.sigma0**2)
    pairs = [(a, b) for a in AUTO_LATERAL_ACCELERATION for b in AUTO_MODEL_BETA]
    sse, count, se = gyro_prediction_errors(
        unit.F, unit.g, unit.wq, unit.Hu, unit.zu, unit.wu, unit.x0, P0, 30, 5, score, gap,
        np.array([a**2 for a, _ in pairs]), np.array([b**2 for _, b in pairs]),
    )  # fmt: skip
    move = ~gap
    for c, (a, b) in enumerate(pairs):
        wu = unit.wu.copy()
        wu[:, 1] = unit.wu[:, 1] / a**2
        wq = unit.wq.copy()
        wq[move, 0] = unit.wq[move, 0] / b**2
        one = gyro_prediction_error(unit.F, unit.g, wq, unit.Hu, unit.zu, wu, unit.x0, P0, 30, 5, score)
        assert (sse[c], count[c], se[c]) == one
    assert len(set(sse.tolist())) == len(pairs)  # the candidates do differ


def test_innovations_only_filter_equals_the_graph_filter_and_continues_across_chunks(
    drive_and_vehicle,
):
    drive, vehicle = drive_and_vehicle
    prep = prepare(drive, vehicle, FactorGraphSettings(preset="physics"))
    graph = build_graph(prep.inputs, vehicle, prep.settings)
    P0 = np.diag(graph.sigma0**2)
    _, _, _, nu_ref, s_ref = chain_kalman(graph.F, graph.g, graph.wq, graph.Hu, graph.zu, graph.wu,
                                          graph.x0, P0)  # fmt: skip
    nu, s, _, _ = chain_innovations(graph.F, graph.g, graph.wq, graph.Hu, graph.zu, graph.wu,
                                    graph.x0, P0, 2)  # fmt: skip
    np.testing.assert_array_equal(nu, nu_ref[:, :2])
    np.testing.assert_array_equal(s, s_ref[:, :2])
    # in chunks, each continued from the prediction the previous one returns: the same numbers
    x, P, parts = graph.x0, P0, []
    n = graph.Hu.shape[0]
    for a in range(0, n, 777):
        b = min(a + 777, n)
        part_nu, _, x, P = chain_innovations(graph.F[a:b], graph.g[a:b], graph.wq[a:b], graph.Hu[a:b],
                                             graph.zu[a:b], graph.wu[a:b], x, P, 2)  # fmt: skip
        parts.append(part_nu)
    np.testing.assert_array_equal(np.vstack(parts), nu_ref[:, :2])


def test_compiled_block_sums_equal_the_numpy_reference():
    rng = np.random.default_rng(5)
    n = 5000
    t = np.cumsum(rng.uniform(0.005, 0.015, n))
    innov = rng.normal(size=(n, 2))
    S = rng.uniform(0.5, 2.0, size=(n, 2))
    innov[rng.random((n, 2)) < 0.2] = np.nan
    S[1000:1100, 0] = np.nan  # a whole stretch of one factor without updates
    start, nis, dof = _block_nis(t, innov, S, 0.25)
    # numpy reference: block index, reduceat sums of the rows with an update
    block = np.floor((t - t[0]) / 0.25).astype(np.int64)
    ref_start = np.flatnonzero(np.r_[True, np.diff(block) != 0])
    ref_nis = np.zeros(ref_start.size)
    ref_dof = np.zeros(ref_start.size)
    for m in range(2):
        ok = np.isfinite(innov[:, m]) & np.isfinite(S[:, m])
        sum_nu = np.add.reduceat(np.where(ok, innov[:, m], 0.0), ref_start)
        sum_s = np.add.reduceat(np.where(ok, S[:, m], 0.0), ref_start)
        has = sum_s > 0
        ref_nis += np.where(has, sum_nu**2 / np.where(has, sum_s, 1.0), 0.0)
        ref_dof += has
    np.testing.assert_array_equal(start, ref_start)
    np.testing.assert_array_equal(dof, ref_dof)
    assert ref_dof.min() == 1.0  # the stretch without the first factor is tested on one dof
    np.testing.assert_allclose(nis, ref_nis, rtol=1e-12)
