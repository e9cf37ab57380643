"""Atomic file writing: a reader (or a crash) sees the old whole file or the new whole file, never a part;
and the lock that lets one process at a time write a run folder or a scoreboard.

Every file the package writes whole (configs, states, scoreboard summaries, pictures, videos) goes
through ``atomic_path``: it is written to a temporary file beside its place and renamed onto it
when complete. Folders that must appear whole (a checkpoint) are staged by aaai.scoring.runs.
The one SHA-256 of a file (:func:`file_sha256`) and of a folder (:func:`folder_sha256`) are here too.
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator

from aaai.errors import ConfigError


def file_sha256(path: str | os.PathLike) -> str:
    """The SHA-256 of a file's bytes (hex), read a MiB at a time."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def folder_sha256(folder: str | os.PathLike) -> str:
    """The SHA-256 of a folder's files (hex): over each file's path inside it, a NUL and the file's
    :func:`file_sha256`, in path order; a renamed, added, removed or changed file changes it."""
    folder = Path(folder)
    digest = hashlib.sha256()
    for file in sorted(f for f in folder.rglob("*") if f.is_file()):
        digest.update(str(file.relative_to(folder)).encode() + b"\0" + file_sha256(file).encode())
    return digest.hexdigest()


def creation_mode() -> int:
    """The permissions open() gives a new file under the current umask."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


class PendingFile:
    """A temporary file beside ``path`` (in the same folder, so that the rename is atomic; with the
    same suffix, so that writers choosing a format by it still do), created empty with the
    permissions open() would give ``path``. ``commit`` moves it onto ``path``, ``discard`` removes it.

    As a context manager it yields the temporary path, commits on leaving the block normally and
    discards on an error. An OSError (a full disk, a permission) names ``path``, not the temporary.
    """

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        try:
            handle, name = tempfile.mkstemp(prefix=f".{self.path.stem}.", suffix=self.path.suffix, dir=self.path.parent)
        except OSError as error:  # it names the temporary: name the file
            raise OSError(error.errno, error.strerror or str(error), str(self.path)) from error
        os.close(handle)
        self.temporary = Path(name)
        try:
            with naming(self.path, self.temporary):
                os.chmod(self.temporary, creation_mode())  # not mkstemp's 0600
        except BaseException:
            self.discard()
            raise

    def commit(self) -> Path:
        """Flushes the temporary file to disk and renames it to ``path``."""
        try:
            with naming(self.path, self.temporary):
                descriptor = os.open(self.temporary, os.O_RDONLY)
                try:
                    os.fsync(descriptor)
                finally:
                    os.close(descriptor)
                os.replace(self.temporary, self.path)
        finally:
            self.discard()
        return self.path

    def discard(self) -> None:
        self.temporary.unlink(missing_ok=True)

    def __enter__(self) -> Path:
        return self.temporary

    def __exit__(self, kind, error, trace) -> None:
        if kind is None:
            self.commit()
            return
        self.discard()
        if isinstance(error, OSError):  # a write into the temporary that failed (a full disk): name the file
            with naming(self.path, self.temporary):
                raise error


def atomic_path(path: str | os.PathLike) -> PendingFile:
    """``with atomic_path(path) as temporary:`` write to ``temporary``; on leaving the block it is
    fsync'd and renamed to ``path`` (with the mode open() would give a new file), or removed if the
    block raised. The folder must exist."""
    return PendingFile(path)


def write_atomic(path: str | os.PathLike, text: str) -> None:
    """Writes a text file atomically, creating its folder if need be."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as temporary:
        temporary.write_text(text)


def append_row(path: str | os.PathLike, columns: list[str], row: dict) -> None:
    """Appends one CSV row to ``path`` durably: the header with it if the file is new or empty, a
    torn last line (a write cut short by a crash) cut off first, header and row written in one
    call, fsynced before returning. If the write fails the file is cut back to its whole rows and
    the OSError propagates."""
    append_rows(path, columns, [[row.get(column, "") for column in columns]])


def append_rows(path: str | os.PathLike, columns: list[str], rows: list[list], sync: bool = True) -> None:
    """:func:`append_row` for several rows (each a list of values in the order of ``columns``),
    written in one call; ``sync=False`` leaves the fsync to the caller (:func:`sync_file`), e.g. a
    log that must be on disk only before a checkpoint that counts its rows. An OSError names ``path``."""
    import csv
    import io

    path = Path(path)
    with naming(path):
        descriptor = os.open(path, os.O_RDWR | os.O_CREAT, creation_mode())
        try:
            size = os.fstat(descriptor).st_size
            if size and os.pread(descriptor, 1, size - 1) != b"\n":  # a torn last line: cut it off
                tail = os.pread(descriptor, min(size, 1 << 16), max(0, size - (1 << 16)))
                cut = tail.rfind(b"\n")
                while cut < 0 and size > len(tail):  # a very long torn line: look further back
                    tail = os.pread(descriptor, size, 0)
                    cut = tail.rfind(b"\n")
                size = size - len(tail) + cut + 1 if cut >= 0 else 0
                os.ftruncate(descriptor, size)
            text = io.StringIO(newline="")
            writer = csv.writer(text)
            if size == 0:
                writer.writerow(columns)
            writer.writerows(rows)
            data = text.getvalue().encode()
            try:
                written = 0
                while written < len(data):
                    written += os.pwrite(descriptor, data[written:], size + written)
                if sync:
                    os.fsync(descriptor)
            except OSError:
                try:
                    os.ftruncate(descriptor, size)
                except OSError:
                    pass  # the torn tail is cut by the next append
                raise
        finally:
            os.close(descriptor)


def sync_file(path: str | os.PathLike) -> None:
    """Flushes a file that exists to disk (nothing for one that does not); an OSError names it."""
    path = Path(path)
    with naming(path):
        try:
            descriptor = os.open(path, os.O_RDONLY)
        except FileNotFoundError:
            return
        try:
            os.fsync(descriptor)
        finally:
            os.close(descriptor)


# --- naming the file of an OS error -----------------------------------------------------------
@contextmanager
def naming(path: str | os.PathLike, *temporaries: str | os.PathLike) -> Iterator[None]:
    """Re-raises an OSError raised inside the block with ``path`` as its file when it names none
    (a write or fsync on an open file: a full disk) or names one of ``temporaries`` (a staging copy
    the user never sees; a file inside a temporary folder is named at its place inside ``path``),
    so that the message says which file could not be written."""
    try:
        yield
    except OSError as error:
        where = _named(Path(path), [Path(t) for t in temporaries], error.filename)
        if where is None:
            raise
        raise OSError(error.errno, error.strerror or str(error), str(where)) from error  # PermissionError etc. by errno


def _named(path: Path, temporaries: list[Path], filename) -> Path | None:
    """The file an error on ``filename`` is about, as the user knows it (None: its own name)."""
    if filename is None:
        return path
    try:
        named = Path(os.fsdecode(filename))
    except TypeError:
        return None  # a descriptor
    for temporary in temporaries:
        if named == temporary:
            return path
        if temporary in named.parents:
            return path / named.relative_to(temporary)
    return None


def os_error_message(error: OSError) -> str:
    """One line for an OS error: the file and the cause ("cannot write 'runs/x/episodes.csv': No
    space left on device")."""
    where = getattr(error, "filename2", None) or error.filename  # a rename: its target
    cause = error.strerror or str(error) or type(error).__name__
    return f"cannot write {str(where)!r}: {cause}" if where is not None else cause


# --- one writer at a time -----------------------------------------------------------------
class InUse(ConfigError):
    """Another process holds the lock (:func:`hold`); ``pid`` is its process id, None if unknown."""

    def __init__(self, message: str, pid: int | None):
        super().__init__(message)
        self.pid = pid


_held: dict[int, Path] = {}  # the descriptors of the locks this process holds


def _close_in_child() -> None:
    """In a child forked from a holder: its copies of the locks are closed (that releases nothing:
    the holder's stay), so that a child outliving a killed holder does not keep its lock."""
    for descriptor in list(_held):
        try:
            os.close(descriptor)
        except OSError:
            pass
    _held.clear()


os.register_at_fork(after_in_child=_close_in_child)


class Lock:
    """An exclusive lock held on a lock file (``fcntl.flock``): :func:`hold` takes it, ``release``
    (or leaving the ``with`` block) gives it back and removes the file. The operating system
    releases it when the process ends, however it ends: a killed holder leaves no lock behind
    (its file, with its pid, stays until the next holder takes it over)."""

    def __init__(self, path: Path, descriptor: int):
        self.path = path
        self.descriptor: int | None = descriptor  # None once released
        _held[descriptor] = path

    def release(self) -> None:
        if self.descriptor is None:
            return
        try:
            self.path.unlink(missing_ok=True)  # while still held: a waiter that opened it sees it gone
        except OSError:
            pass
        _held.pop(self.descriptor, None)
        os.close(self.descriptor)  # releases the lock
        self.descriptor = None

    def __enter__(self) -> "Lock":
        return self

    def __exit__(self, *exc) -> None:
        self.release()


HOLDER_WAIT = 1.0  # seconds a refused process waits for the holder to write its pid


def hold(path: str | os.PathLike, refusal: Callable[[int | None], str]) -> Lock:
    """Takes the exclusive lock on the file ``path`` (created if need be, in a folder that must
    exist) and writes this process's id into it, or refuses at once: :class:`InUse` with the
    message ``refusal(pid)``, ``pid`` the holder's process id (None if it cannot be read)."""
    path = Path(path)
    for _ in range(100):  # a lock file removed by its holder as we opened it is opened again
        with naming(path):
            descriptor = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC | os.O_NOFOLLOW, creation_mode())
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            pid = _holder(descriptor)
            os.close(descriptor)
            raise InUse(refusal(pid), pid) from None
        except BaseException:
            os.close(descriptor)
            raise
        try:
            current = os.stat(path)
        except FileNotFoundError:
            current = None
        if current is None or not os.path.samestat(os.fstat(descriptor), current):
            os.close(descriptor)  # its holder released it and removed the file: lock the new one
            continue
        try:
            os.ftruncate(descriptor, 0)
            os.pwrite(descriptor, f"{os.getpid()}\n".encode(), 0)
        except OSError:
            pass  # a full disk: the lock holds all the same, a refused process reads no pid
        return Lock(path, descriptor)
    raise InUse(refusal(None), None)


def _holder(descriptor: int) -> int | None:
    """The pid in a lock file held by another process: the holder writes it just after taking the
    lock, so a moment is allowed for it (and for a file still naming an earlier, killed holder)."""
    deadline = time.monotonic() + HOLDER_WAIT
    pid = None
    while True:
        try:
            pid = int(os.pread(descriptor, 32, 0).decode().strip() or 0) or None
        except (OSError, ValueError):
            pid = None
        if pid is not None and _alive(pid) or time.monotonic() > deadline:
            return pid
        time.sleep(0.02)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # another user's process
    return True
