"""The README's examples and commands, run from a folder outside the repository, as a user would.

Reference: the README itself. Its ```python blocks run in order as one script in a fresh folder
(tmp_path, not the checkout); every `boundid ...` line of its ```sh blocks then runs there, with
`--out` pointed into that folder (the `make` lines need the checkout and the network: skipped).
The command must exit 0; `--json` output must parse as strict JSON (no NaN or Infinity). Whole
studies and lessons (`report`, `teach`) are slow cases; a fast test shows that those commands find
their inputs from another folder.
"""

import json
import os
import re
import shlex
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from boundid import resources
from boundid.errors import InputError

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
BOUNDID = str(Path(sys.executable).with_name("boundid"))
HEAVY = {"report", "teach", "run", "campaign", "bench"}


def blocks(lang: str) -> list[str]:
    """The fenced code blocks of one language, dedented (a block may sit in a list item)."""
    return [textwrap.dedent(m.group(2)) for m in
            re.finditer(r"^( *)```" + lang + r"\n(.*?)^\1```", README, re.M | re.S)]


def commands() -> list[str]:
    """Every `boundid` command line of the ```sh blocks, without its comment."""
    lines = [line.split("#", 1)[0].strip() for block in blocks("sh") for line in block.splitlines()]
    assert all(not ln or ln.startswith(("boundid", "make ")) for ln in lines), "a README sh line this test cannot run"
    return [ln for ln in lines if ln.startswith("boundid")]


def _strict_json(text: str):
    def bad(name):
        raise ValueError(f"not strict JSON: {name}")
    return json.loads(text, parse_constant=bad)


def _run(cmd: str, cwd: Path, env=None) -> subprocess.CompletedProcess:
    args = shlex.split(cmd)
    args[0] = BOUNDID
    if "--out" in args:
        args[args.index("--out") + 1] = str(cwd / "out")
    return subprocess.run(args, cwd=cwd, capture_output=True, text=True, timeout=1800,
                          env={**os.environ, "MPLBACKEND": "Agg", **(env or {})})


@pytest.fixture(scope="module")
def user_folder(tmp_path_factory):
    """A folder outside the checkout where the README's Python blocks have run (rows.csv, final.json)."""
    folder = tmp_path_factory.mktemp("readme-user")
    assert ROOT not in folder.parents
    script = folder / "readme_example.py"
    script.write_text("\n\n".join(blocks("python")), encoding="utf-8")
    res = subprocess.run([sys.executable, str(script)], cwd=folder, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "boundid certificate" in res.stdout
    return folder


def test_readme_python_examples_run_from_another_folder(user_folder):
    """The Python blocks ran (fixture) and wrote the files the certify commands read."""
    assert (user_folder / "rows.csv").is_file() and (user_folder / "final.json").is_file()


def test_readme_has_the_commands_this_test_runs():
    cmds = commands()
    assert any(c.startswith("boundid certify") and "--json" in c for c in cmds)
    assert {"--version", "list", "report", "teach", "certify"} <= {shlex.split(c)[1] for c in cmds}
    first = blocks("sh")[0]
    assert first.splitlines()[0].startswith("make report") and "make test" in first


@pytest.mark.parametrize("cmd", [pytest.param(c, marks=pytest.mark.slow) if shlex.split(c)[1] in HEAVY else c
                                 for c in commands()])
def test_readme_command_runs_from_another_folder(cmd, user_folder):
    res = _run(cmd, user_folder)
    assert res.returncode == 0, f"{cmd}: exit {res.returncode}\n{res.stderr[-2000:]}"
    if "--json" in cmd:
        out = _strict_json(res.stdout)
        assert out["contains_polytope"] is True and isinstance(out["max_gauge"], float)
    if "--version" in cmd:
        assert re.fullmatch(r"boundid \d+\.\d+\.\d+\S*\n", res.stdout)


def test_report_and_teach_find_the_checkout_inputs_from_another_folder(tmp_path):
    """From an empty folder, `boundid report` reads the checkout's studies (here refused by a budget
    of one sample, which names the study file it read) and `boundid teach` its lessons."""
    res = _run("boundid report --out x", tmp_path, env={"BOUNDID_MAX_SAMPLES": "1"})
    assert res.returncode == 2 and str(ROOT / "studies") in res.stderr and "BOUNDID_MAX_SAMPLES" in res.stderr
    res = _run("boundid teach --out x --only no-such-lesson", tmp_path)
    assert res.returncode == 2 and "lesson1_feasible_set" in res.stderr


def test_find_folder_prefers_the_current_folder_and_says_where_it_looked(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert resources.find_folder("studies", "*.toml", what="study files", option="--studies") == ROOT / "studies"
    (tmp_path / "studies").mkdir()
    (tmp_path / "studies" / "mine.toml").write_text("")
    assert resources.find_folder("studies", "*.toml", what="study files", option="--studies").resolve() == \
        (tmp_path / "studies").resolve()
    monkeypatch.setattr(resources, "checkout_root", lambda: None)
    with pytest.raises(InputError, match=r"no lesson scripts found: looked for lesson\*\.py in .*--lessons"):
        resources.find_folder("studies/teaching", "lesson*.py", what="lesson scripts", option="--lessons")
    with pytest.raises(InputError, match="holds no"):
        resources.find_folder("studies", "*.toml", tmp_path / "nowhere", what="study files", option="--studies")
