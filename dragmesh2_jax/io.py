"""Atomic file writes (bytes, text, JSON, figures), folders that one writer at a time may change, operating-system
faults as one line, and content hashing: nothing is ever left half-written."""

from __future__ import annotations

import contextlib
import ctypes
import errno
import fcntl
import functools
import hashlib
import io
import json
import os
import shutil
import sys
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, Protocol

from dragmesh2_jax.errors import DragMeshError, FolderBusy, NotWritable

LOCK_NAME = ".lock"  # the advisory lock file of a folder that one writer at a time may change
#: Locks this process holds, by folder: [file descriptor, depth] (a writer that calls another writer of the same
#: folder, as reproduce evaluating a run it trains, holds the one lock).
_HELD: dict[Path, list[int]] = {}


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` via a temporary file in the same folder and an atomic rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600 files; give the usual permissions
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    return atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_json(path: str | os.PathLike, obj: Any, indent: int | None = 2) -> Path:
    return atomic_write_text(path, json.dumps(obj, indent=indent) + "\n")


def beside(path: Path) -> Path:
    """Where a folder's replacement is written before it takes ``path``'s place."""
    return path.with_name(f".{path.name}.tmp")


def aside(path: Path) -> Path:
    """Where a replaced folder waits while its replacement is renamed in, on systems that cannot swap two folders."""
    return path.with_name(f".{path.name}.old")


_RENAME_EXCHANGE, _AT_FDCWD = 2, -100  # <linux/fs.h>, <fcntl.h>
#: What renameat2 answers where the kernel, the C library or the filesystem cannot swap two folders.
_NO_EXCHANGE = {errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP}


@functools.cache
def _libc() -> ctypes.CDLL:
    return ctypes.CDLL(None, use_errno=True)


def _exchange(a: Path, b: Path) -> bool:
    """Swap the folders ``a`` and ``b`` in one step (Linux's ``renameat2(RENAME_EXCHANGE)``); False where the system
    cannot."""
    swap = getattr(_libc(), "renameat2", None)
    if swap is None:
        return False
    if swap(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in _NO_EXCHANGE:
        return False
    raise OSError(code, os.strerror(code), str(b))


def replace_folder(new: Path, path: Path) -> None:
    """The finished folder ``new`` takes ``path``'s place. Where the system swaps two folders in one step, a reader
    or a kill at any moment finds ``path`` whole, old or new; elsewhere the old folder is moved ``aside`` for the
    moment between two renames, and a kill there leaves it for :func:`restore_aside`. What is left to delete after a
    kill (the old copy at ``beside`` or ``aside``) is deleted by the next replacement or ``restore_aside``."""
    if not path.exists():
        new.rename(path)
    elif _exchange(new, path):
        shutil.rmtree(new)  # now the old copy
    else:
        old = aside(path)
        shutil.rmtree(old, ignore_errors=True)  # a copy a kill left half deleted
        path.rename(old)
        new.rename(path)
        shutil.rmtree(old)


def restore_aside(folder: Path) -> list[str]:
    """After a kill, under the writer's lock: each folder in ``folder`` that a replacement had moved ``aside`` and
    not yet replaced is put back, and the leftovers of unfinished replacements are deleted. Returns what was done,
    a line each."""
    done = []
    for old in sorted(folder.glob(".*.old")):
        path = old.with_name(old.name[1:-len(".old")])
        if path.exists():
            shutil.rmtree(old)
        else:
            old.rename(path)
            done.append(f"{path}: restored (a kill interrupted its replacement)")
    for tmp in sorted(folder.glob(".*.tmp")):
        if tmp.is_dir():
            shutil.rmtree(tmp)
            done.append(f"{tmp}: removed (a replacement a kill left unfinished)")
    return done


class Drawable(Protocol):
    """A figure that draws itself into a file: matplotlib's ``Figure``, named by what it does so that this module,
    which every writer imports, does not load matplotlib."""

    def savefig(self, fname: Any, **kwargs: Any) -> Any: ...


def atomic_write_figure(path: str | os.PathLike, fig: Drawable, **savefig: Any) -> Path:
    """``fig`` as a PNG at ``path`` (``savefig``: matplotlib's options, such as ``dpi``), written atomically."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", **savefig)
    return atomic_write_bytes(path, buf.getvalue())


def hash_files(paths: Iterable[str | os.PathLike], extra: str = "") -> str:
    """SHA-256 (first 16 hex digits) over the contents of ``paths`` in the given order, plus ``extra``."""
    h = hashlib.sha256()
    for p in paths:
        h.update(Path(p).read_bytes())
        h.update(b"\0")
    h.update(extra.encode())
    return h.hexdigest()[:16]


def object_hash(folder: str | os.PathLike) -> str:
    """The content hash of an object folder: every file under it, in path order."""
    root = Path(folder)
    files = sorted(p for p in root.rglob("*") if p.is_file())
    if not files:
        raise DragMeshError(f"{root}: no object files to hash")
    return hash_files(files, extra="\n".join(str(p.relative_to(root)) for p in files))


def cache_dir() -> Path:
    """Where derived geometry is cached: ``$DRAGMESH2_CACHE`` or ``~/.cache/dragmesh2``."""
    root = os.environ.get("DRAGMESH2_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME", os.path.expanduser("~/.cache")), "dragmesh2"
    )
    return Path(root)


def make_folder(folder: str | os.PathLike) -> Path:
    """``folder`` and its parents, created where missing; one-line errors where that cannot be."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise DragMeshError(f"{folder}: exists and is not a folder") from None
    except OSError as e:
        raise DragMeshError(f"{folder}: cannot be created ({e.strerror})") from None
    return folder


@contextlib.contextmanager
def folder_lock(folder: str | os.PathLike) -> Iterator[Path]:
    """Hold the operating system's advisory lock on ``folder`` (created where missing) for the block: one writer
    at a time. A second process gets one error line naming the holder's process id; this process may enter again.
    The lock goes with the process, however it ends (no stale lock to remove by hand)."""
    folder = make_folder(folder)
    key = folder.resolve()
    if key in _HELD:
        _HELD[key][1] += 1
        try:
            yield folder
        finally:
            _HELD[key][1] -= 1
        return
    path = folder / LOCK_NAME
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    except OSError as e:
        raise NotWritable(f"{folder}: cannot be written ({e.strerror})") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = os.pread(fd, 4096, 0).decode(errors="replace").strip() or "unknown"
        os.close(fd)
        raise FolderBusy(f"{folder}: in use by another writer (process {holder}); wait for it to end, or write "
                            "to another folder") from None
    except OSError as e:  # storage without locks (some network filesystems)
        os.close(fd)
        raise DragMeshError(f"{folder}: cannot be locked ({e.strerror}); write to local storage") from None
    try:
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}: {' '.join(sys.argv[:8])}\n".encode(), 0)
    except OSError:
        pass  # the holder's name is a courtesy; the lock itself is held
    _HELD[key] = [fd, 1]
    try:
        yield folder
    finally:
        del _HELD[key]
        os.close(fd)


#: What to do about an operating-system fault, by its errno.
OS_HINTS = {
    errno.ENOSPC: "free some space and run the same command again (a run resumes from its last checkpoint with "
                  "--resume)",
    errno.EDQUOT: "free some space and run the same command again",
    errno.EROFS: "the storage is read-only: write to another folder",
    errno.EACCES: "no permission: write to another folder",
    errno.EPERM: "no permission: write to another folder",
}


def os_error_line(e: OSError) -> str:
    """An operating-system fault as one line: the file, what went wrong and what to do."""
    where = e.filename if e.filename is not None else "a file"
    what = e.strerror or str(e)
    hint = OS_HINTS.get(e.errno or -1)
    return " ".join(f"{where}: {what}{f'; {hint}' if hint else ''}".split())
