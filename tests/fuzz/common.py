"""Shared pieces of the fuzz tests (not a test module): hypothesis settings, random drives,
and the one property every hostile case must end in.

Every fuzz test is derandomised (the same examples on every run) with a bounded number of
examples, so the whole package runs in well under a minute; ``CASES`` counts the examples each
test ran (printed by ``tests/fuzz/test_zz_summary.py``).
"""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from sideslip.drive import COLUMNS, LIMITS, MIN_ROWS

CASES: Counter[str] = Counter()
RUNNER = CliRunner()


def fuzz_settings(examples: int) -> settings:
    return settings(
        max_examples=examples,
        derandomize=True,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                               HealthCheck.data_too_large],
    )


def count(name: str) -> None:
    CASES[name] += 1


LIMIT_OF = {name: (limit, what) for names, limit, what in LIMITS for name in names}
# typical magnitudes of a drive's columns (SI), well inside the section 5 limits
SCALE = {
    "ax": 2.0, "ay": 3.0, "az": 9.8, "wx": 0.05, "wy": 0.05, "wz": 0.3, "v_fl": 15.0,
    "v_fr": 15.0, "v_rl": 15.0, "v_rr": 15.0, "v_can": 15.0, "steer": 0.05, "gnss_e": 300.0,
    "gnss_n": 300.0, "gnss_u": 5.0, "gnss_ve": 10.0, "gnss_vn": 10.0, "gnss_vu": 0.3,
    "gnss_pos_std": 0.5, "gnss_vel_std": 0.1, "ref_beta": 0.02, "ref_yaw": 2.0, "ref_roll": 0.03,
    "ref_pitch": 0.02, "ref_bank": 0.02, "ref_e": 300.0, "ref_n": 300.0, "ref_u": 5.0,
    "ref_vx": 15.0, "ref_vy": 0.3, "ref_r": 0.3, "ref_ay": 3.0,
}  # fmt: skip
DATA_COLUMNS = [c for c in COLUMNS if c != "t"]
# (the readers take "", "NA", "N/A", "NULL", "nan" for an empty cell: not text here)
TEXT = st.sampled_from(["abc", "fast", "1,5", "n.a.", "--", "0x1F", "12 deg", "true", "\u00e9t\u00e9"])


@st.composite
def drive_columns(draw: Any, min_rows: int = MIN_ROWS, max_rows: int = 300) -> dict[str, np.ndarray]:
    """A valid drive: increasing time at a random rate, a random set of contract columns with
    plausible values (positive speeds, or reversing), slower sensors NaN between samples."""
    n = draw(st.integers(min_rows, max_rows))
    dt = draw(st.sampled_from([0.001, 0.005, 0.01, 0.1, 1.0]))
    seed = draw(st.integers(0, 2**16))
    rng = np.random.default_rng(seed)
    t = draw(st.floats(0.0, 1e5, allow_nan=False)) + dt * np.arange(n)
    names = draw(st.lists(st.sampled_from(DATA_COLUMNS), min_size=0, max_size=12, unique=True))
    cols: dict[str, np.ndarray] = {"t": t}
    for name in names:
        values = SCALE[name] * rng.standard_normal(n).cumsum() / math.sqrt(max(n, 1))
        if name.startswith("v_") or name == "ref_vx":
            values = np.abs(values) * (-1.0 if draw(st.booleans()) and name == "ref_vx" else 1.0)
        if name.endswith("_std"):
            values = np.abs(values)
        limit = LIMIT_OF.get(name, (math.inf, ""))[0]
        values = np.clip(values, -0.9 * limit, 0.9 * limit)
        every = draw(st.sampled_from([1, 1, 1, 5, 10]))  # a slower sensor: NaN between samples
        if every > 1:
            values[np.arange(n) % every != 0] = np.nan
        cols[name] = values
    return cols


def one_error_line(res: Any) -> str:
    """A CLI result that failed: exit 2, one line on stderr, no traceback, no internal error."""
    assert res.exit_code == 2, (res.exit_code, res.stderr[-2000:], res.exception)
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), res.stderr[-2000:]
    assert "Traceback" not in res.output and "internal error" not in res.output, res.output[-2000:]
    return lines[0]


def check_cli_outcome(res: Any, out_dir: Path, before: set[str]) -> bool:
    """Success (exit 0) or one clear error line with nothing new written; True on success."""
    if res.exit_code == 0:
        return True
    one_error_line(res)
    after = {p.name for p in out_dir.iterdir()}
    assert after == before, sorted(after - before)  # nothing half-written, no temp file
    return False


def write_table(cols: dict[str, Any], path: Path) -> None:
    """CSV or Parquet; in Parquet a column holding text is written as text throughout."""
    frame = pd.DataFrame(cols)
    if path.suffix == ".csv":
        frame.to_csv(path, index=False)
        return
    for name in frame.columns:
        if frame[name].dtype == object:
            frame[name] = frame[name].map(lambda v: None if v is None or v != v else str(v))
    frame.to_parquet(path)
