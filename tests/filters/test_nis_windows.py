"""Binned windowed-NIS test: the same verdicts as the row-level test, on fewer quantiles."""

from __future__ import annotations

import numpy as np

from sideslip.filters.consistency import nis_consistency
from sideslip.filters.nis_windows import binned_nis_consistency


def test_binned_test_flags_the_same_span_as_the_row_test() -> None:
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 60.0, 0.01)
    nis = rng.chisquare(1, t.size)
    bad = (t > 20.0) & (t < 30.0)
    nis[bad] *= 4.0  # the model stops fitting: innovations twice their predicted sigma
    nis[::7] = np.nan  # rows without an update
    row = nis_consistency(t, nis, 1, window_s=2.0)
    binned = binned_nis_consistency(t, nis, 1, window_s=2.0)
    # window edges move by at most one 0.1 s bin: verdicts agree except near the edges
    assert np.mean(row.flagged == binned.flagged) > 0.97
    assert binned.flagged[(t > 21.0) & (t < 29.0)].all()
    # consistent span: false alarms of the 99 % bound come in runs (overlapping windows);
    # the binned test raises no more of them than the row test (+3 % for the bin edges)
    quiet = (t > 2.0) & (t < 18.0)
    assert binned.flagged[quiet].mean() <= row.flagged[quiet].mean() + 0.03
    # inflation ~ the NIS excess (4) inside the span, as the row-level test
    np.testing.assert_allclose(np.median(binned.inflation[(t > 21) & (t < 29)]),
                               np.median(row.inflation[(t > 21) & (t < 29)]), rtol=0.05)
    assert binned.summary(t)["n_flagged_spans"] >= 1
