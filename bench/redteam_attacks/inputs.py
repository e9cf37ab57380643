"""What an attack's folder is made of (files, pipes, links, copies of the shared inputs, mutated
replays, scoreboards and model zips) and the check that a file outside it is unchanged."""

from __future__ import annotations

import json
import os
import shlex
import shutil
import zipfile
from pathlib import Path

from .base import Result, base, replay_data


def text(name, content, encoding="utf-8"):
    def make(w: Path):
        path = w / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_bytes(content.encode(encoding))

    return make


def both(*makers):
    def make(w: Path):
        for m in makers:
            m(w)

    return make


def fifo(name):
    return lambda w: os.mkfifo(w / name)


def folder(name):
    return lambda w: (w / name).mkdir(parents=True, exist_ok=True)


def link(name, target):
    def make(w: Path):
        (w / name).parent.mkdir(parents=True, exist_ok=True)
        os.symlink(target.format(W=w, O=w.parent / "outside"), w / name)

    return make


def copy(source: str, name: str):
    def make(w: Path):
        src = base() / source
        if src.is_dir():
            shutil.copytree(src, w / name, symlinks=True)
        else:
            shutil.copy(src, w / name)

    return make


def victim(name="victim.txt", content="precious data\n"):
    return lambda w: (w.parent / "outside" / name).write_text(content)


def replay_file(name, change):
    def make(w: Path):
        data = replay_data()
        out = change(data, w)
        (w / name).write_text(out if isinstance(out, str) else json.dumps(data))

    return make


def board_file(name, change):
    def make(w: Path):
        raw = (base() / "board.csv").read_bytes()
        (w / name).write_bytes(change(raw))
        shutil.copy(base() / "board_scored_with.json", w / (Path(name).stem + "_scored_with.json"))

    return make


def model_file(name, change):
    def make(w: Path):
        with zipfile.ZipFile(base() / "model.zip") as z:
            members = [(i.filename, z.read(i.filename)) for i in z.infolist()]
        change(w / name, members, w)

    return make


def write_zip(path, members, compression=zipfile.ZIP_DEFLATED, **kw):
    with zipfile.ZipFile(path, "w", compression) as z:
        for name, data in members:
            info = name if isinstance(name, zipfile.ZipInfo) else zipfile.ZipInfo(name)
            info.compress_type = compression
            for key, value in kw.items():
                setattr(info, key, value)
            z.writestr(info, data)


def canary_pickle(w: Path) -> bytes:
    """A pickle that, unpickled, creates the canary."""
    import pickle

    class Payload:
        def __reduce__(self):
            return (os.system, (f"touch {shlex.quote(str(w.parent / 'CANARY'))}",))

    return pickle.dumps(Payload())


# --- checks ---------------------------------------------------------------------------------
def unchanged(name="victim.txt", content="precious data\n"):
    def check(w: Path, r: Result):
        path = w.parent / "outside" / name
        if not path.is_file() or path.is_symlink() or path.read_text() != content:
            return f"outside/{name} was changed"
        return None

    return check
