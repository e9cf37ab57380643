"""The durable row writer (aaai.files.append_row) that `aaai play`'s abandoned-episode file uses:
header once, each row whole and fsynced, a torn tail cut, a failed write cut back."""

import csv
import errno
import os

import pytest

from aaai import files
from aaai.files import append_row

COLUMNS = ["player", "seed", "reason"]


def _rows(path):
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def test_header_once_then_rows(tmp_path):
    path = tmp_path / "out_abandoned.csv"
    append_row(path, COLUMNS, {"player": "cat", "seed": 1, "reason": "closed, the tab"})
    append_row(path, COLUMNS, {"player": "dog", "seed": 2, "reason": "idle"})
    assert path.read_text().count("player,seed,reason") == 1
    assert [(r["player"], r["seed"], r["reason"]) for r in _rows(path)] == [
        ("cat", "1", "closed, the tab"),
        ("dog", "2", "idle"),
    ]


def test_a_torn_last_line_is_cut_not_glued_to_the_next_row(tmp_path):
    path = tmp_path / "out_abandoned.csv"
    append_row(path, COLUMNS, {"player": "cat", "seed": 1, "reason": "idle"})
    with open(path, "a") as handle:
        handle.write("dog,2,cl")  # a kill in the middle of a write
    append_row(path, COLUMNS, {"player": "eve", "seed": 3, "reason": "idle"})
    assert [r["player"] for r in _rows(path)] == ["cat", "eve"]
    assert path.read_bytes().endswith(b"eve,3,idle\r\n")


def test_a_torn_header_alone_is_replaced_by_a_whole_one(tmp_path):
    path = tmp_path / "out_abandoned.csv"
    path.write_text("play")
    append_row(path, COLUMNS, {"player": "cat", "seed": 1, "reason": "idle"})
    assert [r["player"] for r in _rows(path)] == ["cat"]


def test_a_failed_write_leaves_the_rows_before_and_raises(tmp_path, monkeypatch):
    path = tmp_path / "out_abandoned.csv"
    append_row(path, COLUMNS, {"player": "cat", "seed": 1, "reason": "idle"})
    before = path.read_bytes()
    real_fsync = os.fsync

    def full(descriptor):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(files.os, "fsync", full)
    with pytest.raises(OSError):
        append_row(path, COLUMNS, {"player": "dog", "seed": 2, "reason": "idle"})
    monkeypatch.setattr(files.os, "fsync", real_fsync)
    assert path.read_bytes() == before
    append_row(path, COLUMNS, {"player": "eve", "seed": 3, "reason": "idle"})
    assert [r["player"] for r in _rows(path)] == ["cat", "eve"]


def test_every_row_is_fsynced(tmp_path, monkeypatch):
    synced = []
    real_fsync = os.fsync
    monkeypatch.setattr(files.os, "fsync", lambda d: (synced.append(d), real_fsync(d)))
    append_row(tmp_path / "a.csv", COLUMNS, {"player": "cat", "seed": 1, "reason": "idle"})
    append_row(tmp_path / "a.csv", COLUMNS, {"player": "cat", "seed": 2, "reason": "idle"})
    assert len(synced) == 2
