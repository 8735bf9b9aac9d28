"""docs/study-files.md is generated from the study-file parser and cannot drift from it.

References: the committed file against a fresh generation; every key of the shipped study files
(studies/*.toml and the measured-data example), read with tomllib independently of boundid's
parser, must appear in the generated key list; a key the parser reads only under one choice
(the recording's columns, under source = "measured") is found with that condition.
"""

import tomllib
from pathlib import Path

from boundid.docs import main, render, study_keys
from boundid.estimators.registry import METHODS

ROOT = Path(__file__).resolve().parents[1]
STUDIES = sorted((ROOT / "studies").glob("*.toml")) + sorted((ROOT / "studies" / "examples").glob("*.toml"))


def _paths(data: dict, prefix: str = "") -> set[str]:
    """Dotted paths of every key of a parsed TOML file, "[]" after an array of tables; the free-form
    [paper] table, option tables (checked against their defaults) and the name tables of [[published]]
    (values, names: keyed by the source's parameter names) are not walked into."""
    out = set()
    for key, value in data.items():
        path = f"{prefix}{key}"
        if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            out.add(f"{path}[]")
            for v in value:
                out |= _paths(v, f"{path}[].")
        else:
            out.add(path)
            if isinstance(value, dict) and key not in ("paper", "options", "values", "names"):
                out |= _paths(value, f"{path}.")
    return out


def test_committed_study_files_doc_is_the_generated_one(tmp_path):
    committed = (ROOT / "docs" / "study-files.md").read_text(encoding="utf-8")
    assert committed == render(study_keys()), "docs/study-files.md is stale: run `make docs`"
    assert main(["--check", "--out", str(ROOT / "docs" / "study-files.md")]) == 0
    (tmp_path / "old.md").write_text(committed.replace("seed", "sead"))
    assert main(["--check", "--out", str(tmp_path / "old.md")]) == 1


def test_every_key_of_the_shipped_studies_is_documented():
    documented = {k.path for k in study_keys()}
    assert len(STUDIES) >= 3
    for study in STUDIES:
        used = _paths(tomllib.loads(study.read_text(encoding="utf-8")))
        assert used <= documented, f"{study.name}: {sorted(used - documented)} not in docs/study-files.md"


def test_conditional_keys_carry_their_condition():
    keys = {k.path: k for k in study_keys()}
    assert keys["experiment.measured.columns.time"].when == {"experiment.source": {"measured"}}
    assert keys["experiment.measured.file"].required
    bounded = {name for name, m in METHODS.items() if m.needs_bound}
    assert keys["estimators[].e_max"].when == {"estimators[].method": bounded}
    assert keys["robot.options"].options_by.keys() >= {'model = "h4"', 'model = "direct_drive"'}
