"""`sideslip convert --template` and `sideslip vehicle new`: starting points a user edits."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from sideslip.cli import app
from sideslip.io.mapping import load_map
from sideslip.io.rosbag import load_bag_map
from sideslip.vehicle import PARAMETERS, load_vehicle


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.mark.parametrize("fmt", ["csv", "mdf4", "rosbag"])
def test_every_template_is_a_commented_map_its_parser_accepts(fmt, tmp_path):
    res = invoke("convert", "--template", fmt)
    assert res.exit_code == 0, res.output
    text = res.stdout
    assert text.startswith(f"# Channel map for `sideslip convert {fmt}") or text.startswith("# Topic map for")
    assert sum(line.lstrip().startswith("#") for line in text.splitlines()) >= 5
    p = tmp_path / "map.toml"
    p.write_text(text)
    cols = load_bag_map(p).columns() if fmt == "rosbag" else [c.column for c in load_map(p).columns]
    assert {"wz", "steer", "gnss_lat"} <= set(cols)


def test_unknown_template_and_missing_arguments_are_one_line():
    res = invoke("convert", "--template", "xls")
    assert res.exit_code == 2 and res.stderr.strip() == "error: --template: 'xls': expected one of csv, mdf4, rosbag"
    res = invoke("convert", "csv")
    assert res.exit_code == 2 and "expected FORMAT SRC --out DRIVE (or --template FORMAT)" in res.stderr


def test_vehicle_new_writes_a_commented_file_that_loads_as_the_preset(tmp_path):
    out = tmp_path / "my_car.toml"
    res = invoke("vehicle", "new", "--preset", "midsize_sedan", "--out", out)
    assert res.exit_code == 0, res.output
    text = out.read_text()
    assert text.startswith("# Vehicle file 'my_car', started from the sideslip preset 'midsize_sedan'")
    for key, (unit, _, _) in PARAMETERS.items():
        assert f"#   {key}" in text and unit in text  # every key explained with its unit
    mine, preset = load_vehicle(str(out)), load_vehicle("midsize_sedan")
    assert mine.name == "my_car"
    for key in PARAMETERS:
        assert getattr(mine, key) == getattr(preset, key)
    res = invoke("vehicle", "new", "--preset", "midsize_sedan", "--out", out)
    assert res.exit_code == 2 and "exists already" in res.stderr
    assert invoke("vehicle", "new", "--preset", "midsize_sedan", "--out", out, "--force").exit_code == 0


def test_vehicle_new_unknown_preset_is_one_line(tmp_path):
    res = invoke("vehicle", "new", "--preset", "tesla", "--out", tmp_path / "t.toml")
    assert res.exit_code == 2
    assert res.stderr.startswith("error: --preset: unknown preset 'tesla': expected one of alphard_minivan,")
    assert not (tmp_path / "t.toml").exists()
