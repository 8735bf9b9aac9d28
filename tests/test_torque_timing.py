"""The timing of the recorded torque in the inverse dynamic rows (``[preprocessing] torque_timing``).

A torque held constant over each sample [t_k, t_{k+1}) (zero-order hold) and recorded as tau[k] is,
to O(h^2), the torque at the middle of its hold: paired with the state at t_k ("sample", the
default) it is half a sample late, a row error of about (h/2) dtau/dt, O(h); "hold" gives the row at
t_k the mean (tau[k-1] + tau[k]) / 2 and leaves O(h^2).

Independent reference: the exact zero-order-hold response of a linear arm, J qdd + b qd = u (the
pendulum with g = 0 and no Coulomb friction), from the matrix exponential of the augmented system
(no integrator, no tolerance): the rows' residual at the true parameters must halve with h under
"sample" and quarter under "hold" -- the orders, not one number.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.linalg import expm

from boundid.cli import main
from boundid.errors import InputError
from boundid.experiments.h4_pipeline import identification_design
from boundid.experiments.preprocessing import torque_at_samples
from boundid.experiments.recording import Recording
from boundid.models.pendulum import Pendulum
from boundid.studies.config import PreprocessingConfig, load_study
from boundid.studies.regressions import inverse_dynamic_design, inverse_dynamic_rows

J, B = 0.21, 0.3  # kg m^2, N m s/rad: I_c + m lc^2 and b of the pendulum below
DURATION = 2.0


def _arm() -> Pendulum:
    return Pendulum(m=1.0, lc=0.2, I_c=J - 0.04, b=B, fc=0.0, g=0.0)


def _held_recording(h: float) -> Recording:
    """The exact response of J qdd + b qd = u to the command u[k] held over [t_k, t_{k+1})."""
    t = np.arange(round(DURATION / h) + 1) * h
    u = 2.0 * np.sin(2 * np.pi * 1.3 * t) + 1.5 * np.cos(2 * np.pi * 3.1 * t + 0.4)
    aug = np.zeros((3, 3))
    aug[0, 1], aug[1, 1], aug[1, 2] = 1.0, -B / J, 1.0 / J
    step = expm(aug * h)
    phi, gamma = step[:2, :2], step[:2, 2]
    x = np.zeros((len(t), 2))
    x[0] = (0.3, -0.5)
    for k in range(len(t) - 1):
        x[k + 1] = phi @ x[k] + gamma * u[k]
    return Recording(t=t, q=x[:, :1], tau=u[:, None])


def _residual(h: float, timing: str) -> float:
    """rms of y - W theta_true over the rows (no low-pass, no decimation: the timing alone)."""
    arm = _arm()
    reg = inverse_dynamic_rows(arm, _held_recording(h), PreprocessingConfig(torque_timing=timing))
    assert reg.info["torque_timing"] == timing
    return float(np.sqrt(np.mean((reg.y - reg.W @ arm.theta_true) ** 2)))


def test_hold_timing_is_second_order_and_sample_timing_first_order():
    hs = (4e-3, 2e-3, 1e-3)
    sample = np.array([_residual(h, "sample") for h in hs])
    hold = np.array([_residual(h, "hold") for h in hs])
    assert np.all(hold < 0.05 * sample), (sample, hold)
    # each halving of h: the "sample" residual halves (O(h)), the "hold" one quarters (O(h^2))
    assert np.all(np.abs(sample[1:] / sample[:-1] - 0.5) < 0.05), sample
    assert np.all(np.abs(hold[1:] / hold[:-1] - 0.25) < 0.05), hold
    # and "sample" is the (h/2) dtau/dt of the half-sample skew
    t = np.arange(round(DURATION / hs[-1]) + 1) * hs[-1]
    dudt = 2.0 * 2 * np.pi * 1.3 * np.cos(2 * np.pi * 1.3 * t) - 1.5 * 2 * np.pi * 3.1 * np.sin(
        2 * np.pi * 3.1 * t + 0.4)
    assert sample[-1] == pytest.approx(hs[-1] / 2 * np.sqrt(np.mean(dudt ** 2)), rel=0.05)


def test_sample_timing_is_the_default_and_changes_nothing():
    """The default pairs tau[k] with t_k: the rows of the recorded torque, unchanged."""
    assert PreprocessingConfig().torque_timing == "sample"
    rec = _held_recording(2e-3)
    pp = PreprocessingConfig(lowpass_cutoff_hz=20.0, decimation=5)
    default = inverse_dynamic_rows(_arm(), rec, pp)
    design = identification_design(_arm(), rec.t, rec.q, 20.0, 5, decimation_cutoff_hz=20.0, jdot="analytic",
                                   edge_s=3.0 / 20.0, slow_window_s=None)
    np.testing.assert_array_equal(default.y, design.regression(rec.tau).y)
    np.testing.assert_array_equal(torque_at_samples(rec.tau, "sample"), rec.tau)


def test_hold_applies_to_every_torque_of_a_design():
    """A design re-times each torque it is given (new noise draws, the validation recording),
    before the low-pass; the first sample, without a predecessor, is extrapolated."""
    rec = _held_recording(2e-3)
    pp = PreprocessingConfig(lowpass_cutoff_hz=20.0, decimation=5, torque_timing="hold")
    design = inverse_dynamic_design(_arm(), rec, pp)
    retimed = torque_at_samples(rec.tau, "hold")
    np.testing.assert_allclose(retimed[1:], 0.5 * (rec.tau[:-1] + rec.tau[1:]))
    np.testing.assert_allclose(retimed[0], 1.5 * rec.tau[0] - 0.5 * rec.tau[1])
    same = inverse_dynamic_design(_arm(), rec, PreprocessingConfig(lowpass_cutoff_hz=20.0, decimation=5))
    other = rec.tau + 0.1
    np.testing.assert_allclose(design.regression(other).y, same.regression(torque_at_samples(other, "hold")).y)
    with pytest.raises(InputError, match=r"torque_timing must be one of 'sample', 'hold'"):
        identification_design(_arm(), rec.t, rec.q, 20.0, 5, torque_timing="held")


STUDY = """
regressions = ["inverse_dynamic"]
[study]
name = "arm"
title = "Arm"
[robot]
model = "pendulum"
[experiment]
source = "simulate"
duration_s = 4.0
sample_period_s = 0.001
[preprocessing]
lowpass_cutoff_hz = 10.0
decimation = 10
{line}
[[estimators]]
method = "wls"
regressions = ["inverse_dynamic"]
"""


def test_study_file_reads_the_key(tmp_path):
    path = tmp_path / "s.toml"
    for line, timing in (("", "sample"), ('torque_timing = "hold"', "hold"), ('torque_timing = "sample"', "sample")):
        path.write_text(STUDY.format(line=line))
        assert load_study(path).preprocessing.torque_timing == timing


@pytest.mark.parametrize("value, match", [
    ('"held"', r"preprocessing\.torque_timing: must be one of 'sample', 'hold'; got 'held'\.$"),
    ("nan", r"preprocessing\.torque_timing: must be a string, got nan\.$"),
])
def test_bad_torque_timing_is_one_line_and_exit_2(tmp_path, capsys, value, match):
    path = tmp_path / "s.toml"
    path.write_text(STUDY.format(line=f"torque_timing = {value}"))
    assert main(["run", str(path), "--quiet", "--out", str(tmp_path / "out")]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("boundid: error: "), captured.err
    assert re.search(match, lines[0]), lines[0]
    assert captured.out == "" and not (tmp_path / "out").exists()
