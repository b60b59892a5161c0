"""The command line's outputs: version and help, 80-column tables, machine-readable formats,
stdout, and files written without replacing symlinks or devices."""

from __future__ import annotations

import json
import os
import stat

import pandas as pd
import pytest
from typer.testing import CliRunner

import sideslip as ss
from sideslip.cli import app
from sideslip.cli.app import console
from tests.helpers import CIRCLE, run_cli

METHODS = ["kinematic_integration", "fg_batch", "fused", "kkf"]


@pytest.fixture(scope="module")
def est(tmp_path_factory):
    path = tmp_path_factory.mktemp("est") / "est.parquet"
    ss.estimate(CIRCLE, "midsize_sedan", methods=METHODS).save(path)
    return path


def invoke(*args, width=None):
    """The command in this process (fast); ``width`` fixes the table width like COLUMNS."""
    if width is not None:
        console.size = (width, 40)
    try:
        res = CliRunner().invoke(app, [str(a) for a in args])
    finally:
        console.size = (80, 25) if width is not None else console.size
    return res


def test_version_short_help_and_completion():
    res = invoke("--version")
    assert res.exit_code == 0 and res.stdout.strip() == f"sideslip {ss.__version__}"
    res = invoke("-h")
    assert res.exit_code == 0 and "Usage:" in res.stdout and "--install-completion" in res.stdout
    for flag in ("-q, --quiet", "-v, --verbose"):
        assert flag.split(", ")[0] in res.stdout and flag.split(", ")[1] in res.stdout
    assert invoke("evaluate", "-h").exit_code == 0


def _too_wide(text: str) -> list[str]:
    return [ln for ln in text.splitlines() if len(ln) > 80 or "…" in ln]


def test_every_table_fits_80_columns(est):
    for args in (("methods",), ("methods", "--long"), ("scenarios",), ("vehicle", "presets"),
                 ("evaluate", CIRCLE, est)):  # fmt: skip
        res = invoke(*args, width=80)
        assert res.exit_code == 0, res.output
        assert _too_wide(res.stdout) == [], args
    res = invoke("evaluate", CIRCLE, est, width=80)
    assert "kinematic_integration" in res.stdout  # the longest name, not cut
    assert "β rms/β max: sideslip RMS/max error" in res.stdout  # the legend line


def test_evaluate_table_fits_80_columns_in_a_real_terminal_width(est):
    env = {**os.environ, "COLUMNS": "80"}
    import subprocess
    import sys

    res = subprocess.run([sys.executable, "-m", "sideslip.cli", "evaluate", str(CIRCLE), str(est)],
                         capture_output=True, text=True, env=env, timeout=300)  # fmt: skip
    assert res.returncode == 0, res.stderr
    assert _too_wide(res.stdout) == []


def test_methods_json_lists_columns_parameters_and_settings():
    res = invoke("methods", "--json")
    data = json.loads(res.stdout)
    assert [m["name"] for m in data] == ss.method_names()
    fg = next(m for m in data if m["name"] == "fg_batch")
    assert "steer" in fg["columns"] and "lateral_acceleration" in fg["settings"]


def test_evaluate_prints_json_or_csv_and_json_dash_is_stdout(est):
    expected = ss.evaluate(CIRCLE, ss.estimate(CIRCLE, "midsize_sedan", methods=METHODS))
    res = invoke("evaluate", CIRCLE, est, "--format", "json")
    got = json.loads(res.stdout)
    assert got.keys() == expected.keys()
    assert got["fused"]["beta_rmse_deg"] == pytest.approx(expected["fused"]["beta_rmse_deg"])
    res = invoke("evaluate", CIRCLE, est, "--format", "csv")
    lines = res.stdout.strip().splitlines()
    assert lines[0].startswith("method,beta_rmse_deg,") and len(lines) == 1 + len(METHODS)
    res = invoke("evaluate", CIRCLE, est, "--json", "-")
    assert json.loads(res.stdout)["kkf"]["beta_rmse_deg"] == pytest.approx(expected["kkf"]["beta_rmse_deg"])
    assert not os.path.exists("-")


def test_json_through_a_symlink_writes_its_target_and_keeps_the_link(est, tmp_path):
    target = tmp_path / "real" / "metrics.json"
    target.parent.mkdir()
    target.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    res = invoke("evaluate", CIRCLE, est, "--json", link)
    assert res.exit_code == 0, res.output
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert "fused" in json.loads(target.read_text())
    assert [p.name for p in target.parent.iterdir()] == ["metrics.json"]  # no temporary left


def test_json_to_dev_stdout_and_dev_null_writes_through_the_device(est):
    res = run_cli("-q", "evaluate", CIRCLE, est, "--json", "/dev/stdout", "--format", "csv")
    assert res.returncode == 0, res.stderr
    head, _, tail = res.stdout.partition("\nmethod,")
    assert "fused" in json.loads(head)  # the JSON went to the pipe, then the CSV
    assert tail.count("\n") == 1 + len(METHODS)  # the rest of the header line, one row per method
    assert os.path.islink("/dev/stdout")
    res = run_cli("-q", "evaluate", CIRCLE, est, "--json", "/dev/null")
    assert res.returncode == 0 and stat.S_ISCHR(os.stat("/dev/null").st_mode)


def test_quiet_keeps_results_and_drops_notes(est, tmp_path):
    res = invoke("-q", "evaluate", CIRCLE, est, "--json", tmp_path / "m.json")
    assert res.exit_code == 0 and "wrote" not in res.stderr and "fused" in res.stdout
    res = invoke("evaluate", CIRCLE, est, "--json", tmp_path / "m.json")
    assert f"wrote {tmp_path / 'm.json'}" in res.stderr


def test_csv_of_the_estimate_table_round_trips(est, tmp_path):
    frame = pd.read_parquet(est)
    assert {"t", "fused.beta", "fused.beta_std", "kkf.yaw"} <= set(frame.columns)
