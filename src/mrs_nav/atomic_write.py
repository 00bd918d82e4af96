"""Outputs written whole or not at all, and never over an input of the same command.

Every file mrs_nav writes goes to a hidden temporary name in its own folder (``.NAME.XXXXXXXX.partial``), is
flushed to disk and then renamed over ``NAME``: a full disk, a read-only folder or a kill leaves the previous
file (or none) under the final name, never a truncated one. On failure the temporary file is removed and the
error names the output and the system's reason (``No space left on device``). A final name that is not a
regular file (``/dev/full``, a FIFO) is refused: renaming over it would replace the device, not write to it.
"""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
import stat
from collections.abc import Iterable, Iterator
from pathlib import Path

from mrs_nav.errors import OutputFileError

#: Failures of writing itself (the folder, the disk, the permissions), reported as the output's error even when
#: the library that wrote did not name the file.
WRITE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM, errno.EFBIG, errno.EIO})


def final_target(path: Path, what: str = "output") -> Path:
    """The file that will be replaced: ``path``, or the file a symbolic link there names; refused (with
    :class:`OutputFileError`) when it exists and is not a regular file."""
    target = Path(os.path.realpath(path)) if path.is_symlink() else path
    try:
        info = target.stat()
    except FileNotFoundError:
        return target
    except OSError as err:
        raise OutputFileError(f"{path}: cannot write {what}: {err.strerror or err}") from None
    if not stat.S_ISREG(info.st_mode):
        kind = "a folder" if stat.S_ISDIR(info.st_mode) else "not a regular file"
        raise OutputFileError(f"{path}: cannot write {what}: {kind}")
    return target


@contextlib.contextmanager
def atomic_path(path: Path | str, what: str = "output") -> Iterator[Path]:
    """A fresh (not yet existing) temporary path beside ``path`` to write to; renamed over ``path`` when the
    block ends without an error, removed otherwise. A failure to write becomes :class:`OutputFileError`."""
    given = Path(path)
    final = final_target(given, what)
    temp = final.with_name(f".{final.name}.{secrets.token_hex(4)}.partial")
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        yield temp
        _fsync(temp)
        os.replace(temp, final)
        _fsync_folder(final.parent)
    except OSError as err:
        if err.errno not in WRITE_ERRNOS and err.filename not in (str(temp), str(final), str(final.parent)):
            raise  # not this output's failure (an input that went away, say): let it speak for itself
        raise OutputFileError(f"{given}: cannot write {what}: {err.strerror or err}") from err
    finally:
        with contextlib.suppress(OSError):  # already renamed into place, never created, or its folder is gone
            temp.unlink()


def write_text(path: Path | str, text: str, what: str = "output") -> Path:
    """Write ``text`` (UTF-8) to ``path`` whole or not at all; returns ``path``."""
    with atomic_path(path, what) as temp:
        temp.write_text(text, encoding="utf-8")
    return Path(path)


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_folder(folder: Path) -> None:
    """Make the rename itself durable; some file systems cannot sync a folder, which costs only that."""
    with contextlib.suppress(OSError):
        _fsync(folder)


def check_not_inputs(outputs: Iterable[tuple[str, Path]], inputs: Iterable[tuple[str, Path]]) -> None:
    """Refuse (with :class:`OutputFileError`, before any work) an output that is one of the command's inputs, or
    another of its outputs (the later would silently replace the earlier): the same file (inode) or the same
    resolved path. Each pair is ``(what the user called it, path)``."""
    known = [(what, path, _identity(path)) for what, path in inputs]
    written: list[tuple[str, Path, tuple[int, int] | None]] = []
    for out_what, out in outputs:
        identity = _identity(out)
        resolved = out.resolve()
        for in_what, path, in_identity in known:
            if (identity is not None and identity == in_identity) or resolved == path.resolve():
                raise OutputFileError(
                    f"{out_what} {out} is the {in_what} {path}: refusing to overwrite an input of this command"
                )
        for other_what, other, other_identity in written:
            if (identity is not None and identity == other_identity) or resolved == other.resolve():
                raise OutputFileError(f"{out_what} {out} is the {other_what} {other}: two outputs under one name")
        written.append((out_what, out, identity))


def _identity(path: Path) -> tuple[int, int] | None:
    try:
        info = path.stat()
    except (OSError, ValueError):
        return None
    return info.st_dev, info.st_ino
