"""Where the input folders of the commands are: ``studies/`` and ``studies/teaching/``.

``boundid report`` and ``boundid teach`` used to look for ``studies/`` in the current folder only,
so they worked from the repository root and nowhere else. :func:`find_folder` looks in the current
folder first (a user's own ``studies/`` wins), then in the boundid checkout the package runs from
(an editable install, ``pip install -e .``: ``src/boundid`` sits two levels below the checkout's
root), and says where it looked when neither has the files.
"""

from __future__ import annotations

from pathlib import Path

from boundid.errors import InputError


def checkout_root() -> Path | None:
    """The root of the boundid source checkout this package is imported from, or None (e.g. an
    installed wheel, whose package has no ``pyproject.toml`` two levels up)."""
    root = Path(__file__).resolve().parents[2]
    return root if (root / "pyproject.toml").is_file() and (root / "src" / "boundid").is_dir() else None


def find_folder(subdir: str | Path, pattern: str, given: str | Path | None = None, *, what: str,
                option: str) -> Path:
    """The folder holding the ``pattern`` files (e.g. ``"*.toml"``) of ``what``.

    given : a folder named on the command line (``option``): used as is, InputError if it holds no
        such file. None: ``./<subdir>``, else ``<checkout>/<subdir>`` (:func:`checkout_root`).
    """
    if given is not None:
        folder = Path(given)
        if not folder.is_dir() or not any(folder.glob(pattern)):
            raise InputError(f"{folder} holds no {pattern} files ({what}); pass {option} a folder that does.")
        return folder
    candidates = [Path.cwd() / subdir]
    root = checkout_root()
    if root is not None and (root / subdir).resolve() != candidates[0].resolve():
        candidates.append(root / subdir)
    for folder in candidates:
        if folder.is_dir() and any(folder.glob(pattern)):
            return folder
    raise InputError(f"no {what} found: looked for {pattern} in {' and '.join(map(str, candidates))}. Run from a "
                     f"boundid checkout, or pass {option} the folder that holds them.")
