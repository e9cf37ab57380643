"""Atomic writing (aaai.files): whole files or nothing, with the permissions open() would give; a failed
write names its file; one holder at a time of a lock, released when its holder ends, however."""

import errno
import os
import signal
import stat
import subprocess
import sys
import time

import pytest

from aaai import files
from aaai.files import InUse, atomic_path, hold, write_atomic
from aaai.scoring import runs


@pytest.fixture
def umask_027():
    old = os.umask(0o027)
    yield
    os.umask(old)


def mode(path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


def test_write_atomic_replaces_whole_with_open_s_mode(tmp_path, umask_027):
    path = tmp_path / "new" / "config.yaml"  # the folder is made
    write_atomic(path, "a: 1\n")
    write_atomic(path, "a: 2\n")
    assert path.read_text() == "a: 2\n"
    assert mode(path) == 0o640  # 0o666 under the umask, not mkstemp's 0600
    assert sorted(p.name for p in path.parent.iterdir()) == ["config.yaml"]
    assert runs.write_atomic is write_atomic  # still importable from aaai.scoring.runs


def test_atomic_path_keeps_the_suffix_and_the_old_file_on_error(tmp_path):
    path = tmp_path / "picture.png"
    path.write_bytes(b"old")
    with atomic_path(path) as temporary:
        assert temporary.parent == tmp_path and temporary.suffix == ".png" and temporary != path
        temporary.write_bytes(b"new")
    assert path.read_bytes() == b"new"
    with pytest.raises(RuntimeError):
        with atomic_path(path) as temporary:
            temporary.write_bytes(b"half")
            raise RuntimeError("the writer failed")
    assert path.read_bytes() == b"new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["picture.png"]  # no temporary left behind


def test_atomic_path_needs_an_existing_folder(tmp_path):
    with pytest.raises(FileNotFoundError):
        atomic_path(tmp_path / "missing" / "x.png")


# --- naming the file of a failed write ------------------------------------------------------------
def test_a_full_disk_while_writing_names_the_file_not_its_temporary(tmp_path, monkeypatch):
    path = tmp_path / "state.json"
    path.write_text("old")
    real_fsync = os.fsync

    def full(descriptor):
        raise OSError(errno.ENOSPC, "No space left on device")  # as a write to a full disk: no file named

    monkeypatch.setattr(files.os, "fsync", full)
    with pytest.raises(OSError) as raised:
        write_atomic(path, "new")
    monkeypatch.setattr(files.os, "fsync", real_fsync)
    assert raised.value.errno == errno.ENOSPC and raised.value.filename == str(path)
    assert files.os_error_message(raised.value) == f"cannot write {str(path)!r}: No space left on device"
    assert path.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["state.json"]
    with pytest.raises(PermissionError) as denied:  # a write into the temporary that is refused
        with atomic_path(path) as temporary:
            raise PermissionError(errno.EACCES, "Permission denied", str(temporary))
    assert denied.value.filename == str(path) and path.read_text() == "old"


# --- one writer at a time ----------------------------------------------------------------------------
def refusal(pid):
    return f"held by {pid}"


def test_a_held_lock_refuses_at_once_naming_the_holder_and_is_free_after_release(tmp_path):
    path = tmp_path / ".lock"
    lock = hold(path, refusal)
    assert path.read_text() == f"{os.getpid()}\n"
    started = time.monotonic()
    with pytest.raises(InUse, match=f"held by {os.getpid()}") as raised:
        hold(path, refusal)  # another open of the file: refused as another process would be
    assert raised.value.pid == os.getpid() and time.monotonic() - started < 0.5
    lock.release()
    assert not path.exists()  # no lock file left behind
    with hold(path, refusal):
        pass
    assert not path.exists()


# The child says its pid itself, once it runs: after the fork's handlers (aaai.files closes its copy
# of the lock there), so a holder killed after that line is read kills no lock the child still holds.
HOLD_FORK_THEN_SLEEP = """
import multiprocessing, os, sys, time
from aaai.files import hold
def rest():
    print(os.getpid(), flush=True)
    time.sleep(60)
hold(sys.argv[1], str)
child = multiprocessing.get_context("fork").Process(target=rest)
child.start()
time.sleep(60)
"""


def test_a_lock_of_a_killed_holder_is_free_at_once_even_while_a_child_it_forked_lives_on(tmp_path):
    path = tmp_path / ".lock"
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLD_FORK_THEN_SLEEP, str(path)], stdout=subprocess.PIPE, text=True
    )
    child = int(holder.stdout.readline())
    try:
        with pytest.raises(InUse) as raised:
            hold(path, refusal)
        assert raised.value.pid == holder.pid
        holder.kill()
        holder.wait()
        assert path.read_text() == f"{holder.pid}\n"  # a killed holder leaves its file, not its lock
        with hold(path, refusal):
            assert path.read_text() == f"{os.getpid()}\n"
    finally:
        holder.kill()
        os.kill(child, signal.SIGKILL)
