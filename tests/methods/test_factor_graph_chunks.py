"""The seed-002 graph built and used chunk by chunk (fg_batch, kf_linear and the "auto" tuning
never hold the whole drive's factors) gives bit-for-bit the numbers of the whole graph at once:
the references here are the generic whole-chain routines of sideslip.filters.banded and
sideslip.methods.fg_tuning on the whole graph."""

from __future__ import annotations

import numpy as np
import pytest

import sideslip.methods.factor_graph as fgm
from sideslip.drive import Drive, drive_from_columns
from sideslip.filters.banded import assemble_chain, selected_inverse, solve_chain
from sideslip.methods.factor_graph import FactorGraphSettings, prepare
from sideslip.methods.fg_kernels import band_marginals
from sideslip.methods.fg_tuning import chain_innovations, chain_kalman
from sideslip.simulate import simulate
from sideslip.vehicle import load_vehicle

# chunk lengths: tiny (many boundaries, some next to the gap), odd, and the whole drive
CHUNKS = (37, 1000, 10**9)


@pytest.fixture(scope="module")
def drive_and_vehicle() -> tuple[Drive, object]:
    """40 s of the demo drive with a 1 s hole in the time stamps (a restart of the chain), a
    gyro gap and an accelerometer gap."""
    base = simulate("demo", seed=4, duration_s=40.0)
    keep = np.ones(len(base), dtype=bool)
    keep[1500:1600] = False
    cols = {"t": base.t[keep], **{k: base[k][keep].copy() for k in base.data}}
    cols["wz"][2500:2600] = np.nan
    cols["ay"][3000:3050] = np.nan
    return drive_from_columns(cols, dict(base.meta)), load_vehicle(base.meta["vehicle"])


SETTINGS = (FactorGraphSettings(), FactorGraphSettings(preset="physics"))


def _whole(prep, vehicle):
    graph = fgm._graph(prep, vehicle)
    assert graph.F.shape[0] == prep.inputs.t.size - 1
    return graph


@pytest.mark.parametrize("settings", SETTINGS, ids=("auto", "physics"))
def test_batch_assembled_in_chunks_is_the_whole_graph_solution_bit_for_bit(drive_and_vehicle, settings):
    drive, vehicle = drive_and_vehicle
    prep = prepare(drive, vehicle, settings)
    assert prep.inputs.time_gap.any()
    assert prep.unit_scaled == (settings.preset == "auto")
    graph = _whole(prep, vehicle)
    lam0, eta0 = graph.prior_information
    ab, rhs = assemble_chain(graph.F, graph.g, graph.wq, graph.Hu, graph.zu, graph.wu, lam0, eta0)
    x_ref, cb = solve_chain(ab, rhs)
    sb = selected_inverse(cb)
    nu_ref, s_ref, _, _ = chain_innovations(graph.F, graph.g, graph.wq, graph.Hu, graph.zu,
                                            graph.wu, graph.x0, np.diag(graph.sigma0**2), 2)  # fmt: skip
    for chunk in CHUNKS:
        x, var, cov, inn = fgm._batch_pass(prep, vehicle, True, chunk)
        assert inn is not None
        np.testing.assert_array_equal(x, x_ref.reshape(-1, 2))
        np.testing.assert_array_equal(var, sb[0].reshape(-1, 2))
        np.testing.assert_array_equal(cov, sb[1, 0::2])
        np.testing.assert_array_equal(inn[0], nu_ref)
        np.testing.assert_array_equal(inn[1], s_ref)
    assert fgm._batch_pass(prep, vehicle, False, 37)[3] is None
    # the public whole-graph solver is the same arithmetic
    for got, want in zip(fgm.solve_batch(graph), fgm._batch_pass(prep, vehicle, False)[:3], strict=True):
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("settings", SETTINGS, ids=("auto", "physics"))
def test_kalman_filter_in_chunks_is_one_pass_over_the_whole_graph_bit_for_bit(drive_and_vehicle, settings):
    drive, vehicle = drive_and_vehicle
    prep = prepare(drive, vehicle, settings)
    graph = _whole(prep, vehicle)
    ref = chain_kalman(graph.F, graph.g, graph.wq, graph.Hu, graph.zu, graph.wu, graph.x0,
                       np.diag(graph.sigma0**2))  # fmt: skip
    for chunk in CHUNKS:
        x, var, cov, inn = fgm._kalman_pass(prep, vehicle, True, chunk)
        assert inn is not None
        for got, want in zip((x, var, cov, *inn), (*ref[:3], ref[3][:, :2], ref[4][:, :2]), strict=True):
            np.testing.assert_array_equal(got, want)
    x, _, _, none = fgm._kalman_pass(prep, vehicle, False, 37)
    assert none is None
    np.testing.assert_array_equal(x, ref[0])


def test_auto_tuning_in_chunks_scores_every_candidate_exactly_as_one_pass(drive_and_vehicle, monkeypatch):
    drive, vehicle = drive_and_vehicle
    monkeypatch.setattr(fgm, "GRAPH_CHUNK", 10**9)
    whole = prepare(drive, vehicle).tuning
    assert len(whole.candidates) == 10
    for chunk in (37, 1000):  # chunks shorter and longer than the 0.3 s look-ahead
        monkeypatch.setattr(fgm, "GRAPH_CHUNK", chunk)
        chunked = prepare(drive, vehicle).tuning
        assert chunked.candidates == whole.candidates
        assert chunked.sigmas == whole.sigmas


def test_band_marginals_keep_only_a_ring_of_the_selected_inverse():
    # random SPD band matrices of a few bandwidths: the ring gives the selected inverse's
    # diagonal and first sub-diagonal exactly, and both match the dense inverse
    rng = np.random.default_rng(3)
    for p, nx, n in ((3, 2, 40), (1, 2, 10), (3, 2, 2)):
        dense = np.zeros((n, n))
        for d in range(1, min(p, n - 1) + 1):
            off = rng.normal(size=n - d) * 0.3
            dense += np.diag(off, -d) + np.diag(off, d)
        dense += np.diag(2.0 * p + rng.uniform(1.0, 2.0, size=n))
        ab = np.zeros((p + 1, n))
        for d in range(min(p, n - 1) + 1):
            ab[d, : n - d] = np.diag(dense, -d)
        _, cb = solve_chain(ab, np.zeros(n))
        var, cov = band_marginals(cb, nx)
        sb = selected_inverse(cb)
        np.testing.assert_array_equal(var, sb[0].reshape(-1, nx))
        np.testing.assert_array_equal(cov, sb[1, 0::nx])
        inv = np.linalg.inv(dense)
        np.testing.assert_allclose(var.ravel(), np.diag(inv), rtol=1e-12)
        np.testing.assert_allclose(cov, np.diag(inv, -1)[0::nx], rtol=1e-10, atol=1e-15)
