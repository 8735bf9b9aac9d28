"""boundid on a recording from an independent simulator: the UR5 of example-robot-data in MuJoCo
(tests/mujoco_recording.py), with stick-slip dry friction the identification model does not have.

Independent references: MuJoCo's own inverse dynamics (``mj_inverse``) for boundid's pinocchio
regressor at the truth mapped from MuJoCo's bodies; MuJoCo's constraint forces for what the truth
torque holds beyond the smooth model; the frequency response of the Butterworth filters for the
main lobe of their impulse response; and the truth's row errors for the low-speed rules.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy import signal

from boundid.errors import StudyError
from boundid.experiments.h4_pipeline import identification_design, low_speed_window
from boundid.experiments.preprocessing import main_lobe
from boundid.experiments.recording import write_recording
from boundid.studies.config import load_study
from mujoco_recording import inverse_forces, record, true_theta, without_dry_friction
from tiny_study import tiny_study

CUTOFF_HZ, DECIMATION = 10.0, 10


@pytest.fixture(scope="module")
def ur5():
    """15 s of the UR5's three positioning joints in MuJoCo at 1 kHz (seed 0), ~4 s to simulate."""
    return record(seed=0)


def _friction_free(rec) -> np.ndarray:
    """The truth with its Coulomb parameters at 0: what MuJoCo's arm is without its dry friction."""
    theta = rec.theta_true.copy()
    theta[[k for k, name in enumerate(rec.robot.param_names) if name.startswith("fc")]] = 0.0
    return theta


def test_the_truth_mapped_from_mujoco_reproduces_mj_inverse(ur5):
    """Reference: mj_inverse of the arm without its dry friction (bodies, armature, damping), on the
    recorded states (q, qd, MuJoCo's qdd under the applied torque) and on random states; boundid's
    pinocchio regressor Y(q, qd, qdd) times the truth (Coulomb terms at 0) must agree to 1e-9 of the
    largest force. MuJoCo and pinocchio also read the URDF's inertias alike (fusestatic against
    pinocchio's merge of the fixed wrist): the inertial truth equals boundid's URDF values."""
    robot, theta = ur5.robot, _friction_free(ur5)
    smooth = without_dry_friction(ur5.model)
    rng = np.random.default_rng(1)
    q_rand = robot.limits.sample_positions(rng, 200)
    states = [(ur5.q_true, ur5.qd_true, ur5.qdd_true),
              (q_rand, rng.uniform(-3, 3, q_rand.shape), rng.uniform(-15, 15, q_rand.shape))]
    for q, qd, qdd in states:
        mujoco_tau = inverse_forces(smooth, q, qd, qdd)
        boundid_tau = robot.regressor(q, qd, qdd) @ theta
        rel = np.abs(boundid_tau - mujoco_tau).max() / np.abs(mujoco_tau).max()
        print(f"\nmax |Y theta - mj_inverse| / max |mj_inverse| = {rel:.2e} over {q.shape[0]} states")
        assert rel < 1e-9
    np.testing.assert_allclose(ur5.theta_true[:30], robot.theta_true[:30], rtol=0, atol=1e-12)
    assert np.array_equal(true_theta(ur5.model, robot), ur5.theta_true)


def test_the_truth_torque_is_the_smooth_model_plus_a_bounded_dry_friction(ur5):
    """Reference: MuJoCo's friction constraint lies in [-fc, fc]: the applied torque minus the smooth
    model (Coulomb terms at 0) stays within fc of each joint, equals fc sign(qd) where the joint
    slides (|qd| > 0.2 rad/s), and differs from it near the stops (stiction, and MuJoCo's soft
    constraint, which below ~0.1 rad/s can even push along the motion while the joint brakes)."""
    theta = _friction_free(ur5)
    dry = ur5.tau_applied - ur5.robot.regressor(ur5.q_true, ur5.qd_true, ur5.qdd_true) @ theta
    assert np.all(np.abs(dry) <= ur5.dry + 1e-9)
    coulomb = ur5.dry * np.sign(ur5.qd_true)
    sliding = np.abs(ur5.qd_true) > 0.2
    np.testing.assert_allclose(dry[sliding], coulomb[sliding], rtol=0, atol=1e-9)
    off = np.abs(dry - coulomb) > 0.1 * ur5.dry
    print(f"\nfriction != fc sign(qd) on {100 * off.mean():.1f} % of the samples, all below "
          f"{np.abs(ur5.qd_true[off]).max():.3f} rad/s")
    assert np.all(off.sum(axis=0) > 10)
    # what the robot logs: 16-bit encoder angles and the torque with its noise
    assert np.abs(ur5.q - ur5.q_true).max() <= np.pi / 65536 + 1e-12
    assert 0.05 < np.std(ur5.tau - ur5.tau_applied) < 0.2


def test_main_lobe_matches_the_filters_frequency_response():
    """Reference: the zero-phase response is the inverse DFT of |H(e^jw)|^2 (from sosfreqz, not from
    filtering an impulse); its main lobe ends at its first lag <= 0."""
    fs = 1000.0
    for filters in ([(10.0, 4)], [(10.0, 8)], [(10.0, 4), (10.0, 8)], [(25.0, 4), (40.0, 8)]):
        nfft = 2 ** 16
        gain = np.ones(nfft // 2 + 1)
        for fc, order in filters:
            _, h = signal.sosfreqz(signal.butter(order, fc, fs=fs, output="sos"), worN=nfft // 2 + 1, whole=False)
            gain *= np.abs(h) ** 2
        response = np.fft.irfft(gain, nfft)
        assert main_lobe(fs, filters) == int(np.argmax(response <= 0)) - 1
    assert main_lobe(fs, []) == 0
    assert low_speed_window(fs, None, 4, 1, 10.0) == 2  # no filter: the difference stencil only


def test_low_speed_window_lowers_the_truths_largest_row_error(ur5):
    """Reference: the truth's row errors y - W theta_true of the identification rows built from the
    applied (noise-free) torque and the encoder angles. The stops' error, spread by the zero-phase
    filters, reaches rows the per-sample rule keeps; dropping the filters' main lobe around each slow
    sample lowers the largest error. The response's support to 1e-3 of its peak drops nearly all rows."""
    robot, fs = ur5.robot, 1000.0
    kw = {"decimation_cutoff_hz": CUTOFF_HZ, "jdot": "analytic", "edge_s": 3.0 / CUTOFF_HZ}

    def rows(min_speed, window):
        design = identification_design(robot, ur5.t, ur5.q, CUTOFF_HZ, DECIMATION, min_speed=min_speed,
                                       slow_window_s=window, **kw)
        reg = design.regression(ur5.tau_applied)
        return reg, np.abs(reg.y - reg.W @ ur5.theta_true).max()

    window = low_speed_window(fs, CUTOFF_HZ, 4, DECIMATION, CUTOFF_HZ)
    assert window == 56
    none, err_none = rows(0.0, None)
    assert none.dropped is None
    print(f"\nlargest truth row error, no threshold: {err_none:.3f} N m ({none.n_rows} rows)")
    for v in (0.1, 0.3):
        sample, err_sample = rows(v, 0.0)
        windowed, err_window = rows(v, None)
        d = windowed.dropped
        print(f"min_speed {v} rad/s: per-sample {err_sample:.3f} N m ({100 * sample.dropped.share:.1f} % dropped), "
              f"window +-{d.window_s:g} s {err_window:.3f} N m ({100 * d.share:.1f} % dropped)")
        assert err_window < 0.6 * err_sample < err_none
        assert d.window_s == window / fs and d.of == none.n_rows and d.rows == none.n_rows - windowed.n_rows
        assert sum(d.per_joint) == d.rows and "rad/s" in d.reason
        assert sample.dropped.window_s == 0 and windowed.n_rows < sample.n_rows
    support = (253 + 484 + 2) / fs  # 1e-3 of the peak of each filter's zero-phase response, + stencil
    wide, _ = rows(0.1, support)
    print(f"window +-{support:g} s (support to 1e-3 of the peaks): {100 * wide.dropped.share:.1f} % dropped")
    assert wide.dropped.share > 0.9


def test_per_joint_thresholds(ur5):
    """Reference: one threshold per joint is the scalar rule joint by joint: a threshold of 0 keeps
    every row of its joint, equal thresholds drop the rows of the scalar threshold."""
    kw = {"decimation_cutoff_hz": CUTOFF_HZ, "jdot": "analytic", "edge_s": 3.0 / CUTOFF_HZ, "slow_window_s": None}
    t, q = ur5.t, ur5.q
    scalar = identification_design(ur5.robot, t, q, CUTOFF_HZ, DECIMATION, min_speed=0.1, **kw).rows
    listed = identification_design(ur5.robot, t, q, CUTOFF_HZ, DECIMATION, min_speed=[0.1] * 3, **kw).rows
    assert np.array_equal(scalar.W, listed.W) and scalar.dropped == listed.dropped
    mixed = identification_design(ur5.robot, t, q, CUTOFF_HZ, DECIMATION, min_speed=[0.1, 0.0, 0.1], **kw).rows
    assert mixed.dropped.per_joint[1] == 0 and mixed.dropped.per_joint[0] == scalar.dropped.per_joint[0]
    assert np.array_equal(mixed.rows_of_joint(2).W, scalar.rows_of_joint(2).W)


def test_a_study_refuses_a_threshold_list_of_the_wrong_length(tmp_path):
    """The direct-drive arm has 2 joints: a list of 3 thresholds names the key and the count."""
    text = tiny_study("speeds", 1, ("inverse_dynamic",), "[preprocessing]\nmin_speed_rad_s = [0.1, 0.2, 0.3]\n")
    path = tmp_path / "speeds.toml"
    path.write_text(text + '\n[[estimators]]\nmethod = "wls"\nregressions = ["inverse_dynamic"]\n')
    with pytest.raises(StudyError, match=r"min_speed_rad_s.*list of 2"):
        load_study(path)
    path.write_text(path.read_text().replace("[0.1, 0.2, 0.3]", "[0.1, 0.2]"))
    assert load_study(path).preprocessing.min_speed_rad_s == (0.1, 0.2)


MEASURED_STUDY = """
regressions = ["inverse_dynamic"]

[study]
name = "ur5_mujoco"
title = "UR5 recorded in MuJoCo"
seed = 1

[robot]
model = "urdf"
options = {{ source = "ur5", joints = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint"], armature = 0.1 }}

[experiment]
source = "measured"

[experiment.measured]
file = "{csv}"

[experiment.measured.columns]
time = "t"
q = ["q1", "q2", "q3"]
tau = ["tau1", "tau2", "tau3"]

[preprocessing]
lowpass_cutoff_hz = 10.0
decimation = 10
min_speed_rad_s = [0.1, 0.1, 0.15]

[prior]
center = "zero"
absolute_range = 50.0

[[estimators]]
method = "wls"
label = "WLS"
regressions = ["inverse_dynamic"]

[[estimators]]
method = "obe"
label = "OBE"
regressions = ["inverse_dynamic"]
e_max = 0.5
"""


def test_boundid_runs_a_study_on_the_mujoco_recording(ur5, tmp_path):
    """The recording in boundid's measured format (write_recording), run by `boundid run`."""
    csv = write_recording(ur5.recording(), tmp_path / "ur5_mujoco.csv")
    study = tmp_path / "ur5_mujoco.toml"
    study.write_text(MEASURED_STUDY.format(csv=csv.name))
    out = tmp_path / "reports"
    proc = subprocess.run([sys.executable, "-m", "boundid.cli", "run", str(study), "--out", str(out), "--quiet"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert (out / "ur5_mujoco" / "index.html").is_file()
