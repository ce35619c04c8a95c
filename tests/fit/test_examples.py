"""Run every numbered example script (examples/NN_*.py) as a subprocess; each must exit 0.

Each script runs with a fresh temporary working folder and ``TRISPLINE_EXAMPLE_OUT``
pointing into it (the examples write their files there), so the checkout stays clean.
The scripts end with their own assertions.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
SCRIPTS = sorted(p for p in EXAMPLES.glob("*.py") if re.match(r"\d\d_", p.name))


def test_examples_exist():
    names = [p.name for p in SCRIPTS]
    assert "01_fit_synthetic_scan.py" in names and "02_fairness_sweep.py" in names


@pytest.mark.parametrize("script", SCRIPTS, ids=[p.stem for p in SCRIPTS])
def test_example_runs(script, tmp_path):
    out = tmp_path / "out"
    env = dict(os.environ, TRISPLINE_EXAMPLE_OUT=str(out), MPLBACKEND="Agg", PYTHONWARNINGS="")
    r = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, f"{script.name} failed:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    if script.name.startswith("01_"):
        assert {"scan_surface.npz", "scan_surface.ply", "scan_control_net.obj", "fitted_scan.png"} <= {
            p.name for p in out.iterdir()}
    if script.name.startswith("02_"):
        lines = (out / "fairness_sweep.csv").read_text().splitlines()
        assert lines[0].startswith("weight,value,") and len(lines) == 9
        assert (out / "fairness_sweep.png").read_bytes()[:4] == b"\x89PNG"
    # nothing half-written left behind
    assert not [p for p in tmp_path.rglob("*") if ".tmp" in p.name]
