"""The teaching kit: lessons in ``studies/teaching/lesson*.py`` and their HTML handouts.

A lesson is a percent-format Python script (``# %%`` cells): it runs with plain ``python`` and
opens as a notebook through jupytext. Each builds a :class:`Handout` (a
:class:`boundid.report.Page` with a key-points box, frame steppers and an instructor key) and
writes it to :func:`output_dir`. Two environment variables steer a lesson:

* ``BOUNDID_TEACH_OUT``: the folder its handout goes to (default ``reports/teaching/<lesson>``);
* ``BOUNDID_TEACH_FAST=1``: smaller settings (fewer samples and frames), for the tests.

:func:`run_lessons` runs every lesson as a notebook (:func:`lesson_notebook` converts the script
with jupytext, :func:`execute_notebook` runs it top to bottom with nbclient in a fresh kernel of
this Python) and writes, per lesson, the handout ``index.html`` and the executed notebook
``<lesson>.ipynb`` beside it, then ``<out>/index.html`` linking both. One run makes both, so the
notebook's outputs are the numbers of the handout. :func:`run_lesson` with ``notebook=False`` runs
the plain script instead, in a fresh interpreter. :func:`lessons_dir` finds the lessons when
``boundid teach`` is run from any folder.

In a notebook (an IPython kernel) importing this module also shows every matplotlib
:class:`~matplotlib.figure.Figure` a cell creates below that cell (a list of figures, the frames
of a stepper, as one animated PNG), and :func:`output_dir` without ``BOUNDID_TEACH_OUT`` is a
folder of the system's temporary directory, so the handout cell writes the student's own
handout there, never into the notebook's folder.
"""

from __future__ import annotations

import base64
import hashlib
import html
import io
import os
import re
import subprocess
import sys
import tempfile
import weakref
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from html.parser import HTMLParser
from pathlib import Path

import pandas as pd
from matplotlib.artist import Artist
from matplotlib.figure import Figure
from PIL import Image

from boundid.errors import InputError, StudyError
from boundid.report.figure_check import figure_problems
from boundid.report.html import Page, Table, paragraphs, render_page, site_header, slug
from boundid.report.output import check_out_dir, replace_folder, write_file_atomically
from boundid.resources import find_folder

OUT_ENV, FAST_ENV = "BOUNDID_TEACH_OUT", "BOUNDID_TEACH_FAST"
DEFAULT_OUT = Path("reports/teaching")
LESSONS_SUBDIR = Path("studies/teaching")

# Distinct series in a lesson figure that are not estimators (seeds, shuffles, models): the
# Okabe-Ito colour-blind-safe colours (yellow left out: unreadable on white), each with its own
# marker and dash pattern, so series stay apart in grey print too. Estimators keep
# boundid.report.color_for.
SERIES_STYLES: tuple[dict, ...] = (
    {"color": "#0072B2", "marker": "o", "linestyle": "-"},
    {"color": "#D55E00", "marker": "s", "linestyle": "--"},
    {"color": "#009E73", "marker": "^", "linestyle": "-."},
    {"color": "#CC79A7", "marker": "D", "linestyle": ":"},
    {"color": "#E69F00", "marker": "v", "linestyle": (0, (5, 1.5, 1, 1.5, 1, 1.5))},
    {"color": "#56B4E9", "marker": "P", "linestyle": (0, (8, 2))},
    {"color": "#000000", "marker": "X", "linestyle": (0, (1, 1))},
)


def series_style(i: int) -> dict:
    """Colour, marker and line style of the ``i``-th series of a lesson figure (matplotlib kwargs)."""
    if not 0 <= i < len(SERIES_STYLES):
        raise InputError(f"a lesson figure draws at most {len(SERIES_STYLES)} distinguishable series; got index {i}.")
    return dict(SERIES_STYLES[i])


def fast_mode() -> bool:
    """True when ``BOUNDID_TEACH_FAST=1`` (lessons then use smaller settings)."""
    return os.environ.get(FAST_ENV, "0") == "1"


def output_dir(lesson: str) -> Path:
    """Folder of a lesson's handout: ``$BOUNDID_TEACH_OUT``, else ``reports/teaching/<lesson>`` (a
    script) or ``<temporary directory>/boundid-teaching/<lesson>`` (a notebook, whose own folder
    must not fill with report folders)."""
    if os.environ.get(OUT_ENV):
        return Path(os.environ[OUT_ENV])
    if _kernel() is not None:
        return Path(tempfile.gettempdir()) / "boundid-teaching" / lesson
    return DEFAULT_OUT / lesson


def fmt(x: float, digits: int = 3) -> str:
    """A number for a sentence of a handout: ``digits`` significant digits, no trailing zeros."""
    return f"{x:.{digits}g}"


# --------------------------------------------------------------------------------- page blocks
@dataclass
class _KeyPoints:
    items: list[str]

    def html(self) -> str:
        lis = "".join(f"<li>{html.escape(' '.join(t.split()))}</li>" for t in self.items)
        return f'<div class="keypoints"><p class="kp-head">What this run shows</p><ul>{lis}</ul></div>'

    def markdown(self) -> str:
        return "**What this run shows**\n\n" + "\n".join(f"- {' '.join(t.split())}" for t in self.items)


@dataclass
class _Setup:
    items: dict

    def html(self) -> str:
        rows = "".join(f"<dt>{html.escape(str(k))}</dt><dd>{html.escape(str(v))}</dd>" for k, v in self.items.items())
        return (f'<details class="setup-box"><summary>Set-up of this run</summary><dl class="setup">{rows}</dl>'
                "</details>")

    def markdown(self) -> str:
        return "\n".join(f"- **{k}**: {v}" for k, v in self.items.items())


@dataclass
class _Exercises:
    items: list[tuple[str, str]]

    def html(self) -> str:
        lis = "".join(f"<li>{paragraphs(q)}</li>" for q, _ in self.items)
        return f'<ol class="exercises">{lis}</ol>'

    def markdown(self) -> str:
        return "\n\n".join(f"{k}. {' '.join(q.split())}" for k, (q, _) in enumerate(self.items, 1))


@dataclass
class _Key:
    items: list[tuple[str, str]]

    def html(self) -> str:
        lis = "".join(f'<li><div class="q">{paragraphs(q)}</div><div class="a"><b>Answer.</b>{paragraphs(a)}</div>'
                      "</li>" for q, a in self.items)
        return ('<details class="key"><summary>For instructors: the answers, computed by this run '
                f'(click to open)</summary><ol>{lis}</ol></details>')

    def markdown(self) -> str:
        return "\n\n".join(f"{k}. {' '.join(q.split())}\n\n   **Answer.** {' '.join(a.split())}"
                           for k, (q, a) in enumerate(self.items, 1))


# The stepper's script, the only one a handout runs (the page's CSP allows it by its SHA-256).
# Each <figure class="stepper"> holds its frames as <img> elements, all but one hidden; buttons,
# a slider and the keys (left/right arrows anywhere on the page; Home, End and space when the
# stepper has the focus) choose the frame shown.
_STEPPER_JS = """
(function () {
  "use strict";
  var all = [], current = null;
  function Stepper(root) {
    var frames = root.querySelectorAll(".stepper-frames img");
    var count = root.querySelector(".stepper-count"), label = root.querySelector(".stepper-label");
    var range = root.querySelector("input[type=range]"), play = root.querySelector("[data-step=play]");
    var delay = Number(root.getAttribute("data-delay")) || 900, i = 0, timer = null;
    function show(k) {
      k = Math.max(0, Math.min(frames.length - 1, k));
      frames[i].hidden = true;
      frames[k].hidden = false;
      i = k;
      count.textContent = "frame " + (k + 1) + " of " + frames.length;
      label.textContent = frames[k].getAttribute("data-label");
      range.value = String(k + 1);
      root.setAttribute("data-frame", String(k + 1));
    }
    function stop() {
      if (timer !== null) { clearInterval(timer); timer = null; }
      play.textContent = "\\u25B6 play";
    }
    function start() {
      if (i === frames.length - 1) { show(0); }
      timer = setInterval(function () { if (i === frames.length - 1) { stop(); } else { show(i + 1); } }, delay);
      play.textContent = "\\u275A\\u275A pause";
    }
    this.act = function (a) {
      current = this;
      if (a === "play") { if (timer === null) { start(); } else { stop(); } return; }
      stop();
      show(a === "first" ? 0 : a === "last" ? frames.length - 1 : i + (a === "next" ? 1 : -1));
    };
    var self = this;
    root.addEventListener("click", function (e) {
      var b = e.target.closest("[data-step]");
      if (b) { self.act(b.getAttribute("data-step")); }
    });
    range.addEventListener("input", function () { current = self; stop(); show(Number(range.value) - 1); });
    root.stepper = this;
    show(0);
  }
  function init() {
    var roots = document.querySelectorAll(".stepper");
    for (var k = 0; k < roots.length; k++) { all.push(new Stepper(roots[k])); }
  }
  document.addEventListener("keydown", function (e) {
    if (e.altKey || e.ctrlKey || e.metaKey || !all.length) { return; }
    var t = e.target, inside = t && t.closest ? t.closest(".stepper") : null;
    if (t && t.matches && t.matches("input, textarea, select")) { return; }
    var s = inside ? inside.stepper : current || all[0];
    var a = {ArrowLeft: "prev", ArrowRight: "next"}[e.key];
    if (!a && inside) { a = {Home: "first", End: "last", " ": "play"}[e.key]; }
    if (a) { e.preventDefault(); s.act(a); }
  });
  if (document.readyState === "loading") { document.addEventListener("DOMContentLoaded", init); } else { init(); }
})();
"""
_STEPPER_HASH = base64.b64encode(hashlib.sha256(_STEPPER_JS.encode("utf-8")).digest()).decode("ascii")

_HANDOUT_CSS = """
.keypoints { border-left: 4px solid var(--accent); background: #eef6fb; padding: .6rem 1rem .5rem;
             margin: 1rem 0; border-radius: 0 6px 6px 0; max-width: 80ch; }
.keypoints .kp-head { font-weight: 700; margin: 0 0 .2rem; }
.keypoints ul { margin: .2rem 0; padding-left: 1.2rem; } .keypoints li { margin: .2rem 0; }
details.setup-box > summary, details.key > summary { cursor: pointer; font-weight: 600; color: var(--muted); }
details.key { border: 1px dashed var(--muted); border-radius: 6px; padding: .5rem 1rem; background: #fffdf5; }
details.key[open] > summary { margin-bottom: .5rem; }
details.key li { margin: .8rem 0; } details.key .q { color: var(--muted); }
details.key .a p:first-of-type { display: inline; }
ol.exercises li { margin: .6rem 0; }
figure.stepper { margin: 1.2rem 0; }
.stepper-bar { display: flex; flex-wrap: wrap; align-items: center; gap: .5rem; margin: 0 0 .4rem; }
.stepper-bar button { font: inherit; font-size: .95rem; padding: .3rem .8rem; border: 1px solid var(--line);
                      border-radius: 5px; background: var(--bg-alt); cursor: pointer; }
.stepper-bar button:hover { border-color: var(--accent); }
.stepper-bar input[type=range] { flex: 1 1 12rem; }
.stepper-count { font-variant-numeric: tabular-nums; min-width: 8.5rem; }
.stepper-label { font-weight: 600; margin: .2rem 0 .4rem; min-height: 1.5em; }
.stepper-frames img { display: block; max-width: 100%; height: auto; border: 1px solid var(--line);
                      border-radius: 4px; }
.stepper-frames img[hidden] { display: none; }
figure.stepper:focus { outline: 2px solid var(--accent); outline-offset: 4px; }
"""


@dataclass
class _Stepper:
    frames: list[bytes]  # PNG, all of one size
    labels: list[str]
    caption: str
    name: str
    size: tuple[int, int]
    delay_ms: int
    first_on_page: bool

    def html(self) -> str:
        n, (w, h) = len(self.frames), self.size
        imgs = "".join(
            f'<img src="data:image/png;base64,{base64.b64encode(png).decode("ascii")}" width="{w}" height="{h}" '
            f'alt="{html.escape(lab)}" data-label="{html.escape(lab)}"{" hidden" if k else ""}>'
            for k, (png, lab) in enumerate(zip(self.frames, self.labels, strict=True)))
        cap = html.escape(self.caption)
        script = f"<script>{_STEPPER_JS}</script>" if self.first_on_page else ""
        return (f'<figure class="stepper" id="stepper-{self.name}" tabindex="0" data-delay="{self.delay_ms}" '
                f'aria-label="{cap}"><div class="stepper-bar">'
                '<button type="button" data-step="first" title="first frame (Home)">first</button>'
                '<button type="button" data-step="prev" title="previous frame (left arrow)">&#x25C0; previous</button>'
                '<button type="button" data-step="play" title="play / pause (space)">&#x25B6; play</button>'
                '<button type="button" data-step="next" title="next frame (right arrow)">next &#x25B6;</button>'
                f'<input type="range" min="1" max="{n}" value="1" aria-label="frame">'
                f'<output class="stepper-count">frame 1 of {n}</output></div>'
                f'<p class="stepper-label">{html.escape(self.labels[0])}</p>'
                f'<div class="stepper-frames">{imgs}</div>'
                f'<figcaption><b>Frames.</b> {cap} Keys: left and right arrows step through the frames; '
                f'click the frames first for space (play/pause), Home and End.<span class="files">'
                f'<a href="figures/{self.name}-01.png">PNG frames</a></span></figcaption></figure>{script}')

    def markdown(self) -> str:
        return (f"**Frames.** {self.caption} ({len(self.frames)} frames: "
                f"[first](figures/{self.name}-01.png) ... [last](figures/{self.name}-{len(self.frames):02d}.png))")

    def files(self) -> dict[str, bytes]:
        return {f"{self.name}-{k:02d}.png": png for k, png in enumerate(self.frames, 1)}


_BLOCKS = (_KeyPoints, _Setup, _Exercises, _Key, _Stepper)


def _png(fig: Figure, dpi: int, colors: int) -> tuple[bytes, tuple[int, int]]:
    """A figure as a palette PNG of at most ``colors`` colours (small enough to embed many frames)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, metadata={"Software": None})
    img = Image.open(buf).convert("RGB").quantize(colors=colors, method=Image.Quantize.MEDIANCUT)
    out = io.BytesIO()
    img.save(out, format="PNG", optimize=True)
    return out.getvalue(), img.size


class Handout(Page):
    """A :class:`Page` for a lesson. Beyond Page's sections, texts, tables and figures:

    * :meth:`key_points`: the sentences a reader must take away, in a box on the first screen,
      written by the lesson from its own numbers;
    * :meth:`stepper`: an animation as frames with previous/next/play buttons, a slider, a frame
      counter and arrow keys (a few lines of inline JavaScript, allowed by hash in the page's
      Content-Security-Policy; the page stays self-contained and works from file://);
    * :meth:`exercises`: questions, and the answers the lesson computed in a folded
      "Instructor key" section;
    * every figure and frame is checked by :func:`boundid.report.figure_check.figure_problems`
      (nothing cut off, no overlapping tick labels) before it goes in: InputError otherwise.

    The set-up (``setup``) is shown folded under the key points instead of above the contents.
    """

    css = Page.css + _HANDOUT_CSS
    csp = f"{Page.csp}; script-src 'sha256-{_STEPPER_HASH}'"

    def __init__(self, title: str, description: str = "", *, setup: Mapping[str, object] | None = None, **kwargs):
        kwargs.setdefault("home", "../../index.html")  # a handout lives at reports/teaching/<lesson>/
        kwargs.setdefault("trail", [("teaching kit", "../index.html")])
        super().__init__(title, description, **kwargs)
        self._key_points: _KeyPoints | None = None
        if setup:
            self._sections[0].blocks.append(_Setup(dict(setup)))

    def key_points(self, items: Sequence[str]) -> Handout:
        """The lesson's message, a few sentences (computed from the run's numbers), in a box at the top."""
        if isinstance(items, str) or not items or not all(isinstance(t, str) and t.strip() for t in items):
            raise InputError("Handout.key_points takes a non-empty list of sentences.")
        if self._key_points is not None:
            raise InputError("Handout.key_points was already given; pass every sentence in one call.")
        self._key_points = _KeyPoints(list(items))
        self._sections[0].blocks.insert(0, self._key_points)
        return self

    def figure(self, fig: Figure, caption: str, *, name: str | None = None) -> Handout:
        _check_figure(fig, name or caption)
        return super().figure(fig, caption, name=name)

    def stepper(self, frames: Sequence[Figure], labels: Sequence[str], caption: str, *, name: str,
                dpi: int = 100, delay_ms: int = 900, colors: int = 96) -> Handout:
        """An animation in the current section: one matplotlib figure per frame (all of one size,
        drawn with fixed axes by the caller), ``labels`` one line of text per frame (shown above
        it and as its alt text). Frames are embedded as palette PNGs and written as
        ``figures/<name>-NN.png``. Show it at >= 800 px: e.g. figsize (10, 4.8) at dpi 100."""
        if len(frames) < 2 or len(frames) != len(labels):
            raise InputError(f"Handout.stepper needs >= 2 frames and one label per frame; got {len(frames)} frames "
                             f"and {len(labels)} labels.")
        pngs, sizes = [], set()
        for k, fig in enumerate(frames):
            if not isinstance(fig, Figure):
                raise InputError(f"Handout.stepper: frame {k + 1} is a {type(fig).__name__}, not a matplotlib Figure.")
            _check_figure(fig, f"{name}, frame {k + 1}")
            png, size = _png(fig, dpi, colors)
            pngs.append(png)
            sizes.add(size)
        if len(sizes) != 1:
            raise InputError(f"Handout.stepper: the frames of {name!r} differ in size {sorted(sizes)}; give every "
                             "frame the same figsize (and no tight bounding box), so the axes stay fixed.")
        first = not any(isinstance(b, _Stepper) for s in self._sections for b in s.blocks)
        self._sections[-1].blocks.append(_Stepper(pngs, [str(t) for t in labels], caption,
                                                  slug(name, self._names), sizes.pop(), delay_ms, first))
        return self

    def exercises(self, items: Sequence[tuple[str, str]]) -> Handout:
        """Sections "Exercises" (the questions) and "Instructor key" (each question with the answer
        the lesson computed, folded). ``items``: (question, answer) pairs of plain text."""
        if not items or not all(isinstance(q, str) and isinstance(a, str) and q.strip() and a.strip()
                                for q, a in items):
            raise InputError("Handout.exercises takes a non-empty list of (question, answer) text pairs.")
        self.section("Exercises")
        self._sections[-1].blocks.append(_Exercises(list(items)))
        self.section("Instructor key")
        self._sections[-1].blocks.append(_Key(list(items)))
        return self

    # ------------------------------------------------------------------------------ output
    def _block_html(self, block) -> str:
        if isinstance(block, _BLOCKS):
            return block.html()
        if isinstance(block, Table):  # yes/no on the page; the CSV keeps True/False
            df = block.df.copy()
            for col in df.columns[[pd.api.types.is_bool_dtype(t) for t in df.dtypes]]:
                df[col] = df[col].map({True: "yes", False: "no"})
            block = replace(block, df=df)
        return super()._block_html(block)

    def to_markdown(self) -> str:
        saved = [s.blocks for s in self._sections]
        for s in self._sections:  # the handout's own blocks become Markdown text for Page's rendering
            s.blocks = [b.markdown() if isinstance(b, _BLOCKS) else b for b in s.blocks]
        try:
            return super().to_markdown()
        finally:
            for s, blocks in zip(self._sections, saved, strict=True):
                s.blocks = blocks

    def write(self, path: str | Path) -> Path:
        out = super().write(path)
        steppers = [b for s in self._sections for b in s.blocks if isinstance(b, _Stepper)]
        if steppers:
            (out.parent / "figures").mkdir(exist_ok=True)
        for st in steppers:
            for name, png in st.files().items():
                (out.parent / "figures" / name).write_bytes(png)
        return out


def _check_figure(fig: Figure, what: str) -> None:
    problems = figure_problems(fig)
    if problems:
        raise InputError(f"figure {what!r} cuts off or overlaps what a reader must read: " + "; ".join(problems)
                         + ". Put legends outside the axes with fig.legend(loc='outside ...') and a constrained "
                           "layout, and use fewer ticks or a larger figure.")


# --------------------------------------------------------------------------------- running
def lessons_dir(directory: str | Path | None = None) -> Path:
    """The folder of the lesson scripts: ``directory`` if given, else ``studies/teaching`` of the
    current folder or of the boundid checkout the package runs from (see
    :func:`boundid.resources.find_folder`)."""
    return find_folder(LESSONS_SUBDIR, "lesson*.py", directory, what="lesson scripts", option="--lessons")


def lessons(directory: str | Path | None = None) -> list[Path]:
    """The lesson scripts ``lesson*.py`` of ``directory`` (default :func:`lessons_dir`), in name order."""
    return sorted(lessons_dir(directory).glob("lesson*.py"))


def run_lesson(script: str | Path, out_dir: str | Path, fast: bool = False, timeout: float = 600.0,
               notebook: bool = True) -> Path:
    """Run one lesson; returns its handout page ``<out_dir>/index.html``.

    ``notebook=True``: the lesson runs as a notebook (:func:`lesson_notebook`,
    :func:`execute_notebook`, a fresh kernel started in the lesson's folder) and the executed
    notebook is written beside the handout as ``<out_dir>/<lesson>.ipynb``; ``notebook=False``: the
    script runs with ``python`` in a fresh interpreter, as ``python lesson.py`` would. The files
    go into a fresh folder that replaces ``out_dir`` as a whole once the lesson succeeded
    (:func:`boundid.report.output.replace_folder`: no file of an earlier run is left behind, and a
    failed run leaves the previous handout as it was). Raises :class:`StudyError` when the lesson
    fails (naming the cell, for a notebook) or writes no page. ``timeout``: seconds for the
    script, or for each cell of the notebook.
    """
    script, out_dir = Path(script), Path(out_dir)
    if notebook:
        _notebook_tools()
    with replace_folder(out_dir) as tmp:
        env = {**os.environ, OUT_ENV: str(Path(tmp).resolve()), FAST_ENV: "1" if fast else "0"}
        if notebook:
            nb = execute_notebook(lesson_notebook(script, fast), tmp, env=env, timeout=timeout, name=script.name)
            _relative_paths(nb, tmp)
            _write_notebook(nb, tmp / f"{script.stem}.ipynb")
            if not (tmp / "index.html").is_file():
                raise StudyError(f"lesson {script.name} ran as a notebook but wrote no handout: its last cell must "
                                 "write the Handout to output_dir(...) / 'index.html'.")
        else:
            res = subprocess.run([sys.executable, str(script)], env={**env, "MPLBACKEND": "Agg"},
                                 capture_output=True, text=True, timeout=timeout)
            if res.returncode != 0 or not (tmp / "index.html").is_file():
                raise StudyError(f"lesson {script.name} failed (exit {res.returncode}):\n{res.stderr[-3000:]}")
    return out_dir / "index.html"


def run_lessons(directory: str | Path | None = None, out: str | Path = DEFAULT_OUT, fast: bool = False,
                only: list[str] | None = None, notebook: bool = True) -> list[Path]:
    """Run the lessons (all, or those whose file stem contains one of ``only``), writing each
    handout to ``<out>/<stem>/index.html``, its executed notebook to ``<out>/<stem>/<stem>.ipynb``
    (unless ``notebook=False``) and ``<out>/index.html`` linking them."""
    found = lessons(directory)
    scripts = [s for s in found if not only or any(o in s.stem for o in only)]
    if not scripts:
        raise InputError(f"no lesson matches {only}; lessons: {[s.stem for s in found]}.")
    check_out_dir(out, tuple(s.stem for s in scripts))
    if notebook:
        _notebook_tools()  # before the first lesson: a missing package is one line, not a traceback
    pages = [run_lesson(s, Path(out) / s.stem, fast, notebook=notebook) for s in scripts]
    write_kit_index(out)
    return pages


KIT_DESCRIPTION = ("Handouts of the boundid lessons: feasible sets, OBE, the factorized form, statistics versus "
                   "bounds, and the direct-drive arm's regression models. Each handout is one self-contained page "
                   "(it works offline) with exercises and an instructor key; beside it, the lesson as a Jupyter "
                   "notebook (.ipynb) that a student opens, runs top to bottom and changes.")


class _Head(HTMLParser):
    """<title> and <meta name="description"> of a written handout."""

    def __init__(self):
        super().__init__()
        self.title, self.description, self._in_title = "", "", False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self._in_title = tag == "title"
        if tag == "meta" and a.get("name") == "description":
            self.description = a.get("content") or ""

    def handle_endtag(self, tag):
        self._in_title = False

    def handle_data(self, data):
        if self._in_title:
            self.title += data


def write_kit_index(out: str | Path = DEFAULT_OUT, title: str = "boundid teaching kit") -> Path:
    """``<out>/index.html``: every handout ``<out>/*/index.html`` with its title and description,
    a link to it and, where there is one, to the lesson's notebook ``<out>/<lesson>/<lesson>.ipynb``."""
    root = Path(out)
    items = []
    for page in sorted(root.glob("*/index.html")):
        name, head = page.parent.name, _Head()
        head.feed(page.read_text(encoding="utf-8"))
        links = [("handout (HTML page)", f"{name}/index.html")]
        if (page.parent / f"{name}.ipynb").is_file():
            links.append(("notebook (.ipynb: open it in Jupyter, run it, change it)", f"{name}/{name}.ipynb"))
        more = "".join(f'<a href="{html.escape(h)}">{html.escape(label)}</a>' for label, h in links)
        items.append(f'<div class="entry"><h3><a href="{html.escape(name)}/index.html">'
                     f"{html.escape(head.title.strip() or name)}</a><code>{html.escape(name)}</code></h3>"
                     f'{paragraphs(head.description)}<p class="links">{more}</p></div>')
    root.mkdir(parents=True, exist_ok=True)
    return write_file_atomically(root / "index.html", render_page(
        title, paragraphs(KIT_DESCRIPTION) + "".join(items), description=KIT_DESCRIPTION,
        header=site_header(title, "../index.html")))


# --------------------------------------------------------------------------------- notebooks
#: the kernel a lesson notebook names: the generic one every Jupyter has, so a student's opens it
NOTEBOOK_KERNEL = {"name": "python3", "display_name": "Python 3 (ipykernel)", "language": "python"}
_INSTALL_FIX = "python -m pip install nbclient ipykernel"


def _notebook_tools():
    """(jupytext, nbformat, nbclient) or StudyError naming the install command (one line)."""
    missing = []
    for module in ("jupytext", "nbformat", "nbclient", "ipykernel", "jupyter_client"):
        try:
            __import__(module)
        except ImportError:
            missing.append(module)
    if missing:
        raise StudyError(f"the lessons run as notebooks and need {', '.join(missing)}, not installed in this Python "
                         f"({sys.executable}): run `{_INSTALL_FIX} jupytext` (or `make install`).")
    import jupytext
    import nbclient
    import nbformat

    return jupytext, nbformat, nbclient


def _cell_lines(text: str) -> list[int]:
    """First line (1-based) of each cell of a percent-format script, as jupytext splits it: a cell
    starts at each ``# %%`` line, and text before the first one (if any) is a cell of its own."""
    lines = text.splitlines()
    marks = [k + 1 for k, line in enumerate(lines) if line.startswith("# %%")]
    if any(line.strip() for line in lines[:(marks[0] - 1) if marks else len(lines)]):
        marks.insert(0, 1)
    return marks


def _title(nb) -> str:
    for cell in nb.cells:
        if cell.cell_type == "markdown":
            m = re.search(r"^#\s+(.+)$", cell.source, re.M)
            if m:
                return m.group(1).strip()
    return ""


def lesson_notebook(script: str | Path, fast: bool = False):
    """The lesson ``script`` as an nbformat v4 notebook (jupytext), not executed: the lesson's own
    cells, after one added markdown cell saying what the lesson is and how to run it; metadata
    naming the generic ``python3`` kernel (no jupytext pairing); cell ids ``cell-<k>``. Each
    lesson cell keeps the line it starts at in the script as ``metadata.boundid.line`` until the
    notebook is written."""
    jupytext, nbformat, _ = _notebook_tools()
    script = Path(script)
    text = script.read_text(encoding="utf-8")
    nb = jupytext.reads(text, fmt="py:percent")
    lines = _cell_lines(text)
    if len(lines) == len(nb.cells):
        for cell, line in zip(nb.cells, lines, strict=True):
            cell.metadata["boundid"] = {"line": line}
    title = _title(nb) or script.stem
    settings = ("It was run here with the fast settings (`BOUNDID_TEACH_FAST=1`: fewer samples and frames); "
                "without that variable it uses the full settings of the handout." if fast else
                "It was run here with the full settings, the numbers of its handout; start Jupyter with "
                "`BOUNDID_TEACH_FAST=1` set for smaller, quicker settings.")
    where = " (in `studies/teaching/` of the boundid repository)" if script.parent.parts[-2:] == LESSONS_SUBDIR.parts \
        else ""
    intro = (f"**boundid teaching kit, {title}.** This notebook is the lesson script `{script.name}`{where}, "
             "converted to a notebook and run top to bottom: the outputs below are that run's. "
             f"{settings}\n\n"
             "**To run it**, open it in Jupyter (JupyterLab, Notebook or VS Code) with a Python 3 kernel that can "
             "`import boundid` (the repository's `.venv` after `make install`), then *Restart the kernel and run "
             "all cells*. Change a number (the settings are in the first code cell) and run the cells again: every "
             "figure and table below follows. The last cell writes the handout of your run, an HTML page, to a "
             "temporary folder and prints its path; the handout of the run shown here is `index.html` beside this "
             "notebook.")
    nb.cells.insert(0, nbformat.v4.new_markdown_cell(intro))
    for k, cell in enumerate(nb.cells):  # stable ids (not random ones): a rerun changes only what changed
        cell.id = f"cell-{k}"
    nb.metadata = nbformat.from_dict({"kernelspec": dict(NOTEBOOK_KERNEL),
                                      "language_info": {"name": "python"}})
    nbformat.validate(nb)
    return nb


def _kernel_manager():
    """A kernel manager that starts ``python -m ipykernel_launcher`` with this Python
    (``sys.executable``), whatever the ``python3`` kernel spec found on the Jupyter path says."""
    from jupyter_client.kernelspec import KernelSpec, KernelSpecManager
    from jupyter_client.manager import AsyncKernelManager

    class _ThisPython(KernelSpecManager):
        def get_kernel_spec(self, kernel_name, *args, **kwargs):
            return KernelSpec(argv=[sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
                              name=NOTEBOOK_KERNEL["name"], display_name=NOTEBOOK_KERNEL["display_name"],
                              language="python")

    return AsyncKernelManager(kernel_name=NOTEBOOK_KERNEL["name"], kernel_spec_manager=_ThisPython())


_ANSI = re.compile(r"\x1b\[[0-9;]*m")


def execute_notebook(nb, cwd: str | Path, env: Mapping[str, str] | None = None, timeout: float = 600.0,
                     name: str = "notebook"):
    """Run ``nb`` top to bottom with nbclient in a fresh kernel of this Python started in ``cwd``
    (environment ``env``, default this process's); returns it with its outputs. A cell that raises,
    a cell running longer than ``timeout`` seconds or a kernel that dies gives a one-line
    :class:`StudyError` naming ``name``, the code cell (its number In [k]) and its line in the
    script."""
    _, _, nbclient = _notebook_tools()
    from nbclient.exceptions import CellExecutionError, CellTimeoutError, DeadKernelError

    env = dict(os.environ if env is None else env)
    env.pop("MPLBACKEND", None)  # the kernel's default (inline), as in a student's Jupyter
    env.setdefault("PYDEVD_DISABLE_FILE_VALIDATION", "1")  # no debugger warning on the kernel's stderr
    client = nbclient.NotebookClient(nb, km=_kernel_manager(), timeout=timeout, startup_timeout=120,
                                     kernel_name=NOTEBOOK_KERNEL["name"], allow_errors=False,
                                     record_timing=False, resources={"metadata": {"path": str(cwd)}})
    with tempfile.TemporaryFile("w+", encoding="utf-8", errors="replace") as log:  # the kernel's own output
        try:
            client.execute(env=env, stdout=log, stderr=log)
        except (CellExecutionError, CellTimeoutError, DeadKernelError) as exc:
            tail = _log_tail(log) if isinstance(exc, DeadKernelError) else ""
            raise StudyError(_failure(nb, name, exc, timeout) + (f" (kernel output: {tail})" if tail else "")) \
                from None
        except (RuntimeError, TimeoutError) as exc:  # no kernel: ipykernel broken, startup timed out
            tail = _log_tail(log)
            raise StudyError(f"lesson {name}: no kernel of {sys.executable} could be started "
                             f"({type(exc).__name__}: {' '.join(str(exc).split())[:200]}"
                             + (f"; kernel output: {tail}" if tail else "") + f"); try `{_INSTALL_FIX}`.") from None
        finally:
            nb.metadata.get("kernelspec", {}).update(NOTEBOOK_KERNEL)
    return nb


def _log_tail(log) -> str:
    """The end of what the kernel process printed, on one line, without ipykernel's TCP warning."""
    log.seek(0)
    lines = [ln for ln in log.read().splitlines() if "running over TCP without encryption" not in ln]
    return " ".join(" ".join(lines).split())[-300:]


def _failure(nb, name: str, exc: BaseException, timeout: float) -> str:
    """One line: which lesson, which code cell (In [k]) at which script line, and why."""
    code = [c for c in nb.cells if c.cell_type == "code"]
    failed = next((c for c in code if any(o.get("output_type") == "error" for o in c.get("outputs", ()))), None)
    if failed is None:  # a timeout or a dead kernel: the last code cell that started
        failed = next((c for c in reversed(code) if c.get("execution_count") is not None), None)
    if failed is None:
        return f"lesson {name} failed to run as a notebook: {type(exc).__name__}: {' '.join(str(exc).split())[:300]}"
    k = code.index(failed) + 1
    first = next((ln.strip() for ln in failed.source.splitlines() if ln.strip()), "")
    where = f"code cell {k} (In [{k}]"
    line = failed.metadata.get("boundid", {}).get("line")
    if line is not None:
        err = next((o for o in failed.outputs if o.get("output_type") == "error"), None)
        in_cell = None
        if err is not None:  # "Cell In[k], line n" of the traceback: the line within the cell
            hits = re.findall(r"Cell In\[\d+\], line (\d+)", _ANSI.sub("", "\n".join(err.get("traceback", []))))
            in_cell = int(hits[-1]) if hits else None
        where += f", line {line + (in_cell or 1)} of {name}" if in_cell else f", starting at line {line + 1} of {name}"
    where += f": `{first[:60]}`)"
    err = next((o for o in failed.get("outputs", ()) if o.get("output_type") == "error"), None)
    if err is not None:
        why = f"{err.get('ename')}: {' '.join(str(err.get('evalue', '')).split())[:300]}"
    elif type(exc).__name__ == "CellTimeoutError":
        why = f"it ran longer than {timeout:g} s"
    else:
        why = f"{type(exc).__name__}: {' '.join(str(exc).split())[:200]}"
    return f"lesson {name} failed in {where}: {why}"


def _relative_paths(nb, folder: Path) -> None:
    """Outputs name files of the lesson's folder relative to it (the notebook's own folder), not by
    the temporary path the run wrote them to."""
    prefixes = sorted({str(folder) + os.sep, str(folder.resolve()) + os.sep}, key=len, reverse=True)
    for cell in nb.cells:
        for out in cell.get("outputs", ()):
            if "text" in out:
                for pre in prefixes:
                    out["text"] = out["text"].replace(pre, "")
            for mime, value in out.get("data", {}).items():
                if mime.startswith("text/") and isinstance(value, str):
                    for pre in prefixes:
                        value = value.replace(pre, "")
                    out["data"][mime] = value


def _write_notebook(nb, path: Path) -> Path:
    _, nbformat, _ = _notebook_tools()
    for cell in nb.cells:
        cell.metadata.pop("boundid", None)
    nbformat.validate(nb)
    nbformat.write(nb, str(path))
    return path


# --------------------------------------------------------------------------------- in a kernel
def _kernel():
    """The IPython shell of the Jupyter kernel this code runs in, or None (a script, a terminal)."""
    ipython = sys.modules.get("IPython")
    shell = ipython.get_ipython() if ipython is not None else None
    return shell if getattr(shell, "kernel", None) is not None else None


_shown: weakref.WeakSet = weakref.WeakSet()


def _figure_png(fig: Figure) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    _shown.add(fig)
    return buf.getvalue()


def _frames_png(frames: Sequence[Figure], delay_ms: int = 900, colors: int = 96) -> bytes:
    """Frames of one size as one animated PNG (browsers and Jupyter play it), in one palette of
    ``colors`` colours drawn from all frames (a few hundred kB for twenty frames)."""
    imgs = [Image.open(io.BytesIO(_figure_png(f))).convert("RGB") for f in frames]
    w, h = imgs[0].size
    every = Image.new("RGB", (w, h * len(imgs)))
    for k, img in enumerate(imgs):
        every.paste(img, (0, k * h))
    palette = every.quantize(colors=colors, method=Image.Quantize.MEDIANCUT)
    frames_p = [img.quantize(palette=palette) for img in imgs]
    out = io.BytesIO()
    frames_p[0].save(out, format="PNG", save_all=True, append_images=frames_p[1:], duration=delay_ms, loop=0)
    return out.getvalue()


def _show_new_figures(*_args) -> None:
    """After a cell: show the figures created by it that are bound to a name of the notebook and
    not yet shown (pyplot's own figures are left to the inline backend); a list of figures of one
    size (the frames of a stepper) shows as one animated PNG."""
    shell = _kernel()
    if shell is None:
        return
    from IPython.display import display

    for value in list(shell.user_ns.values()):
        if isinstance(value, list | tuple) and len(value) > 1 and all(isinstance(f, Figure) for f in value):
            if any(f not in _shown and f.canvas.manager is None for f in value):
                sizes = {tuple(f.get_size_inches()) + (f.dpi,) for f in value}
                if len(sizes) == 1:
                    display({"image/png": _frames_png(value)}, raw=True)
                else:
                    for f in value:
                        display({"image/png": _figure_png(f)}, raw=True)
    for value in list(shell.user_ns.values()):
        if isinstance(value, Figure) and value not in _shown and value.canvas.manager is None:
            display({"image/png": _figure_png(value)}, raw=True)


def _in_kernel_setup() -> None:
    """In a Jupyter kernel: a figure as a cell's value shows as a PNG, other matplotlib artists
    (a title, a legend) as a cell's value show nothing, and figures a cell creates show below it
    (:func:`_show_new_figures`). Registered once per kernel."""
    shell = _kernel()
    if shell is None or getattr(shell, "_boundid_teaching", False):
        return
    shell._boundid_teaching = True
    shell.display_formatter.formatters["image/png"].for_type(Figure, _figure_png)
    # a cell ending in ax.legend(...) or fig.supylabel(...) shows no "Text(0.02, 0.5, ...)" line
    shell.display_formatter.ipython_display_formatter.for_type(Artist, lambda _artist: None)
    shell.events.register("post_run_cell", _show_new_figures)


_in_kernel_setup()
