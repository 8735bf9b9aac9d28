"""The documentation site (docs/site/, built by `make docs` into reports/docs/) covers the library.

References: the packages themselves. Every public name of boundid.sets, boundid.estimators and
boundid.models (their __all__) and, for boundid.experiments and boundid.studies (no __all__), every
public module and every public class and function defined in it, is listed in the API reference's
sources, so a new public name without a page fails here; every guide and theory page exists, starts
with what a reader gets from it, and is in a toctree. The site's docstring reading and reference
check (docs/site/_ext/boundid_sphinx.py) are tested on small cases. The full build is `make docs`
(about 35 s on 2 cores, warnings as errors): the slow case below runs it.
"""

import importlib
import inspect
import pkgutil
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SITE = ROOT / "docs" / "site"

WITH_ALL = ("sets", "estimators", "models")
WITHOUT_ALL = ("experiments", "studies")
GUIDES = ("own-recording", "own-robot", "certify-estimator", "dask-campaign")
THEORY = ("obe", "exact-bounds", "sdp", "set-families", "physical", "excitation")


def public_names() -> dict[str, set[str]]:
    """Package -> the dotted names its API page must list."""
    out = {}
    for pkg in WITH_ALL:
        out[pkg] = {f"boundid.{pkg}.{n}" for n in importlib.import_module(f"boundid.{pkg}").__all__}
    for pkg in WITHOUT_ALL:
        names = set()
        package = importlib.import_module(f"boundid.{pkg}")
        for info in pkgutil.iter_modules(package.__path__):
            if info.name.startswith("_"):
                continue
            mod = importlib.import_module(f"boundid.{pkg}.{info.name}")
            names.add(mod.__name__)
            names |= {f"{mod.__name__}.{n}" for n, v in vars(mod).items() if not n.startswith("_")
                      and getattr(v, "__module__", None) == mod.__name__
                      and (inspect.isclass(v) or inspect.isfunction(v))}
        out[pkg] = names
    return out


def listed(page: str) -> set[str]:
    """The dotted names an API page documents: its automodule targets and its autosummary entries,
    each under the current module."""
    names, module = set(), None
    for line in (SITE / "api" / f"{page}.md").read_text(encoding="utf-8").splitlines():
        if m := re.match(r"\.\. (automodule|currentmodule):: (\S+)", line.strip()):
            module = m.group(2)
            if m.group(1) == "automodule":
                names.add(module)
        elif re.match(r"^   [A-Za-z]\w*$", line) and module:
            names.add(f"{module}.{line.strip()}")
    return names


@pytest.mark.parametrize("pkg", WITH_ALL + WITHOUT_ALL)
def test_every_public_name_is_in_the_api_reference(pkg):
    missing = public_names()[pkg] - listed(pkg)
    assert not missing, f"not in docs/site/api/{pkg}.md: {sorted(missing)}"


def _toctree_entries(page: Path) -> set[str]:
    entries = set()
    for block in re.findall(r"```\{toctree\}\n(.*?)```", page.read_text(encoding="utf-8"), re.S):
        entries |= {ln.strip() for ln in block.splitlines() if ln.strip() and not ln.startswith(":")}
    return entries


@pytest.mark.parametrize(("folder", "pages"), [("guides", GUIDES), ("theory", THEORY)])
def test_guide_and_theory_pages_exist_and_are_in_the_toctree(folder, pages):
    assert f"{folder}/index" in _toctree_entries(SITE / "index.md")
    assert set(pages) <= _toctree_entries(SITE / folder / "index.md")
    for name in pages:
        text = (SITE / folder / f"{name}.md").read_text(encoding="utf-8")
        assert re.search(r"^What you get from this (page|guide)", text, re.M), f"{folder}/{name}.md"


def test_the_reference_includes_the_docs_files():
    """The study-file reference and the other docs/ files are included, not copied."""
    for name in ("study-files", "verdict-file", "models", "references", "scaling"):
        text = (SITE / "reference" / f"{name}.md").read_text(encoding="utf-8")
        assert f"{{include}} ../../{name}.md" in text and (ROOT / "docs" / f"{name}.md").is_file()
        assert name in _toctree_entries(SITE / "reference" / "index.md")


def _extension():
    """docs/site/_ext/boundid_sphinx.py (needs Sphinx: the `docs` extra, in the locks)."""
    pytest.importorskip("sphinx")
    sys.path.insert(0, str(SITE / "_ext"))
    return importlib.import_module("boundid_sphinx")


def test_plain_text_docstrings_keep_their_layout():
    plain_text_docstring = _extension().plain_text_docstring
    lines = ["Summary with |x - c| <= 1 and ``a|b``.", "", "field : what it is", "    continued here",
             "other : more", "", "Parameters", "----------", "W : (N, p)   the rows"]
    out = plain_text_docstring(lines)
    assert out[0] == r"Summary with \|x - c\| <= 1 and ``a|b``."
    assert ".. parsed-literal::" in out and "   field : what it is" in out
    assert ".. rubric:: Parameters" in out and "----------" not in out
    items = ["- a list item", "  its continuation", "- another"]
    assert plain_text_docstring(items) == items  # valid reStructuredText is left alone


def test_a_reference_to_a_name_that_does_not_exist_is_broken():
    exists_in_boundid = _extension().exists_in_boundid
    assert exists_in_boundid("boundid.sets.Ellipsoid", None, None)
    assert exists_in_boundid("ACCELERATION", "boundid.models", "RobotModel")  # in the class's own module
    assert exists_in_boundid("gamma_star", "boundid.studies.bounds", None)
    assert not exists_in_boundid("no_such_function", "boundid.studies.bounds", None)
    assert not exists_in_boundid("boundid.sets.NoSuchSet", None, None)


@pytest.mark.slow
def test_the_site_builds_without_a_warning(tmp_path):
    pytest.importorskip("sphinx")
    res = subprocess.run([sys.executable, "-m", "sphinx", "-b", "html", "-E", "-W", "--keep-going", "-q", "-j", "2",
                          "-d", str(tmp_path / "doctrees"), str(SITE), str(tmp_path / "html")],
                         capture_output=True, text=True, timeout=900)
    assert res.returncode == 0, res.stderr[-3000:]
    assert (tmp_path / "html" / "index.html").is_file()
    assert (tmp_path / "html" / "api" / "generated" / "boundid.estimators.OBE.html").is_file()
