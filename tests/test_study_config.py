"""Study files: the shipped ones parse; mistakes are reported with file, key and allowed values."""

import math
from pathlib import Path

import numpy as np
import pytest

from boundid.errors import InputError, StudyError
from boundid.estimators.registry import METHODS
from boundid.experiments.recording import Recording, read_recording, write_recording
from boundid.studies.config import REGRESSIONS, load_study
from boundid.studies.registry import make_robot
from boundid.studies.schema import Section

STUDIES = sorted((Path(__file__).parents[1] / "studies").glob("*.toml"))

MINIMAL = """
regressions = ["inverse_dynamic"]
[study]
name = "s"
title = "t"
[robot]
model = "direct_drive"
[experiment]
source = "simulate"
[[estimators]]
method = "wls"
regressions = ["inverse_dynamic"]
"""


@pytest.mark.parametrize("path", STUDIES, ids=lambda p: p.name)
def test_shipped_studies_parse(path):
    cfg = load_study(path)
    assert cfg.name == path.stem
    assert cfg.estimators


def _write(tmp_path, text):
    p = tmp_path / "study.toml"
    p.write_text(text)
    return p


def test_minimal_study_parses(tmp_path):
    cfg = load_study(_write(tmp_path, MINIMAL))
    assert cfg.estimators[0].method == "wls" and cfg.experiment.duration_s == 10.0


@pytest.mark.parametrize(
    "edit, match",
    [
        (('model = "direct_drive"', 'model = "puma"'), r"robot\.model: must be one of .*'direct_drive'"),
        (('method = "wls"', 'method = "lasso"'), r"estimators\[0\]\.method: must be one of"),
        (('source = "simulate"', 'source = "simulate"\nduration_s = -1'), r"experiment\.duration_s: must be > 0"),
        (('source = "simulate"', 'source = "simulate"\nduraton_s = 5'), r"experiment\.duraton_s: unknown key"),
        (('name = "s"\n', ""), r"study\.name: is required"),
        (('regressions = ["inverse_dynamic"]\n[study]', 'regressions = ["energy"]\n[study]'), r"regressions: entries"),
    ],
)
def test_mistakes_name_file_and_key(tmp_path, edit, match):
    path = _write(tmp_path, MINIMAL.replace(*edit))
    with pytest.raises(StudyError, match=match) as err:
        load_study(path)
    assert str(path) in str(err.value)


def test_not_toml_and_missing_file(tmp_path):
    with pytest.raises(StudyError, match="not valid TOML"):
        load_study(_write(tmp_path, "[study\nname="))
    with pytest.raises(StudyError, match="no such study file"):
        load_study(tmp_path / "nope.toml")


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_recording_round_trip(tmp_path, suffix):
    """Written and read back bit for bit (CSV with 17 significant digits, Parquet binary)."""
    t = np.arange(50) * 0.0025
    rec = Recording(t, np.column_stack([np.sin(t), np.cos(t)]), np.column_stack([t, -t]))
    path = write_recording(rec, tmp_path / f"rec{suffix}")
    back = read_recording(path, "t", ["q1", "q2"], ["tau1", "tau2"])
    np.testing.assert_array_equal(back.q, rec.q)
    np.testing.assert_array_equal(back.tau, rec.tau)
    assert back.h == pytest.approx(0.0025)


def test_recording_errors_name_the_problem(tmp_path):
    t = np.arange(10) * 0.01
    rec = Recording(t, t[:, None], t[:, None])
    path = write_recording(rec, tmp_path / "r.csv")
    with pytest.raises(InputError, match=r"no column\(s\) \['q9'\]"):
        read_recording(path, "t", ["q9"], ["tau1"])
    bad_t = t.copy()
    bad_t[5] += 0.004
    write_recording(Recording(bad_t, t[:, None], t[:, None]), path)
    with pytest.raises(InputError, match="not uniformly spaced"):
        read_recording(path, "t", ["q1"], ["tau1"])


@pytest.mark.parametrize("method", [m.name for m in METHODS.values() if m.needs_bound])
def test_bound_must_match_the_exact_polytope(tmp_path, method):
    """A guaranteed set certified against a polytope of another bound would be a meaningless
    comparison: the rule holds for every registered method that needs e_max, which is required."""
    table = f'[[estimators]]\nmethod = "{method}"\nregressions = ["inverse_dynamic"]\n'
    text = MINIMAL + table + 'e_max = 2.0\n[exact]\nregression = "inverse_dynamic"\ne_max = 3.0\n'
    with pytest.raises(StudyError, match=rf"exact\.e_max: is 3.0 but estimator '{method.upper()}'"):
        load_study(_write(tmp_path, text))
    with pytest.raises(StudyError, match=rf"estimators\[1\]\.e_max: is required for a {method} estimator"):
        load_study(_write(tmp_path, MINIMAL + table))


def test_options_tables_are_typed_by_their_defaults(tmp_path):
    """robot.options and experiment.options take the type of each option's default (a float
    default accepts an integer, a tuple default a list of that length, returned as a tuple);
    values the model refuses are refused when the study is read, naming robot.options."""
    toy = MINIMAL.replace('model = "direct_drive"', 'model = "linear_toy"\noptions = { m = 2, l = 0.25 }')
    cfg = load_study(_write(tmp_path, toy))
    assert cfg.robot_options == {"m": 2.0, "l": 0.25} and isinstance(cfg.robot_options["m"], float)
    h4 = MINIMAL.replace('model = "direct_drive"', 'model = "h4"\noptions = { home = [0, 0, -0.7, 0] }')
    assert load_study(_write(tmp_path, h4)).robot_options == {"home": (0.0, 0.0, -0.7, 0.0)}
    for options, match in [("{ home = [0, 0, -0.7] }", r"robot\.options\.home: must be a list of 4 numbers"),
                           ('{ axes = ["+y", "-y", "+x", 4] }', r"robot\.options\.axes: must be a list of 4 strings"),
                           ("{ L = -0.3 }", r"robot\.options for h4: H4Geometry\.L must be a positive length")]:
        text = MINIMAL.replace('model = "direct_drive"', f'model = "h4"\noptions = {options}')
        with pytest.raises(StudyError, match=match):
            load_study(_write(tmp_path, text))
    with pytest.raises(StudyError, match=r"robot\.options for direct_drive: physical parameters must be .* >= 0"):
        load_study(_write(tmp_path, MINIMAL.replace('model = "direct_drive"',
                                                    'model = "direct_drive"\noptions = { m1 = -1.0 }')))


def test_estimator_options_are_checked_when_read(tmp_path):
    """Ranges the estimators would refuse only when run are refused when the study is read."""
    for option, match in [("forgetting = 1.5", r"forgetting: must be > 0, <= 1, got 1\.5\.$"),
                          ("shape0 = 0", r"shape0: must be >= 1e-150, <= 1e\+150, got 0\.0\.$"),
                          ("shape0 = 1e200", r"shape0: must be >= 1e-150, <= 1e\+150, got 1e\+200\.$"),
                          ("center0 = -inf", r"center0: must be a finite number, got -inf\.$"),
                          ('shape0 = "big"', r"shape0: must be a number"),
                          ("P0 = 10.0", r"P0: was renamed 'shape0'.*write shape0 = 10.0"),
                          ("theta0 = 0.0", r"theta0: was renamed 'center0'"),
                          ("bogus = 1", r"bogus: unknown key; the rls estimator takes .*center0 \(number, "
                                        r"default 0.0\), shape0 \(number >= 1e-150, <= 1e\+150, default 1000.0\), "
                                        r"forgetting")]:
        text = MINIMAL + f'[[estimators]]\nmethod = "rls"\nregressions = ["inverse_dynamic"]\n{option}\n'
        with pytest.raises(StudyError, match=r"estimators\[1\]\." + match):
            load_study(_write(tmp_path, text))
    text = MINIMAL.replace('method = "wls"', 'method = "wls"\nlevel = 1.0')
    with pytest.raises(StudyError, match=r"level: must be > 0, < 1, got 1\.0"):
        load_study(_write(tmp_path, text))
    text = MINIMAL.replace('method = "wls"', 'method = "zonotope"\ne_max = 1.0\norder = 1')
    with pytest.raises(StudyError, match=r"order: must be >= 2, got 1\.$"):
        load_study(_write(tmp_path, text))


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_numbers_must_be_finite(value):
    """NaN passes every comparison with a bound (nan < 0 and nan > 1 are both False), so a range
    alone lets it through: Section.float refuses NaN and +-inf, with or without a range, naming
    the file, the key and the range; an options table (robot, experiment) refuses them too, in a
    number or in a list of numbers."""
    sec = Section({"x": value, "y": value}, "t", "f.toml")
    with pytest.raises(StudyError, match=rf"^f\.toml: t\.x: must be a finite number > 0, <= 1, got {value}\.$"):
        sec.float("x", lo=0.0, strict_lo=True, hi=1.0)
    with pytest.raises(StudyError, match=rf"^f\.toml: t\.y: must be a finite number, got {value}\.$"):
        sec.float("y")
    for known, given in [({"x": 1.0}, value), ({"x": (0.0, 0.0)}, [0.0, value])]:
        table = Section({"options": {"x": given}}, "robot", "f.toml")
        with pytest.raises(StudyError, match=r"robot\.options\.x: must be finite, not NaN or inf"):
            table.options("options", known, "robot 'toy'")


def test_integers_are_checked_against_both_bounds():
    sec = Section({"n": 11}, "t", "f.toml")
    with pytest.raises(StudyError, match=r"^f\.toml: t\.n: must be >= 1, <= 10, got 11\.$"):
        sec.int("n", lo=1, hi=10)
    assert sec.int("n", lo=1) == 11


def test_prior_box_must_hold_the_simulated_truth(tmp_path):
    """Reference: the H4 model's true Imot1 = 0.0199 kg m^2 and its a-priori value 0.012: a box of
    +-50 % about the a-priori values, [0.006, 0.018], excludes it. The study is refused naming
    [prior], the parameter, its truth and box, and the keys to change; +-150 % (the H4 study's) holds
    every truth."""
    h4 = MINIMAL.replace('model = "direct_drive"', 'model = "h4"') + '[prior]\ncenter = "model"\n'
    with pytest.raises(StudyError, match=r"\[prior\]: the prior box excludes the true parameters of the simulated "
                                         r"robot \(Imot1 = 0\.0199 kg m\^2 outside \[0\.006, 0\.018\].*raise "
                                         r"prior\.relative_range \(now 0\.5; .*prior\.center \(now 'model'\)"):
        load_study(_write(tmp_path, h4 + "relative_range = 0.5\n"))
    assert load_study(_write(tmp_path, h4 + "relative_range = 1.5\n")).prior.relative_range == 1.5


def test_seed_must_be_a_non_negative_integer(tmp_path):
    cfg = load_study(_write(tmp_path, MINIMAL))
    assert cfg.with_seed(np.int64(5)).seed == 5
    for bad in (-1, 1.5, True):
        with pytest.raises(InputError, match="seed must be an integer >= 0"):
            cfg.with_seed(bad)


@pytest.mark.parametrize("h, decimation, cutoff", [(0.0025, 10, None), (0.0025, 1, 10.0), (0.0025, 1, None),
                                                     (0.001, 10, 20.0), (0.0025, 1, 150.0)])
def test_minimum_duration_matches_the_regression_builders(h, decimation, cutoff):
    """Reference: the row counts of the builders themselves on a recording of that length. Just
    above the minimum every model has >= p rows; two (decimated) samples below it the inverse
    dynamic model has fewer than p."""
    from boundid.models import DirectDriveArm
    from boundid.studies.config import PreprocessingConfig
    from boundid.studies.runner import build_regressions
    from boundid.studies.sizing import minimum_duration

    model, pp = DirectDriveArm(), PreprocessingConfig(lowpass_cutoff_hz=cutoff, decimation=decimation)
    need = minimum_duration(h, 2, model.p, REGRESSIONS, cutoff, decimation)

    def rows(duration, name):
        t = np.arange(int(np.floor(duration / h + 1e-9)) + 1) * h
        q = np.column_stack([np.sin(3 * t), np.cos(2 * t)])
        return build_regressions(model, Recording(t, q, q.copy()), pp, (name,))[name].n_rows

    for name, d in need.items():
        assert rows(d + h * decimation, name) >= model.p, name
    assert rows(need["inverse_dynamic"] - 2 * h * decimation, "inverse_dynamic") < model.p


def test_experiment_too_short_or_cutoff_too_high_is_refused_when_read(tmp_path):
    """0.01 s (the filtfilt padlen case) and a low-pass cut-off above the decimated Nyquist
    frequency are refused when the study is read, with the minimum or the limit."""
    with pytest.raises(StudyError, match=r"duration_s is 0\.01 s: too short for the inverse_dynamic model, which "
                                         r"needs more than 0\.05 s"):
        load_study(_write(tmp_path, MINIMAL.replace('source = "simulate"', 'source = "simulate"\nduration_s = 0.01')))
    text = MINIMAL + "[preprocessing]\ndecimation = 4\nlowpass_cutoff_hz = 60.0\n"
    with pytest.raises(StudyError, match=r"preprocessing\.lowpass_cutoff_hz: 60 Hz must be below 50 Hz"):
        load_study(_write(tmp_path, text))


def test_recording_cells_are_named_by_column_and_row(tmp_path):
    t = np.arange(10) * 0.01
    path = write_recording(Recording(t, t[:, None], t[:, None]), tmp_path / "r.csv")
    lines = path.read_text().splitlines()
    lines[3] = lines[3].split(",")[0] + ",,0.02"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"1 empty or infinite value\(s\), the first in column 'q1' at data row 3"):
        read_recording(path, "t", ["q1"], ["tau1"])
    lines[3] = lines[3].split(",")[0] + ",1.0e,0.02"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"column 'q1', data row 3: '1.0e' is not a number"):
        read_recording(path, "t", ["q1"], ["tau1"])


def test_a_study_names_any_urdf_robot(tmp_path):
    """Reference: example-robot-data's panda URDF (7 arm joints, 10 inertial parameters per link
    plus viscous and Coulomb friction per joint), identified by default in its base parameters
    (independent count: the rank of the standard regressor over random states); a source that is
    neither a name nor a file is refused naming the example robots."""
    text = MINIMAL.replace('model = "direct_drive"', 'model = "urdf"\noptions = { source = "panda" }')
    text = text.replace('source = "simulate"', 'source = "simulate"\nduration_s = 30.0')
    cfg = load_study(_write(tmp_path, text))
    model = make_robot(cfg.robot, cfg.robot_options)
    assert model.n_joints == 7 and model.robot.p == 7 * 12
    rng = np.random.default_rng(0)
    lim = model.limits
    W = model.robot.regressor(lim.sample_positions(rng, 60), rng.uniform(-1, 1, (60, 7)),
                              rng.uniform(-1, 1, (60, 7))).reshape(-1, model.robot.p)
    assert model.p == np.linalg.matrix_rank(W) < model.robot.p
    standard = make_robot(cfg.robot, {**cfg.robot_options, "parameters": "standard"})
    assert standard.p == 7 * 12
    with pytest.raises(StudyError, match=r"robot.options for urdf: unknown robot 'nao'.*'panda'"):
        load_study(_write(tmp_path, text.replace('"panda"', '"nao"')))
