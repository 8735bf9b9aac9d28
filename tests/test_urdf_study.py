"""A study can name any URDF file: the direct-drive arm written as a 2-link URDF
(boundid.models.direct_drive.planar_arm_urdf), tracked in closed loop within the limits read from
the file, identified in its base parameters.

Independent references: the built-in closed-form DirectDriveArm (torques of the identified
model against its inverse dynamics), the LP guarantee (the base truth inside the exact bounds and
the OBE when the bound holds at the truth) and the recorded reference trajectory.
"""

from __future__ import annotations

import numpy as np
import pytest

from boundid.errors import InputError, StudyError
from boundid.models import BaseParameterModel, DirectDriveArm
from boundid.models.direct_drive import planar_arm_urdf
from boundid.studies.config import load_study
from boundid.studies.runner import run_study
from tiny_study import run_study_text


def planar_study(folder, control="tracking", extra_robot="") -> str:
    urdf = planar_arm_urdf(folder)
    return f"""
regressions = ["inverse_dynamic"]

[study]
name = "planar_urdf"
title = "The direct-drive arm as a URDF"
seed = 5

[robot]
model = "urdf"
options = {{ source = "{urdf}"{extra_robot} }}

[experiment]
source = "simulate"
control = "{control}"
duration_s = 4.0
sample_period_s = 0.001
coulomb_width_rad_s = 0.05
validation_duration_s = 2.0
options = {{ period_s = 4.0, substeps = 2 }}

[experiment.noise]
encoder_counts_per_rev = 524288
torque = {{ kind = "uniform", level = 0.1 }}

[preprocessing]
lowpass_cutoff_hz = 10.0
decimation = 10
min_speed_rad_s = 0.1

[prior]
center = "zero"
absolute_range = 100.0

[[estimators]]
method = "wls"
label = "WLS"
regressions = ["inverse_dynamic"]

[[estimators]]
method = "obe"
label = "OBE"
form = "factorized"
regressions = ["inverse_dynamic"]
e_max = 0.5

[exact]
regression = "inverse_dynamic"
e_max = 0.5
lp_bounds = true
sdp = []
"""


@pytest.fixture(scope="module")
def planar_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("planar")
    return run_study_text(folder, "planar", planar_study(folder))[1]


def test_a_study_names_a_urdf_file_and_identifies_the_direct_drive_arm(planar_run):
    r, arm = planar_run, DirectDriveArm()
    assert isinstance(r.model, BaseParameterModel) and r.model.p == 10
    assert not r.failures, r.failures
    # the model read from the file has the arm's dynamics on the recorded motion
    rec = r.data.recording
    k = slice(1, -1)
    qd = (rec.q[2:] - rec.q[:-2]) / (2 * rec.h)
    qdd = (rec.q[2:] - 2 * rec.q[1:-1] + rec.q[:-2]) / rec.h ** 2
    np.testing.assert_allclose(r.model.inverse_dynamics(rec.q[k], qd, qdd), arm.inverse_dynamics(rec.q[k], qd, qdd),
                               atol=1e-9)
    # the identified base parameters give the arm's torques (WLS, within the noise's reach)
    wls = r.estimates[("WLS", "inverse_dynamic")].center
    tau_arm = arm.inverse_dynamics(rec.q[k], qd, qdd)
    tau_wls = r.model.inverse_dynamics(rec.q[k], qd, qdd, wls)
    assert np.sqrt(np.mean((tau_wls - tau_arm) ** 2)) < 0.02 * np.sqrt(np.mean(tau_arm ** 2))


def test_the_guaranteed_sets_of_the_urdf_study_contain_the_base_truth(planar_run):
    r = planar_run
    truth = r.model.theta_true
    assert r.exact.truth_error_ratio <= 1.0  # the bound holds on every row at the truth ...
    b = r.exact.bounds                        # ... so the exact bounds and the OBE must contain it
    assert np.all(b.lo <= truth + 1e-9) and np.all(truth <= b.hi + 1e-9)
    assert r.estimates[("OBE", "inverse_dynamic")].set.contains(truth)
    phys = r.exact.physical  # under the links' pseudo-inertia LMIs, lifted to base parameters
    assert phys.error is None and "SDP" in phys.method, (phys.error, phys.method)
    assert phys.intervals["truth_inside"].eq("yes").all()


def test_the_tracking_run_follows_its_reference_within_the_file_limits(planar_run):
    r = planar_run
    info, lim = r.data.info, r.model.limits
    assert info["identification_tracking_error_rms_rad"] < 1e-3
    assert info["identification_saturated_fraction"] == 0.0
    assert all(v <= 1.0 for v in info["identification_limit_usage"].values())
    assert np.all(np.abs(r.data.recording.q) <= lim.upper)
    assert r.data.validation is not None and r.data.validation.t.size == 2000


def test_robots_without_the_tracking_experiment_are_refused(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(planar_study(tmp_path).replace('model = "urdf"\noptions', 'model = "direct_drive"\n#'))
    with pytest.raises(StudyError, match="tracking"):
        run_study(load_study(path))


def test_urdf_options_are_checked(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(planar_study(tmp_path, extra_robot=', parameters = "minimal"'))
    with pytest.raises(StudyError, match="'base' or 'standard'"):
        load_study(path)


def test_a_urdf_without_velocity_limits_gets_them_from_the_study(tmp_path):
    """The tracking experiment needs velocity and acceleration limits; a file without them is refused
    naming the study option, and robot.options velocity_limit supplies them (acceleration: 5 x per s)."""
    from boundid.experiments.limited_trajectories import fourier_within_limits
    from boundid.studies.registry import make_robot

    text = planar_arm_urdf(tmp_path).read_text().replace(' velocity="6"', ' velocity="0"')  # 0: not given
    (tmp_path / "nolimits.urdf").write_text(text)
    bare = make_robot("urdf", {"source": str(tmp_path / "nolimits.urdf")})
    with pytest.raises(InputError, match="robot.options velocity_limit"):
        fourier_within_limits(bare, np.random.default_rng(0))
    given = make_robot("urdf", {"source": str(tmp_path / "nolimits.urdf"), "velocity_limit": 4.0})
    np.testing.assert_array_equal(given.limits.velocity, [4.0, 4.0])
    np.testing.assert_array_equal(given.limits.acceleration, [20.0, 20.0])
    fourier_within_limits(given, np.random.default_rng(0))


def test_the_study_exports_the_wls_estimate_into_a_urdf_that_reads_back(planar_run, tmp_path):
    """Reference: the exported copy read back by pinocchio (a second parse of the file): its base
    parameters K theta equal the WLS centre; the page names WLS and links the files."""
    from boundid.models import UrdfRobot
    from boundid.report.study_page import write_study_report

    r = planar_run
    page = write_study_report(r, tmp_path / "planar").read_text()
    urdf = tmp_path / "planar" / "export" / f"{r.model.robot.name}_identified.urdf"
    assert urdf.is_file() and (urdf.with_suffix(".yaml")).is_file() and "The WLS centre" in page
    back = UrdfRobot(urdf)
    wls = r.estimates[("WLS", "inverse_dynamic")].center
    np.testing.assert_allclose(r.model.base.base(back.theta_true), wls, rtol=1e-9, atol=1e-12)
