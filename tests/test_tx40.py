"""The Staubli TX40's real recording as its study file reads it (studies/tx40_real.toml): the
inverse-dynamic regression rebuilt from the committed recording, fitted by WLS, and checked by an
independent route: pinocchio's RNEA on the URDF with the WLS-identified inertias (a standard vector
of the base estimate), plus the drive inertias, friction, offsets and the coupled wrist's motor 6
written out here, at angles filtered and differentiated here and filtered like the torque,
reproduces the measured torques of the regression's rows to the WLS residual. The transmission
itself (FIGAROH's red_q, red_tau) is checked in tests/test_measured_recording.py on the same files;
here only that the study writes the same one.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy.signal import butter, sosfiltfilt

from boundid.estimators.least_squares import wls
from boundid.report.tables import estimate_summary
from boundid.studies.config import load_study
from boundid.studies.data import acquire
from boundid.studies.registry import make_robot
from boundid.studies.regressions import build_regressions
from test_measured_recording import TX40_N

STUDY = Path(__file__).resolve().parents[1] / "studies" / "tx40_real.toml"
# T40X_config.yaml's published values, boundid's names (FIGAROH's Ia5, Ia6, fv5, fv6 less Iam6, fvm6)
PUBLISHED = {"fv1": 8.05, "fv2": 5.53, "fv3": 1.97, "fv4": 1.11, "fv5": 1.86 - 0.616, "fv6": 0.65 - 0.616,
             "fc1": 7.14, "fc2": 8.26, "fc3": 6.34, "fc4": 2.48, "fc5": 3.03, "fc6": 0.282,
             "Ia3": 9.88e-2, "Ia4": 3.13e-2, "Ia5": 4.68e-2 - 9.64e-3, "Ia6": 1.05e-2 - 9.64e-3,
             "Iam6": 9.64e-3, "fvm6": 0.616, "fsm6": 1.95,
             "off1": 0.392, "off2": 1.37, "off3": 0.326, "off4": -0.102, "off5": -0.0288, "off6": 0.127}


@pytest.fixture(scope="module")
def tx40():
    cfg = load_study(STUDY)
    m = cfg.experiment.measured
    cfg = replace(cfg, experiment=replace(cfg.experiment, measured=replace(m, holdout_fraction=0.0)))  # all of it
    model = make_robot(cfg.robot, cfg.robot_options)
    rec = acquire(cfg, model, np.random.default_rng(cfg.seed)).recording
    reg = build_regressions(model, rec, cfg.preprocessing, ("inverse_dynamic",))["inverse_dynamic"]
    est = wls(reg.W, reg.y, reg.joint, names=model.param_names)
    return cfg, model, rec, reg, est


def test_study_reads_the_recording_through_figaroh_s_transmission(tx40):
    """The study's transmission is the one tests/test_measured_recording.py checks against FIGAROH's
    matrices; its reference values are the published ones, by the model's own parameter names."""
    cfg, model, rec, _, _ = tx40
    tr = cfg.experiment.measured.transmission
    assert list(tr.gear_ratios) == TX40_N and [tuple(c) for c in tr.coupling] == [(6, 5, 32.0)]
    np.testing.assert_allclose(tr.joint_offsets_rad, [0, -np.pi / 2, np.pi / 2, 0, 0, 0], rtol=0, atol=1e-15)
    assert rec.q.shape == (45000, 6) and rec.h == pytest.approx(2e-4, rel=1e-12)
    ref = cfg.paper["reference_values"]
    assert set(ref) <= set(model.param_names)
    assert ref == pytest.approx(PUBLISHED, rel=1e-12)


def _rnea_torque(model, rec, reg, beta) -> np.ndarray:
    """Torques of the regression's rows (N,) by pinocchio's RNEA on the URDF with the standard vector of
    beta, plus Ia qdd + fv qd + fc sign(qd) + off and motor 6 (r = e5 + e6): r (Iam6 r.qdd + fvm6 r.qd +
    fsm6 sign(r.qd)), at every sample of the angles low-passed (zero-phase Butterworth of order 4 at the
    study's cut-off) and differentiated by central differences here; then low-passed like the measured
    torque (zero-phase, order 8, the decimation cut-off: parallel filtering) and read at the rows."""
    n = model.n_joints
    theta = model.standard(beta)
    value = dict(zip(model.robot.param_names, theta, strict=True))
    urdf = pin.buildModelFromUrdf(str(model.robot.urdf_path))
    assert urdf.nv == n
    for j in range(1, n + 1):
        urdf.inertias[j] = pin.Inertia.FromDynamicParameters(np.asarray(theta[10 * (j - 1):10 * j]))
    data = urdf.createData()
    fs = 1.0 / rec.h
    qf = sosfiltfilt(butter(4, reg.info["cutoff_hz"], fs=fs, output="sos"), rec.q, axis=0)
    qd = np.gradient(qf, rec.h, axis=0)
    qdd = np.gradient(qd, rec.h, axis=0)
    tau = np.array([pin.rnea(urdf, data, qf[k], qd[k], qdd[k]) for k in range(qf.shape[0])])
    per = {key: np.array([value.get(f"{key}{j}", 0.0) for j in range(1, n + 1)]) for key in ("Ia", "fv", "fc", "off")}
    r = np.zeros(n)
    r[4] = r[5] = 1.0
    w = qd @ r
    tau += per["Ia"] * qdd + per["fv"] * qd + per["fc"] * np.sign(qd) + per["off"]
    tau += np.outer(value["Iam6"] * (qdd @ r) + value["fvm6"] * w + value["fsm6"] * np.sign(w), r)
    tau = sosfiltfilt(butter(8, reg.info["decimation_cutoff_hz"], fs=fs, output="sos"), tau, axis=0)
    return tau[np.rint(reg.t * fs).astype(int), reg.joint]


def test_rnea_on_the_wls_estimate_reproduces_the_measured_torques(tx40):
    """Per joint, the RMS of measured minus RNEA torque equals the WLS residual's RMS to 0.1 %, and RNEA
    and the regression (W beta) differ by under 1e-3 of it (measured: ~5e-6): the same model by two
    routes (pinocchio's joint torque regressor with the study's filters and base parameters, and RNEA on
    a standard vector with the friction, drive and coupling terms and filters written here)."""
    _, model, rec, reg, est = tx40
    beta = est.center
    fit = reg.W @ beta
    rnea = _rnea_torque(model, rec, reg, beta)
    for j in range(model.n_joints):
        rows = reg.joint == j
        resid = np.sqrt(np.mean((reg.y[rows] - fit[rows]) ** 2))
        measured = np.sqrt(np.mean((reg.y[rows] - rnea[rows]) ** 2))
        routes = np.sqrt(np.mean((fit[rows] - rnea[rows]) ** 2))
        assert measured == pytest.approx(resid, rel=1e-3), f"joint {j + 1}"
        assert routes <= 1e-3 * resid, f"joint {j + 1}"


def test_wls_finds_the_published_wrist_coupling(tx40):
    """The coupled wrist's motor 6 (rotor inertia and viscous friction, joint-side scaled) as WLS
    identifies it agrees with FIGAROH's published Iam6, fvm6 to 10 %, and the fit explains the torques:
    its residual is under 10 % of each joint's RMS torque."""
    _, model, _, reg, est = tx40
    got = dict(zip(model.param_names, est.center, strict=True))
    for name in ("Iam6", "fvm6"):
        assert got[name] == pytest.approx(PUBLISHED[name], rel=0.1), name
    resid = reg.y - reg.W @ est.center
    for j in range(model.n_joints):
        rows = reg.joint == j
        assert np.sqrt(np.mean(resid[rows] ** 2)) < 0.1 * np.sqrt(np.mean(reg.y[rows] ** 2)), f"joint {j + 1}"


def test_page_counts_the_listed_reference_values(tx40):
    """With reference values of some parameters only (NaN for the others), the page's estimate table
    counts the listed ones inside each interval instead of testing a whole vector that has NaNs."""
    cfg, model, _, _, est = tx40
    ref = np.array([cfg.paper["reference_values"].get(n, np.nan) for n in model.param_names])
    lo, hi = est.intervals
    listed = np.isfinite(ref)
    inside = int(np.sum((lo[listed] <= ref[listed]) & (ref[listed] <= hi[listed])))
    row = estimate_summary({"WLS": est}, ref).loc["WLS"]
    assert row["truth in set"] == row["truth in intervals"] == f"{inside} of {int(listed.sum())} intervals"


def test_published_tables_map_onto_the_base_parameters(tx40):
    """FIGAROH's 60 base parameters (its definitions, in standard parameters) are all combinations of
    this model's base parameters, 57 of them one parameter each (its fv5, fv6 and Ia5 include the coupled
    motor's); the configuration's values, read through the study file's names, give the reference values
    the study lists by this model's names (fv5 = 1.86 - 0.616 ...), a second route to the same numbers."""
    from boundid.studies.published import functional

    cfg, model, _, _, _ = tx40
    tables = {t.label: t for t in cfg.published}
    figaroh = tables["FIGAROH OLS"]
    cs = [functional(figaroh.names.get(n, n), model) for n, _ in figaroh.entries]
    assert len(cs) == 60 and all(c is not None for c in cs)
    assert sum(int(np.sum(np.abs(c) > 1e-9) == 1) for c in cs) == 57
    config = tables["T40X_config"]
    ref = cfg.paper["reference_values"]
    beta = np.array([ref.get(n, 0.0) for n in model.param_names])
    checked = 0
    for name, value in config.entries:
        c = functional(config.names.get(name, name), model)
        if c is None:
            assert name in ("Ia1", "Ia2")  # inside Izz1R, Izz2R
            continue
        assert c @ beta == pytest.approx(value, rel=1e-9, abs=1e-12), name
        checked += 1
    assert checked == 25


def test_the_wls_projection_exports_files_pinocchio_and_mujoco_load(tx40, tmp_path):
    """The TX40's WLS centre is not physically consistent; its projection onto the physical set (in the
    WLS covariance metric) is exported. Clarabel cannot place the standard vector nearest the URDF inside
    the thin set the projection's active links leave (link 4 came out 1e-5 kg m^2 past its triangle
    inequality), so the projection's own standard vector is written: both files load, every link a rigid
    body, and its base parameters are the projection's."""
    from test_export_loads import assert_loads, exported_standard

    _, model, _, _, est = tx40
    paths = model.export_identified(est.center, tmp_path, estimate="the WLS centre", cov=est.statistics.cov)
    x = exported_standard(paths)
    assert_loads(model.robot, paths, x)
    text = paths[0].read_text()
    assert "projection" in text and "the projection's own standard parameters" in text
