"""Tables on disk: the block-wise writer reads back as the whole-table one, and the footer's
row count (issue 17: a day-long estimate is written without a second copy in memory)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

import sideslip.tables as tables
from sideslip.errors import InputError
from sideslip.tables import meta_path, read_table, save_columns, save_table, table_rows


def _columns(n: int = 1000) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(3)
    return {
        "t": np.arange(n) * 0.01,
        "fused.beta": rng.normal(0, 0.02, n).astype(np.float32),  # as a method may hold it
        "fused.e": 1e5 + np.cumsum(rng.normal(0, 0.3, n)),
        "kkf.yaw": np.where(np.arange(n) % 7 == 0, np.nan, rng.normal(0, 1, n)),
    }


@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_block_wise_write_reads_back_as_the_whole_table(tmp_path, monkeypatch, suffix):
    cols = _columns()
    monkeypatch.setattr(tables, "WRITE_CHUNK_ROWS", 128)  # 8 blocks, the last one short
    meta = {"drive": "d.parquet", "vehicle": "midsize_sedan"}
    save_columns(cols, tmp_path / f"blocks{suffix}", meta)
    save_table(pd.DataFrame({k: np.asarray(v, float) for k, v in cols.items()}), tmp_path / f"whole{suffix}", meta)
    blocks, meta_b = read_table(tmp_path / f"blocks{suffix}")
    whole, meta_w = read_table(tmp_path / f"whole{suffix}")
    pd.testing.assert_frame_equal(blocks, whole)  # same values, NaN where NaN, float64 on disk
    assert meta_b == meta_w == meta
    assert all(blocks[c].dtype == np.float64 for c in blocks.columns)
    if suffix == ".parquet":
        assert pq.ParquetFile(tmp_path / "blocks.parquet").metadata.num_row_groups == 8
    else:
        assert json.loads(meta_path(tmp_path / "blocks.csv").read_text()) == meta
        assert (tmp_path / "blocks.csv").read_text().count("fused.beta") == 1  # one header


def test_block_wise_write_of_zero_columns_and_bad_suffix(tmp_path):
    save_columns({"t": np.zeros(0)}, tmp_path / "empty.parquet")
    frame, _ = read_table(tmp_path / "empty.parquet")
    assert list(frame.columns) == ["t"] and len(frame) == 0
    with pytest.raises(InputError, match=r"out\.txt: expected an output path ending in \.csv or \.parquet"):
        save_columns({"t": np.zeros(3)}, tmp_path / "out.txt")


def test_table_rows_reads_the_parquet_footer_only(tmp_path):
    save_columns(_columns(777), tmp_path / "a.parquet")
    assert table_rows(tmp_path / "a.parquet") == 777
    pd.DataFrame({"t": [0.0, 1.0]}).to_csv(tmp_path / "a.csv", index=False)
    assert table_rows(tmp_path / "a.csv") is None  # a CSV's length is known once read
    (tmp_path / "broken.parquet").write_bytes(b"PAR1 not really")
    assert table_rows(tmp_path / "broken.parquet") is None  # loading it names the problem
