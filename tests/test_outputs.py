"""Safe output writing: never over an input, checked before any method runs, through links and
to devices, nothing left behind by a failure or an interrupt (contract section 5)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from sideslip.cli import app
from sideslip.drive import drive_from_columns, save_drive
from sideslip.errors import InputError
from sideslip.outputs import atomic_write, check_outputs, output_group
from tests.conftest import sim_drive
from tests.helpers import CIRCLE

RUNNER = CliRunner()


def _cli(*args: object):
    return RUNNER.invoke(app, [str(a) for a in args])


def _one_error_line(res) -> str:
    assert res.exit_code == 2, (res.exit_code, res.output, res.exception)
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), res.stderr
    assert "Traceback" not in res.output and "internal error" not in res.output
    return lines[0]


@pytest.fixture
def drive_csv(tmp_path: Path) -> Path:
    p = tmp_path / "drive.csv"
    p.write_bytes(CIRCLE.read_bytes())
    return p


# ------------------------------------------------------------------------------------------
# an output that is an input
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("how", ["same", "symlink", "hardlink", "relative"])
def test_estimate_out_naming_the_input_is_refused_and_the_drive_kept(tmp_path, drive_csv, how):
    before = drive_csv.read_bytes()
    if how == "same":
        out = drive_csv
    elif how == "symlink":
        out = tmp_path / "link.csv"
        out.symlink_to(drive_csv)
    elif how == "hardlink":
        out = tmp_path / "hard.csv"
        os.link(drive_csv, out)
    else:
        out = tmp_path / "sub" / ".." / "drive.csv"
        (tmp_path / "sub").mkdir()
    res = _cli("estimate", drive_csv, "--vehicle", "midsize_sedan", "--out", out)
    line = _one_error_line(res)
    assert f"is the input {drive_csv}" in line and "would replace the input" in line
    assert "ran " not in res.stderr  # refused before any method ran
    assert drive_csv.read_bytes() == before


def test_estimate_csv_side_car_may_not_overwrite_the_inputs_side_car(tmp_path):
    drive = tmp_path / "d.parquet"
    save_drive(drive_from_columns({"t": [0.0, 1.0], "wz": [0.0, 0.0]}), drive)
    side = tmp_path / "d.meta.json"
    side.write_text('{"source": "mine"}')
    res = _cli("estimate", drive, "--vehicle", "midsize_sedan", "--out", tmp_path / "d.csv")
    assert "is the input" in _one_error_line(res) and side.read_text() == '{"source": "mine"}'


def test_other_commands_refuse_an_output_that_is_an_input(tmp_path, drive_csv):
    est = tmp_path / "est.parquet"
    assert _cli("estimate", drive_csv, "--vehicle", "midsize_sedan", "--method",
                "kinematic_integration", "--out", est).exit_code == 0
    est_bytes = est.read_bytes()
    assert "is the input" in _one_error_line(_cli("evaluate", drive_csv, est, "--json", est))
    mp = tmp_path / "m.toml"
    mp.write_text('[columns.wz]\nchannel = "wz"\nunit = "rad/s"\n')
    assert "is the input" in _one_error_line(_cli("convert", "csv", drive_csv, "--out", drive_csv,
                                                  "--map", mp))
    html_link = tmp_path / "r.html"
    html_link.symlink_to(est)  # an .html name that is the estimate table
    assert "is the input" in _one_error_line(_cli("report", drive_csv, est, "--out", html_link))
    assert est.read_bytes() == est_bytes


# ------------------------------------------------------------------------------------------
# outputs checked writable before anything runs
# ------------------------------------------------------------------------------------------
def test_unwritable_out_is_one_line_before_any_method_runs(tmp_path, drive_csv):
    res = _cli("estimate", drive_csv, "--vehicle", "midsize_sedan", "--out", "/proc/sideslip/est.parquet")
    assert "cannot write in /proc" in _one_error_line(res) and "ran " not in res.stderr
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    res = _cli("estimate", drive_csv, "--vehicle", "midsize_sedan", "--out", a_file / "est.parquet")
    assert f"{a_file} is a file, not a folder" in _one_error_line(res) and "ran " not in res.stderr
    res = _cli("estimate", drive_csv, "--vehicle", "midsize_sedan", "--out", tmp_path / "x" / "est.parquet")
    assert res.exit_code == 0  # a folder that does not exist yet is created


def test_out_dir_that_is_a_file_and_out_that_is_a_folder(tmp_path, drive_csv):
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    line = _one_error_line(_cli("demo", "--out-dir", a_file))
    assert line == f"error: {a_file}: is a file: expected a folder for the outputs"
    assert a_file.read_text() == "x"
    folder = tmp_path / "drive.parquet"
    folder.mkdir()
    line = _one_error_line(_cli("simulate", "demo", "--out", folder))
    assert line == f"error: {folder}: is a folder: expected a file name"
    line = _one_error_line(_cli("report", drive_csv, drive_csv, "--out", "/proc/r.html"))
    assert "cannot write in /proc" in line


def test_output_that_is_no_table_is_refused_before_simulating(tmp_path):
    line = _one_error_line(_cli("simulate", "demo", "--out", tmp_path / "drive.txt"))
    assert line == f"error: {tmp_path / 'drive.txt'}: expected an output path ending in .csv or .parquet"
    assert "wrote" not in line and list(tmp_path.iterdir()) == []


def test_check_outputs_creates_nothing(tmp_path):
    check_outputs([tmp_path / "a" / "b" / "est.parquet"], [], folders=[tmp_path / "c"])
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------------------------
# evaluate/report with a second file that holds no estimates
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("command", ["evaluate", "report"])
def test_drive_given_twice_is_one_line_saying_no_estimates(tmp_path, drive_csv, command):
    extra = ["--out", tmp_path / "r.html"] if command == "report" else ["--json", tmp_path / "m.json"]
    line = _one_error_line(_cli(command, drive_csv, drive_csv, *extra))
    assert line.startswith(f"error: {drive_csv}: holds no estimates: expected the columns METHOD.beta")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["drive.csv"]


# ------------------------------------------------------------------------------------------
# the writer: links, devices, '-', groups
# ------------------------------------------------------------------------------------------
def test_write_through_a_symlink_replaces_the_target_and_keeps_the_link(tmp_path):
    target_dir = tmp_path / "shared"
    target_dir.mkdir()
    target = target_dir / "m.json"
    target.write_text("old")
    link = tmp_path / "m.json"
    link.symlink_to(target)
    atomic_write(link, lambda tmp: tmp.write_text("new"))
    assert link.is_symlink() and target.read_text() == "new"
    assert sorted(p.name for p in target_dir.iterdir()) == ["m.json"]  # temp was in the target's folder


def test_write_to_devices_and_fifos_goes_direct(tmp_path):
    atomic_write("/dev/null", lambda tmp: tmp.write_text("nothing"))
    assert Path("/dev/null").is_char_device()
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    atomic_write(fifo, lambda tmp: tmp.write_text("through the pipe"))
    reader.join(5)
    assert got == [b"through the pipe"] and fifo.is_fifo()


def test_json_to_dev_stdout_keeps_the_link_and_dash_means_stdout(tmp_path, drive_csv):
    est = tmp_path / "est.parquet"
    assert _cli("estimate", drive_csv, "--vehicle", "midsize_sedan", "--method",
                "kinematic_integration", "--out", est).exit_code == 0
    link = tmp_path / "stdout"
    link.symlink_to("/dev/stdout")
    res = subprocess.run([sys.executable, "-m", "sideslip.cli", "evaluate", str(drive_csv), str(est),
                          "--json", str(link)], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert '"kinematic_integration"' in res.stdout and link.is_symlink()
    res = subprocess.run([sys.executable, "-m", "sideslip.cli", "evaluate", str(drive_csv), str(est),
                          "--json", "-"], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    import json

    assert "beta_rmse_deg" in json.loads(res.stdout)["kinematic_integration"]  # JSON alone on stdout


def test_group_writes_all_or_nothing_and_leaves_no_temp(tmp_path):
    with pytest.raises(RuntimeError), output_group():
        atomic_write(tmp_path / "a.csv", lambda tmp: tmp.write_text("a"))
        atomic_write(tmp_path / "b.json", lambda tmp: tmp.write_text("b"))
        raise RuntimeError("the second method failed")
    assert list(tmp_path.iterdir()) == []
    with output_group():
        atomic_write(tmp_path / "a.csv", lambda tmp: tmp.write_text("a"))
        assert not (tmp_path / "a.csv").exists()  # visible only when the group ends
    assert (tmp_path / "a.csv").read_text() == "a" and len(list(tmp_path.iterdir())) == 1


def test_failed_write_leaves_the_old_file(tmp_path):
    out = tmp_path / "m.json"
    out.write_text("old")

    def broken(tmp: Path) -> None:
        tmp.write_text("half")
        raise OSError(28, "No space left on device")

    with pytest.raises(InputError, match=r"m.json: cannot write \(No space left on device\)"):
        atomic_write(out, broken)
    assert out.read_text() == "old" and list(tmp_path.iterdir()) == [out]


# ------------------------------------------------------------------------------------------
# a one-row drive
# ------------------------------------------------------------------------------------------
def test_one_row_drive_is_one_line_without_lapack_noise(tmp_path):
    p = tmp_path / "one.csv"
    pd.read_csv(CIRCLE).head(1).to_csv(p, index=False)
    res = subprocess.run([sys.executable, "-m", "sideslip.cli", "estimate", str(p), "--vehicle",
                          "midsize_sedan", "--out", str(tmp_path / "e.parquet")],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 2
    assert res.stderr.strip() == (f"error: {p}: column 't': expected at least 2 rows (time stamps) "
                                  "to estimate anything, got 1")
    assert sorted(x.name for x in tmp_path.iterdir()) == ["one.csv"]


# ------------------------------------------------------------------------------------------
# SIGINT / SIGTERM
# ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def long_drive(tmp_path_factory) -> Path:
    """The demo drive repeated 12 times (23 min at 100 Hz): long enough that writing its
    estimate CSV takes about a second, so a signal can land while the file is written."""
    d = sim_drive("demo")
    span = d.t[-1] - d.t[0] + d.dt_median
    reps = 12
    cols = {"t": np.concatenate([d.t + k * span for k in range(reps)])}
    cols.update({k: np.tile(v, reps) for k, v in d.data.items() if v.dtype.kind == "f"})
    p = tmp_path_factory.mktemp("long") / "long.parquet"
    save_drive(drive_from_columns(cols, dict(d.meta)), p)
    return p


def _as_from_a_shell() -> None:
    """In the child before exec: SIGINT and SIGTERM at their defaults and none blocked, as an
    interactive shell starts a command.  A test run started in the background of a script
    (``cmd &`` without job control, nohup, some CI runners) ignores SIGINT, every child
    inherits that, and Python then never turns SIGINT into KeyboardInterrupt (seen: the
    suite run as ``(make test &)`` failed both SIGINT cases, exit 0 with complete outputs)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_SETMASK, [])


def _lines(stream, sink: list[str]) -> None:
    for line in stream:
        sink.append(line)


@pytest.mark.parametrize("phase", ["methods", "write"])
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_interrupt_leaves_no_output_and_no_temp_file(tmp_path, long_drive, sig, phase):
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    proc = subprocess.Popen(
        [sys.executable, "-m", "sideslip.cli", "estimate", str(long_drive), "--vehicle", "midsize_sedan",
         "--method", "kinematic_integration", "--method", "fused", "--out", str(out_dir / "est.csv")],
        stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True, preexec_fn=_as_from_a_shell,
    )
    err: list[str] = []
    threading.Thread(target=_lines, args=(proc.stderr, err), daemon=True).start()
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if phase == "methods" and any("ran kinematic_integration" in ln for ln in err):
            break  # fused is running now
        if phase == "write" and any(p.name.endswith(".part") for p in out_dir.iterdir()):
            break  # the estimate table is being written
        time.sleep(0.002)
    assert proc.poll() is None, "the command ended before the signal could be sent"
    proc.send_signal(sig)
    code = proc.wait(60)
    time.sleep(0.1)
    assert code == 128 + sig, "".join(err)
    assert err[-1].strip() == "error: interrupted"
    assert not any("Traceback" in ln for ln in err)
    left = sorted(p.name for p in out_dir.iterdir())
    # no temp file ever; no estimate and no params -- unless the signal came while the
    # finished files were being renamed into place (signals are held for those few
    # microseconds), in which case both are complete
    assert left in ([], ["est.csv", "est.meta.json", "est.params.json"]), left
    if left:
        assert len(pd.read_csv(out_dir / "est.csv")) == len(pd.read_parquet(long_drive))


def test_a_signal_another_thread_takes_is_held_until_the_section_ends():
    """The kernel hands a process-directed SIGTERM to any thread that does not block it (numpy's
    and pyarrow's pools), and CPython then runs the handler in the main thread at its next
    instruction: blocking the signal in the main thread alone let it interrupt a held section
    (an unrecorded .part file left behind).  Here another thread takes the signal inside the
    section; the handler must defer it to the section's end."""
    from sideslip.outputs import Interrupted, _signals_held, install_signal_handlers

    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    release = threading.Event()
    helper = threading.Thread(target=release.wait, daemon=True)  # started with no signal blocked
    helper.start()
    try:
        install_signal_handlers()
        inside = []
        with pytest.raises(Interrupted) as raised, _signals_held():
            signal.pthread_kill(helper.ident, signal.SIGTERM)
            time.sleep(0.05)  # the handler has run by now (in this, the main thread)
            inside.append("reached the end of the section")
        assert inside == ["reached the end of the section"]
        assert raised.value.signum == signal.SIGTERM
    finally:
        release.set()
        for sig, handler in saved.items():
            signal.signal(sig, handler)
