"""Local Sphinx extension of boundid's documentation site: how the docstrings are read, and what strict means.

boundid's docstrings are plain text with reStructuredText roles for cross-references
(:class:`~boundid.sets.Ellipsoid`) and ``literals``, plus numpy-style sections in a few places. The
plain text has ASCII mathematics (|y_k - w_k^T theta| <= e_max_k) and field lists laid out in
aligned columns, which reStructuredText would misread. So, before autodoc renders a docstring:

* every "|" is escaped: boundid's docstrings never use substitutions, a bar is an absolute value
  or a norm;
* a word's trailing "_" is escaped (it is part of a name, not a hyperlink reference);
* a paragraph whose lines are laid out by indentation (a continuation line indented under a field,
  an aligned column) is shown as it is written, as a parsed literal block (the roles still link);
* a numpy-style section (a title such as Parameters over a line of dashes) becomes a rubric over
  its lines as written: its entries are aligned columns ("W : (N, p), y : (N,)   the regression"),
  which napoleon would read as types.

Strict cross-references: a reference to a name of another library is not checked (conf.py's
nitpick_ignore_regex). A reference to one of boundid's own names must name something that exists:
if the name is documented on the site it links; if it exists in boundid but is not on the site (a
private helper, a module constant, a module outside the API reference) it is shown as code; if
it names nothing at all (a renamed function, a typo) the build fails.

Missing docstrings: every module, class, exception and function the API reference documents has one
(a dataclass's generated signature does not count); otherwise the build fails.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import re

from sphinx.util import logging

_log = logging.getLogger(__name__)
_SECTION_RULE = re.compile(r"^\s*-{3,}\s*$")
_CODE = re.compile(r"(``.+?``|:[\w:]+:`[^`]+`|`[^`]+`_?)")
_ITEM = re.compile(r"^(\s*)([-*+]|\d+\.|\(\w+\))\s+")


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip())


def _laid_out(block: list[str]) -> bool:
    """True when reStructuredText would misread the paragraph: a line indented deeper than the line
    before it (unless that line is a list item whose text starts at that column, or ends in ::), or
    a list that starts right under a paragraph line."""
    in_list = bool(_ITEM.match(block[0]))
    for prev, line in zip(block, block[1:], strict=False):
        if _ITEM.match(line) and not in_list:
            return True
        in_list = in_list or bool(_ITEM.match(line))
        if _indent(line) <= _indent(prev) or prev.rstrip().endswith("::"):
            continue
        item = _ITEM.match(prev)
        if item and _indent(line) == item.end():
            continue
        return True
    return False


def _escape(line: str) -> str:
    """Bars and trailing underscores escaped outside ``literals`` and :role:`targets`."""
    parts = _CODE.split(line)
    for i in range(0, len(parts), 2):
        parts[i] = re.sub(r"(\w)_(?=\W|$)", r"\1\\_", re.sub(r"(?<!\\)\|", r"\\|", parts[i]))
    return "".join(parts)


def plain_text_docstring(lines: list[str]) -> list[str]:
    """The docstring's lines as reStructuredText that shows what the author wrote (see the module)."""
    out: list[str] = []
    block: list[str] = []
    in_section = False

    def flush():
        if block and (in_section or _laid_out(block)):
            base = min(_indent(b) for b in block)
            out.extend(["", ".. parsed-literal::", ""] + ["   " + b[base:] for b in block] + [""])
        else:
            out.extend(block)
        block.clear()

    escaped = [_escape(line) for line in lines] + [""]
    for i, line in enumerate(escaped[:-1]):
        if _SECTION_RULE.match(escaped[i + 1]) and line.strip():  # a numpy-style section title
            flush()
            out.extend(["", f".. rubric:: {line.strip()}", ""])
            in_section = True
        elif _SECTION_RULE.match(line) and i and escaped[i - 1].strip():
            continue
        elif line.strip():
            block.append(line)
        else:
            flush()
            out.append(line)
    flush()
    return out


def _process(app, what, name, obj, options, lines):
    lines[:] = plain_text_docstring(lines)


def _signature(app, what, name, obj, options, signature, return_annotation):
    """A dataclass field's default_factory shows as ``...``: Sphinx cannot parse ``<factory>``."""
    if signature and "<factory>" in signature:
        return signature.replace("<factory>", "..."), return_annotation
    return None


def _own_docstring(obj) -> str:
    """The object's own docstring: '' for a dataclass whose __doc__ is the generated signature."""
    doc = inspect.getdoc(obj) or ""
    if dataclasses.is_dataclass(obj) and isinstance(obj, type) and doc.startswith(f"{obj.__name__}("):
        return ""
    return doc


def _require_docstring(app, what, name, obj, options, lines):
    if what in ("module", "class", "exception", "function") and name.startswith("boundid") \
            and not _own_docstring(obj).strip():
        _log.warning("%s %s has no docstring", what, name, type="boundid", subtype="docstring")


def _lookup(path: str):
    """The boundid object a dotted path names, or raise LookupError."""
    parts = path.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            fields = {f.name for f in dataclasses.fields(obj)} if dataclasses.is_dataclass(obj) else set()
            if hasattr(obj, attr):
                obj = getattr(obj, attr)
            elif attr in fields or attr in getattr(obj, "__annotations__", {}):
                obj = None  # a dataclass field or an annotated attribute: exists, no object to walk into
            else:
                raise LookupError(path)
        return obj
    raise LookupError(path)


def exists_in_boundid(target: str, module: str | None, cls: str | None) -> bool:
    """Whether a cross-reference target names an existing boundid object, as Python would resolve
    it from the docstring's module (and class)."""
    candidates = [target]
    if module:
        candidates += [f"{module}.{target}"] + ([f"{module}.{cls}.{target}"] if cls else [])
        try:  # the module the documented class is defined in (autosummary documents it under its package)
            home = getattr(_lookup(f"{module}.{cls}"), "__module__", None) if cls else None
        except LookupError:
            home = None
        if home:
            candidates += [f"{home}.{target}", f"{home}.{cls}.{target}"]
    for path in candidates:
        if not path.startswith("boundid"):
            continue
        try:
            _lookup(path)
            return True
        except LookupError:
            continue
    return False


def _missing_reference(app, env, node, contnode):
    if node.get("refdomain") != "py":
        return None
    if exists_in_boundid(node["reftarget"], node.get("py:module"), node.get("py:class")):
        return contnode  # exists, not on the site: shown as code, unlinked
    return None  # nitpicky: the build fails, naming the reference


def setup(app):
    app.connect("autodoc-process-docstring", _process)
    app.connect("autodoc-process-docstring", _require_docstring)
    app.connect("autodoc-process-signature", _signature)
    app.connect("missing-reference", _missing_reference, priority=900)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
