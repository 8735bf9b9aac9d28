"""Every citation in the code, the study files and the tests points inside the repository: to
docs/references.md by key ("[FogelHuang1982] eq. 12", "[H4Paper] eq. 37", "[refs §SDP]") or to
docs/models.md, never to a design note, a paper by its seed number, an issue or a path outside the
repository. Reference: the keys and sections of docs/references.md itself.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FOLDERS = ("src", "studies", "tests")
SUFFIXES = {".py", ".toml", ".md"}
FORBIDDEN = {
    "a numbered section of the old reference list": re.compile(r"\bREFERENCES\b"),
    "a paper by its seed number": re.compile(r"\bseed[ -]0\d\d\b|\bseed eqs?\. "),
    "a design note": re.compile(r"design note", re.IGNORECASE),
    "an issue number": re.compile(r"\bissue #?\d+", re.IGNORECASE),
    "a path outside the repository": re.compile(r"/work/shared"),
    "a model note outside the repository": re.compile(r"\b[A-Z0-9_]+_MODEL\.md"),
}
NAMED_KEYS = {"H4Paper", "DirectDrivePaper", "LesecqBarraud", "HiGHS", "Clarabel", "Pinocchio"}
AUTHOR_YEAR = re.compile(r"\[([A-Z][A-Za-z]+\d{4}[a-z]?)\]")
SECTION = re.compile(r"\[refs §(\w+)\]")


def _files():
    for folder in FOLDERS:
        for path in sorted((ROOT / folder).rglob("*")):
            if path.is_file() and path.suffix in SUFFIXES and path != Path(__file__).resolve():
                yield path  # this file names the patterns it looks for


def test_no_citation_points_outside_the_repository():
    """No file cites the old reference list, a seed paper, a design note, an issue or an outside path."""
    found = []
    for path in _files():
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for what, pattern in FORBIDDEN.items():
                if pattern.search(line):
                    found.append(f"{path.relative_to(ROOT)}:{n}: {what}: {line.strip()[:90]}")
    assert not found, "cite docs/references.md or docs/models.md instead:\n" + "\n".join(found)


def test_every_cited_key_and_section_exists():
    """Each [AuthorYear] key and [refs §X] section cited in the code is an entry of docs/references.md."""
    refs = (ROOT / "docs" / "references.md").read_text(encoding="utf-8")
    keys = set(re.findall(r"\*\*\[(\w+)\]\*\*", refs))
    sections = set(re.findall(r"^### refs §(\w+)", refs, flags=re.MULTILINE))
    assert NAMED_KEYS <= keys and {"OBE", "QR", "LP", "SDP"} <= sections
    missing = []
    for path in _files():
        text = path.read_text(encoding="utf-8")
        missing += [f"{path.relative_to(ROOT)}: [{k}]" for k in set(AUTHOR_YEAR.findall(text)) - keys]
        missing += [f"{path.relative_to(ROOT)}: [refs §{s}]" for s in set(SECTION.findall(text)) - sections]
    assert not missing, "cited but not in docs/references.md:\n" + "\n".join(sorted(missing))
