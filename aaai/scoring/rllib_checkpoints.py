"""RLlib checkpoints signed on this machine: an RLlib checkpoint is made of pickles (by RLlib's design),
so it loads only when trusted (``--trust-model``) or when its files carry this machine's signature.

The signature (:data:`SIGNATURE`, beside the checkpoint's ``rllib/`` folder) is written when this
machine's ``aaai train --backend rllib`` saves it (:func:`sign_checkpoint`): an HMAC-SHA256 over the
folder's digest (:func:`aaai.files.folder_sha256`) with a key kept in
``~/.config/aaai/checkpoint.key`` (or the file named by ``AAAI_CHECKPOINT_KEY``), created on first
use, readable by its owner only. A key shorter than :data:`MIN_KEY_BYTES` or readable by group or
others is refused, naming the file and the fix.
"""

from __future__ import annotations

import hashlib
import hmac
import os
import secrets
import stat
import tempfile
from pathlib import Path

from aaai.config import ConfigError
from aaai.files import folder_sha256, write_atomic
from aaai.scoring.model_archive import TRUST_FLAG, UntrustedModel

SIGNATURE = "rllib.hmac"  # beside the rllib/ folder of a saved point


def key_path() -> Path:
    return Path(os.environ.get("AAAI_CHECKPOINT_KEY") or Path.home() / ".config" / "aaai" / "checkpoint.key")


MIN_KEY_BYTES = 32  # a signing key shorter than this (an empty file left by a full disk) is refused


def _create_key(path: Path) -> None:
    """Writes a new key whole or not at all: a temporary file (mode 0600) beside it is written and
    fsync'd, then linked to its name, which fails if another process made the key meanwhile (theirs
    is kept). A full disk leaves no key, never an empty one."""
    path.parent.mkdir(parents=True, exist_ok=True)
    descriptor, name = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)  # O_EXCL, mode 0600
    try:
        with os.fdopen(descriptor, "wb") as handle:
            handle.write(secrets.token_hex(32).encode())
            handle.flush()
            os.fsync(handle.fileno())
        try:
            os.link(name, path)
        except FileExistsError:
            return  # made by another process meanwhile
        if hasattr(os, "O_DIRECTORY"):
            folder = os.open(path.parent, os.O_RDONLY | os.O_DIRECTORY)
            try:
                os.fsync(folder)
            finally:
                os.close(folder)
    except OSError as error:
        raise ConfigError(
            f"the checkpoint signing key {str(path)!r} cannot be created ({error.strerror or error}); nothing was "
            "written: free space or fix the folder's permissions and run again"
        ) from None
    finally:
        Path(name).unlink(missing_ok=True)


def signing_key() -> bytes:
    """This machine's signing key (created on first use, owner-only). A key that anyone could guess
    (shorter than :data:`MIN_KEY_BYTES`) or read (group or others may read it) is refused, naming it."""
    return _key()


def _key() -> bytes:
    """This machine's signing key (created on first use, owner-only). A key that anyone could guess
    (shorter than :data:`MIN_KEY_BYTES`) or read (group or others may read it) is refused, naming it."""
    path = key_path()
    if not path.exists():
        _create_key(path)
    try:
        mode = path.stat().st_mode
        key = path.read_bytes().strip()
    except OSError as error:
        raise ConfigError(
            f"the checkpoint signing key {str(path)!r} cannot be read ({error.strerror or error})"
        ) from None
    if os.name == "posix" and mode & (stat.S_IRWXG | stat.S_IRWXO):
        raise ConfigError(
            f"the checkpoint signing key {str(path)!r} is open to group or others (mode {stat.S_IMODE(mode):04o}), so "
            f"another user could forge checkpoint signatures; refused. Fix: chmod 600 {str(path)!r}"
        )
    if len(key) < MIN_KEY_BYTES:
        raise ConfigError(
            f"the checkpoint signing key {str(path)!r} holds {len(key)} bytes; allowed: at least {MIN_KEY_BYTES} "
            "(a shorter key lets anyone forge a signature); refused. Delete the file and a new key is made on next "
            f"use; RLlib checkpoints signed with the old one then load only with {TRUST_FLAG}"
        )
    return key


def sign_checkpoint(folder: str | Path) -> Path:
    """Signs an RLlib checkpoint folder this machine wrote (the signature goes beside it)."""
    folder = Path(folder)
    signature = hmac.new(_key(), folder_sha256(folder).encode(), hashlib.sha256).hexdigest()
    target = folder.parent / SIGNATURE
    write_atomic(target, signature + "\n")
    return target


def signed_here(folder: str | Path) -> bool:
    """Whether an RLlib checkpoint carries this machine's signature over its present files."""
    folder = Path(folder)
    try:
        stored = (folder.parent / SIGNATURE).read_text().strip()
    except OSError:
        return False
    if not key_path().exists():
        return False
    key = _key()  # a key that is too short or open to others is refused here, naming it
    expected = hmac.new(key, folder_sha256(folder).encode(), hashlib.sha256).hexdigest()
    return hmac.compare_digest(stored, expected)


def check_rllib_checkpoint(folder: str | Path, trust: bool = False) -> None:
    """Refuses to load an RLlib checkpoint (pickles) that is neither trusted nor signed here."""
    if trust or signed_here(folder):
        return
    raise UntrustedModel(
        f"RLlib checkpoint {str(folder)!r} is made of pickles, which run code as they load, and it does not carry "
        f"this machine's signature ({SIGNATURE}, written when aaai train --backend rllib saved it here); refused. "
        f"If you trust it, pass {TRUST_FLAG}"
    )
