"""The README's Python example runs as written (examples must not rot)."""

from __future__ import annotations

import contextlib
import io
import re

from tests.helpers import ROOT


def test_readme_python_example_runs_and_prints_every_runnable_method():
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks, "README has no python example"
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(blocks[0], "README.md", "exec"), {})
    lines = out.getvalue().splitlines()
    assert len(lines) >= 15
    fused = next(line for line in lines if line.startswith("fused "))
    # fused on dlc_bank seed 1: well under 0.2 deg (measured about 0.07)
    assert float(fused.split()[3]) < 0.2
