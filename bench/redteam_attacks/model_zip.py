"""The model-zip group: ``eval --policy m.zip`` with odd member names, duplicate members, pickles
that would create the canary, links, the encrypted flag, prefixes, comments and compressions."""

from __future__ import annotations

import zipfile

from .base import attack, eval_argv
from .inputs import canary_pickle, copy, model_file, write_zip

GROUP = "model-zip"


def add(name, data):
    def change(path, members, w):
        write_zip(path, members + [(name, data)])

    return change


def rename(old, new):
    def change(path, members, w):
        write_zip(path, [(new if n == old else n, d) for n, d in members])

    return change


def evil_first(name):
    def change(path, members, w):
        write_zip(path, [(name, b"{}" if name == "data" else b"garbage")] + members)

    return change


def member(name, data, **kw):
    """The member ``name`` holding ``data`` (a function of the work folder), the other members kept."""

    def change(path, members, w):
        write_zip(path, [(n, data(w) if n == name else d) for n, d in members], **kw)

    return change


def padded(count):
    """Empty members added up to ``count`` members."""

    def change(path, members, w):
        write_zip(path, members + [(f"x{i}", b"") for i in range(count - len(members))])

    return change


def written(compression=zipfile.ZIP_DEFLATED, then=None):
    """The members written again with ``compression``; ``then`` changes the file's bytes after."""

    def change(path, members, w):
        write_zip(path, members, compression)
        if then:
            path.write_bytes(then(path.read_bytes()))

    return change


def flag_encrypted(data: bytes) -> bytes:
    """The zip's bytes with the "encrypted" flag set on every member, local and central."""
    raw = bytearray(data)
    for signature, offset in ((b"PK\x03\x04", 6), (b"PK\x01\x02", 8)):
        i = 0
        while (i := raw.find(signature, i)) >= 0:
            raw[i + offset] |= 1
            i += 4
    return bytes(raw)


def with_comment(path, members, w):
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for n, d in members:
            z.writestr(n, d)
        z.comment = b"c" * 65535


def outside_empty(w, r):
    return "a file appeared outside" if any((w.parent / "outside").iterdir()) else None


def attacks():
    cases = {
        "member-traversal": (add("../../outside/evil.txt", b"x"), "any"),
        "member-absolute": (add("/tmp/aaai-redteam-evil.txt", b"x"), "any"),
        "member-nul-name": (add("data\x00.txt", b"x"), "any"),
        "member-unicode": (add("dätä/ü.txt", b"x"), "any"),
        "member-backslash": (add("..\\..\\evil.txt", b"x"), "any"),
        "member-dir-entry": (add("data/", b""), "any"),
        "member-long-name": (add("a" * 60000, b"x"), "any"),
        "duplicate-data-first-evil": (evil_first("data"), "any"),
        "duplicate-policy-first-evil": (evil_first("policy.pth"), "any"),
        "data-uppercase-only": (rename("data", "DATA"), "error"),
        "policy-renamed": (rename("policy.pth", "policy.pt"), "error"),
        "variables-pickle-canary": (member("pytorch_variables.pth", canary_pickle), "any"),
        "optimizer-pickle-canary": (member("policy.optimizer.pth", canary_pickle), "any"),
        "policy-pickle-canary": (member("policy.pth", canary_pickle), "error"),
        "version-10mb": (member("_stable_baselines3_version", lambda w: b"9" * 10_000_000), "any"),
        "system-info-binary": (member("system_info.txt", lambda w: bytes(range(256)) * 100), "any"),
        "sixty-four-members": (padded(64), "any"),
        "sixty-five-members": (padded(65), "error"),
        "symlink-member-data": (member("data", lambda w: b"/etc/passwd", external_attr=0o120777 << 16), "error"),
        "encrypted-flag": (written(then=flag_encrypted), "error"),
        "prefixed-sfx": (written(then=lambda raw: b"#!/bin/sh\ntouch CANARY\n" + raw), "any"),
        "comment-64k": (with_comment, "any"),
        "stored-not-deflated": (written(zipfile.ZIP_STORED), "any"),
        "bzip2": (written(zipfile.ZIP_BZIP2), "any"),
        "lzma": (written(zipfile.ZIP_LZMA), "any"),
    }
    for name, (change, expect) in cases.items():
        attack(
            f"model-{name}", GROUP, eval_argv(policy="m.zip"), model_file("m.zip", change), expect, check=outside_empty
        )
    attack("model-unicode-name", GROUP, eval_argv(policy="мод ü.zip"), copy("model.zip", "мод ü.zip"), "ok")
    attack("model-no-zip-extension", GROUP, eval_argv(policy="model"), copy("model.zip", "model"), "any")
