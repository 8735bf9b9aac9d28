"""Study files: the shipped ones parse; mistakes are reported with file, key and allowed values."""

from pathlib import Path

import numpy as np
import pytest

from boundid.errors import InputError, StudyError
from boundid.experiments.recording import Recording, read_recording, write_recording
from boundid.studies.config import load_study

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


def test_obe_bound_must_match_the_exact_polytope(tmp_path):
    """An OBE certified against a polytope of another bound would be a meaningless comparison."""
    text = MINIMAL + ('[[estimators]]\nmethod = "obe"\nregressions = ["inverse_dynamic"]\ne_max = 2.0\n'
                      '[exact]\nregression = "inverse_dynamic"\ne_max = 3.0\n')
    with pytest.raises(StudyError, match=r"exact\.e_max: is 3.0 but estimator 'OBE'"):
        load_study(_write(tmp_path, text))
