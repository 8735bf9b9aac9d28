"""Reading study files: typed look-ups that name the file, the key and the allowed values.

Nothing in a study file is executed: it is parsed with ``tomllib`` and every value is checked
against its expected type and range here.
"""

from __future__ import annotations

import builtins
import math
import re
import tomllib
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from boundid._validation import NumbersOption, TablesOption
from boundid.errors import StudyError

_MISSING = object()

# A plain name (study, scenario): it names a folder or files, so no path separators, no dots, no
# leading '-'; at most 64 characters (room for the temporary and hash suffixes of the files).
PLAIN_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$")


def read_toml(path: str | Path) -> dict:
    """The parsed TOML of a study file; StudyError naming the file for unreadable, non-UTF-8 or bad TOML."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise StudyError(f"{path}: cannot read the study file: {exc.strerror or exc}.") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise StudyError(f"{path}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at line {line}); "
                         "save the study file as UTF-8.") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise StudyError(f"{path}: not valid TOML: {exc}") from None


def describe_option(default: Any) -> str:
    """The type of an option as a study file writes it, from its default value ("number", "list of 4 strings")."""
    if isinstance(default, NumbersOption):
        return "number or list of numbers"
    if isinstance(default, TablesOption):
        return "list of tables"
    if isinstance(default, tuple):
        if not default:
            return "list of strings"
        return f"list of {len(default)} {describe_option(default[0])}s"
    if isinstance(default, builtins.bool):
        return "true or false"
    if isinstance(default, builtins.int):
        return "integer"
    if isinstance(default, builtins.float):
        return "number"
    return "string"


def range_text(lo: float | None = None, hi: float | None = None, strict_lo: bool = False,
               strict_hi: bool = False) -> str:
    """The range lo..hi in words, as messages and docs/study-files.md write it ("> 0, <= 1"; "" unbounded)."""
    parts = ([f"{'>' if strict_lo else '>='} {lo:g}"] if lo is not None else []) + (
        [f"{'<' if strict_hi else '<='} {hi:g}"] if hi is not None else [])
    return ", ".join(parts)


def _finite(value: Any) -> bool:
    """Whether every number of an option value (a number, or a list of them) is finite (not NaN, not +-inf)."""
    values = value if isinstance(value, builtins.list) else [value]
    return all(math.isfinite(v) for v in values if isinstance(v, builtins.float))


def _number(value: Any) -> bool:
    return isinstance(value, builtins.int | builtins.float) and not isinstance(value, builtins.bool)


def _matches(value: Any, default: Any) -> bool:
    if isinstance(default, NumbersOption):
        return _number(value) or (isinstance(value, builtins.list) and all(_number(v) for v in value))
    if isinstance(default, TablesOption):
        return isinstance(value, builtins.list) and all(isinstance(v, builtins.dict) for v in value)
    if isinstance(default, builtins.bool) or isinstance(value, builtins.bool):
        return isinstance(value, builtins.bool) and isinstance(default, builtins.bool)
    if isinstance(default, builtins.float):
        return isinstance(value, builtins.int | builtins.float)
    if default == ():  # a list of names, of any length
        return isinstance(value, builtins.list) and all(isinstance(v, builtins.str) for v in value)
    if isinstance(default, tuple):
        return (isinstance(value, builtins.list) and len(value) == len(default)
                and all(_matches(v, d) for v, d in zip(value, default, strict=True)))
    return isinstance(value, type(default))


class Section:
    """A table of a study file, with the dotted path that led to it (for error messages)."""

    def __init__(self, data: dict, path: str, file: Path | str):
        if not isinstance(data, dict):
            raise StudyError(f"{file}: [{path}] must be a table, got {type(data).__name__}.")
        self.data, self.path, self.file = data, path, file
        self._read: set[str] = set()

    def _where(self, key: str) -> str:
        return f"{self.file}: {self.path + '.' if self.path else ''}{key}"

    def error(self, key: str, message: str) -> StudyError:
        return StudyError(f"{self._where(key)}: {message}")

    def has(self, key: str) -> bool:
        return key in self.data

    def _get(self, key: str, default: Any) -> Any:
        self._read.add(key)
        if key in self.data:
            return self.data[key]
        if default is _MISSING:
            raise self.error(key, "is required but missing.")
        return default

    def str(self, key: str, default: Any = _MISSING, choices: Iterable[str] | None = None) -> str:
        v = self._get(key, default)
        if v is None:
            return v
        if not isinstance(v, builtins.str):
            raise self.error(key, f"must be a string, got {v!r}.")
        if choices is not None and v not in (allowed := tuple(choices)):
            raise self.error(key, f"must be one of {', '.join(map(repr, allowed))}; got {v!r}.")
        return v

    def float(self, key: str, default: Any = _MISSING, lo: float | None = None, hi: float | None = None,
              strict_lo: bool = False, strict_hi: bool = False) -> float:
        """A finite number (NaN and +-inf refused) in the range lo..hi (exclusive when strict)."""
        v = self._get(key, default)
        if v is None:
            return v
        if isinstance(v, builtins.bool) or not isinstance(v, builtins.int | builtins.float):
            raise self.error(key, f"must be a number, got {v!r}.")
        v = builtins.float(v)
        allowed = range_text(lo, hi, strict_lo, strict_hi)
        if not math.isfinite(v):
            raise self.error(key, f"must be a finite number{' ' + allowed if allowed else ''}, got {v}.")
        if (lo is not None and (v < lo or (strict_lo and v == lo))) or (
                hi is not None and (v > hi or (strict_hi and v == hi))):
            raise self.error(key, f"must be {allowed}, got {v}.")
        return v

    def int(self, key: str, default: Any = _MISSING, lo: int | None = None, hi: int | None = None) -> int:
        """An integer in the range lo..hi (inclusive)."""
        v = self._get(key, default)
        if v is None:
            return v
        if isinstance(v, builtins.bool) or not isinstance(v, builtins.int):
            raise self.error(key, f"must be an integer, got {v!r}.")
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            raise self.error(key, f"must be {range_text(lo, hi)}, got {v}.")
        return v

    def bool(self, key: str, default: Any = _MISSING) -> bool:
        v = self._get(key, default)
        if not isinstance(v, builtins.bool):
            raise self.error(key, f"must be true or false, got {v!r}.")
        return v

    def list(self, key: str, default: Any = _MISSING, of: type | tuple = builtins.str,
             choices: Iterable[str] | None = None) -> list:
        v = self._get(key, default)
        ok = isinstance(v, builtins.list) and all(isinstance(x, of) and not isinstance(x, builtins.bool) for x in v)
        if not ok:
            kind = of.__name__ if isinstance(of, type) else "/".join(t.__name__ for t in of)
            raise self.error(key, f"must be a list of {kind}, got {v!r}.")
        if choices is not None:
            allowed = tuple(choices)
            for x in v:
                if x not in allowed:
                    raise self.error(key, f"entries must be among {', '.join(map(repr, allowed))}; got {x!r}.")
        return v

    def section(self, key: str, required: bool = False) -> Section:
        v = self._get(key, _MISSING if required else {})
        return Section(v, f"{self.path + '.' if self.path else ''}{key}", self.file)

    def sections(self, key: str) -> list[Section]:
        """An array of tables ([[key]] in TOML)."""
        v = self._get(key, [])
        if not isinstance(v, builtins.list):
            raise self.error(key, "must be an array of tables ([[...]]).")
        return [Section(x, f"{self.path + '.' if self.path else ''}{key}[{i}]", self.file) for i, x in enumerate(v)]

    def raw(self, key: str, default: Any = _MISSING) -> Any:
        return self._get(key, default)

    def plain_name(self, key: str) -> str:
        """A name that becomes a folder or file name: letters, digits, '_' and '-' (see PLAIN_NAME)."""
        v = self.str(key)
        if not PLAIN_NAME.match(v):
            raise self.error(key, f"must be a plain name of letters, digits, '_' or '-' (at most 64, not starting "
                                  f"with '_' or '-'): it names a folder or files; got {v!r}.")
        return v

    def options(self, key: str, known: Mapping[str, Any], owner: str) -> dict:
        """An options table checked against ``known`` = {option: default}: the type of each value is
        that of its default (a float default accepts integers; a tuple default is a list of that
        length, an empty tuple a list of strings of any length; a
        :class:`~boundid._validation.NumbersOption` a number or a list of numbers, a
        :class:`~boundid._validation.TablesOption` a list of tables); every number must be finite (in
        tables, the owner checks); lists come back as tuples. Unknown options are refused, listing the
        known ones (the ranges are the owner's to check)."""
        table = self.section(key)
        out = {}
        for name, value in table.data.items():
            if not known:
                raise table.error(name, f"unknown option: {owner} takes no options; remove the table.")
            if name not in known:
                listing = ", ".join(f"{k} ({describe_option(d)})" for k, d in known.items())
                raise table.error(name, f"unknown option for {owner}; the known ones are: {listing}.")
            default = known[name]
            if not _matches(value, default):
                kind = describe_option(default)
                article = "" if kind.startswith("true") else ("an " if kind[0] in "aeiou" else "a ")
                raise table.error(name, f"must be {article}{kind} (default {default!r}), got {value!r}.")
            if not _finite(value):
                raise table.error(name, f"must be finite, not NaN or inf ({describe_option(default)}, default "
                                        f"{default!r}), got {value!r}.")
            if isinstance(value, builtins.list) and (default == () or isinstance(default, NumbersOption)):
                value = tuple(builtins.float(v) if isinstance(default, NumbersOption) else v for v in value)
            elif isinstance(value, builtins.list):
                value = tuple(builtins.float(v) if isinstance(d, builtins.float) else v
                              for v, d in zip(value, default, strict=True))
            elif isinstance(default, builtins.float):
                value = builtins.float(value)
            out[name] = value
            table._read.add(name)
        return out

    def check_unknown(self, known: str | None = None) -> None:
        """Unknown keys are typos until proven otherwise: refuse them. ``known`` describes the keys
        this table accepts (default: the keys read so far)."""
        unknown = sorted(set(self.data) - self._read)
        if unknown:
            known = known or f"the keys read here are {', '.join(sorted(self._read))}"
            raise self.error(unknown[0], f"unknown key; {known}.")
