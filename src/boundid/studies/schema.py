"""Reading study files: typed look-ups that name the file, the key and the allowed values.

Nothing in a study file is executed: it is parsed with ``tomllib`` and every value is checked
against its expected type and range here.
"""

from __future__ import annotations

import builtins
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from boundid.errors import StudyError

_MISSING = object()


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
              strict_lo: bool = False) -> float:
        v = self._get(key, default)
        if v is None:
            return v
        if isinstance(v, builtins.bool) or not isinstance(v, builtins.int | builtins.float):
            raise self.error(key, f"must be a number, got {v!r}.")
        v = builtins.float(v)
        if lo is not None and (v < lo or (strict_lo and v == lo)):
            raise self.error(key, f"must be {'>' if strict_lo else '>='} {lo}, got {v}.")
        if hi is not None and v > hi:
            raise self.error(key, f"must be <= {hi}, got {v}.")
        return v

    def int(self, key: str, default: Any = _MISSING, lo: int | None = None) -> int:
        v = self._get(key, default)
        if v is None:
            return v
        if isinstance(v, builtins.bool) or not isinstance(v, builtins.int):
            raise self.error(key, f"must be an integer, got {v!r}.")
        if lo is not None and v < lo:
            raise self.error(key, f"must be >= {lo}, got {v}.")
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

    def check_unknown(self) -> None:
        """Unknown keys are typos until proven otherwise: refuse them."""
        unknown = sorted(set(self.data) - self._read)
        if unknown:
            raise self.error(unknown[0], f"unknown key; the keys read here are {', '.join(sorted(self._read))}.")
