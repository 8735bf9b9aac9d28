"""Recordings as robots write them: a sample period instead of a time column,
positions and torques in two files, declared units, motor-side signals through a transmission.

Independent references: the arrays written (round trips); R, R^-1 and R^T worked out by hand for a
2-joint coupled transmission; FIGAROH's own TX40 conversion (its matrices red_q and red_tau, in
numpy) on the robot's recording shipped in studies/data/tx40;
and one study run on the joint-side recording, whose results.csv the motor-side twin must repeat.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from boundid.cli import main
from boundid.errors import InputError
from boundid.experiments.excitation import RampedMultisine
from boundid.experiments.measurement import TorqueNoise
from boundid.experiments.recording import Recording, read_recording, write_recording
from boundid.experiments.simulation import measure, simulate_open_loop
from boundid.experiments.transmission import Transmission, TransmissionError
from boundid.models import DirectDriveArm
from boundid.studies.config import load_study

H = 0.0025
TX40 = Path(__file__).resolve().parents[1] / "studies" / "data" / "tx40"
TX40_N = [32.0, 32.0, 45.0, -48.0, 45.0, 32.0]
JOINTS = [f"Joint_{j}" for j in range(1, 7)]
# a coupled 2-joint transmission: R = [[10, 0], [3, -5]] (motor 2 turns with 3 q1 - 5 q2)
COUPLED = Transmission((10.0, -5.0), ((2, 1, 3.0),), (0.5, 0.0), (2.0, 0.5))


def _recording(n: int = 200) -> Recording:
    t = np.arange(n) * H
    return Recording(t, np.column_stack([np.sin(12 * t), 0.5 * np.cos(2 * t)]),
                     np.column_stack([4 * np.cos(3 * t), 1.0 - t]))


def _save(columns: dict, path: Path) -> Path:
    df = pd.DataFrame(columns)
    if path.suffix == ".parquet":
        df.to_parquet(path, index=False)
    else:
        df.to_csv(path, index=False, float_format="%.17g")
    return path


def _layout(rec: Recording, layout: str, folder: Path, suffix: str) -> dict:
    """Write ``rec`` in ``layout``; the read_recording arguments that read it back."""
    q, tau, t = rec.q, rec.tau, rec.t
    kwargs = {"time": "t", "q": ["q1", "q2"], "tau": ["tau1", "tau2"]}
    if "motor" in layout:
        q, tau = COUPLED.to_motor(q, tau)
        kwargs["transmission"] = COUPLED
    if "deg" in layout:
        q, t = np.degrees(q), t * 1e3
        kwargs |= {"angle_unit": "deg", "time_unit": "ms"}
    time = {} if "period" in layout else {"t": t}
    if "period" in layout:
        kwargs |= {"time": None, "sample_period_s": H}
    qs, taus = {"q1": q[:, 0], "q2": q[:, 1]}, {"tau1": tau[:, 0], "tau2": tau[:, 1]}
    if "two files" in layout:
        kwargs["path"] = _save(time | qs, folder / f"pos{suffix}")
        kwargs["tau_file"] = _save(taus, folder / f"tau{suffix}")
    else:
        kwargs["path"] = _save(time | qs | taus, folder / f"rec{suffix}")
    return kwargs


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
@pytest.mark.parametrize("layout", ["one file, time", "one file, period", "two files, time", "two files, period",
                                    "one file, deg and ms", "two files, period, motor side",
                                    "two files, period, motor side, deg"])
def test_every_layout_reads_back_what_was_written(layout, suffix, tmp_path):
    """Joint-side radians and seconds read back bit for bit; a unit or transmission conversion to
    rounding (1e-13 relative)."""
    rec = _recording()
    kwargs = _layout(rec, layout, tmp_path, suffix)
    back = read_recording(kwargs.pop("path"), kwargs.pop("time"), kwargs.pop("q"), kwargs.pop("tau"), **kwargs)
    assert back.h == pytest.approx(H, rel=1e-12) and back.t.shape == rec.t.shape
    if "deg" in layout or "motor" in layout:
        np.testing.assert_allclose(back.t, rec.t, rtol=1e-13, atol=1e-16)
        np.testing.assert_allclose(back.q, rec.q, rtol=1e-13, atol=1e-14)
        np.testing.assert_allclose(back.tau, rec.tau, rtol=1e-13, atol=1e-14)
    else:
        for got, want in ((back.t, rec.t), (back.q, rec.q), (back.tau, rec.tau)):
            np.testing.assert_array_equal(got, want)


def test_coupled_transmission_by_hand():
    """R = [[10, 0], [3, -5]], offsets q_0 = [0.5, 0], gains k = [2, 0.5]. Joint angles [1, 2]:
    q_m = R (q - q_0) = R [0.5, 2] = [5, -8.5]; signal [1, 4]: tau_m = [2, 2], tau = R^T tau_m =
    [10 * 2 + 3 * 2, -5 * 2] = [26, -10]."""
    np.testing.assert_array_equal(COUPLED.matrix, [[10.0, 0.0], [3.0, -5.0]])
    q, tau = COUPLED.to_joint(np.array([[5.0, -8.5]]), np.array([[1.0, 4.0]]))
    np.testing.assert_allclose(q, [[1.0, 2.0]], rtol=1e-15)
    np.testing.assert_allclose(tau, [[26.0, -10.0]], rtol=1e-15)
    q_m, signal = COUPLED.to_motor(q, tau)
    np.testing.assert_allclose(q_m, [[5.0, -8.5]], rtol=1e-15)
    np.testing.assert_allclose(signal, [[1.0, 4.0]], rtol=1e-15)


def _tx40_head(folder: Path, rows: int) -> tuple[Path, Path]:
    """The first ``rows`` rows of the TX40's two files (Parquet, as shipped)."""
    out = []
    for name in ("motor_positions.parquet", "motor_torques.parquet"):
        pd.read_parquet(TX40 / name).head(rows).to_parquet(folder / name, index=False)
        out.append(folder / name)
    return out[0], out[1]


def test_tx40_motor_side_against_figaroh(tmp_path):
    """The TX40's recording read as its study file writes it (two files, no time column, 5 kHz,
    motor side, gear ratios of T40X_config.yaml, motor 6 turning with q5 + q6, the MDH offsets of
    joints 2 and 3) equals FIGAROH's conversion in numpy on the first 1,000 rows: q = inv(red_q)
    q_m, q2 -= pi/2, q3 += pi/2, tau = red_tau tau_m with red_q[5, 4] = red_tau[4, 5] = N[5]. Read
    as joint side, the whole recording is refused: its motor angles span 268 rad."""
    yaml = (TX40 / "T40X_config.yaml").read_text(encoding="utf-8")
    assert [float(x) for x in re.search(r"\bN : \[(.*?)\]", yaml).group(1).split(",")] == TX40_N
    pos, curr = _tx40_head(tmp_path, 1000)
    study = tmp_path / "tx40.toml"
    study.write_text(f"""
regressions = ["inverse_dynamic"]
[study]
name = "tx40"
title = "TX40"
[robot]
model = "direct_drive"
[experiment]
source = "measured"
[experiment.measured]
file = "{pos.name}"
tau_file = "{curr.name}"
sample_period_s = 0.0002
[experiment.measured.columns]
q = {JOINTS}
tau = {JOINTS}
[experiment.measured.transmission]
gear_ratios = {TX40_N}
coupling = [[6, 5, 32.0]]
joint_offsets_rad = [0, {-np.pi / 2!r}, {np.pi / 2!r}, 0, 0, 0]
[[estimators]]
method = "wls"
regressions = ["inverse_dynamic"]
""".replace("'", '"'))
    m = load_study(study).experiment.measured
    rec = read_recording(m.file, m.time, m.q, m.tau, tau_file=m.tau_file, sample_period_s=m.sample_period_s,
                         transmission=m.transmission)

    q_m = pd.read_parquet(pos).to_numpy()
    tau_m = pd.read_parquet(curr).to_numpy()
    red_q = np.diag(TX40_N)
    red_q[5, 4] = TX40_N[5]
    q = np.dot(np.linalg.inv(red_q), q_m.T).T
    q[:, 1] += -np.pi / 2
    q[:, 2] += np.pi / 2
    red_tau = np.diag(TX40_N)
    red_tau[4, 5] = TX40_N[5]
    tau = np.dot(red_tau, tau_m.T).T
    assert rec.q.shape == rec.tau.shape == (1000, 6) and rec.h == pytest.approx(2e-4, rel=1e-12)
    np.testing.assert_allclose(rec.q, q, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(rec.tau, tau, rtol=1e-12, atol=1e-12)
    with pytest.raises(InputError, match=r"joint 4 spans 268\.2 rad .* or motor-side\? .*angle_unit = \"deg\", or "
                                         r"give \[experiment\.measured\.transmission\]\.$"):
        read_recording(TX40 / "motor_positions.parquet", None, JOINTS, JOINTS, tau_file=TX40 / "motor_torques.parquet",
                       sample_period_s=0.0002)


MEASURED_STUDY = """
regressions = ["filtered_dynamic"]
[study]
name = "arm"
title = "Direct-drive arm from a recording"
seed = 1
[robot]
model = "direct_drive"
[experiment]
source = "measured"
[experiment.measured]
{measured}
[prior]
center = "zero"
absolute_range = 100.0
[[estimators]]
method = "wls"
regressions = ["filtered_dynamic"]
"""
JOINT_SIDE = 'file = "rec.csv"\n[experiment.measured.columns]\ntime = "t"\nq = ["q1", "q2"]\ntau = ["tau1", "tau2"]'
MOTOR_SIDE = ('file = "pos.csv"\ntau_file = "curr.csv"\nsample_period_s = 0.0025\n'
              '[experiment.measured.columns]\nq = ["m1", "m2"]\ntau = ["i1", "i2"]\n'
              '[experiment.measured.transmission]\ngear_ratios = [10.0, -5.0]\ncoupling = [[2, 1, 3.0]]\n'
              'joint_offsets_rad = [0.5, 0.0]\ntorque_gains = [2.0, 0.5]')


def _motor_files(folder: Path, rec: Recording) -> None:
    q_m, signal = COUPLED.to_motor(rec.q, rec.tau)
    _save({"m1": q_m[:, 0], "m2": q_m[:, 1]}, folder / "pos.csv")
    _save({"i1": signal[:, 0], "i2": signal[:, 1]}, folder / "curr.csv")


def _error_line(folder: Path, measured: str, capsys) -> str:
    """``boundid run`` on the study with this [experiment.measured] body: exit 2, one error line."""
    study = folder / "study.toml"
    study.write_text(MEASURED_STUDY.format(measured=measured))
    capsys.readouterr()
    assert main(["run", str(study), "--out", str(folder / "out"), "--quiet"]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("boundid: error: ") and captured.out == "", captured.err
    return lines[0]


def _rewrite(path: Path, **columns) -> None:
    df = pd.read_csv(path)
    for name, values in columns.items():
        df[name] = values
    _save(dict(df.items()), path)


BAD = [
    ("time column in ms declared s", lambda f: _rewrite(f / "rec.csv", t=np.arange(200) * 2.5), JOINT_SIDE,
     r"sample period 2\.5 s from time column 't': is the time column in ms\? set experiment\.measured\.time_unit = "
     r"\"ms\"\.$"),
    ("time column in s declared ms", lambda f: None, JOINT_SIDE.replace('file = "rec.csv"',
                                                                        'file = "rec.csv"\ntime_unit = "ms"'),
     r"is it in s\? set experiment\.measured\.time_unit = \"s\"\.$"),
    ("sample_period_s in ms", lambda f: None, MOTOR_SIDE.replace("0.0025", "2.5"),
     r"sample period 2\.5 s \(0\.4 Hz\): is it in ms\? experiment\.measured\.sample_period_s is in s"),
    ("degrees declared rad", lambda f: _rewrite(f / "rec.csv", q2=90 * np.sin(np.arange(200) * 0.05)), JOINT_SIDE,
     r"joint 2 spans [\d.]+ rad .* are the angles in degrees, or motor-side\? set experiment\.measured\.angle_unit = "
     r"\"deg\", or give \[experiment\.measured\.transmission\]\.$"),
    ("small motion in degrees declared rad", lambda f: _rewrite(f / "rec.csv", q2=20 * np.sin(np.arange(200) * 0.05)),
     JOINT_SIDE, r"joint 2 moves at [\d.]+ rad/s \([\d.]+ rpm\), faster than any robot joint; are the angles in "
     r"degrees, or motor-side\? set experiment\.measured\.angle_unit = \"deg\""),
    ("motor degrees declared rad", lambda f: _rewrite(f / "pos.csv", m1=np.degrees(pd.read_csv(f / "pos.csv").m1)),
     MOTOR_SIDE, r"joint 1 spans .* are the motor angles in degrees\? set experiment\.measured\.angle_unit = \"deg\""),
    ("constant positions", lambda f: _rewrite(f / "rec.csv", q1=0.25), JOINT_SIDE,
     r"rec\.csv: column 'q1' holds one value \(0\.25\) throughout .* \[experiment\.measured\.columns\]\?$"),
    ("row counts differ", lambda f: _save(dict(pd.read_csv(f / "curr.csv").iloc[:-1].items()), f / "curr.csv"),
     MOTOR_SIDE, r"pos\.csv has 200 rows, the torques file .*curr\.csv 199; experiment\.measured\.file and tau_file "
                 r"must hold the same samples"),
    ("time column and sample_period_s", lambda f: None, JOINT_SIDE.replace('file = "rec.csv"',
                                                                           'file = "rec.csv"\nsample_period_s = 0.1'),
     r"experiment\.measured\.sample_period_s: is given with a time column \(columns\.time\); keep one"),
    ("neither time column nor sample_period_s", lambda f: None, MOTOR_SIDE.replace("sample_period_s = 0.0025\n", ""),
     r"experiment\.measured\.columns\.time: is required unless experiment\.measured\.sample_period_s"),
    ("singular R", lambda f: None, MOTOR_SIDE.replace("[[2, 1, 3.0]]", "[[1, 2, 10.0], [2, 1, -5.0]]"),
     r"experiment\.measured\.transmission\.coupling: gives a singular R \(condition number .*\)"),
    ("zero gear ratio", lambda f: None, MOTOR_SIDE.replace("[10.0, -5.0]", "[10.0, 0]").replace(
        "coupling = [[2, 1, 3.0]]\n", ""), r"experiment\.measured\.transmission\.gear_ratios: gives a singular R"),
    ("three gear ratios, two joints", lambda f: None, MOTOR_SIDE.replace("[10.0, -5.0]", "[10.0, -5.0, 2.0]"),
     r"experiment\.measured\.transmission\.gear_ratios: has 3 number\(s\), columns\.q names 2 joints"),
    ("one torque gain, two joints", lambda f: None, MOTOR_SIDE.replace("[2.0, 0.5]", "[2.0]"),
     r"experiment\.measured\.transmission\.torque_gains: has 1 number\(s\), gear_ratios 2"),
    ("NaN in a gain", lambda f: None, MOTOR_SIDE.replace("[2.0, 0.5]", "[2.0, nan]"),
     r"experiment\.measured\.transmission\.torque_gains: entry 2 is nan: every entry must be a finite number\.$"),
    ("zero gain", lambda f: None, MOTOR_SIDE.replace("[2.0, 0.5]", "[0, 0.5]"),
     r"experiment\.measured\.transmission\.torque_gains: entry 1 is 0"),
    ("inf in an offset", lambda f: None, MOTOR_SIDE.replace("[0.5, 0.0]", "[inf, 0.0]"),
     r"experiment\.measured\.transmission\.joint_offsets_rad: entry 1 is inf"),
    ("coupling joint out of range", lambda f: None, MOTOR_SIDE.replace("[[2, 1, 3.0]]", "[[2, 3, 3.0]]"),
     r"transmission\.coupling: entry \[2, 3, 3\.0\] must be \[motor, joint, ratio\] with motor and joint integers "
     r"in 1\.\.2\.$"),
    ("coupling on the diagonal", lambda f: None, MOTOR_SIDE.replace("[[2, 1, 3.0]]", "[[2, 2, 3.0]]"),
     r"transmission\.coupling: entry \[2, 2, 3\.0\] is on the diagonal, which gear_ratios sets"),
    ("coupling ratio nan", lambda f: None, MOTOR_SIDE.replace("[[2, 1, 3.0]]", "[[2, 1, nan]]"),
     r"transmission\.coupling: entry \[2, 1, nan\]: the ratio must be a finite number\.$"),
    ("no position column", lambda f: None, JOINT_SIDE.replace('q = ["q1", "q2"]\ntau = ["tau1", "tau2"]',
                                                              "q = []\ntau = []"),
     r"experiment\.measured\.columns\.q: names no column: give one position column per joint\.$"),
    ("unknown transmission key", lambda f: None, MOTOR_SIDE + "\noffsets = [0.0, 0.0]",
     r"experiment\.measured\.transmission\.offsets: unknown key"),
]


@pytest.mark.parametrize("prepare, measured, match", [c[1:] for c in BAD], ids=[c[0] for c in BAD])
def test_bad_recording_is_one_line_naming_the_key(prepare, measured, match, tmp_path, capsys):
    """Each mistake ends ``boundid run`` with exit 2 and one line that names the key (or column) and the fix."""
    rec = _recording()
    write_recording(rec, tmp_path / "rec.csv")
    _motor_files(tmp_path, rec)
    prepare(tmp_path)
    line = _error_line(tmp_path, measured, capsys)
    assert re.search(match, line), line


def test_transmission_refuses_bad_entries_in_python():
    """The same checks without a study file: TransmissionError (an InputError) naming the field."""
    for kwargs, key in (({"gear_ratios": ()}, "gear_ratios"), ({"gear_ratios": (1.0, float("nan"))}, "gear_ratios"),
                        ({"gear_ratios": (1.0, 2.0), "coupling": ((1, 2, 1.0), (1, 2, 2.0))}, "coupling"),
                        ({"gear_ratios": (1.0, 1.0), "joint_offsets_rad": (0.0,)}, "joint_offsets_rad")):
        with pytest.raises(TransmissionError, match=rf"^transmission\.{key}: ") as err:
            Transmission(**kwargs)
        assert err.value.key == key and "\n" not in str(err.value)


def test_motor_side_study_gives_the_joint_side_results(tmp_path):
    """A boundid simulation (direct-drive arm, 2 s, uniform torque noise) written as the joint-side
    recording, and as a robot writes it: motor angles in degrees and motor signals in two files, no
    time column, through the coupled transmission. ``boundid run`` on both gives the same
    results.csv, to rounding. The angles are not quantised: the models' sign(qd) tells an encoder
    count that did not change (qd = 0) from one ulp of the coupled conversion's rounding."""
    traj = simulate_open_loop(DirectDriveArm(), RampedMultisine.direct_drive_paper(), 2.0, H)
    meas = measure(traj, None, TorqueNoise("uniform", 0.5), np.random.default_rng(5))
    estimators = ('\n[[estimators]]\nmethod = "obe"\nregressions = ["filtered_dynamic"]\ne_max = 6.0\n'
                  '[exact]\nregression = "filtered_dynamic"\ne_max = 6.0\n')
    tables = []
    for side, measured in (("joint", JOINT_SIDE), ("motor", MOTOR_SIDE.replace(
            'tau_file = "curr.csv"', 'tau_file = "curr.csv"\nangle_unit = "deg"'))):
        folder = tmp_path / side
        folder.mkdir()
        if side == "joint":
            write_recording(Recording(meas.t, meas.q, meas.tau), folder / "rec.csv")
        else:
            q_m, signal = COUPLED.to_motor(meas.q, meas.tau)
            _save({"m1": np.degrees(q_m[:, 0]), "m2": np.degrees(q_m[:, 1])}, folder / "pos.csv")
            _save({"i1": signal[:, 0], "i2": signal[:, 1]}, folder / "curr.csv")
        study = folder / "arm.toml"
        study.write_text(MEASURED_STUDY.format(measured=measured) + estimators)
        assert main(["run", str(study), "--out", str(folder / "out"), "--quiet"]) == 0
        tables.append(pd.read_csv(folder / "out" / "arm" / "results.csv"))
    joint, motor = tables
    assert list(joint.columns) == list(motor.columns) and len(joint) == len(motor) > 0
    assert {"WLS", "OBE", "LP exact"} <= set(joint.estimator)
    numbers = joint.select_dtypes("number").columns
    pd.testing.assert_frame_equal(joint.drop(columns=numbers), motor.drop(columns=numbers))
    np.testing.assert_allclose(motor[numbers].to_numpy(float), joint[numbers].to_numpy(float), rtol=1e-7, atol=1e-9)
