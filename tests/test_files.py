"""Atomic writing (aaai.files): whole files or nothing, with the permissions open() would give."""

import os
import stat

import pytest

from aaai.files import atomic_path, write_atomic
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
