"""The import structure of ``src/boundid`` (REDESIGN item 8), read with ``ast`` from the source,
not by importing it: no import runs up the six layers, no private name crosses a package, no
import cycle (lazy imports inside functions included); and ``import boundid.estimators`` leaves
cvxpy unloaded (checked in a fresh interpreter)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"
#: layer of each top-level part of the package (docs: README "Layout")
LAYERS = {"__init__": 0, "_validation": 0, "errors": 0, "resources": 0, "sets": 1, "estimators": 2, "models": 3,
          "experiments": 4, "studies": 5, "report": 6, "cli": 6, "bench": 6, "teaching": 6, "docs": 6}


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted((SRC / "boundid").rglob("*.py")):
        parts = list(path.relative_to(SRC).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _imports(name: str, path: Path) -> list[tuple[str, str, int]]:
    """(imported module, imported name or "", line) of every boundid import in the file, at any depth."""
    is_pkg = path.name == "__init__.py"
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(a.name, "", node.lineno) for a in node.names if a.name.split(".")[0] == "boundid"]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                pkg = name.split(".") if is_pkg else name.split(".")[:-1]
                base = ".".join(pkg[: len(pkg) - node.level + 1] + ([base] if base else []))
            if base.split(".")[0] != "boundid":
                continue
            for a in node.names:
                sub = f"{base}.{a.name}"
                out.append((sub, "", node.lineno) if sub in MODULES else (base, a.name, node.lineno))
    return out


def _layer(module: str) -> int:
    parts = module.split(".")
    return LAYERS["__init__"] if len(parts) == 1 else LAYERS[parts[1]]


def _package(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def test_no_import_runs_up_the_layers():
    """Reference: the layer table of the README: sets 1, estimators 2, models 3, experiments 4,
    studies 5, report/cli/bench/teaching 6; _validation, errors, resources at 0."""
    up = [f"{src} (layer {_layer(src)}) line {line} imports {dst} (layer {_layer(dst)})"
          for src, path in MODULES.items() for dst, _, line in _imports(src, path) if _layer(dst) > _layer(src)]
    assert not up, "\n".join(up)


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def test_no_private_name_crosses_a_package():
    """A name starting with "_" (module or object) is used only inside its own package; the
    package-wide ``boundid._validation`` (layer 0) is shared by design."""
    bad = []
    for src, path in MODULES.items():
        for dst, obj, line in _imports(src, path):
            if dst == "boundid._validation":
                continue
            private = any(_private(p) for p in dst.split(".")[1:]) or _private(obj)
            if private and _package(dst) != _package(src):
                bad.append(f"{src} line {line}: {dst}{'.' + obj if obj else ''}")
    assert not bad, "\n".join(bad)


def test_no_import_cycles():
    """Tarjan's strongly connected components of the import graph (lazy imports included; a
    submodule importing its own parent package is Python's rule, not an edge) are all single
    modules."""
    graph = {src: sorted({dst for dst, _, _ in _imports(src, path) if dst in MODULES and dst != src
                          and not src.startswith(dst + ".")}) for src, path in MODULES.items()}
    index, low, stack, on, cycles = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10 * len(graph)))
    for v in graph:
        if v not in index:
            visit(v)
    assert not cycles, cycles


def test_importing_the_estimators_does_not_load_cvxpy():
    """Reference: sys.modules of a fresh interpreter after ``import boundid.estimators`` (and the
    method registry): cvxpy is loaded only where an SDP is solved."""
    code = ("import sys, boundid.estimators, boundid.estimators.registry; "
            "sys.exit(3 if 'cvxpy' in sys.modules else 0)")
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0
