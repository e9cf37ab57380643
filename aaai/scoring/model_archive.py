"""A model file read as data within limits: the archive's members, the JSON data part with every pickle
dropped unread, and the weights loaded as plain tensors (``torch.load(weights_only=True)``).

A model file is data of bounded size: before a member is read its declared size is checked
against a budget (:data:`MAX_DATA_BYTES` for the data part, :data:`MAX_MEMBER_BYTES` for each other
member, :data:`MAX_ARCHIVE_BYTES` for all of them, :data:`MAX_MEMBERS` members), and it is inflated
in chunks that stop at the budget; the data part nests at most :data:`MAX_JSON_DEPTH` levels, a
weights member holds at most :data:`MAX_RECORDS` records of finite numbers. A file that cannot be
read without running code from it is refused with :class:`UntrustedModel`, which names the field and
``--trust-model``; a damaged one, or one beyond a limit, names the file and the limit.
"""

from __future__ import annotations

import contextlib
import io
import json
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aaai.config import ConfigError

TRUST_FLAG = "--trust-model"

# --- limits on a model file (each refusal names the file, the member and the limit) ------------
MAX_MEMBERS = 64  # files inside one model .zip (stable-baselines3 writes 4 or 5)
MAX_DATA_BYTES = 16 << 20  # the JSON data part, inflated (a trained model's is a few kB)
MAX_MEMBER_BYTES = 640 << 20  # any other member (policy.pth, policy.optimizer.pth), inflated
MAX_ARCHIVE_BYTES = 1 << 30  # all members together, inflated
MAX_JSON_DEPTH = 64  # nesting of the data part (stable-baselines3 writes 4 levels)
MAX_LAYERS = 16  # hidden layers in net_arch (per network, for pi and vf)
MAX_WIDTH = 4096  # units in one hidden layer (the largest train.net_width)
MAX_PARAMETERS = 64_000_000  # the policy's parameters (256 MiB as float32; the optimiser holds twice that again)
MAX_RECORDS = 4096  # tensors in one .pth member (torch.save's zip holds one record per storage)
CHUNK_BYTES = 1 << 20  # a member is inflated this much at a time, stopping at its budget


class UntrustedModel(ConfigError):
    """A model that cannot be loaded without running code from it (and --trust-model was not given)."""


def _refuse(path: Path, field: str, why: str) -> UntrustedModel:
    return UntrustedModel(
        f"model file {str(path)!r}: field {field!r} {why}, so it cannot be loaded without running code from the "
        f"file; refused. If you trust this file (it executes as you), pass {TRUST_FLAG} to load it with "
        "stable-baselines3's own loader"
    )


def _bad(path: Path, problem: str) -> ConfigError:
    """A model file that is damaged or beyond a limit: one line naming it (trust would not help)."""
    return ConfigError(f"model file {str(path)!r}: {problem}; refused")


def _mib(size: int) -> str:
    return f"{size / (1 << 20):.1f} MiB"


# --- the archive ------------------------------------------------------------------------------
def _budget(name: str) -> int:
    return MAX_DATA_BYTES if name == "data" else MAX_MEMBER_BYTES


def _size_problem(archive: zipfile.ZipFile) -> str | None:
    """Why the members' declared sizes are beyond the budgets (None: within them)."""
    infos = archive.infolist()
    if len(infos) > MAX_MEMBERS:
        return f"it holds {len(infos)} members; allowed: at most {MAX_MEMBERS}"
    for info in infos:
        if info.file_size > _budget(info.filename):
            return (
                f"member {info.filename!r} inflates to {_mib(info.file_size)}; allowed: at most "
                f"{_mib(_budget(info.filename))}"
            )
    total = sum(info.file_size for info in infos)
    if total > MAX_ARCHIVE_BYTES:
        return f"its members inflate to {_mib(total)} together; allowed: at most {_mib(MAX_ARCHIVE_BYTES)}"
    return None


def size_problem(path: str | Path) -> str | None:
    """Why a model .zip is beyond the size budgets, from its members' declared sizes (nothing is
    inflated), or None when it is within them or is no zip (that is told elsewhere)."""
    try:
        with zipfile.ZipFile(path) as archive:
            return _size_problem(archive)
    except (zipfile.BadZipFile, OSError, EOFError, ValueError):
        return None


def _read_member(path: Path, archive: zipfile.ZipFile, name: str) -> bytes:
    """A member, inflated in chunks that stop at its budget (a declared size can lie)."""
    budget = _budget(name)
    info = archive.getinfo(name)
    if info.file_size > budget:
        raise _bad(path, f"member {name!r} inflates to {_mib(info.file_size)}; allowed: at most {_mib(budget)}")
    parts, size = [], 0
    with archive.open(info) as handle:
        while chunk := handle.read(CHUNK_BYTES):
            size += len(chunk)
            if size > budget:
                raise _bad(path, f"member {name!r} inflates beyond {_mib(budget)}, the most allowed")
            parts.append(chunk)
    return b"".join(parts)


def _depth_problem(value: Any) -> str | None:
    """Why a parsed data part nests too deep (checked without recursion), or None."""
    stack = [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if depth > MAX_JSON_DEPTH:
            return f"its data part nests deeper than {MAX_JSON_DEPTH} levels, the most allowed"
        if isinstance(item, dict):
            stack.extend((v, depth + 1) for v in item.values())
        elif isinstance(item, list):
            stack.extend((v, depth + 1) for v in item)
    return None


def _strip_pickles(value: Any) -> Any:
    """The value with every ":serialized:" entry removed, unread (at any depth)."""
    if isinstance(value, dict):
        return {k: _strip_pickles(v) for k, v in value.items() if k != ":serialized:"}
    if isinstance(value, list):
        return [_strip_pickles(v) for v in value]
    return value


def _pickled(value: Any) -> bool:
    return isinstance(value, dict) and ":type:" in value


@dataclass
class Archive:
    """A stable-baselines3 model file, read without unpickling: its data part (pickled fields
    reduced to the readable text beside them) and its weight files' names."""

    path: Path
    data: dict
    names: list[str]

    def tensors(self, name: str) -> Any:
        """A .pth member, read within its budget with ``torch.load(weights_only=True)`` (tensors and
        plain containers only), every tensor checked to be finite."""
        return read_tensors(self.path, name)


def read_tensors(path: str | Path, name: str = "policy.pth", trust_helps: bool = True) -> Any:
    """A .pth member of a model file: inflated within :data:`MAX_MEMBER_BYTES`, loaded with
    ``torch.load(weights_only=True)`` and checked (numbers only, every float finite). Only a member
    that holds objects other than tensors names ``--trust-model`` (what unpickling would read), and
    only where that flag would load it (``trust_helps``)."""
    import pickle

    import torch

    path = Path(path)
    try:
        with zipfile.ZipFile(path) as archive:
            blob = _read_member(path, archive, name)
    except KeyError:
        raise _bad(path, f"it lacks {name}") from None
    except (zipfile.BadZipFile, OSError, EOFError, ValueError, NotImplementedError) as error:
        raise _bad(path, f"member {name!r} cannot be read ({_first_line(error)})") from None
    except MemoryError:
        raise _out_of_memory(path, name) from None
    problem = _torch_format_problem(blob)
    if problem:
        raise _bad(path, f"member {name!r} {problem}")
    try:
        value = torch.load(io.BytesIO(blob), map_location="cpu", weights_only=True)
    except pickle.UnpicklingError as error:  # weights_only met an object other than tensors
        found = re.search(r"WeightsUnpickler error: ([^.\n]*)", str(error))
        what = f"holds more than plain tensors ({found.group(1) if found else _first_line(error)})"
        if trust_helps:
            raise _refuse(path, name, what) from None
        raise _bad(path, f"member {name!r} {what}") from None
    except MemoryError:
        raise _out_of_memory(path, name) from None
    except Exception as error:  # noqa: BLE001 - any other failure is damage in the file
        raise _bad(path, f"member {name!r} is damaged ({type(error).__name__}: {_first_line(error)})") from None
    problem = _tensor_problem(value)
    if problem:
        raise _bad(path, f"member {name!r}: {problem}")
    return value


def _torch_format_problem(blob: bytes) -> str | None:
    """Why a .pth blob is not torch.save's own format, whose tensors can be no larger than the blob:
    a zip of stored (uncompressed) records. The legacy format sizes storages from its header, and a
    deflated record would inflate beyond the member's budget inside torch.load."""
    if not blob.startswith(b"PK\x03\x04"):
        return "is not in torch.save's format (a zip of records)"
    try:
        with zipfile.ZipFile(io.BytesIO(blob)) as inner:
            records = inner.infolist()
    except (zipfile.BadZipFile, OSError, EOFError, ValueError) as error:
        return f"is damaged ({_first_line(error)})"
    if len(records) > MAX_RECORDS:
        return f"holds {len(records)} records; allowed: at most {MAX_RECORDS}"
    for record in records:
        if record.compress_type != zipfile.ZIP_STORED or record.file_size != record.compress_size:
            return f"holds a compressed record {record.filename!r} (torch.save writes none)"
    return None


def _out_of_memory(path: Path, name: str) -> ConfigError:
    """Memory ran out within the budgets: the machine's limit, not the file's trust, is the cause."""
    with contextlib.suppress(OSError, zipfile.BadZipFile, KeyError):
        with zipfile.ZipFile(path) as archive:
            size = _mib(archive.getinfo(name).file_size)
            return ConfigError(
                f"model file {str(path)!r}: member {name!r} ({size} inflated) does not fit in the memory this "
                "process may use; free memory or raise the limit"
            )
    return ConfigError(f"model file {str(path)!r}: member {name!r} does not fit in the memory this process may use")


def _first_line(error: BaseException) -> str:
    text = str(error).strip()
    return text.splitlines()[0][:200] if text else type(error).__name__


def _tensor_problem(value: Any) -> str | None:
    """Why a loaded .pth value is not plain finite numbers (walked without recursion), or None."""
    import torch

    stack: list[tuple[str, Any]] = [("", value)]
    while stack:
        where, item = stack.pop()
        if isinstance(item, dict):
            stack.extend((f"{where}.{k}" if where else str(k), v) for k, v in item.items())
        elif isinstance(item, (list, tuple)):
            stack.extend((f"{where}[{i}]", v) for i, v in enumerate(item))
        elif isinstance(item, torch.Tensor):
            if item.is_complex() or item.dtype in (torch.uint64, torch.uint32, torch.uint16) or item.is_quantized:
                return f"tensor {where!r} has dtype {item.dtype}; allowed: float, int or bool tensors"
            if item.is_floating_point() and not bool(torch.isfinite(item).all()):
                bad = int((~torch.isfinite(item)).sum())
                return f"tensor {where!r} holds {bad} values that are NaN or infinite; allowed: finite numbers"
    return None


def read_archive(path: str | Path) -> Archive:
    """Opens a model file and parses its data part as JSON only."""
    path = Path(path)
    try:
        with zipfile.ZipFile(path) as archive:
            problem = _size_problem(archive)
            if problem:
                raise _bad(path, problem)
            names = archive.namelist()
            text = _read_member(path, archive, "data").decode("utf-8")
    except KeyError:
        raise ConfigError(f"model file {str(path)!r} is not a stable-baselines3 model (it has no data part)") from None
    except (zipfile.BadZipFile, OSError, EOFError, UnicodeDecodeError, ValueError, NotImplementedError) as error:
        raise ConfigError(f"model file {str(path)!r} cannot be read: {_first_line(error)}") from None
    except MemoryError:
        raise _out_of_memory(path, "data") from None
    try:
        data = json.loads(text)
    except RecursionError:
        raise _bad(path, f"its data part nests deeper than {MAX_JSON_DEPTH} levels, the most allowed") from None
    except ValueError as error:
        raise ConfigError(
            f"model file {str(path)!r} cannot be loaded by stable-baselines3: its data part is not JSON ({error})"
        ) from None
    if not isinstance(data, dict):
        raise ConfigError(f"model file {str(path)!r}: its data part is not a JSON object")
    problem = _depth_problem(data)
    if problem:
        raise _bad(path, problem)
    return Archive(path, _strip_pickles(data), names)
