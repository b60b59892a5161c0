"""The per-method aggregate: outcome shares over the drives, median and p95 of each metric."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.batch import JobResult, aggregate_frame, console_lines


def _results() -> list[JobResult]:
    out = []
    for i, beta in enumerate((0.1, 0.2, 0.4, 0.8)):
        out.append(JobResult(f"/d/{i}.parquet", str(i), "run" if i < 3 else "resumed", 100, 1.0,
                             ("m_a", "m_b"), {}, {"m_a": {"beta_rmse_deg": beta}, "m_b": {"roll_rmse_deg": 2 * beta}}))
    out.append(JobResult("/d/x.parquet", "x", "run", 100, 1.0, ("m_a",), {"m_b": "needs wx"},
                         {"m_a": {"beta_rmse_deg": 5.0}}))
    out.append(JobResult("/d/bad.csv", "bad", "failed", error="/d/bad.csv: column 'steer': row 3: ..."))
    return out


def test_shares_of_run_resumed_not_run_and_failed_add_up_per_method() -> None:
    agg = aggregate_frame(_results(), ["m_a", "m_b"]).set_index("method")
    assert agg.loc["m_a", ["drives_run", "drives_resumed", "drives_not_run", "drives_failed"]].tolist() == [4, 1, 0, 1]
    assert agg.loc["m_b", ["drives_run", "drives_resumed", "drives_not_run", "drives_failed"]].tolist() == [3, 1, 1, 1]
    shares = agg[["share_run", "share_resumed", "share_not_run", "share_failed"]].sum(axis=1)
    assert np.allclose(shares, 1.0)


def test_median_and_p95_are_over_the_drives_that_have_the_metric() -> None:
    agg = aggregate_frame(_results(), ["m_a", "m_b"]).set_index("method")
    beta = np.array([0.1, 0.2, 0.4, 0.8, 5.0])
    assert agg.loc["m_a", "beta_rmse_deg_median"] == pytest.approx(np.median(beta))
    assert agg.loc["m_a", "beta_rmse_deg_p95"] == pytest.approx(np.percentile(beta, 95))
    assert agg.loc["m_b", "roll_rmse_deg_median"] == pytest.approx(np.median([0.2, 0.4, 0.8, 1.6]))


def test_console_lines_fit_80_columns_even_for_long_names() -> None:
    results = [JobResult("/d/0.parquet", "0", "run", 10, 1.0, ("a_very_long_method_name_indeed",), {},
                         {"a_very_long_method_name_indeed": {"beta_rmse_deg": 123.456, "roll_rmse_deg": 0.5}})]
    lines = console_lines(aggregate_frame(results, ["a_very_long_method_name_indeed"]))
    assert len(lines) == 3 and max(len(ln) for ln in lines) <= 80
    assert "123.5" in lines[2] and "100%" in lines[2]
