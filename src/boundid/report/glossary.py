"""The glossary and the bibliography of the report site, and the links from a page's prose to them.

* :data:`GLOSSARY`: every term the study pages use without defining it (gamma*, e_max, the exact
  polytope, the raw set and "∩ prior box", the set families, guaranteed / statistical / unverified
  ...), each with a one or two sentence definition and, where one applies, its key in
  ``docs/references.md``. :func:`glossary_body` renders it as ``reports/glossary.html``.
* :func:`references` parses ``docs/references.md`` (the repository's bibliography: entries
  ``- **[Key]** Authors. *Title.* Venue, year, pages. What boundid takes from it.`` and sections
  ``### refs §X: ...``); nothing of it is copied here. :func:`full_reference` gives one entry's
  authors, title, venue and year; :func:`references_body` renders the whole file as
  ``reports/references.html``, one anchor per key (``#H4Paper``) and per section (``#refs-LP``).
* :class:`Linker` turns a page's plain text into escaped HTML in which the first occurrence of each
  glossary term links to its entry and every citation ``[Key]`` or ``[refs §LP]`` of
  ``docs/references.md`` links to the references page.

Matching rules of :class:`Linker` (each term has one or more written *forms*):

* whole words: the characters either side of a match are neither a letter, a digit, ``_`` nor
  ``-`` (so ``gamma*_j``, ``e_max_rule`` and ``non-outlier`` do not match ``gamma*``, ``e_max``,
  ``outlier``);
* case: a form starting with a lower-case letter also matches with that letter capitalised (at the
  start of a sentence); otherwise a form matches exactly as written (``Box``, the estimator, is not
  the ``box`` of "prior box");
* the longest form wins where forms overlap ("OBE ∩ prior box" before "∩ prior box" before "prior
  box"); a term links once per page, at its first occurrence in document order, later ones stay
  text;
* only text given to :meth:`Linker.text` (paragraphs, captions, the set-up box) and whole table
  cells given to :meth:`Linker.cell` (header cells and the first, label, column) link: never a
  heading, the navigation bar, an existing link or a number.
"""

from __future__ import annotations

import html
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from boundid.errors import InputError
from boundid.resources import checkout_root

#: the two site pages, beside the site index reports/index.html
GLOSSARY_PAGE, REFERENCES_PAGE = "glossary.html", "references.html"


@dataclass(frozen=True)
class Term:
    """One glossary entry: ``name`` its heading, ``anchor`` its id on the glossary page,
    ``definition`` one or two sentences (plain text; citations as ``[Key]``), ``ref`` its key or
    section in docs/references.md (``"H4Paper"``, ``"refs §LP"``) or None, ``forms`` the ways the
    pages write it (see the module docstring for how they match)."""

    name: str
    anchor: str
    definition: str
    forms: tuple[str, ...]
    ref: str | None = None


GLOSSARY: tuple[Term, ...] = (
    Term("gamma*", "gamma-star",
         "The smallest error bound the data allow: the largest row residual max_k |y_k - w_k^T theta| / s_k of the "
         "Chebyshev (minimax) fit over the prior box, one LP. The feasible set is non-empty iff e_max >= gamma* (in "
         "the same row proportions s_k); gamma* is a lower bound on the true errors' largest value, never an "
         "estimate of it.",
         ("gamma*",), "refs §LP"),
    Term("Chebyshev fit", "chebyshev-fit",
         "The parameter vector of the prior box that minimises the largest (scaled) row residual; that residual is "
         "gamma*. The rows at that level (the active strips) decide gamma*.",
         ("Chebyshev fit", "Chebyshev (minimax) fit", "minimax fit"), "refs §LP"),
    Term("e_max (error bound)", "e-max",
         "The error bound: every row's error is assumed to satisfy |y_k - w_k^T theta| <= e_max (one number, or one "
         "per joint's rows; a study may set it by a rule, e_max = factor x gamma*). Every guaranteed set rests on "
         "it: it must hold at the truth on every row.",
         ("e_max", "error bound", "error bounds")),
    Term("strip", "strip",
         "The parameter vectors one row allows under the bound, {theta : |y_k - w_k^T theta| <= e_max_k}: the slab "
         "between two parallel hyperplanes.",
         ("strip", "strips")),
    Term("prior box", "prior-box",
         "What is known before the data: an interval for each parameter (the study's [prior], e.g. a-priori values "
         "+- 150 %). The exact polytope lies in it; the recursive sets start from it (the OBE from the ellipsoid "
         "that circumscribes it).",
         ("prior box",)),
    Term("exact polytope (feasible set)", "exact-polytope",
         "Every parameter vector consistent with the data under the bound: the intersection of all rows' strips with "
         "the prior box, a convex polytope (empty iff gamma* > 1). Every guaranteed set must contain it; the pages "
         "certify each one against it.",
         ("exact polytope", "feasible polytope", "feasible set", "feasible sets", "feasible parameter set"),
         "refs §LP"),
    Term("LP bounds (exact interval hull)", "lp-bounds",
         "The exact interval hull of the exact polytope: each parameter's minimum and maximum over it, 2p linear "
         "programs (labelled \"LP exact\"). No interval enclosure of the polytope is narrower; the pages divide "
         "every set's widths by these.",
         ("LP bounds", "exact LP bounds", "LP exact", "LP box", "exact LP interval", "LP interval",
          "exact LP width", "LP width"), "refs §LP"),
    Term("design set (excitation design)", "design-set",
         "What a trajectory can guarantee before any data: D = {d : |W d| <= e_max, |d_j| <= r_j}, W the "
         "inverse-dynamic rows of its noise-free motion, r the prior half-widths. It is the exact polytope about the "
         "truth when the errors are zero and the truth is at the prior's centre; for any errors within the bound "
         "(and the truth in the prior box) the exact polytope of those rows lies within the truth + 2 D. Its LP "
         "widths over the prior widths (design widths) score the trajectory; twice a design width below 0.99 of the "
         "prior width narrows that parameter for certain.",
         ("design set", "design sets", "design width", "design widths", "narrowed for certain",
          "narrows for certain"), "refs §LP"),
    Term("raw set", "raw-set",
         "A recursive estimator's set as the estimator returns it, not intersected with the prior box; its intervals "
         "may reach outside the box (the OBE forgets the box after its first ellipsoid).",
         ("raw set", "raw sets")),
    Term("∩ prior box", "cap-prior-box",
         "Intersected with the prior box: the truth lies in a guaranteed set and, under the prior, in the box, so in "
         "both; widths \"∩ prior box\" are those of the set's intervals clipped to the box, the raw set's are given "
         "beside them.",
         ("∩ prior box", "intersected with the prior box")),
    Term("OBE (optimal bounding ellipsoid)", "obe",
         "The recursive ellipsoid estimator: each row's strip is intersected with the current ellipsoid and the "
         "intersection enclosed in the ellipsoid of least volume of the OBE pencil (or least trace, or least sigma). "
         "A row whose strip misses the ellipsoid is an outlier and is skipped.",
         ("OBE", "OBEs"), "FogelHuang1982"),
    Term("OBE standard", "obe-standard",
         "The OBE with centre, sigma and M^-1 kept by Sherman-Morrison ([H4Paper] eqs. 28-30). Cheap, but each "
         "rank-one downdate subtracts and loses digits; when its bound on its own rounding error grows too large "
         "its set is reported unverified.",
         ("OBE-standard", "OBE standard", "standard-form OBE", "standard OBE"), "H4Paper"),
    Term("OBE factorized", "obe-factorized",
         "The same OBE recursion in square-root information form (M = X^T X, X triangular, each update a QR by "
         "Givens rotations; [H4Paper] eqs. 33-35, [LesecqBarraud]): it adds, never subtracts, so M stays positive "
         "definite and accurate. The H4 paper's estimator.",
         ("OBE-factorized", "OBE factorized", "factorized OBE"), "H4Paper"),
    Term("OBE ∩ prior box", "obe-prior-box",
         "The OBE variant that keeps the prior box in the recursion: the box's p sides enter as strips before the "
         "first row and again every few rows, so the ellipsoid always encloses ellipsoid ∩ prior box (the plain OBE "
         "forgets the box).",
         ("OBE ∩ prior box",), "refs §OBE"),
    Term("Box", "box",
         "The box (interval) recursion: each row replaces the box by the exact interval hull of box ∩ strip; 2p "
         "numbers kept, O(p) per row.",
         ("Box", "box recursion")),
    Term("Parallelotope", "parallelotope",
         "The parallelotope recursion (c + G times the unit box, G invertible): each row keeps, of the p + 1 "
         "parallelotopes bounded by p of the p + 1 tightened strips (its p sides and the new strip), the one of "
         "least volume.",
         ("parallelotope", "parallelotopes"), "VicinoZappa1996"),
    Term("Zonotope", "zonotope",
         "The zonotope recursion (a centre plus a sum of at most 2p segments): each row keeps the enclosure of "
         "zonotope ∩ strip of least total segment length, its generators then reduced to the order limit "
         "[Combastel2003].",
         ("zonotope", "zonotopes"), "AlamoBravoCamacho2005"),
    Term("Polytope (limited)", "polytope-limited",
         "The limited-complexity polytope recursion: it keeps at most K strips and a bounding box, and after each "
         "block of rows takes the exact LP bounds of (kept strips ∩ block ∩ box) and keeps the K strips nearest to "
         "active at the 2p bound vertices. An outer bound of the exact polytope for any p.",
         ("Polytope (limited)", "limited polytope", "limited-complexity polytope"), "refs §LP"),
    Term("guaranteed", "guaranteed",
         "A set (or torque band) that contains every parameter vector consistent with the data under the bound (the "
         "exact polytope), so the truth whenever every row's error is within e_max, whatever the noise's "
         "distribution; the estimator vouches for its own rounding.",
         ("guaranteed",)),
    Term("statistical", "statistical",
         "A set from a noise model (least squares, RLS, Kalman): confidence intervals and ellipsoids, and prediction "
         "bands, at a level (95 %) that holds only if the noise is white, Gaussian and independent of the "
         "regressors; filtered equations, differentiated encoder noise and model error break that, so a statistical "
         "set may miss the truth.",
         ("statistical",)),
    Term("unverified", "unverified",
         "A set-membership estimator's set that the estimator cannot vouch for (its bound on its own rounding error "
         "grew too large, or a segment of a variant could not vouch): rounding may have moved it off the truth. It "
         "is shown and certified, labelled \"(unverified)\", and never counted as guaranteed.",
         ("unverified",)),
    Term("outlier", "outlier",
         "A row whose error exceeds its bound, |y_k - w_k^T theta| > e_max_k. The OBE meets one as a strip that "
         "misses its ellipsoid (the data contradict the bound), records it and skips it; the fewest outliers any "
         "parameter vector of the prior box leaves is found exactly by a MILP (OMNE, [Lahanier1987]).",
         ("outlier", "outliers", "outlier rate"), "Lahanier1987"),
    Term("q-relaxed set", "q-relaxed",
         "The parameter vectors of the prior box that violate at most q rows' bounds: a union of polytopes, not "
         "convex. Its interval hull (2p MILPs) shows what allowing q outliers does to each interval.",
         ("q-relaxed set", "q-relaxed feasible set", "q-relaxed bounds", "q-relaxed"), "JaulinWalter2002"),
    Term("physically consistent bounds", "physically-consistent",
         "The exact bounds of the exact polytope intersected with the model's physical constraints (non-negative "
         "masses and friction, each link's pseudo-inertia matrix positive semidefinite): LPs for linear "
         "constraints, conic programs otherwise. Never wider than the plain LP bounds.",
         ("physically consistent bounds", "physically consistent interval", "physically consistent intervals",
          "physically consistent"), "refs §PHYS"),
    Term("base parameters", "base-parameters",
         "The combinations of the standard inertial parameters that the dynamics identify: parameters that never act "
         "are dropped and the others regrouped (boundid: QR with column pivoting on random states), so the "
         "regressor has full column rank.",
         ("base parameters", "base parameter"), "GautierKhalil1990"),
    Term("confidence band", "confidence-band",
         "Where the model's mean torque w^T theta lies at a level (95 %): w^T theta_hat +- 1.96 sqrt(w^T Cov w), "
         "from the parameters' covariance alone. It says nothing of where one measurement falls.",
         ("confidence band", "confidence bands")),
    Term("prediction band", "prediction-band",
         "Where a new measured torque lies at a level (95 %): w^T theta_hat +- 1.96 sqrt(w^T Cov w + sigma^2), the "
         "confidence band widened by the noise variance; the statistical bands of the validation sections.",
         ("prediction band", "prediction bands")),
    Term("holds by construction", "by-construction",
         "Said of a check or a paper's claim that cannot fail on the run's own data, so it is reported but never "
         "counted as evidence. A claim of a paper holds by construction when the simulation puts it into the data "
         "(the simulator's parameters are the paper's table) or when no outcome could contradict it (a centre that "
         "stays at the prior where the data do not constrain the parameter); a check of the bound does when the "
         "bound was taken from the data (an e_max rule, factor x gamma* with factor >= 1, is consistent with them "
         "by definition). Among the verdicts of a claims register it sits beside reproduced, partly (one part of "
         "the claim holds, another does not), not reproduced and cannot be tested (what the test needs is missing).",
         ("holds by construction", "by construction")),
)

# ----------------------------------------------------------------------------------- references
_ENTRY = re.compile(r"^- \*\*\[(\w+)\]\*\*\s*(.*)$", re.S)
_SECTION = re.compile(r"^refs §(\S+?):")
_YEAR = re.compile(r"\b(1[89]|20)\d\d\b")
_ABBREV = {"pp", "vol", "no", "ed", "Ch", "ch", "eq", "eqs", "Proc", "Int", "Conf", "Trans", "J", "Symp"}
_ITALIC = re.compile(r"(?<![\w*])\*(?=\S)(.+?)(?<=\S)\*(?![\w*])", re.S)
_BOLD = re.compile(r"\*\*(.+?)\*\*", re.S)
_MDLINK = re.compile(r"\[([^\]]+)\]\(([^)\s]+)\)")
_CODE = re.compile(r"`([^`]+)`")
_CITE = re.compile(r"\[(refs §[\w*]+|[A-Za-z]\w*)\]")


@dataclass(frozen=True)
class Reference:
    """One entry of docs/references.md: ``key``; ``citation`` its bibliographic part in the file's
    Markdown (authors, *title*, venue and year, pages); ``text`` the whole entry (Markdown)."""

    key: str
    citation: str
    text: str

    @property
    def title(self) -> str:
        """The italic title ("" for an entry without one)."""
        m = _ITALIC.search(self.citation)
        return " ".join(m.group(1).split()) if m else ""

    @property
    def plain(self) -> str:
        """The citation as plain text: authors. Title. Venue, year, pages."""
        return _plain(self.citation)


def _plain(markdown: str) -> str:
    text = _MDLINK.sub(r"\1", markdown)
    text = _BOLD.sub(r"\1", text)
    text = _ITALIC.sub(r"\1", text)
    return " ".join(_CODE.sub(r"\1", text).split())


def _citation(text: str) -> str:
    """The bibliographic part of an entry's text: up to the first sentence end after the year that
    follows the title (a whole entry without a title or a year)."""
    m = _ITALIC.search(text)
    start = m.end() if m else 0
    year = _YEAR.search(text, start)
    if year is None:
        return text
    for dot in re.finditer(r"\.(?=\s|$)", text[year.end():]):
        end = year.end() + dot.end()
        word = re.search(r"(\w+)\.$", text[:end])
        if word is None or word.group(1) not in _ABBREV:
            return text[:end]
    return text


def references_file() -> Path | None:
    """docs/references.md of the checkout the package runs from, or None (an installed wheel)."""
    root = checkout_root()
    path = root / "docs" / "references.md" if root is not None else None
    return path if path is not None and path.is_file() else None


@lru_cache(maxsize=4)
def _parse(path: Path, mtime: float) -> tuple[dict[str, Reference], tuple[str, ...]]:
    refs, sections = {}, []
    for block in _blocks(path.read_text(encoding="utf-8")):
        if block[0] == "item":
            m = _ENTRY.match(block[1])
            if m:
                text = " ".join(m.group(2).split())
                refs[m.group(1)] = Reference(m.group(1), _citation(text), text)
        elif block[0] == "h3":
            s = _SECTION.match(block[1])
            if s:
                sections.append(s.group(1))
    return refs, tuple(sections)


def references(path: str | Path | None = None) -> dict[str, Reference]:
    """{key: Reference} of docs/references.md (``path``: another file of that form). InputError
    when there is no such file."""
    path = Path(path) if path is not None else references_file()
    if path is None or not path.is_file():
        raise InputError(f"no references file {path or 'docs/references.md'}: run from a boundid checkout.")
    return _parse(path.resolve(), path.stat().st_mtime)[0]


def reference_sections(path: str | Path | None = None) -> tuple[str, ...]:
    """The names X of the ``### refs §X: ...`` sections of docs/references.md."""
    path = Path(path) if path is not None else references_file()
    if path is None or not path.is_file():
        return ()
    return _parse(path.resolve(), path.stat().st_mtime)[1]


def full_reference(key: str, path: str | Path | None = None) -> str:
    """The full reference of ``key`` in docs/references.md as plain text: authors, title, venue,
    year (and pages), e.g. ``full_reference("H4Paper")`` -> "P. Poignet, N. Ramdani, O. A. Vivas.
    Ellipsoidal estimation of parallel robot dynamic parameters. Proc. IEEE/RSJ ... 2003, pp.
    3300-3305." InputError for a key the file does not have."""
    refs = references(path)
    key = key.strip("[]")
    if key not in refs:
        raise InputError(f"[{key}] is not an entry of docs/references.md (keys: {', '.join(sorted(refs))}).")
    return refs[key].plain


def reference_anchor(ref: str) -> str:
    """The id of a key (``H4Paper``) or section (``refs §LP`` -> ``refs-LP``) on the references page."""
    ref = ref.strip("[]")
    return "refs-" + re.sub(r"[^\w-]", "-", ref[6:]) if ref.startswith("refs §") else ref


def study_citations(cfg) -> list[tuple[str, str]]:
    """(label, key) of the works a study page names in full under its headline: the paper it
    reproduces ("h4" -> [H4Paper], "direct_drive" -> [DirectDrivePaper]; "Reproduces on simulated data"
    for a simulated study, "The paper" for a recording of that robot), else the sources its
    [[published]] tables cite, each as "Source" (the TX40: [FIGAROH], its recording and values, and
    [Leboutet2021]). Keys docs/references.md does not have are left out."""
    try:
        known = references()
    except InputError:
        return []
    paper = {"h4": "H4Paper", "direct_drive": "DirectDrivePaper"}.get(cfg.robot)
    if paper is not None:
        label = "Reproduces on simulated data" if cfg.experiment.source == "simulate" else "The paper"
        return [(label, paper)] if paper in known else []
    keys = dict.fromkeys(k for t in getattr(cfg, "published", ()) for k in _CITE.findall(t.source) if k in known)
    return [("Source", k) for k in keys]


# ------------------------------------------------------------------------------------- linking
def _form_pattern(form: str) -> str:
    first, rest = form[0], re.escape(form[1:])
    return (f"[{first}{first.upper()}]" if first.islower() else re.escape(first)) + rest


class Linker:
    """Plain text -> escaped HTML with links: the first occurrence of each glossary term to
    ``<glossary_href>#<anchor>``, every citation of docs/references.md to ``<references_href>#<key>``.
    ``glossary_href`` / ``references_href``: the pages relative to the page being written ("" for
    the same page, None for no links of that kind). ``seen`` (anchors) grows as terms link;
    ``used`` holds the pages linked to (for the writer, which makes sure they exist)."""

    def __init__(self, glossary_href: str | None, references_href: str | None,
                 terms: Sequence[Term] = GLOSSARY, seen: Iterable[str] = ()):
        self.glossary_href, self.references_href = glossary_href, references_href
        self.seen: set[str] = set(seen)
        self.used: set[str] = set()
        self._terms: dict[str, Term] = {}
        for t in terms if glossary_href is not None else ():
            for f in t.forms:
                self._terms[f] = t
                self._terms[f[0].upper() + f[1:]] = t
        forms = sorted({f for t in terms for f in t.forms} if glossary_href is not None else (), key=len, reverse=True)
        alternatives = [r"(?P<cite>\[(?:refs §[\w*]+|[A-Za-z]\w*)\])", r"(?P<doc>docs/references\.md)"]
        if forms:
            alternatives.insert(0, r"(?<![\w-])(?P<term>" + "|".join(map(_form_pattern, forms)) + r")(?![\w-])")
        self._pattern = re.compile("|".join(alternatives))
        self._refs: dict[str, Reference] = {}
        self._sections: tuple[str, ...] = ()
        if references_href is not None:
            try:
                self._refs, self._sections = references(), reference_sections()
            except InputError:
                self.references_href = None

    def _term(self, text: str) -> str:
        t = self._terms[text]
        if t.anchor in self.seen:
            return html.escape(text)
        self.seen.add(t.anchor)
        self.used.add(GLOSSARY_PAGE)
        return (f'<a class="term" href="{html.escape(self.glossary_href)}#{t.anchor}" '
                f'title="{html.escape(t.definition)}">{html.escape(text)}</a>')

    def _cite(self, text: str) -> str:
        ref = text[1:-1]
        known = (ref in self._refs if not ref.startswith("refs §") else ref[6:] in self._sections)
        if self.references_href is None or not known:
            return html.escape(text)
        self.used.add(REFERENCES_PAGE)
        title = f' title="{html.escape(self._refs[ref].plain)}"' if ref in self._refs else ""
        return (f'<a class="cite" href="{html.escape(self.references_href)}#{reference_anchor(ref)}"{title}>'
                f"{html.escape(text)}</a>")

    def text(self, text: str) -> str:
        """``text`` (plain) escaped, with its terms and citations linked."""
        out, pos = [], 0
        for m in self._pattern.finditer(text):
            out.append(html.escape(text[pos:m.start()]))
            if m.group("term") is not None:
                out.append(self._term(m.group(0)))
            elif m.group("cite") is not None:
                out.append(self._cite(m.group(0)))
            elif self.references_href is not None:
                self.used.add(REFERENCES_PAGE)
                out.append(f'<a href="{html.escape(self.references_href)}">{html.escape(m.group(0))}</a>')
            else:
                out.append(html.escape(m.group(0)))
            pos = m.end()
        out.append(html.escape(text[pos:]))
        return "".join(out)

    def cell(self, escaped: str) -> str:
        """A table cell's content (escaped HTML): linked when the whole cell is a glossary term's
        form seen for the first time, else unchanged."""
        text = html.unescape(escaped).strip()
        if text in self._terms and "<" not in escaped:
            return self._term(text)
        return escaped

    def reference_html(self, key: str) -> str:
        """The full reference of ``key`` as HTML (title in italics) with its key linked to the
        references page; the bare key when there is no references file."""
        ref = self._refs.get(key)
        if ref is None:
            return html.escape(f"[{key}]")
        self.used.add(REFERENCES_PAGE)
        return (_inline(ref.citation, None) + f' <a class="cite" href="{html.escape(self.references_href)}#'
                f'{reference_anchor(key)}">[{html.escape(key)}]</a>')


# ----------------------------------------------------------------------------------- rendering
def _inline(markdown: str, cite_href: str | None, keys: Iterable[str] = (), sections: Iterable[str] = ()) -> str:
    """One paragraph of docs/references.md as HTML: `code`, **bold**, *italic*, [text](link) as its
    text (the files it names are not part of the site), citations linked to ``cite_href#anchor``."""
    keys, sections = set(keys), set(sections)
    codes: list[str] = []

    def keep(m):
        codes.append(f"<code>{html.escape(m.group(1))}</code>")
        return f"\x00{len(codes) - 1}\x00"

    text = html.escape(_MDLINK.sub(r"\1", _CODE.sub(keep, " ".join(markdown.split()))), quote=False)
    text = _BOLD.sub(r"<strong>\1</strong>", text)
    text = _ITALIC.sub(r"<em>\1</em>", text)
    if cite_href is not None:
        def cite(m):
            ref = m.group(1)
            ok = ref in keys or (ref.startswith("refs §") and ref[6:] in sections)
            return f'<a href="{cite_href}#{reference_anchor(ref)}">{m.group(0)}</a>' if ok else m.group(0)
        text = _CITE.sub(cite, text)
    return re.sub("\x00(\\d+)\x00", lambda m: codes[int(m.group(1))], text)


def _blocks(markdown: str) -> list[tuple[str, str]]:
    """docs/references.md as blocks: ("h1" | "h2" | "h3", heading), ("item", a list item with its
    continuation lines), ("p", paragraph), ("pre", code), and inside the last item: ("pre-item",
    code) and ("item-more", the item's text after that code)."""
    out: list[tuple[str, str]] = []
    lines = markdown.splitlines()
    i, para, item, item_kind = 0, [], None, "item"

    def flush():
        nonlocal para, item
        if para:
            out.append(("p", "\n".join(para)))
        if item:
            out.append((item_kind, "\n".join(item)))
        para, item = [], None

    while i < len(lines):
        line = lines[i]
        stripped = line.strip()
        if stripped.startswith("```"):
            indent = len(line) - len(line.lstrip())
            in_item = item is not None and indent >= 2
            flush()
            code, i = [], i + 1
            while i < len(lines) and not lines[i].strip().startswith("```"):
                code.append(lines[i][indent:] if lines[i][:indent].strip() == "" else lines[i].lstrip())
                i += 1
            out.append(("pre-item" if in_item else "pre", "\n".join(code)))
            if in_item:
                item, item_kind = [], "item-more"
            i += 1
            continue
        if not stripped:
            flush()
        elif line.startswith("#"):
            flush()
            level = len(line) - len(line.lstrip("#"))
            out.append((f"h{level}", line.lstrip("#").strip()))
        elif line.startswith("- "):
            flush()
            item, item_kind = [line], "item"
        elif item is not None and line.startswith("  "):
            item.append(stripped)
        else:
            if item is not None:
                flush()
            para.append(line)
        i += 1
    flush()
    return out


def references_body(path: str | Path | None = None) -> str:
    """The HTML body of the references page: docs/references.md rendered, one anchor per key (the
    list item of ``**[Key]**``) and per ``### refs §X`` section (``refs-X``), citations linked."""
    path = Path(path) if path is not None else references_file()
    if path is None or not path.is_file():
        raise InputError(f"no references file {path or 'docs/references.md'}: run from a boundid checkout.")
    refs, sections = _parse(path.resolve(), path.stat().st_mtime)
    ids: set[str] = set(refs) | {reference_anchor(f"refs §{s}") for s in sections}

    def inline(text: str) -> str:
        return _inline(text, "", refs, sections)

    parts, open_list = [], False
    for kind, text in _blocks(path.read_text(encoding="utf-8")):
        is_item = kind in ("item", "pre-item", "item-more")
        if open_list and not is_item:
            parts.append("</ul>")
            open_list = False
        if kind == "h1":
            continue
        if kind in ("h2", "h3"):
            s = _SECTION.match(text)
            anchor = reference_anchor(f"refs §{s.group(1)}") if s else slug(text, ids, "section")
            parts.append(f'<{kind} id="{html.escape(anchor)}">{inline(text)}</{kind}>')
        elif kind == "p":
            parts.append(f"<p>{inline(text)}</p>")
        elif kind == "pre":
            parts.append(f"<pre>{html.escape(text)}</pre>")
        elif kind == "item":
            if not open_list:
                parts.append('<ul class="refs">')
                open_list = True
            m = _ENTRY.match(" ".join(text.split()))
            anchor = f' id="{html.escape(m.group(1))}"' if m else ""
            parts.append(f"<li{anchor}>{inline(text[2:])}</li>")
        elif kind == "pre-item":
            parts[-1] = parts[-1][:-len("</li>")] + f"<pre>{html.escape(text)}</pre></li>"
        else:  # item-more: text after a code block inside an item
            parts[-1] = parts[-1][:-len("</li>")] + f" {inline(text)}</li>"
    if open_list:
        parts.append("</ul>")
    return "\n".join(parts)


def slug(text: str, taken: set[str], empty: str = "item") -> str:
    """A URL-safe id for ``text`` (lower case, words joined by "-", at most 48 characters; ``empty``
    for text without a letter or digit), made unique among ``taken`` by a suffix -2, -3 ..., and
    added to it."""
    base = re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")[:48].strip("-") or empty
    out, k = base, 2
    while out in taken:
        out, k = f"{base}-{k}", k + 1
    taken.add(out)
    return out


GLOSSARY_INTRO = ("The words the study pages use without stopping to define them. On a study page the first "
                  "occurrence of each links here; a key in brackets, such as [H4Paper], is an entry of the references "
                  "page.")


def glossary_body(references_href: str | None = REFERENCES_PAGE, terms: Sequence[Term] = GLOSSARY) -> str:
    """The HTML body of the glossary page: one ``<dt id="<anchor>">`` per term with its definition,
    the other terms it uses linked within the page, its reference linked to the references page
    (``references_href``; None: no links to it), and the ways the pages write it."""
    items = []
    for t in terms:
        linker = Linker("", references_href, terms, seen={t.anchor})
        ref = ""
        if t.ref is not None:
            ref = " " + linker.text(f"[{t.ref}]")
        forms = [f for f in t.forms if f != t.name]
        also = (f'<span class="forms">Written: {", ".join(html.escape(f) for f in forms)}.</span>' if forms else "")
        items.append(f'<dt id="{t.anchor}">{html.escape(t.name)}</dt><dd>{linker.text(t.definition)}{ref}{also}</dd>')
    return f"<p>{html.escape(GLOSSARY_INTRO)}</p>\n<dl class=\"glossary\">" + "\n".join(items) + "</dl>"
