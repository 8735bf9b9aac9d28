"""The shipped measured-data example (studies/examples/): its CSV is what its script makes, and a
user who copies the study file and the CSV into a folder of their own can run it.

References: the script re-run here (same seed: the committed CSV must match it, the angles to one
16-bit encoder count and the torques to 1e-6 N m, since the ODE solver's last digits may differ
between machines), and the recording's own sampling read back with pandas.
"""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "studies" / "examples"
BOUNDID = str(Path(sys.executable).with_name("boundid"))


def _script():
    spec = importlib.util.spec_from_file_location("make_measured_csv", EXAMPLES / "make_measured_csv.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_committed_csv_is_what_the_script_makes(tmp_path):
    committed = pd.read_csv(EXAMPLES / "direct_drive_measured.csv")
    assert (EXAMPLES / "direct_drive_measured.csv").stat().st_size < 1_000_000
    made = pd.read_csv(_script().main(tmp_path / "made.csv"))
    assert list(committed.columns) == ["t_s", "q1_rad", "q2_rad", "tau1_Nm", "tau2_Nm"] == list(made.columns)
    assert len(committed) == len(made) == 2401
    np.testing.assert_allclose(committed.t_s, made.t_s, rtol=0, atol=1e-12)
    dt = np.diff(committed.t_s.to_numpy())
    assert np.ptp(dt) < 1e-3 * dt.mean()  # uniformly spaced, as read_recording requires
    count = 2 * np.pi / 2 ** 16
    np.testing.assert_allclose(committed[["q1_rad", "q2_rad"]], made[["q1_rad", "q2_rad"]], rtol=0, atol=1.01 * count)
    np.testing.assert_allclose(committed[["tau1_Nm", "tau2_Nm"]], made[["tau1_Nm", "tau2_Nm"]], rtol=0, atol=1e-6)


@pytest.mark.slow  # a whole study, like the README's other `boundid run` lines (tests/test_readme.py)
def test_a_user_copy_of_the_example_runs(tmp_path):
    """The README's command for the example, run in a folder outside the checkout that holds a copy
    of studies/examples/ (as a user who copied it): the closing verdict says the truth is unknown
    (measured data) and the data respect the bound."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    (line,) = re.findall(r"^\s*(boundid run studies/examples/\S+\.toml) --out \S+$", readme, re.M)
    shutil.copytree(EXAMPLES, tmp_path / "studies" / "examples", ignore=shutil.ignore_patterns("__pycache__"))
    res = subprocess.run([BOUNDID, *line.split()[1:], "--out", "out", "--quiet"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=900, env={**os.environ, "MPLBACKEND": "Agg"})
    assert res.returncode == 0, res.stderr[-2000:]
    verdict = res.stdout.strip().splitlines()[-1]
    assert verdict.startswith("measured_direct_drive: OK: truth unknown (measured data): e_max = ")
    assert (tmp_path / "out" / "measured_direct_drive" / "index.html").is_file()
    results = pd.read_csv(tmp_path / "out" / "measured_direct_drive" / "results.csv")
    assert {"RLS", "WLS", "OBE-factorized", "LP exact"} <= set(results.estimator)
