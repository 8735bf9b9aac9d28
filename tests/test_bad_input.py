"""Bad input ends in one line and exit 2, never a traceback; report folders stay in their place and
are never half-written; a run that fails after computing still writes its page.

Independent references: the cases of the bad-input lists "Output escapes its folder" and "Raw
tracebacks for ordinary bad input", and the numbers that were once not checked when
the file was read (each must print exactly one ``boundid: error:`` line, exit 2 within 10 s, print
nothing on stdout and compute nothing -- the simulation and the regression builder are replaced by
ones that fail the test); every number the parser reads, each as NaN and +-inf; the bytes of the
previous report on disk before a SIGKILL mid-write; the failures the run itself raised.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import signal
import subprocess
import sys
import time
import typing
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from boundid.cli import main
from boundid.errors import InputError, ResourceError, SolverError, StudyError
from boundid.estimators.kalman import KalmanEstimator
from boundid.estimators.obe import OBE
from boundid.estimators.registry import METHODS
from boundid.estimators.rls import RLS
from boundid.experiments.recording import Recording, write_recording
from boundid.report import output
from boundid.sets import Polytope
from boundid.studies import data, runner
from boundid.studies.config import load_study

WLS_ONLY = """
regressions = ["filtered_dynamic"]

[study]
name = "dd"
title = "Direct-drive arm, 1 s"
seed = 3

[robot]
model = "direct_drive"

[experiment]
source = "simulate"
duration_s = 1.0

[experiment.noise]
torque = { kind = "uniform", level = 0.5 }

[prior]
absolute_range = 100.0

[[estimators]]
method = "wls"
regressions = ["filtered_dynamic"]
"""
BASE = WLS_ONLY + """
[[estimators]]
method = "rls"
regressions = ["filtered_dynamic"]
"""

SIMULATED = 'source = "simulate"\nduration_s = 1.0\n\n[experiment.noise]\ntorque = { kind = "uniform", level = 0.5 }\n'
MEASURED = ('source = "measured"\n[experiment.measured]\nfile = "{file}"\n[experiment.measured.columns]\n'
            'time = "t"\nq = ["q1", "q2"]\ntau = ["tau1", "tau2"]\n')

H4 = """
regressions = ["inverse_dynamic"]
[study]
name = "h4"
title = "H4"
[robot]
model = "h4"
[experiment]
source = "simulate"
control = "closed_loop"
duration_s = 4.0
sample_period_s = 0.001
validation_duration_s = 2.0
options = { fast_period = 1.0, blah = 3 }
[[estimators]]
method = "wls"
regressions = ["inverse_dynamic"]
"""

SCENARIO = '\n[[campaign.scenarios]]\nname = "a"\n{}\n'


def _study(tmp: Path, text: str, name: str = "study.toml") -> str:
    path = tmp / name
    path.write_text(text, encoding="utf-8")
    return str(path)


def _edit(tmp: Path, old: str, new: str, name: str = "study.toml") -> str:
    assert old in BASE
    return _study(tmp, BASE.replace(old, new), name)


def _recording(tmp: Path, name: str = "rec.csv") -> Path:
    t = np.arange(801) * 0.0025
    return write_recording(Recording(t, np.column_stack([np.sin(t), np.cos(t)]), np.column_stack([t, -t])),
                           tmp / name)


def _measured(tmp: Path, file: Path) -> str:
    return _edit(tmp, SIMULATED, MEASURED.format(file=file.name))


def _csv_with_text_cell(tmp: Path) -> Path:
    path = _recording(tmp)
    lines = path.read_text().splitlines()
    lines[5] = "0.0125,abc,1,2,3"
    path.write_text("\n".join(lines) + "\n")
    return path


def _truncated_parquet(tmp: Path) -> Path:
    path = _recording(tmp, "rec.parquet")
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    return path


def _file(tmp: Path, name: str, content: str | bytes) -> Path:
    path = tmp / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    return path


def _latin1_study(tmp: Path) -> str:
    return str(_file(tmp, "s.toml", BASE.replace("Direct-drive", "Direct-drive \xe9").encode("latin-1")))


def _regression_file(tmp: Path, kind: str) -> str:
    df = pd.DataFrame({"w1": [1.0, 0.0], "w2": [0.0, 1.0], "y": [0.0, 0.0], "e_max": [1.0, 1.0]})
    if kind == "good":
        df.to_csv(tmp / "reg.csv", index=False)
        return str(tmp / "reg.csv")
    if kind == "text":
        df.astype(object).assign(w2=[0.0, "abc"]).to_csv(tmp / "reg.csv", index=False)
        return str(tmp / "reg.csv")
    if kind == "empty":
        (tmp / "reg.csv").write_text("")
        return str(tmp / "reg.csv")
    df.to_parquet(tmp / "reg.parquet")
    (tmp / "reg.parquet").write_bytes((tmp / "reg.parquet").read_bytes()[:-40])
    return str(tmp / "reg.parquet")


def _ellipsoid(tmp: Path, **extra) -> str:
    (tmp / "ell.json").write_text(json.dumps({"center": [0, 0], "information": [[1, 0], [0, 1]], **extra}))
    return str(tmp / "ell.json")


def _certify(tmp: Path, regression: str, ellipsoid: str | None = None) -> list[str]:
    return ["certify", "--regression", regression, "--ellipsoid", ellipsoid or _ellipsoid(tmp), "--no-sdp"]


def _report_dir(tmp: Path) -> str:
    (tmp / "studies").mkdir()
    _edit(tmp / "studies", 'name = "dd"', 'name = "dd"', "a.toml")
    _edit(tmp / "studies", 'name = "dd"', 'name = "DD"', "b.toml")
    return str(tmp / "studies")


def _out_with_file_in_place(tmp: Path) -> str:
    (tmp / "out").mkdir()
    (tmp / "out" / "dd").write_text("not a folder")
    return str(tmp / "out")


def _run(study: str, *extra: str, out: str | None = None) -> list[str]:
    return ["run", study, "--quiet", *extra] + (["--out", out] if out else [])


# (id, argv builder, a regular expression the one error line must match)
CASES = [
    # Output escapes its folder
    ("name ../x", lambda t: _run(_edit(t, 'name = "dd"', 'name = "../x"'), out=str(t)),
     r"study\.name: must be a plain"),
    ("absolute name", lambda t: _run(_edit(t, 'name = "dd"', f'name = "{t}/x"'), out=str(t)), r"plain name"),
    ("name of another command's folder", lambda t: _run(_edit(t, 'name = "dd"', 'name = "teaching"'), out=str(t)),
     r"folder of another command"),
    ("two studies, one name (run)", lambda t: ["run", _edit(t, "x", "x", "a.toml"), _edit(t, "x", "x", "b.toml"),
                                               "--out", str(t)], r"both name their study 'dd'"),
    ("names differing in case (report)", lambda t: ["report", "--studies", _report_dir(t), "--out", str(t / "o"),
                                                    "--quiet"], r"both name their study"),
    ("--out is a file", lambda t: _run(_study(t, BASE), out=str(_study(t, "", "file"))), r"is a file, not a folder"),
    ("--out below a file", lambda t: _run(_study(t, BASE), out=str(Path(_study(t, "", "file")) / "x")),
     r"is a file, not a folder"),
    ("--out cannot be created", lambda t: _run(_study(t, BASE), out="/proc/boundid-reports"),
     r"--out /proc/boundid-reports: cannot create or write to this folder"),
    ("report folder is a file", lambda t: _run(_study(t, BASE), out=_out_with_file_in_place(t)),
     r"dd is a file, where the report folder 'dd' goes"),
    # Raw tracebacks for ordinary bad input
    ("CSV cell not a number", lambda t: _run(_measured(t, _csv_with_text_cell(t)), out=str(t)),
     r"rec\.csv: column 'q1', data row 5: 'abc' is not a number"),
    ("empty CSV", lambda t: _run(_measured(t, _file(t, "rec.csv", "")), out=str(t)), r"rec\.csv is empty"),
    ("CSV with a header only", lambda t: _run(_measured(t, _file(t, "rec.csv", "t,q1,q2,tau1,tau2\n")), out=str(t)),
     r"has a header but no data rows"),
    ("truncated Parquet recording", lambda t: _run(_measured(t, _truncated_parquet(t)), out=str(t)),
     r"rec\.parquet cannot be read as Parquet"),
    ("certify: cell not a number", lambda t: _certify(t, _regression_file(t, "text")),
     r"column 'w2', data row 2: 'abc' is not a number"),
    ("certify: empty CSV", lambda t: _certify(t, _regression_file(t, "empty")), r"reg\.csv is empty"),
    ("certify: corrupt Parquet", lambda t: _certify(t, _regression_file(t, "parquet")), r"cannot be read as Parquet"),
    ('certify: "sigma": "x"', lambda t: _certify(t, _regression_file(t, "good"), _ellipsoid(t, sigma="x")),
     r'"sigma" must be a positive number, got "x"'),
    ("non-UTF-8 study file", lambda t: _run(_latin1_study(t), out=str(t)), r"not UTF-8 text \(byte 0xe9 at line 6\)"),
    ("--seed -1 (run)", lambda t: _run(_study(t, BASE), "--seed", "-1", out=str(t)),
     r"--seed: must be an integer >= 0"),
    ("--seed -1 (campaign)", lambda t: ["campaign", _study(t, BASE), "--seed", "-1", "--out", str(t)],
     r"--seed: must be an integer >= 0"),
    ("duration 0.01 s (padlen)", lambda t: _run(_edit(t, "duration_s = 1.0", "duration_s = 0.01"), out=str(t)),
     r"duration_s is 0\.01 s: too short"),
    ("duration 1e9 s", lambda t: _run(_edit(t, "duration_s = 1.0", "duration_s = 1e9"), out=str(t)),
     r"400,000,000,001 samples x 2 joints .* the budget is 2,000,000 values .* BOUNDID_MAX_SAMPLES"),
    ("duration 1e5 s", lambda t: _run(_edit(t, "duration_s = 1.0", "duration_s = 1e5"), out=str(t)),
     r"40,000,001 samples x 2 joints .* BOUNDID_MAX_MEMORY_GB"),
    ('robot.options = {m1 = "heavy"}', lambda t: _run(_edit(t, 'model = "direct_drive"',
                                                            'model = "direct_drive"\noptions = {m1 = "heavy"}'),
                                                      out=str(t)), r"robot\.options\.m1: must be a number"),
    ("robot.options = {blah = 3}", lambda t: _run(_edit(t, 'model = "direct_drive"',
                                                        'model = "direct_drive"\noptions = {blah = 3}'), out=str(t)),
     r"robot\.options\.blah: unknown option .* m1 \(number\)"),
    ("experiment.options = {blah = 3}", lambda t: _run(_edit(t, 'source = "simulate"',
                                                             'source = "simulate"\noptions = {blah = 3}'), out=str(t)),
     r"experiment\.options\.blah: unknown option: the open-loop experiment takes no options"),
    ("closed loop: experiment.options = {blah = 3}", lambda t: _run(_study(t, H4), out=str(t)),
     r"experiment\.options\.blah: unknown option .* amplifier_gain \(number\), .* substeps \(integer\)"),
    ("projection of an unknown parameter", lambda t: _run(_study(t, BASE + '[exact]\nregression = "filtered_dynamic"\n'
                                                                    'e_max = 6.0\nprojections = [["th1", "zz"]]\n'),
                                                          out=str(t)),
     r"exact\.projections: 'zz' is not a parameter of the direct_drive model"),
    ("estimator option typo", lambda t: _run(_edit(t, 'method = "rls"', 'method = "rls"\nforgeting = 0.9'),
                                             out=str(t)), r"estimators\[1\]\.forgeting: unknown key; the rls .* "
                                                          r"forgetting \(number > 0, <= 1, default 1.0\)"),
    ("obe without e_max", lambda t: _run(_edit(t, 'method = "rls"', 'method = "obe"'), out=str(t)),
     r"estimators\[1\]\.e_max: is required"),
    # Numbers once not checked when the file was read
    ("coulomb_width_rad_s = nan (hung the run)",
     lambda t: _run(_edit(t, "duration_s = 1.0", "duration_s = 1.0\ncoulomb_width_rad_s = nan"), out=str(t)),
     r"experiment\.coulomb_width_rad_s: must be a finite number >= 0, got nan\.$"),
    ("duration_s = nan", lambda t: _run(_edit(t, "duration_s = 1.0", "duration_s = nan"), out=str(t)),
     r"experiment\.duration_s: must be a finite number > 0, got nan\.$"),
    ("duration_s = inf", lambda t: _run(_edit(t, "duration_s = 1.0", "duration_s = inf"), out=str(t)),
     r"experiment\.duration_s: must be a finite number > 0, got inf\.$"),
    ("sample_period_s = nan", lambda t: _run(_edit(t, "duration_s = 1.0", "duration_s = 1.0\nsample_period_s = nan"),
                                             out=str(t)), r"experiment\.sample_period_s: must be a finite number > 0"),
    ("sample_period_s = inf", lambda t: _run(_edit(t, "duration_s = 1.0", "duration_s = 1.0\nsample_period_s = inf"),
                                             out=str(t)), r"experiment\.sample_period_s: must be a finite number > 0"),
    ("absolute_range = nan (no [exact] regression, exit 0)",
     lambda t: _run(_edit(t, "absolute_range = 100.0", "absolute_range = nan"), out=str(t)),
     r"prior\.absolute_range: must be a finite number > 0, got nan\.$"),
    ("absolute_range = inf", lambda t: _run(_edit(t, "absolute_range = 100.0", "absolute_range = inf"), out=str(t)),
     r"prior\.absolute_range: must be a finite number > 0, got inf\.$"),
    ("kalman R = nan", lambda t: _run(_edit(t, 'method = "rls"', 'method = "kalman"\nR = nan'), out=str(t)),
     r"estimators\[1\]\.R: must be a finite number > 0, got nan\.$"),
    ("rls shape0 = inf", lambda t: _run(_edit(t, 'method = "rls"', 'method = "rls"\nshape0 = inf'), out=str(t)),
     r"estimators\[1\]\.shape0: must be a finite number >= 1e-150, <= 1e\+150, got inf\.$"),
    ("rls shape0 = 1e-300", lambda t: _run(_edit(t, 'method = "rls"', 'method = "rls"\nshape0 = 1e-300'),
                                           out=str(t)), r"estimators\[1\]\.shape0: must be >= 1e-150, <= 1e\+150"),
    ("obe e_max = inf", lambda t: _run(_edit(t, 'method = "rls"', 'method = "obe"\ne_max = inf'), out=str(t)),
     r"estimators\[1\]\.e_max: must be a finite number > 0, got inf\.$"),
    ("exact e_max = nan", lambda t: _run(_study(t, BASE + '[exact]\nregression = "filtered_dynamic"\ne_max = nan\n'),
                                         out=str(t)), r"exact\.e_max: must be a finite number > 0, got nan\.$"),
    ("robot option m1 = nan", lambda t: _run(_edit(t, 'model = "direct_drive"',
                                                   'model = "direct_drive"\noptions = {m1 = nan}'), out=str(t)),
     r"robot\.options\.m1: must be finite, not NaN or inf"),
    ("closed loop: experiment option fast_period = inf", lambda t: _run(_study(t, H4.replace(
        "options = { fast_period = 1.0, blah = 3 }", "options = { fast_period = inf }")), out=str(t)),
     r"experiment\.options\.fast_period: must be finite, not NaN or inf"),
    ("prior box excludes the truth (was: the data contradict e_max)",
     lambda t: _run(_study(t, BASE.replace("absolute_range = 100.0", "absolute_range = 10.0")
                           + '[exact]\nregression = "filtered_dynamic"\ne_max = 6.0\n'), out=str(t)),
     r": \[prior\]: the prior box excludes the true parameters of the simulated robot \(th4 = 38\.47 N m outside "
     r"\[-10, 10\]\), .* widen the box: raise prior\.absolute_range \(now 10\), or change prior\.center "
     r"\(now 'zero'\)\.$"),
    ("prior box too small for floating point",
     lambda t: _run(_edit(t, "absolute_range = 100.0", "absolute_range = 1e-80"), out=str(t)),
     r"\[prior\]: the prior box's half-widths must lie between 3\.33e-76 and 3\.33e\+74 .* th1 has 1e-80 kg m\^2"),
    ("scenario torque level = nan (campaign)", lambda t: ["campaign", _study(t, BASE + SCENARIO.format(
        "torque = { kind = 'uniform', level = nan }")), "--out", str(t)],
     r"campaign\.scenarios\[0\]\.torque\.level: must be a finite number >= 0, got nan\.$"),
    ("scenario structural_error = inf (run)", lambda t: _run(_study(t, BASE + SCENARIO.format(
        "structural_error = inf")), out=str(t)),
     r"campaign\.scenarios\[0\]\.structural_error: must be a finite number >= 0, got inf\.$"),
    ("unknown scenario key (run)", lambda t: _run(_study(t, BASE + SCENARIO.format("torque_noise = 1.0")), out=str(t)),
     r"campaign\.scenarios\[0\]\.torque_noise: unknown key; the keys read here are description, "
     r"encoder_counts_per_rev, name, structural_error, torque\.$"),
    ("unknown scenario key (campaign)", lambda t: ["campaign", _study(t, BASE + SCENARIO.format("torque_noise = 1.0")),
                                                   "--out", str(t)],
     r"campaign\.scenarios\[0\]\.torque_noise: unknown key; the keys read here are description, "
     r"encoder_counts_per_rev, name, structural_error, torque\.$"),
]


def _cli(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as exc:  # argparse usage errors
        return int(exc.code)


def _must_not_compute(*args, **kwargs):
    raise AssertionError("bad input reached the computation")


@pytest.mark.parametrize("build, match", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input_is_one_line_and_exit_2(build, match, tmp_path, capsys, monkeypatch):
    """Every listed case exits 2 within 10 s with exactly one ``boundid: error:`` line naming the
    problem and nothing on stdout, and nothing is computed (the simulation and the regression
    builder would fail the test)."""
    for module, name in ((data, "simulate_open_loop"), (data, "closed_loop_data"), (runner, "build_regressions")):
        monkeypatch.setattr(module, name, _must_not_compute)
    argv = build(tmp_path)
    capsys.readouterr()
    t0 = time.monotonic()
    assert _cli(argv) == 2
    assert time.monotonic() - t0 < 10.0
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("boundid: error: "), captured.err
    assert re.search(match, lines[0]), lines[0]
    assert captured.out == ""


def test_run_and_campaign_share_the_scenario_schema(tmp_path, capsys):
    """``boundid run`` reads the [campaign] table with the parser of ``boundid campaign``: the same
    unknown scenario key gives both commands the same line."""
    study = _study(tmp_path, BASE + SCENARIO.format("level = 0.5"))
    lines = []
    for argv in (_run(study, out=str(tmp_path)), ["campaign", study, "--out", str(tmp_path), "--quiet"]):
        capsys.readouterr()
        assert _cli(argv) == 2
        lines.append(capsys.readouterr().err)
    assert lines[0] == lines[1] == (f"boundid: error: {study}: campaign.scenarios[0].level: unknown key; the keys "
                                    "read here are description, encoder_counts_per_rev, name, structural_error, "
                                    "torque.\n")


def _toml(value) -> str:
    """A value as TOML text: tables inline, floats with nan and inf spelled as TOML spells them."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return "{ " + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + " }"


def _place(doc: dict, path: str, value) -> None:
    """Set the dotted ``path`` of ``doc`` ("[]": the first table of an array of tables) to ``value``."""
    *tables, key = path.split(".")
    for name in tables:
        doc = doc.setdefault(name[:-2], [{}])[0] if name.endswith("[]") else doc.setdefault(name, {})
    doc[key] = value


def _every_number(keys) -> list[tuple[dict, str, object]]:
    """(settings, key, default) of every number a study file can hold: the float keys of the
    sections and [[estimators]] tables, and the float (and list of floats) options of every
    robot and experiment, each with the choices under which the parser reads it."""
    out = []
    for k in keys:
        when = {choice_key: sorted(values)[0] for choice_key, values in k.when.items()}
        if k.kind == "number":
            out.append((when, k.path, 1.0))
        for case, options in (k.options_by or {"": k.options or {}}).items():
            choice = dict(when)
            if case:  # 'model = "h4"'
                name, value = case.split(" = ")
                choice[k.path.rsplit(".", 1)[0] + "." + name] = json.loads(value)
            out += [(choice, f"{k.path}.{o}", d) for o, d in options.items()
                    if isinstance(d, float) or (isinstance(d, tuple) and d and isinstance(d[0], float))]
    return out


def test_every_number_refuses_nan_and_inf(tmp_path):
    """Every number the schema knows, enumerated from the parser itself (the study-file keys
    boundid.docs finds by probing it, with the options of every robot, experiment and estimator),
    is refused as NaN, inf or -inf when the file is read, naming its key: a new key cannot slip
    through. Cross-check: every float field of every registered method's options dataclass is
    among them."""
    from boundid.docs import study_keys

    numbers = _every_number(study_keys())
    paths = {path for _, path, _ in numbers}
    float_options = {f"estimators[].{f.name}" for m in METHODS.values() for f in dataclasses.fields(m.options)
                     if typing.get_type_hints(m.options)[f.name] in (float, float | None)}
    assert float_options and float_options <= paths
    assert {"experiment.coulomb_width_rad_s", "prior.absolute_range", "robot.options.m1",
            "experiment.options.fast_period", "campaign.scenarios[].torque.level"} <= paths
    slipped = []
    for settings, path, default in numbers:
        for bad in (math.nan, math.inf, -math.inf):
            doc = {"regressions": ["filtered_dynamic"], "study": {"name": "dd", "title": "t"},
                   "robot": {"model": "direct_drive"}, "experiment": {"source": "simulate", "duration_s": 1.0},
                   "prior": {"absolute_range": 100.0},
                   "estimators": [{"method": "wls", "regressions": ["filtered_dynamic"]}],
                   "campaign": {"scenarios": [{"name": "a"}]}}
            for key, choice in settings.items():
                _place(doc, key, choice)
            if METHODS[doc["estimators"][0]["method"]].needs_bound:
                doc["estimators"][0]["e_max"] = 1.0
            _place(doc, path, [bad] * len(default) if isinstance(default, tuple) else bad)
            study = tmp_path / "study.toml"
            study.write_text("\n".join(f"{k} = {_toml(v)}" for k, v in doc.items()) + "\n")
            key = re.escape(path.replace("[]", "[0]"))
            try:
                load_study(study)
            except StudyError as exc:
                if re.search(rf"{re.escape(str(study))}: {key}: must be (a )?finite", str(exc)):
                    continue
                slipped.append(f"{path} = {bad}: {exc}")
            else:
                slipped.append(f"{path} = {bad}: accepted")
    assert not slipped, "\n".join(slipped)


def test_entry_point_refuses_nan_at_once(tmp_path):
    """In a real process, the NaN Coulomb width that used to hang the simulation (> 420 s) ends at
    once: one line, exit 2, nothing on stdout."""
    study = _edit(tmp_path, "duration_s = 1.0", "duration_s = 1.0\ncoulomb_width_rad_s = nan")
    proc = subprocess.run([sys.executable, "-m", "boundid.cli", "run", study, "--out", str(tmp_path)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.splitlines() == [f"boundid: error: {study}: experiment.coulomb_width_rad_s: must be a finite "
                                        "number >= 0, got nan."]


@pytest.mark.parametrize("estimator, shape0", [(OBE, 1e-300), (OBE, 1e200), (RLS, 1e-300), (KalmanEstimator, 1e200)])
def test_prior_shape_out_of_floating_point_is_refused(estimator, shape0):
    """OBE(3, shape0=1e-300) divided by zero (the product of two squared semi-axes underflows);
    every ellipsoidal prior is now refused outside 1e-150..1e150 with one sentence naming shape0."""
    with pytest.raises(InputError) as err:
        estimator(3, shape0=shape0)
    message = str(err.value)
    assert message.startswith("shape0 (the prior's squared semi-axes, in parameter units squared) must lie between "
                              "1e-150 and 1e+150, got eigenvalues from ")
    assert message.count(". ") == 0 and message.endswith(".") and "\n" not in message
    for limit in (1e-150, 1e150):  # the limits themselves are accepted
        assert estimator(3, shape0=limit).p == 3


def test_summary_md_escapes_what_it_quotes(tmp_path):
    """A study title and description holding HTML: the page escapes them, and so does summary.md
    (a Markdown renderer passes raw HTML through), while the text still reads the same."""
    title = "<script>alert(1)</script> & co"
    text = WLS_ONLY.replace('title = "Direct-drive arm, 1 s"',
                            f'title = "{title}"\ndescription = "<img src=x onerror=alert(2)>"')
    out = tmp_path / "out"
    assert _cli(["run", _study(tmp_path, text), "--out", str(out), "--quiet"]) == 0
    md = (out / "dd" / "summary.md").read_text(encoding="utf-8")
    page = (out / "dd" / "index.html").read_text(encoding="utf-8")
    for raw in ("<script", "<img"):
        assert raw not in md and raw not in page
    assert md.startswith("# &lt;script&gt;alert(1)&lt;/script&gt; &amp; co\n")
    assert "&lt;img src=x onerror=alert(2)&gt;" in md


def test_entry_point_prints_no_traceback(tmp_path):
    """The same in a real process: the installed command, a non-UTF-8 study, one line, exit 2."""
    study = tmp_path / "s.toml"
    study.write_bytes(b"name = \"\xff\"\n")
    proc = subprocess.run([sys.executable, "-m", "boundid.cli", "run", str(study), "--out", str(tmp_path)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.strip().splitlines() == [f"boundid: error: {study}: not UTF-8 text (byte 0xff at line 1); "
                                                "save the study file as UTF-8."]


# ------------------------------------------------------------------------------ atomic report folders

KILL_MID_WRITE = r"""
import os, signal, sys
import boundid.report.html as html
from boundid.cli import main

calls, original = [], html.latex_table

def dying(*args, **kwargs):  # Page.write renders one LaTeX table per table: die at the second
    calls.append(1)
    if len(calls) == 2:
        os.kill(os.getpid(), signal.SIGKILL)
    return original(*args, **kwargs)

html.latex_table = dying
main(["run", sys.argv[1], "--out", sys.argv[2], "--quiet", "--seed", "11"])
"""


def _tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_killed_write_leaves_the_previous_page_whole(tmp_path):
    """Run once; add a campaign/ sub-folder; SIGKILL a second run (another seed) in the middle of
    writing its page: every file of the first report is byte for byte as before, the half-written
    page sits in a hidden sibling only. A third run replaces the folder, keeps campaign/ and
    removes what the killed one left."""
    study, out = _study(tmp_path, WLS_ONLY), tmp_path / "out"  # no figures: fast pages
    assert _cli(["run", study, "--out", str(out), "--quiet"]) == 0
    (out / "dd" / "campaign" / "data").mkdir(parents=True)
    (out / "dd" / "campaign" / "data" / "r0.parquet").write_bytes(b"replicate")
    before = _tree(out / "dd")
    proc = subprocess.run([sys.executable, "-c", KILL_MID_WRITE, study, str(out)], capture_output=True, timeout=300)
    assert proc.returncode == -signal.SIGKILL, proc.stderr.decode()[-2000:]
    assert _tree(out / "dd") == before
    (half,) = out.glob(".dd.new-*")
    assert (half / "results.csv").is_file() and not (half / "index.html").exists()
    assert _cli(["run", study, "--out", str(out), "--quiet", "--seed", "11"]) == 0
    after = _tree(out / "dd")
    # the study, the site index and the site's glossary and references pages
    assert sorted(p.name for p in out.iterdir()) == ["dd", "glossary.html", "index.html", "references.html"]
    assert after["campaign/data/r0.parquet"] == b"replicate"
    assert after["index.html"] != before["index.html"] and after["results.csv"] != before["results.csv"]


def test_studies_at_once_give_the_numbers_of_studies_in_turn(tmp_path):
    """--jobs 2 (each study in a process of its own, forked from a fork server) writes the same results.csv, byte for
    byte, as --jobs 1 (in turn, in this process), for two studies of different seeds."""
    a = _study(tmp_path, WLS_ONLY, "a.toml")
    b = _study(tmp_path, WLS_ONLY.replace('name = "dd"', 'name = "dd2"').replace("seed = 3", "seed = 4"), "b.toml")
    for jobs in ("1", "2"):
        assert _cli(["run", a, b, "--out", str(tmp_path / jobs), "--quiet", "--jobs", jobs]) == 0
    def results(jobs, name):
        return (tmp_path / jobs / name / "results.csv").read_bytes()

    for name in ("dd", "dd2"):
        assert results("2", name) == results("1", name)
    assert results("1", "dd") != results("1", "dd2")


@pytest.mark.parametrize("exchange", [True, False], ids=["renameat2", "two renames"])
def test_replace_folder_swaps_and_recovers(tmp_path, monkeypatch, exchange):
    """The swap (atomic exchange, or the two-rename fallback) replaces the folder and carries the
    kept sub-folder over; a failure while writing leaves the old folder; state left by a kill
    between the steps of a swap is recovered by the next write."""
    if not exchange:
        monkeypatch.setattr(output, "_exchange", lambda a, b: False)
    dest = tmp_path / "page"
    with output.replace_folder(dest) as tmp:
        (tmp / "index.html").write_text("one")
        (tmp / "stale.svg").write_text("one")
    (dest / "campaign").mkdir()
    (dest / "campaign" / "x").write_text("kept")
    with pytest.raises(RuntimeError), output.replace_folder(dest, keep=("campaign",)) as tmp:
        (tmp / "index.html").write_text("two")
        raise RuntimeError("figure failed")
    assert _tree(dest) == {"index.html": b"one", "stale.svg": b"one", "campaign/x": b"kept"}
    with output.replace_folder(dest, keep=("campaign",)) as tmp:
        (tmp / "index.html").write_text("two")
    assert _tree(dest) == {"index.html": b"two", "campaign/x": b"kept"}
    assert [p.name for p in tmp_path.iterdir()] == ["page"]
    # killed after the exchange, before campaign/ was carried over: it sits in the hidden sibling
    (tmp_path / ".page.new-1").mkdir()
    (dest / "campaign").rename(tmp_path / ".page.new-1" / "campaign")
    # killed between the two renames of the fallback: the previous folder sits aside, none in place
    other = tmp_path / "other"
    other.mkdir()
    (other / "index.html").write_text("previous")
    other.rename(tmp_path / ".other.old-1")
    output.recover_folder(dest, keep=("campaign",))
    output.recover_folder(other)
    assert _tree(dest) == {"index.html": b"two", "campaign/x": b"kept"}
    assert _tree(other) == {"index.html": b"previous"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["other", "page"]


# ------------------------------------------------------------------------------ failures after computing


def test_failing_estimator_and_projection_are_recorded_and_the_page_written(tmp_path, monkeypatch):
    """An estimator raising LinAlgError (RLS on data x 1e7 does) and a projection whose LP fails
    are listed in the failures table with their reasons; the other estimator, the exact optima
    and the page are there."""
    real = runner.run_estimator

    def broken(ec, reg, model, prior):
        if ec.method == "rls":
            raise np.linalg.LinAlgError("Eigenvalues did not converge")
        return real(ec, reg, model, prior)

    def no_shadow(*args, **kwargs):
        raise SolverError("HiGHS status 'time limit reached'")

    monkeypatch.setattr(runner, "run_estimator", broken)
    monkeypatch.setattr(Polytope, "project", no_shadow)
    text = BASE + '[exact]\nregression = "filtered_dynamic"\ne_max = 6.0\nprojections = [["th1", "th2"]]\n'
    out = tmp_path / "out"
    assert _cli(["run", _study(tmp_path, text), "--out", str(out), "--quiet"]) == 0
    failures = pd.read_csv(out / "dd" / "tables" / "failures.csv")
    assert failures.values.tolist() == [
        ["estimator", "RLS / filtered_dynamic", "LinAlgError: Eigenvalues did not converge"],
        ["projection", "(th1, th2)", "SolverError: HiGHS status 'time limit reached'"]]
    html = (out / "dd" / "index.html").read_text()
    assert "tab-table-ii" in html and "tab-estimates" in html and "fig-projection" not in html
    assert set(pd.read_csv(out / "dd" / "results.csv")["estimator"]) == {"WLS", "LP exact"}


def test_too_tight_bound_diverging_resimulation_gives_a_page(tmp_path):
    """The case of e_max far below the noise; the OBE centre describes dynamics whose
    re-simulation diverges (the state becomes infinite) -- recorded as a failure, the page is written."""
    tight = BASE.replace('method = "rls"', 'method = "obe"\ne_max = 0.05').replace("seed = 3", "seed = 7")
    text = _study(tmp_path, tight)
    out = tmp_path / "out"
    assert _cli(["run", text, "--out", str(out), "--quiet"]) == 0
    failures = pd.read_csv(out / "dd" / "tables" / "failures.csv")
    resim = failures[failures["stage"] == "re-simulation"]
    assert list(resim["subject"]) == ["OBE / filtered_dynamic"]
    assert resim["failure"].iloc[0].startswith("simulation failed: SolverError: DOP853 (compiled): the state "
                                               "became infinite or NaN on [")
    assert (out / "dd" / "index.html").stat().st_size > 10_000


def test_resource_budget_is_stated_and_can_be_raised(tmp_path, monkeypatch):
    """The refusal gives the numbers and the budget; the environment variables raise it (the
    study then loads; nothing is run here); a malformed value is refused by name."""
    path = _edit(tmp_path, "duration_s = 1.0", "duration_s = 1e5")
    with pytest.raises(ResourceError, match=r"40,000,001 samples x 2 joints = 80,000,002 values, estimated "
                                             r"memory 27\.5 GB; the budget is 2,000,000 values and 4 GB"):
        load_study(path)
    monkeypatch.setenv("BOUNDID_MAX_SAMPLES", "1e8")
    monkeypatch.setenv("BOUNDID_MAX_MEMORY_GB", "64")
    assert load_study(path).experiment.duration_s == 1e5
    monkeypatch.setenv("BOUNDID_MAX_MEMORY_GB", "lots")
    with pytest.raises(StudyError, match=r"BOUNDID_MAX_MEMORY_GB = 'lots' must be a positive number"):
        load_study(path)
