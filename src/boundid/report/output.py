"""Report folders that stay in their place and are never half-written.

- :func:`check_out_dir`, before any computing: the reports folder exists or can be created, is a
  folder, can be written to, and none of the report folders to come is a file or a link.
- :func:`replace_folder`: the caller writes a page into a fresh hidden sibling of its folder
  (``.<name>.new-<token>``); on success the sibling is swapped into place in one step (Linux
  ``renameat2(RENAME_EXCHANGE)``; elsewhere two renames), the sub-folders listed in ``keep`` (the
  output of another command, such as a study's ``campaign/``) are carried over from the old
  folder, and the old folder is removed. A failure or a kill while writing leaves the previous
  folder as it was; the next write to the same folder cleans up what a killed one left behind.
- :func:`write_file_atomically`: one file, written beside its place and moved there with ``os.replace``.

Writers to folders of one parent are serialised with an advisory lock (``flock``) on the parent.
"""

from __future__ import annotations

import ctypes
import errno
import fcntl
import os
import shutil
import tempfile
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from boundid.errors import OutputError

_AT_FDCWD = -100
_RENAME_EXCHANGE = 2


def check_out_dir(out: str | Path, names: tuple[str, ...] = ()) -> Path:
    """Create ``out`` if needed and check it can hold the report folders ``out/<name>``.

    OutputError naming the path and the fix when ``out`` (or a parent) is a file, cannot be created
    or written to, or an ``out/<name>`` is a file or a symbolic link.
    """
    out = Path(out)
    for p in (out, *out.parents):
        if p.exists() or p.is_symlink():
            if not p.is_dir():
                raise OutputError(f"--out {out}: {p} is a file, not a folder; give a folder (created if missing).")
            break
    try:
        out.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(dir=out, prefix=".boundid-write-check-")
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise OutputError(f"--out {out}: cannot create or write to this folder ({exc.strerror or exc}); "
                          "choose a writable folder.") from None
    for name in names:
        dest = out / name
        if dest.is_symlink() or (dest.exists() and not dest.is_dir()):
            raise OutputError(f"{dest} is a {'symbolic link' if dest.is_symlink() else 'file'}, where the report "
                              f"folder {name!r} goes; move it away or choose another --out.")
    return out


def _exchange(a: Path, b: Path) -> bool:
    """Swap the paths ``a`` and ``b`` atomically (Linux renameat2); False where the system cannot."""
    rename2 = getattr(ctypes.CDLL(None, use_errno=True), "renameat2", None)
    if rename2 is None:
        return False
    if rename2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP):  # file system or kernel without RENAME_EXCHANGE
        return False
    raise OSError(err, os.strerror(err), str(b))


def _leftovers(dest: Path) -> list[Path]:
    return sorted(dest.parent.glob(f".{dest.name}.new-*")) + sorted(dest.parent.glob(f".{dest.name}.old-*"))


def recover_folder(dest: str | Path, keep: tuple[str, ...] = ()) -> None:
    """Finish what a killed write to ``dest`` left: restore the previous folder if ``dest`` is
    missing, carry the ``keep`` sub-folders back into ``dest``, remove the hidden siblings."""
    dest = Path(dest)
    left = _leftovers(dest)
    olds = [p for p in left if ".old-" in p.name]
    if not dest.exists() and olds:
        latest = max(olds, key=lambda p: p.stat().st_mtime)
        latest.rename(dest)
        left.remove(latest)
    for sibling in left:
        for name in keep:
            if (sibling / name).is_dir() and dest.is_dir() and not (dest / name).exists():
                (sibling / name).rename(dest / name)
        shutil.rmtree(sibling, ignore_errors=True)


def _swap_into_place(new: Path, dest: Path, keep: tuple[str, ...]) -> None:
    if not dest.exists():
        new.rename(dest)
        return
    old = dest.parent / f".{dest.name}.old-{new.name.rsplit('-', 1)[1]}"
    if _exchange(new, dest):
        new.rename(old)
    else:
        dest.rename(old)
        new.rename(dest)
    for name in keep:
        if (old / name).exists() and not (dest / name).exists():
            (old / name).rename(dest / name)
    shutil.rmtree(old)


@contextmanager
def _locked(folder: Path) -> Iterator[None]:
    fd = os.open(folder, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


@contextmanager
def replace_folder(dest: str | Path, keep: tuple[str, ...] = ()) -> Iterator[Path]:
    """``with replace_folder(out / name) as tmp: <write the page into tmp>``; then ``out/name`` is
    the new folder (with the ``keep`` sub-folders of the old one), or, on any failure, the old
    one unchanged. OSError while writing becomes OutputError naming ``dest``."""
    dest = Path(dest)
    try:
        dest.parent.mkdir(parents=True, exist_ok=True)
        with _locked(dest.parent):
            recover_folder(dest, keep)
            new = dest.parent / f".{dest.name}.new-{uuid.uuid4().hex[:12]}"
            new.mkdir()
            try:
                yield new
            except BaseException:
                shutil.rmtree(new, ignore_errors=True)
                raise
            _swap_into_place(new, dest, keep)  # interrupted, it leaves hidden siblings for recover_folder
    except OSError as exc:
        raise OutputError(f"writing the report folder {dest} failed ({exc}); the previous one, if any, is "
                          "unchanged.") from None


def write_file_atomically(path: str | Path, text: str | bytes) -> Path:
    """Write ``text`` (UTF-8; bytes as they are) to ``path`` through a temporary file beside it and
    ``os.replace``."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex[:12]}.tmp")
    try:
        if isinstance(text, bytes):
            tmp.write_bytes(text)
        else:
            tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path
