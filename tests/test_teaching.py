"""The teaching kit: every lesson runs as a plain script (fast settings) and writes a handout.

References: the lesson scripts themselves run in a fresh interpreter (as a student would run
them); each handout is checked with independent readers: Python's html.parser for the page
structure, Pillow for every embedded image (it must decode), a regular expression for network
URLs (the page must be self-contained), and jupytext (when installed) for the notebook form.
"""

import base64
import io
import re
from html.parser import HTMLParser
from pathlib import Path

import pytest
from PIL import Image

from boundid.errors import InputError, StudyError
from boundid.teaching import Handout, lessons, run_lesson, run_lessons

ROOT = Path(__file__).resolve().parents[1]
LESSONS = lessons(ROOT / "studies" / "teaching")


class _Imgs(HTMLParser):
    def __init__(self):
        super().__init__()
        self.srcs, self.h2 = [], 0

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.srcs.append(dict(attrs)["src"])
        self.h2 += tag == "h2"


def _check_page(page: Path) -> list[Image.Image]:
    text = page.read_text(encoding="utf-8")
    assert not re.search(r"(src|href)=\"(https?:)?//", text), "the handout loads something from the network"
    assert "http://" not in text.replace("http://www.w3.org", "") and "https://" not in text
    parser = _Imgs()
    parser.feed(text)
    assert parser.srcs, "a handout shows at least one figure"
    images = []
    for src in parser.srcs:
        m = re.fullmatch(r"data:image/(png|gif);base64,([A-Za-z0-9+/=]+)", src)
        assert m, f"image not embedded as base64 PNG/GIF: {src[:60]}"
        img = Image.open(io.BytesIO(base64.b64decode(m.group(2), validate=True)))
        img.load()
        assert img.format.lower() == m.group(1)
        images.append(img)
    assert "Exercises" in text
    return images


@pytest.mark.parametrize("script", LESSONS, ids=[s.stem for s in LESSONS])
def test_lesson_runs_and_writes_a_self_contained_handout(script, tmp_path):
    """Run the lesson with BOUNDID_TEACH_FAST=1 into tmp_path; the page exists, every <img> is a
    data: URI that Pillow decodes, no URL points to the network, the exercises are there, and an
    animation (if any) has several frames and stays under 1 MB."""
    page = run_lesson(script, tmp_path / script.stem, fast=True)
    images = _check_page(page)
    for img in images:
        if img.format == "GIF":
            assert getattr(img, "n_frames", 1) >= 3
    for gif in (page.parent / "figures").glob("*.gif"):
        assert gif.stat().st_size < 1_000_000
    assert (page.parent / "summary.md").is_file()


def test_lessons_are_percent_format_notebooks():
    """Each lesson has # %% cells; jupytext (if installed) reads it as a notebook with code and
    markdown cells."""
    for script in LESSONS:
        text = script.read_text(encoding="utf-8")
        assert text.count("# %%") >= 3 and "# %% [markdown]" in text
    jupytext = pytest.importorskip("jupytext")
    for script in LESSONS:
        nb = jupytext.read(script)
        kinds = {c.cell_type for c in nb.cells}
        assert kinds == {"code", "markdown"}


def test_handout_embeds_a_gif_and_writes_it_beside_the_page(tmp_path):
    """Handout.image: the GIF bytes appear verbatim (base64) in the page and as figures/<name>.gif;
    summary.md links it; bad input raises InputError."""
    frames = [Image.new("P", (8, 8), i) for i in range(3)]
    buf = io.BytesIO()
    frames[0].save(buf, format="GIF", save_all=True, append_images=frames[1:], duration=100, loop=0)
    page = Handout("t").section("s", "text").image(buf.getvalue(), "an animation", name="anim")
    out = page.write(tmp_path / "index.html")
    assert base64.b64encode(buf.getvalue()).decode() in out.read_text()
    assert (tmp_path / "figures" / "anim.gif").read_bytes() == buf.getvalue()
    assert "figures/anim.gif" in (tmp_path / "summary.md").read_text()
    with pytest.raises(InputError):
        Handout("t").image(b"", "empty")
    with pytest.raises(InputError):
        Handout("t").image(b"x", "svg", ext="svg")


def test_runner_reports_a_failing_lesson_and_indexes_handouts(tmp_path):
    """A lesson that raises gives StudyError with its traceback; run_lessons writes an index
    linking the handouts it produced (checked on a tiny lesson written here)."""
    d = tmp_path / "lessons"
    d.mkdir()
    (d / "lesson_bad.py").write_text("raise RuntimeError('boom')\n")
    with pytest.raises(StudyError, match="boom"):
        run_lesson(d / "lesson_bad.py", tmp_path / "bad")
    (d / "lesson_bad.py").unlink()
    (d / "lesson_ok.py").write_text(
        "from boundid.teaching import Handout, output_dir\n"
        "Handout('ok lesson').section('Exercises', 'none').write(output_dir('ok') / 'index.html')\n")
    pages = run_lessons(d, tmp_path / "out", fast=True)
    assert pages == [tmp_path / "out" / "lesson_ok" / "index.html"]
    assert "lesson_ok/index.html" in (tmp_path / "out" / "index.html").read_text()
    with pytest.raises(InputError):
        run_lessons(d, tmp_path / "out", only=["nothing"])
