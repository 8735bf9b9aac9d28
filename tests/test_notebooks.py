"""The lessons as notebooks: ``boundid teach`` converts each lesson script with jupytext, runs it
top to bottom with nbclient in a fresh kernel and writes the executed ``<lesson>.ipynb`` beside
the handout.

References: nbformat's own reader and JSON-schema validator for the written files (v4, no
conversion), jupytext for the lesson's cells as the notebook must hold them unchanged, Pillow for
every image output (it must decode; a stepper's frames as an animated PNG), and the CLI's exit
code convention (2 and one ``boundid: error:`` line for a lesson that cannot be run). Lesson 1
runs in the fast suite; the others are ``slow`` (about a minute together in fast mode).
"""

import base64
import io
import os
import re
import sys
from pathlib import Path

import pytest
from PIL import Image

from boundid.cli import main
from boundid.errors import StudyError
from boundid.teaching import OUT_ENV, execute_notebook, lesson_notebook, lessons, run_lesson, run_lessons

nbformat = pytest.importorskip("nbformat")
jupytext = pytest.importorskip("jupytext")
pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")

ROOT = Path(__file__).resolve().parents[1]
LESSONS = lessons(ROOT / "studies" / "teaching")
CLUTTER = re.compile(r"^(<matplotlib\.|Text\(|\[<matplotlib)")


def _images(cell) -> list[Image.Image]:
    out = []
    for o in cell.get("outputs", ()):
        png = o.get("data", {}).get("image/png")
        if png is not None:
            img = Image.open(io.BytesIO(base64.b64decode(png, validate=True)))
            img.load()
            out.append(img)
    return out


def _texts(nb) -> list[str]:
    texts = []
    for cell in nb.cells:
        for o in cell.get("outputs", ()):
            texts.append(o.get("text", ""))
            texts.extend(v for k, v in o.get("data", {}).items() if k.startswith("text/"))
            texts.extend(o.get("traceback", ()))
    return texts


def _check_notebook(path: Path, script: Path, *, forbidden: tuple[str, ...]) -> object:
    """The written notebook: valid nbformat v4 read as it is, the python3 kernel, stable cell ids,
    the added intro cell then the lesson's own cells unchanged, every code cell run in order, no error output, no
    matplotlib repr line, every image decodes, no path of the machine that built it."""
    nb = nbformat.read(path, as_version=nbformat.NO_CONVERT)
    assert nb.nbformat == 4
    nbformat.validate(nb)
    assert nb.metadata.kernelspec.name == "python3" and nb.metadata.kernelspec.language == "python"
    assert nb.metadata.language_info.name == "python" and "jupytext" not in nb.metadata
    assert [c.id for c in nb.cells] == [f"cell-{k}" for k in range(len(nb.cells))], "stable ids: reruns diff cleanly"
    intro = nb.cells[0]
    assert intro.cell_type == "markdown" and script.name in intro.source and "To run it" in intro.source
    own = jupytext.read(script).cells
    assert [(c.cell_type, c.source) for c in nb.cells[1:]] == [(c.cell_type, c.source) for c in own]
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert [c.execution_count for c in code] == list(range(1, len(code) + 1)), "run top to bottom, once"
    outputs = [o for c in code for o in c.outputs]
    assert outputs and not any(o.output_type == "error" for o in outputs)
    for o in outputs:
        if o.output_type == "execute_result":
            assert not CLUTTER.match(o.data.get("text/plain", "")), o.data
    assert sum(len(_images(c)) for c in code) >= 1, "the lesson's figures show inline"
    text = "\n".join(_texts(nb))
    for f in forbidden:
        assert f not in text, f"an output names {f!r}"
    return nb


@pytest.mark.parametrize("script", [pytest.param(s, marks=() if s.stem.startswith("lesson1_") else pytest.mark.slow)
                                    for s in LESSONS], ids=[s.stem for s in LESSONS])
def test_lesson_runs_as_a_notebook(script, tmp_path):
    """Fast mode, a fresh kernel: the handout and the executed notebook are written side by side;
    the notebook is valid, carries its outputs and its figures, and its handout cell prints the
    handout's path relative to the notebook (not the temporary folder it was written in)."""
    out = tmp_path / script.stem
    page = run_lesson(script, out, fast=True)
    assert page == out / "index.html" and page.is_file() and (out / "summary.md").is_file()
    nb = _check_notebook(out / f"{script.stem}.ipynb", script,
                         forbidden=(str(tmp_path), str(ROOT), os.path.expanduser("~") + os.sep, ".new-"))
    assert "fast settings" in nb.cells[0].source
    last = [c for c in nb.cells if c.cell_type == "code"][-1]
    assert "".join(o.get("text", "") for o in last.outputs).strip() == "index.html"
    if script.stem.startswith("lesson2_"):  # the stepper's frames: one animated PNG
        assert any(getattr(img, "n_frames", 1) >= 3 for c in nb.cells for img in _images(c))


TINY = '''# %% [markdown]
# # Lesson 0: a tiny lesson
# Its text, which the notebook must keep as it is.

# %%
from matplotlib.figure import Figure

from boundid.teaching import Handout, output_dir

fig = Figure(figsize=(4, 3), layout="constrained")
ax = fig.subplots()
ax.plot([0, 1], [0, 1])
ax.set_title("a line")

# %%
frames = []
for k in range(3):
    f = Figure(figsize=(4, 3), layout="constrained")
    f.subplots().plot([0, 1], [0, k])
    frames.append(f)

# %%
page = Handout("tiny lesson", "a lesson written by the test").figure(fig, "a line", name="line")
page.stepper(frames, ["a", "b", "c"], "three frames", name="frames")
print(page.write(output_dir("lesson0_tiny") / "index.html"))
'''


def test_figures_show_inline_and_the_index_links_the_notebook(tmp_path):
    """A tiny lesson: the figure its cell creates shows below that cell (and no "Text(...)" line
    for the cell's last expression, a title), the list of frames as one animated PNG of 3 frames,
    the handout cell adds no figure twice; the kit's index links the notebook beside the handout."""
    d = tmp_path / "lessons"
    d.mkdir()
    (d / "lesson0_tiny.py").write_text(TINY)
    pages = run_lessons(d, tmp_path / "out", fast=True)
    assert pages == [tmp_path / "out" / "lesson0_tiny" / "index.html"]
    nb = _check_notebook(tmp_path / "out" / "lesson0_tiny" / "lesson0_tiny.ipynb", d / "lesson0_tiny.py",
                         forbidden=(str(tmp_path),))
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert [len(_images(c)) for c in code] == [1, 1, 0]
    assert not any(o.output_type == "execute_result" for o in code[0].outputs)
    anim = _images(code[1])[0]
    assert anim.n_frames == 3 and anim.size == (400, 300)
    index = (tmp_path / "out" / "index.html").read_text()
    assert 'href="lesson0_tiny/index.html"' in index and 'href="lesson0_tiny/lesson0_tiny.ipynb"' in index


def test_a_relative_output_folder_is_the_callers(tmp_path, monkeypatch):
    """run_lesson with a relative out_dir (as `boundid teach --out build/x` passes it): the kernel runs in
    the lesson's folder, yet the handout lands in the folder relative to the caller's directory."""
    (tmp_path / "lesson0_tiny.py").write_text(TINY)
    monkeypatch.chdir(tmp_path)
    page = run_lesson(Path("lesson0_tiny.py"), Path("rel") / "lesson0_tiny", fast=True)
    assert (tmp_path / page).is_file() and (tmp_path / "rel" / "lesson0_tiny" / "lesson0_tiny.ipynb").is_file()


def test_in_a_notebook_the_handout_goes_to_a_temporary_folder(tmp_path):
    """Opened by a student (no BOUNDID_TEACH_OUT), the handout cell writes into the system's
    temporary folder, not into the notebook's own folder."""
    (tmp_path / "lesson0_tiny.py").write_text(TINY)
    env = {k: v for k, v in os.environ.items() if k != OUT_ENV}
    nb = execute_notebook(lesson_notebook(tmp_path / "lesson0_tiny.py"), tmp_path, env=env)
    printed = Path(nb.cells[-1].outputs[-1].text.strip())
    assert printed.parts[-3:] == ("boundid-teaching", "lesson0_tiny", "index.html") and printed.is_file()
    assert not (tmp_path / "reports").exists() and not (tmp_path / "index.html").exists()


BROKEN = '''# %% [markdown]
# # Lesson 9: broken

# %%
x = 1

# %%
y = x + 1
raise ValueError("bad value\\nin the second cell")
'''


def test_a_failing_cell_is_named_in_one_line(tmp_path, capsys):
    """A lesson whose second code cell raises: StudyError naming the lesson, the cell (In [2]), its
    line in the script and the exception, on one line; no folder is left; the CLI exits 2 with
    that one line."""
    d = tmp_path / "lessons"
    d.mkdir()
    (d / "lesson9_broken.py").write_text(BROKEN)
    with pytest.raises(StudyError) as err:
        run_lesson(d / "lesson9_broken.py", tmp_path / "out" / "lesson9_broken", fast=True)
    msg = str(err.value)
    assert "\n" not in msg
    assert msg.startswith("lesson lesson9_broken.py failed in code cell 2 (In [2], line 9 of lesson9_broken.py")
    assert msg.endswith("ValueError: bad value in the second cell")
    assert not (tmp_path / "out" / "lesson9_broken").exists()
    assert main(["teach", "--lessons", str(d), "--out", str(tmp_path / "reports"), "--fast"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("boundid: error: lesson lesson9_broken.py failed in code cell 2")


def test_missing_nbclient_is_one_line_naming_the_fix(tmp_path, monkeypatch, capsys):
    """Without nbclient (or ipykernel) in this Python: one line naming the pip command, before any
    lesson runs; exit 2."""
    monkeypatch.setitem(sys.modules, "nbclient", None)  # import nbclient then raises ImportError
    (tmp_path / "lesson0_tiny.py").write_text(TINY)
    with pytest.raises(StudyError, match=r"need nbclient, not installed .*pip install nbclient ipykernel"):
        run_lessons(tmp_path, tmp_path / "out")
    assert main(["teach", "--lessons", str(tmp_path), "--out", str(tmp_path / "reports")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "pip install nbclient ipykernel" in lines[0]
    assert not (tmp_path / "reports" / "teaching" / "lesson0_tiny").exists()
