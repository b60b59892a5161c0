"""Stanford Revs text-log converter: columns, units and error lines.

Format tests run on a small synthetic lap written here; the shipped lap's facts come from
../shared/data/revs_250lm_20140222/DATA_NOTES.md (55,001 rows at 100 Hz from 149.99 s,
beta_true = atan2(vy, vx), corr(ay, vx r) = 0.97).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sideslip.drive import load_drive
from sideslip.errors import InputError
from sideslip.io import FORMATS, convert
from sideslip.io.revs import convert_revs

LAP = Path(__file__).resolve().parents[3] / "shared" / "data" / "revs_250lm_20140222"


def _write_lap(folder: Path, n: int = 50) -> dict[str, np.ndarray]:
    folder.mkdir(parents=True, exist_ok=True)
    t = 10.0 + 0.01 * np.arange(n)
    vx = np.full(n, 30.0)
    vy = 0.3 * np.sin(t)
    cols = {
        "t": t, "vx": vx, "vy": vy, "beta_true": np.arctan2(vy, vx),
        "yawRate": 0.2 * np.cos(t), "yawRateFilt": np.degrees(0.2 * np.cos(t)),
        "ayCG": 6.0 * np.cos(t), "axCG": np.zeros(n), "delta": 0.02 * np.cos(t),
    }  # fmt: skip
    for name, values in cols.items():
        np.savetxt(folder / f"{name}.txt", values, fmt="%15.7e")
    return cols


def test_columns_map_to_the_contract_names_and_units(tmp_path: Path) -> None:
    cols = _write_lap(tmp_path / "lap")
    drive = convert("revs", tmp_path / "lap", None, None)
    np.testing.assert_allclose(drive.t, cols["t"], rtol=1e-7)
    np.testing.assert_allclose(drive["wz"], cols["yawRate"], rtol=1e-6)  # rad/s, not deg/s
    np.testing.assert_allclose(drive["ref_r"], cols["yawRate"], rtol=1e-6)
    np.testing.assert_allclose(drive["ay"], cols["ayCG"], rtol=1e-6)
    np.testing.assert_allclose(drive["v_can"], cols["vx"], rtol=1e-6)
    np.testing.assert_allclose(drive["steer"], cols["delta"], rtol=1e-6)
    np.testing.assert_allclose(drive["ref_beta"], cols["beta_true"], rtol=1e-6)
    np.testing.assert_allclose(drive["ref_vy"], cols["vy"], rtol=1e-6)
    assert "revs" in FORMATS


def test_a_folder_holding_one_lap_folder_is_accepted(tmp_path: Path) -> None:
    _write_lap(tmp_path / "20140222_lap")
    assert len(convert_revs(tmp_path)) == 50


def test_missing_file_is_one_line_naming_it(tmp_path: Path) -> None:
    _write_lap(tmp_path / "lap")
    (tmp_path / "lap" / "delta.txt").unlink()
    with pytest.raises(InputError, match=r"delta\.txt: file missing: expected one number per line"):
        convert_revs(tmp_path / "lap")


def test_wrong_length_names_file_and_expected_rows(tmp_path: Path) -> None:
    _write_lap(tmp_path / "lap")
    np.savetxt(tmp_path / "lap" / "ayCG.txt", np.zeros(49))
    with pytest.raises(InputError, match=r"ayCG\.txt: 49 rows: expected 50 \(as many as t\.txt\)"):
        convert_revs(tmp_path / "lap")


def test_non_numeric_row_names_file_and_row(tmp_path: Path) -> None:
    _write_lap(tmp_path / "lap")
    path = tmp_path / "lap" / "vx.txt"
    lines = path.read_text().splitlines()
    lines[7] = "abc"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError) as err:
        convert_revs(tmp_path / "lap")
    msg = str(err.value)
    assert "vx.txt" in msg and "row 7" in msg and "'abc' is not a number" in msg
    assert "\n" not in msg


def test_no_lap_folder_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"t\.txt: file missing: expected a Revs lap folder"):
        convert_revs(tmp_path)


@pytest.mark.realdata
def test_shipped_lap_converts_through_the_cli(tmp_path: Path) -> None:
    if not LAP.is_dir():
        pytest.skip(f"real data absent: {LAP} (../shared/data is not shipped with the repo)")
    out = tmp_path / "revs.parquet"
    done = subprocess.run(
        [sys.executable, "-m", "sideslip.cli", "convert", "revs", str(LAP), "--out", str(out)],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    drive = load_drive(out)
    assert len(drive) == 55001  # DATA_NOTES: 550 s at 100 Hz
    assert drive.t[0] == pytest.approx(149.99)
    # DATA_NOTES: beta_true = atan2(vy, vx); corr(ay, vx r) = 0.97 (rad/s gyro, m/s^2 accel)
    np.testing.assert_allclose(drive["ref_beta"], np.arctan2(drive["ref_vy"], drive["ref_vx"]),
                               atol=1e-6)
    corr = np.corrcoef(drive["ay"], drive["v_can"] * drive["wz"])[0, 1]
    assert corr == pytest.approx(0.97, abs=0.01)
