"""Atomic file writing: a reader (or a crash) sees the old whole file or the new whole file, never a part.

Every file the package writes whole (configs, states, scoreboard summaries, pictures, videos) goes
through ``atomic_path``: it is written to a temporary file beside its place and renamed onto it
when complete. Folders that must appear whole (a checkpoint) are staged by aaai.scoring.runs.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path


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
    discards on an error.
    """

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        handle, name = tempfile.mkstemp(prefix=f".{self.path.stem}.", suffix=self.path.suffix, dir=self.path.parent)
        os.close(handle)
        self.temporary = Path(name)
        try:
            os.chmod(self.temporary, creation_mode())  # not mkstemp's 0600
        except BaseException:
            self.discard()
            raise

    def commit(self) -> Path:
        """Flushes the temporary file to disk and renames it to ``path``."""
        try:
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
        else:
            self.discard()


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
    import csv
    import io

    path = Path(path)
    descriptor = os.open(path, os.O_RDWR | os.O_CREAT, creation_mode())
    try:
        size = os.fstat(descriptor).st_size
        if size:
            tail = os.pread(descriptor, min(size, 1 << 16), max(0, size - (1 << 16)))
            if not tail.endswith(b"\n"):
                cut = tail.rfind(b"\n")
                while cut < 0 and size > len(tail):  # a very long torn line: look further back
                    tail = os.pread(descriptor, size, 0)
                    cut = tail.rfind(b"\n")
                size = size - len(tail) + cut + 1 if cut >= 0 else 0
                os.ftruncate(descriptor, size)
        text = io.StringIO(newline="")
        writer = csv.DictWriter(text, fieldnames=columns, extrasaction="ignore")
        if size == 0:
            writer.writeheader()
        writer.writerow(row)
        data = text.getvalue().encode()
        try:
            written = 0
            while written < len(data):
                written += os.pwrite(descriptor, data[written:], size + written)
            os.fsync(descriptor)
        except OSError:
            try:
                os.ftruncate(descriptor, size)
            except OSError:
                pass  # the torn tail is cut by the next append
            raise
    finally:
        os.close(descriptor)
