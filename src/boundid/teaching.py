"""The teaching kit: lessons in ``studies/teaching/lesson*.py`` and their HTML handouts.

A lesson is a percent-format Python script (``# %%`` cells): it runs with plain ``python`` and
opens as a notebook through jupytext. Each builds a :class:`Handout` (a
:class:`boundid.report.Page` that can also embed animated GIFs) and writes it to
:func:`output_dir`. Two environment variables steer a lesson:

* ``BOUNDID_TEACH_OUT``: the folder its handout goes to (default ``reports/teaching/<lesson>``);
* ``BOUNDID_TEACH_FAST=1``: smaller settings (fewer samples and frames), for the tests.

:func:`run_lessons` runs every lesson in a subprocess (a clean interpreter each, as a student
would) and writes ``<out>/index.html`` linking the handouts.
"""

from __future__ import annotations

import base64
import html
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from boundid.errors import InputError, StudyError
from boundid.report.html import Page, _slug, write_index

OUT_ENV, FAST_ENV = "BOUNDID_TEACH_OUT", "BOUNDID_TEACH_FAST"
DEFAULT_OUT = Path("reports/teaching")
DEFAULT_LESSONS = Path("studies/teaching")


def fast_mode() -> bool:
    """True when ``BOUNDID_TEACH_FAST=1`` (lessons then use smaller settings)."""
    return os.environ.get(FAST_ENV, "0") == "1"


def output_dir(lesson: str) -> Path:
    """Folder of a lesson's handout: ``$BOUNDID_TEACH_OUT`` or ``reports/teaching/<lesson>``."""
    return Path(os.environ.get(OUT_ENV) or DEFAULT_OUT / lesson)


@dataclass
class _Image:
    data: bytes
    mime: str
    ext: str
    caption: str
    name: str


class Handout(Page):
    """A :class:`Page` that can also hold raw images (an animated GIF): :meth:`image` embeds the
    bytes as a base64 ``data:`` URI (allowed by the page's Content-Security-Policy) and
    :meth:`write` also saves them as ``figures/<name>.<ext>``. Page itself only takes matplotlib
    figures, which it renders to PNG; an animation has to come in as encoded bytes."""

    _MIME = {"gif": "image/gif", "png": "image/png"}

    def image(self, data: bytes, caption: str, *, ext: str = "gif", name: str | None = None) -> Handout:
        """An encoded image (``ext`` "gif" or "png") in the current section."""
        if ext not in self._MIME:
            raise InputError(f"Handout.image takes {sorted(self._MIME)} bytes, got ext={ext!r}.")
        if not isinstance(data, bytes | bytearray) or not data:
            raise InputError("Handout.image needs the encoded image as non-empty bytes.")
        self._sections[-1].blocks.append(
            _Image(bytes(data), self._MIME[ext], ext, caption, _slug(name or caption, self._names)))
        return self

    def _block_html(self, block) -> str:
        if not isinstance(block, _Image):
            return super()._block_html(block)
        data = base64.b64encode(block.data).decode("ascii")
        cap = html.escape(block.caption)
        return (f'<figure class="fig" id="fig-{block.name}"><img src="data:{block.mime};base64,{data}" '
                f'alt="{cap}"><figcaption><b>Animation.</b> {cap}<span class="files">'
                f'<a href="figures/{block.name}.{block.ext}">{block.ext.upper()}</a></span></figcaption></figure>')

    def _images(self) -> list[_Image]:
        return [b for s in self._sections for b in s.blocks if isinstance(b, _Image)]

    def to_markdown(self) -> str:
        saved = [s.blocks for s in self._sections]
        for s in self._sections:  # images become Markdown links for Page's text rendering
            s.blocks = [f"![{b.caption}](figures/{b.name}.{b.ext})" if isinstance(b, _Image) else b for b in s.blocks]
        try:
            return super().to_markdown()
        finally:
            for s, blocks in zip(self._sections, saved, strict=True):
                s.blocks = blocks

    def write(self, path: str | Path) -> Path:
        out = super().write(path)
        if self._images():
            (out.parent / "figures").mkdir(exist_ok=True)
        for b in self._images():
            (out.parent / "figures" / f"{b.name}.{b.ext}").write_bytes(b.data)
        return out


def lessons(directory: str | Path = DEFAULT_LESSONS) -> list[Path]:
    """The lesson scripts ``lesson*.py`` of ``directory``, in name order."""
    found = sorted(Path(directory).glob("lesson*.py"))
    if not found:
        raise InputError(f"no lesson*.py scripts in {directory}; run from the repository root or pass the folder.")
    return found


def run_lesson(script: str | Path, out_dir: str | Path, fast: bool = False, timeout: float = 600.0) -> Path:
    """Run one lesson script with ``python`` (a fresh interpreter); returns its handout page.

    Raises :class:`StudyError` with the end of the script's stderr when it fails or writes no page.
    """
    script, out_dir = Path(script), Path(out_dir)
    env = {**os.environ, OUT_ENV: str(out_dir), FAST_ENV: "1" if fast else "0", "MPLBACKEND": "Agg"}
    res = subprocess.run([sys.executable, str(script)], env=env, capture_output=True, text=True, timeout=timeout)
    page = out_dir / "index.html"
    if res.returncode != 0 or not page.is_file():
        raise StudyError(f"lesson {script.name} failed (exit {res.returncode}):\n{res.stderr[-3000:]}")
    return page


def run_lessons(directory: str | Path = DEFAULT_LESSONS, out: str | Path = DEFAULT_OUT, fast: bool = False,
                only: list[str] | None = None) -> list[Path]:
    """Run the lessons (all, or those whose file stem contains one of ``only``), writing each
    handout to ``<out>/<stem>/index.html`` and ``<out>/index.html`` linking them."""
    scripts = [s for s in lessons(directory) if not only or any(o in s.stem for o in only)]
    if not scripts:
        raise InputError(f"no lesson matches {only}; lessons: {[s.stem for s in lessons(directory)]}.")
    pages = [run_lesson(s, Path(out) / s.stem, fast) for s in scripts]
    write_index(out, None, title="boundid teaching kit",
                description="Handouts of the boundid lessons: feasible sets, OBE, the factorized form, "
                            "statistics versus bounds, and the direct-drive arm's regression models.")
    return pages
