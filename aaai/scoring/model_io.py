"""Loading trained models without running code from them.

A stable-baselines3 model file (.zip) holds the weights (``policy.pth``, read here with
``torch.load(weights_only=True)``) and a JSON part (``data``) in which every value that is not plain
JSON (the policy class, the spaces, the schedules, buffers) is a cloudpickle, base64-encoded under
``":serialized:"``. ``PPO.load`` unpickles those, and an unpickled value can run any code. Here the
pickles are dropped unread, as the file is parsed, and every such field is rebuilt from what we know:

- the policy class from :data:`POLICIES` (the class the file names in readable text, looked up in
  our registry; the file's own class is never used);
- the observation and action spaces from the environment the model is to act in (checked against
  the readable description the file keeps of its own, see :func:`space_problems`);
- ``policy_kwargs`` from the plain JSON (activation functions, optimisers and feature extractors
  named in text are looked up in registries here), else from the run's config;
- schedules as constants (``ConstantSchedule(val=...)`` read from the text, else the plain number).

A file that cannot be rebuilt so is refused with :class:`UntrustedModel`, which names the field and
the ``--trust-model`` flag; with that flag (``trust=True``) stable-baselines3's own loader is used.

RLlib checkpoints are pickles by RLlib's design (``class_and_ctor_args.pkl``, ``module_state.pkl``):
they are loaded only when trusted, or when their files carry this machine's signature, written when
this machine's ``aaai train --backend rllib`` saved them (:func:`sign_checkpoint`): an HMAC-SHA256
over the checkpoint's files with a key kept in ``~/.config/aaai/checkpoint.key`` (or the file named
by ``AAAI_CHECKPOINT_KEY``), created on first use, readable by its owner only. :class:`RLlibPolicy`
loads such a checkpoint's policy for scoring. A key shorter than :data:`MIN_KEY_BYTES` or readable
by group or others is refused, naming the file and the fix.

A model file is also data of bounded size: before a member is read its declared size is checked
against a budget (:data:`MAX_DATA_BYTES` for the data part, :data:`MAX_MEMBER_BYTES` for each other
member, :data:`MAX_ARCHIVE_BYTES` for all of them, :data:`MAX_MEMBERS` members), and it is inflated
in chunks that stop at the budget. The network the file declares (``net_arch``: at most
:data:`MAX_LAYERS` layers of at most :data:`MAX_WIDTH` units) is sized without memory (on torch's
``meta`` device) and refused beyond :data:`MAX_PARAMETERS` parameters, and every tensor's name,
shape, dtype and finiteness is checked against it, all before the network is built.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import hashlib
import hmac
import importlib
import io
import json
import os
import re
import secrets
import stat
import tempfile
import threading
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aaai import safe_yaml
from aaai.config import Config, ConfigError, load_config
from aaai.files import atomic_path, write_atomic
from aaai.scoring.runs import MODULE_PATH, rllib_checkpoint

TRUST_FLAG = "--trust-model"

# The policy class a file names (its readable ``__init__`` text) -> (module, algorithm, the policy name
# that algorithm takes). The classes themselves are imported from these libraries, never from the file.
POLICIES = {
    "ActorCriticPolicy": ("stable_baselines3", "PPO", "MlpPolicy"),
    "ActorCriticCnnPolicy": ("stable_baselines3", "PPO", "CnnPolicy"),
    "MultiInputActorCriticPolicy": ("stable_baselines3", "PPO", "MultiInputPolicy"),
    "RecurrentActorCriticPolicy": ("sb3_contrib", "RecurrentPPO", "MlpLstmPolicy"),
    "RecurrentActorCriticCnnPolicy": ("sb3_contrib", "RecurrentPPO", "CnnLstmPolicy"),
    "RecurrentMultiInputActorCriticPolicy": ("sb3_contrib", "RecurrentPPO", "MultiInputLstmPolicy"),
}
POLICY_MODULES = ("stable_baselines3.common.policies", "sb3_contrib.common.recurrent.policies")

# Classes a policy_kwargs value may name (as text "<class 'module.Name'>"), by that dotted name.
CLASSES = {
    f"torch.nn.modules.activation.{name}": ("torch.nn", name)
    for name in ("ReLU", "Tanh", "ELU", "LeakyReLU", "SiLU", "GELU", "Sigmoid", "Softplus")
}
CLASSES.update(
    {
        f"torch.optim.{module}.{name}": ("torch.optim", name)
        for module, name in (("adam", "Adam"), ("adamw", "AdamW"), ("rmsprop", "RMSprop"), ("sgd", "SGD"))
    }
)
CLASSES.update(
    {
        f"stable_baselines3.common.torch_layers.{name}": ("stable_baselines3.common.torch_layers", name)
        for name in ("CombinedExtractor", "FlattenExtractor", "NatureCNN")
    }
)
CLASS_KEYS = {"activation_fn", "optimizer_class", "features_extractor_class"}
# policy_kwargs keys taken as plain JSON (numbers, booleans, lists and dicts of them).
PLAIN_KEYS = {
    "net_arch",
    "log_std_init",
    "ortho_init",
    "full_std",
    "use_expln",
    "squash_output",
    "share_features_extractor",
    "normalize_images",
    "optimizer_kwargs",
    "features_extractor_kwargs",
    "lstm_hidden_size",
    "n_lstm_layers",
    "shared_lstm",
    "enable_critic_lstm",
    "lstm_kwargs",
}

# Fields of the data part that a rebuilt PPO takes as they are (plain JSON numbers and flags).
HYPERPARAMETERS = (
    "n_steps",
    "batch_size",
    "n_epochs",
    "gamma",
    "gae_lambda",
    "ent_coef",
    "vf_coef",
    "max_grad_norm",
    "normalize_advantage",
    "target_kl",
    "use_sde",
    "sde_sample_freq",
    "seed",
    "verbose",
)
COUNTERS = (
    "num_timesteps",
    "_total_timesteps",
    "_num_timesteps_at_start",
    "_episode_num",
    "_n_updates",
    "_current_progress_remaining",
)

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

_TRUST = contextvars.ContextVar("aaai_trust_model", default=False)


class UntrustedModel(ConfigError):
    """A model that cannot be loaded without running code from it (and --trust-model was not given)."""


@contextlib.contextmanager
def trusting(trust: bool = True):
    """Within the block, loads that are not told otherwise trust model files (``aaai train
    --trust-model``: the trainers' resume paths read this)."""
    token = _TRUST.set(bool(trust))
    try:
        yield
    finally:
        _TRUST.reset(token)


def trusted(trust: bool | None = None) -> bool:
    return _TRUST.get() if trust is None else bool(trust)


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


# The environment config a model was trained with, kept in its file beside stable-baselines3's own
# members (which its loader ignores): a model file is scored in its own environment on its own.
CONFIG_MEMBER = "aaai_config.yaml"


def save_model(model, path: str | Path, config: Config) -> Path:
    """``model.save`` with ``config`` as the file's :data:`CONFIG_MEMBER`, written whole (a temporary
    file beside ``path``, renamed onto it when complete)."""
    path = Path(path)
    with atomic_path(path) as partial:
        model.save(partial)
        with zipfile.ZipFile(partial, "a", compression=zipfile.ZIP_DEFLATED) as archive:
            archive.writestr(CONFIG_MEMBER, config.to_yaml())
    return path


def model_config(path: str | Path) -> Config | None:
    """The environment config a model file carries (:data:`CONFIG_MEMBER`, read as YAML data and
    checked as any config), or None for a file without one. One that does not load is refused,
    naming the file."""
    try:
        with zipfile.ZipFile(path) as archive:
            if CONFIG_MEMBER not in archive.namelist():
                return None
            size = archive.getinfo(CONFIG_MEMBER).file_size
            if size > safe_yaml.MAX_BYTES:
                raise ConfigError(
                    f"model file {str(path)!r}: its {CONFIG_MEMBER} inflates to {size} bytes; "
                    f"allowed: at most {safe_yaml.MAX_BYTES}"
                )
            with archive.open(CONFIG_MEMBER) as member:
                text = member.read(safe_yaml.MAX_BYTES + 1).decode("utf-8")
    except (zipfile.BadZipFile, OSError, EOFError, UnicodeDecodeError) as error:
        raise ConfigError(f"model file {str(path)!r}: its {CONFIG_MEMBER} cannot be read: {error}") from None
    try:
        data = safe_yaml.parse(text, f"model file {str(path)!r}: its {CONFIG_MEMBER}")[0]
        if not isinstance(data, dict):
            raise ConfigError(f"it is {type(data).__name__}, not a mapping")
        return load_config(data)
    except ConfigError as error:
        raise ConfigError(
            f"model file {str(path)!r}: the config it carries ({CONFIG_MEMBER}) does not load: {error}; "
            "allowed: a config aaai loads (or score the file with --config)"
        ) from None


def file_sha256(path: str | Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


# --- the fields rebuilt -------------------------------------------------------------------------
def policy_class_name(archive: Archive) -> str:
    """The registered policy class the file names (refused if it names another)."""
    entry = archive.data.get("policy_class")
    if not isinstance(entry, dict):
        raise _bad(archive.path, "its field 'policy_class' is missing or not the description of a class")
    match = re.fullmatch(r"<function (\w+)\.__init__ at 0x[0-9a-fA-F]+>", str(entry.get("__init__", "")))
    if match is None or match.group(1) not in POLICIES or entry.get("__module__") not in POLICY_MODULES:
        shown = match.group(1) if match else entry.get(":type:", "?")
        raise _refuse(
            archive.path,
            "policy_class",
            f"names {shown!r} (module {entry.get('__module__')!r}), which is "
            f"not one of ours ({', '.join(sorted(POLICIES))})",
        )
    return match.group(1)


def _algorithm(archive: Archive):
    module, algorithm, alias = POLICIES[policy_class_name(archive)]
    try:
        library = importlib.import_module(module)
    except ImportError:
        raise ConfigError(
            f"model file {str(archive.path)!r} is a {algorithm} model, which needs {module} "
            f"(pip install {module.replace('_', '-')})"
        ) from None
    return getattr(library, algorithm), alias


def _policy_class(archive: Archive):
    """The policy class the file names, from our registry (its library imported here)."""
    name = policy_class_name(archive)
    _algorithm(archive)  # the library is there
    module = (
        "sb3_contrib.common.recurrent.policies" if name.startswith("Recurrent") else "stable_baselines3.common.policies"
    )
    return getattr(importlib.import_module(module), name)


def _named_class(path: Path, field: str, text: Any):
    match = re.fullmatch(r"<class '([\w.]+)'>", str(text))
    if match is None or match.group(1) not in CLASSES:
        raise _refuse(
            path, field, f"names {text!r}, which is not among the classes allowed there ({', '.join(sorted(CLASSES))})"
        )
    module, name = CLASSES[match.group(1)]
    return getattr(importlib.import_module(module), name)


def _plain(value: Any) -> bool:
    if isinstance(value, dict):
        return all(isinstance(k, str) and _plain(v) for k, v in value.items())
    if isinstance(value, list):
        return all(_plain(v) for v in value)
    return value is None or isinstance(value, (bool, int, float, str))


def policy_kwargs(archive: Archive, fallback: dict | None = None) -> dict:
    """The policy's keyword arguments from the file's plain JSON (class names looked up in
    :data:`CLASSES`), or ``fallback`` (from the run's config) when the file has none."""
    stored = archive.data.get("policy_kwargs")
    if stored is None:
        return dict(fallback or {})
    if not isinstance(stored, dict):
        raise _bad(archive.path, f"its field 'policy_kwargs' is {str(stored)[:60]!r}; allowed: a mapping")
    kwargs = {}
    for key, value in stored.items():
        field = f"policy_kwargs.{key}"
        if key in (":type:", "device"):
            continue
        if key in CLASS_KEYS:
            kwargs[key] = _named_class(archive.path, field, value)
        elif key in PLAIN_KEYS and _plain(value) and not (_pickled(stored) and isinstance(value, str)):
            kwargs[key] = value
        else:
            if _pickled(value) or _pickled(stored) or str(value).startswith("<"):  # an object: only its pickle says
                raise _refuse(archive.path, field, f"holds {str(value)[:80]!r}, which is not a plain setting we know")
            raise _bad(archive.path, f"field {field!r} holds {str(value)[:80]!r}, not a setting the policy takes")
    net_arch = kwargs.get("net_arch")
    if isinstance(net_arch, list) and net_arch and isinstance(net_arch[0], dict):
        kwargs["net_arch"] = net_arch[0]  # the old format, as stable-baselines3 converts it
    return kwargs


def schedule_constant(archive: Archive, field: str, default: float | None = None) -> float | None:
    """A schedule field as a constant: a plain number, ``ConstantSchedule(val=x)`` in the pickled
    entry's text, or ``default`` when the field is absent."""
    value = archive.data.get(field)
    if value is None:
        return default
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    if isinstance(value, dict):
        text = str(value.get("value_schedule", value.get("val", "")))
        match = re.fullmatch(r"ConstantSchedule\(val=([-+0-9.eE]+|inf)\)", text)
        if match:
            return float(match.group(1))
    if _pickled(value):  # a pickled function: only running it tells what it returns
        raise _refuse(archive.path, field, "is a schedule that is not a constant")
    raise _bad(archive.path, f"field {field!r} is {str(value)[:60]!r}; allowed: a number or a constant schedule")


# --- spaces -------------------------------------------------------------------------------------
# A file keeps its spaces as text: a Box's fields (shape, dtype, its bounds as numpy prints them) and
# a Dict's sub-spaces as their reprs. Gymnasium has changed what its spaces keep and print (1.4
# fills ``low_repr`` only when the space is printed), so spaces are compared by value: kind, shape,
# dtype and bounds, read from whichever form the file has.
_NUMBER = re.compile(r"[-+]?(?:inf|nan|\d+\.?\d*(?:[eE][-+]?\d+)?|\.\d+(?:[eE][-+]?\d+)?)")
_BOX = re.compile(r"Box\((?P<low>[^,]+), (?P<high>[^,]+), \((?P<shape>[\d, ]*)\), (?P<dtype>\w+)\)", re.DOTALL)


def _bound(text: Any) -> np.ndarray | None:
    """A bound as numpy printed it (a scalar, or an array without commas); None when it was not
    kept or was shortened (numpy prints ``...`` for a large array)."""
    if not isinstance(text, str) or "..." in text:
        return None
    numbers = _NUMBER.findall(text)
    if not numbers or re.sub(r"[\[\]\s]", "", _NUMBER.sub("", text)):
        return None
    return np.array([float(n) for n in numbers], dtype=np.float64)


@dataclass(frozen=True)
class SpaceValue:
    """One space by value: its kind, shape, dtype and bounds (for a Box), and the text shown for it."""

    text: str
    kind: str
    shape: tuple | None = None
    dtype: str | None = None
    low: np.ndarray | None = dataclasses.field(default=None, compare=False)
    high: np.ndarray | None = dataclasses.field(default=None, compare=False)

    def agrees(self, other: "SpaceValue") -> bool:
        if self.kind != other.kind:
            return False
        if self.kind != "Box":
            return self.text == other.text
        if (self.shape, self.dtype) != (other.shape, other.dtype):
            return False
        size = int(np.prod(self.shape)) if self.shape is not None else 0
        for mine, theirs in ((self.low, other.low), (self.high, other.high)):
            if mine is None or theirs is None:
                continue  # a bound the file does not keep in full: shape and dtype decide
            if mine.size not in (1, size) or theirs.size not in (1, size):
                return False
            a, b = np.broadcast_to(mine, (size,)), np.broadcast_to(theirs, (size,))
            if not np.allclose(a, b, rtol=1e-6, atol=1e-7, equal_nan=True):
                return False
        return True


def _box_text(text: str) -> SpaceValue:
    """A Box's repr (``Box(low, high, (shape), dtype)``) as a value; another space's as its text."""
    match = _BOX.fullmatch(text.strip())
    if match is None:
        return SpaceValue(text, text.split("(", 1)[0].strip())
    shape = tuple(int(n) for n in re.findall(r"\d+", match.group("shape")))
    return SpaceValue(text, "Box", shape, match.group("dtype"), _bound(match.group("low")), _bound(match.group("high")))


def _space_parts(text: str) -> dict[str, SpaceValue]:
    """A Dict space's repr ``{'a': Box(...), 'b': Box(...)}`` as {key: value}."""
    found = list(re.finditer(r"'([^']+)': ", text))
    parts = {}
    for i, match in enumerate(found):
        end = found[i + 1].start() if i + 1 < len(found) else len(text)
        parts[match.group(1)] = _box_text(text[match.end() : end].rstrip(" ,}"))
    return parts


def stored_space(archive: Archive, field: str) -> dict[str, SpaceValue] | None:
    """The space a file keeps, by value: {key: value} for a Dict space, {"": value} for a Box or a
    Discrete; None when the file keeps no readable description of it."""
    entry = archive.data.get(field)
    if not isinstance(entry, dict):
        return None
    kind = str(entry.get(":type:", ""))
    if kind.endswith(".Dict'>") and isinstance(entry.get("spaces"), str):
        return _space_parts(entry["spaces"])
    if kind.endswith(".Box'>") and isinstance(entry.get("_shape"), list):
        shape = tuple(int(n) for n in entry["_shape"])
        low = entry.get("low_repr") if isinstance(entry.get("low_repr"), str) else entry.get("low")
        high = entry.get("high_repr") if isinstance(entry.get("high_repr"), str) else entry.get("high")
        text = f"Box({low}, {high}, {shape}, {entry.get('dtype')})"
        return {"": SpaceValue(text, "Box", shape, str(entry.get("dtype")), _bound(low), _bound(high))}
    if kind.endswith(".Discrete'>"):
        start = entry.get("start")
        shown = "" if start in (None, 0, "0") else f", start={start}"
        text = f"Discrete({entry.get('n')}{shown})"
        return {"": SpaceValue(text, "Discrete")}
    return None


def _live_value(space) -> SpaceValue:
    from gymnasium import spaces

    if isinstance(space, spaces.Box):
        low, high = np.asarray(space.low, np.float64).ravel(), np.asarray(space.high, np.float64).ravel()
        return SpaceValue(repr(space), "Box", tuple(space.shape), str(space.dtype), low, high)
    return SpaceValue(repr(space), type(space).__name__)


def describe_space(space) -> dict[str, SpaceValue]:
    """:func:`stored_space` for a live gymnasium space."""
    from gymnasium import spaces

    if isinstance(space, spaces.Dict):
        return {key: _live_value(sub) for key, sub in space.spaces.items()}
    return {"": _live_value(space)}


def compare_spaces(name: str, model: dict[str, SpaceValue], live: dict[str, SpaceValue]) -> list[str]:
    """How a model's space (``model``) differs from the environment's, by value, one line per key."""
    problems = []
    for key in sorted(set(model) | set(live)):
        label = f"{name} {key!r}" if key else f"{name} space"
        mine, theirs = model.get(key), live.get(key)
        if mine is None or theirs is None or not mine.agrees(theirs):
            shown = [v.text if v is not None else "absent" for v in (mine, theirs)]
            problems.append(f"{label}: model {shown[0]}, environment {shown[1]}")
    return problems


def as_model_sees(observation_space):
    """The observation space as stable-baselines3 hands it to its policy: images channel-first (its
    VecTransposeImage turns an H x W x C image of the environment into C x H x W; the policy
    transposes each observation likewise as it acts)."""
    from gymnasium import spaces
    from stable_baselines3.common.preprocessing import is_image_space, is_image_space_channels_first
    from stable_baselines3.common.vec_env import VecTransposeImage

    def needs(space) -> bool:
        return is_image_space(space) and not is_image_space_channels_first(space)

    if isinstance(observation_space, spaces.Dict):
        if not any(needs(sub) for sub in observation_space.spaces.values()):
            return observation_space
        return spaces.Dict(
            {
                key: VecTransposeImage.transpose_space(sub, key) if needs(sub) else sub
                for key, sub in observation_space.spaces.items()
            }
        )
    return VecTransposeImage.transpose_space(observation_space) if needs(observation_space) else observation_space


def space_problems(archive: Archive, observation_space, action_space) -> list[str]:
    """How the file's spaces differ from the environment's, by value, one line each (empty: they
    agree). ``observation_space`` is the environment's own (images as it renders them)."""
    problems = []
    for field_name, space, name in (
        ("observation_space", as_model_sees(observation_space), "observation"),
        ("action_space", action_space, "action"),
    ):
        stored = stored_space(archive, field_name)
        if stored is None:
            raise _refuse(archive.path, field_name, "keeps no readable description of the space")
        problems += compare_spaces(name, stored, describe_space(space))
    return problems


# --- the network, sized and checked before it is built ------------------------------------------
def _layers_problem(field: str, layers: Any) -> str | None:
    if not isinstance(layers, list):
        return f"{field} is {str(layers)[:60]!r}; allowed: a list of layer widths"
    if len(layers) > MAX_LAYERS:
        return f"{field} has {len(layers)} layers; allowed: at most {MAX_LAYERS}"
    for width in layers:
        if isinstance(width, bool) or not isinstance(width, int) or not 1 <= width <= MAX_WIDTH:
            return f"{field} has a layer of width {repr(width)[:30]}; allowed: whole numbers from 1 to {MAX_WIDTH}"
    return None


def net_arch_problem(kwargs: dict) -> str | None:
    """Why the network a policy's keyword arguments declare is not allowed (None: it is): ``net_arch``
    a list of widths or {"pi": [...], "vf": [...]}, at most :data:`MAX_LAYERS` layers of 1 to
    :data:`MAX_WIDTH` units; an LSTM's size within the same bounds."""
    arch = kwargs.get("net_arch")
    if isinstance(arch, dict):
        extra = sorted(set(arch) - {"pi", "vf"})
        if extra:
            return f"policy_kwargs.net_arch names {extra[0]!r}; allowed: pi and vf"
        for key in sorted(arch):
            problem = _layers_problem(f"policy_kwargs.net_arch.{key}", arch[key])
            if problem:
                return problem
    elif arch is not None:
        problem = _layers_problem("policy_kwargs.net_arch", arch)
        if problem:
            return problem
    for key, most in (("lstm_hidden_size", MAX_WIDTH), ("n_lstm_layers", MAX_LAYERS)):
        value = kwargs.get(key)
        if value is not None and (isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= most):
            return f"policy_kwargs.{key} is {repr(value)[:30]}; allowed: whole numbers from 1 to {most}"
    return None


_META = threading.Lock()


def expected_state(path: Path, cls, observation_space, action_space, use_sde: bool, kwargs: dict) -> dict:
    """{name: (shape, dtype)} of the policy's state dict, made on torch's meta device (no memory, no
    initialisation); refused when ``net_arch`` is not allowed or the network is larger than
    :data:`MAX_PARAMETERS`, naming its size."""
    from unittest import mock

    import torch

    problem = net_arch_problem(kwargs)
    if problem:
        raise _bad(path, problem)
    original = torch.nn.Module.to

    def to(module, *args, **kw):  # stable-baselines3 moves layers to a device; a meta layer stays where it is
        if any(parameter.is_meta for parameter in module.parameters()):
            return module
        return original(module, *args, **kw)

    with _META, torch.device("meta"), mock.patch.object(torch.nn.Module, "to", to):
        try:
            policy = cls(as_model_sees(observation_space), action_space, _constant(0.0), use_sde=use_sde, **kwargs)
        except Exception as error:  # noqa: BLE001 - settings read from the file that the policy does not take
            raise ConfigError(
                f"model file {str(path)!r}: its policy cannot be built for this environment "
                f"({type(error).__name__}: {_first_line(error)})"
            ) from None
    count = sum(parameter.numel() for parameter in policy.parameters())
    size = sum(parameter.numel() * parameter.element_size() for parameter in policy.parameters())
    if count > MAX_PARAMETERS:
        raise _bad(
            path,
            f"its network has {count:,} parameters ({_mib(size)}); allowed: at most {MAX_PARAMETERS:,} "
            "(see policy_kwargs.net_arch)",
        )
    return {name: (tuple(tensor.shape), tensor.dtype) for name, tensor in policy.state_dict().items()}


def check_state(path: Path, state: Any, expected: dict, name: str = "policy.pth") -> None:
    """Refuses weights whose tensors are not the network's: a missing or unknown tensor, or one of
    another shape or dtype, named with both sides."""
    import torch

    if not isinstance(state, dict) or not all(isinstance(v, torch.Tensor) for v in state.values()):
        raise _bad(path, f"member {name!r} is not a mapping of names to tensors")
    for key in sorted(set(expected) | set(state)):
        if key not in state:
            raise _bad(path, f"member {name!r} lacks tensor {key!r}, which its network has")
        if key not in expected:
            raise _bad(path, f"member {name!r} holds tensor {str(key)[:80]!r}, which its network does not have")
        shape, dtype = expected[key]
        if tuple(state[key].shape) != shape or state[key].dtype != dtype:
            raise _bad(
                path,
                f"tensor {key!r} in {name!r} is {tuple(state[key].shape)} {state[key].dtype}; the network its "
                f"net_arch and the environment's spaces declare has {shape} {dtype}",
            )


def check_start_weights(path: str | Path, observation_space, action_space, kwargs: dict) -> None:
    """``aaai train --init-from``: the model's weights (only policy.pth is read, never unpickled)
    checked within the budgets against the network a new run builds (a stable-baselines3
    MultiInputPolicy with ``kwargs``), before the run's folder exists."""
    from stable_baselines3.common.policies import MultiInputActorCriticPolicy

    path = Path(path)
    problem = size_problem(path)
    if problem:
        raise _bad(path, problem)
    state = read_tensors(path, "policy.pth", trust_helps=False)
    expected = expected_state(path, MultiInputActorCriticPolicy, observation_space, action_space, False, kwargs)
    check_state(path, state, expected)


# --- loading ------------------------------------------------------------------------------------
def _constant(value: float):
    return lambda _progress: value


class SafePolicy:
    """A stable-baselines3 policy network rebuilt from a model file without unpickling, for acting.

    ``predict`` is the policy's own (what ``PPO.predict`` calls), so actions equal the original's."""

    def __init__(self, policy, recurrent: bool):
        self.policy, self.recurrent = policy, recurrent

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        return self.policy.predict(observation, state, episode_start, deterministic=deterministic)


def in_float64(module) -> None:
    """Makes a torch policy act in float64: its weights are turned to float64, and every floating
    tensor that enters one of its layers is cast to float64 first (the observation is float32 up to
    there). In float32 a forward pass differs in its last bits from one CPU's code path to another's
    (MKL picks its kernels by the CPU); in float64 such differences are 2**29 times smaller, and
    actions put on a grid (:func:`aaai.scoring.policies.on_grid`) no longer show them."""
    import torch

    def cast(value):
        if isinstance(value, torch.Tensor):
            return value.double() if value.is_floating_point() else value
        if isinstance(value, dict):
            return {key: cast(item) for key, item in value.items()}
        if isinstance(value, (tuple, list)):
            return type(value)(cast(item) for item in value)
        return value

    module.double()
    for layer in module.modules():
        layer.register_forward_pre_hook(lambda _layer, args: cast(args))


def load_policy_network(
    path: str | Path,
    observation_space,
    action_space,
    fallback_kwargs: dict | None = None,
    archive: Archive | None = None,
) -> SafePolicy:
    """The policy of a model file, for the given spaces, its weights loaded with weights_only."""
    archive = archive or read_archive(path)
    name = policy_class_name(archive)
    cls = _policy_class(archive)
    kwargs = policy_kwargs(archive, fallback_kwargs)
    use_sde = archive.data.get("use_sde", False)
    if not isinstance(use_sde, bool):
        raise _bad(archive.path, f"field 'use_sde' is {str(use_sde)[:30]!r}; allowed: true or false")
    learning_rate = schedule_constant(archive, "learning_rate", 0.0)
    expected = expected_state(archive.path, cls, observation_space, action_space, use_sde, kwargs)
    state = archive.tensors("policy.pth")
    check_state(archive.path, state, expected)  # all before the network is built
    try:
        policy = cls(observation_space, action_space, _constant(learning_rate), use_sde=use_sde, **kwargs)
    except (TypeError, ValueError, KeyError, AssertionError) as error:
        raise ConfigError(
            f"model file {str(archive.path)!r}: its policy cannot be built for this environment "
            f"({type(error).__name__}: {error})"
        ) from None
    try:
        policy.load_state_dict(state, strict=True)
    except RuntimeError as error:
        raise ConfigError(
            f"model file {str(archive.path)!r}: its weights do not fit the policy for this "
            f"environment: {str(error).splitlines()[0]}"
        ) from None
    policy.set_training_mode(False)
    return SafePolicy(policy, recurrent=name.startswith("Recurrent"))


def load_for_training(
    path: str | Path, env, fallback_kwargs: dict | None = None, trust: bool | None = None, **overrides
):
    """A whole model (weights, optimiser state, step counters) to go on training in ``env``; the
    same as ``PPO.load(path, env=env, **overrides)`` but without unpickling (unless trusted)."""
    path = Path(path)
    if trusted(trust):
        from stable_baselines3 import PPO

        return PPO.load(path, env=env, device="cpu", **overrides)
    archive = read_archive(path)
    algorithm, alias = _algorithm(archive)
    problems = space_problems(archive, env.observation_space, env.action_space)
    if problems:
        raise ConfigError(f"model file {str(path)!r} does not fit this environment: " + "; ".join(problems))
    hyper = {}
    for key in HYPERPARAMETERS:
        value = archive.data.get(key)
        if key in archive.data and not _plain(value):
            raise _refuse(path, key, "is not a plain value")
        if key in archive.data:
            hyper[key] = value
    hyper["learning_rate"] = (
        schedule_constant(archive, "learning_rate")
        if "learning_rate" in archive.data
        else schedule_constant(archive, "lr_schedule")
    )
    hyper["clip_range"] = schedule_constant(archive, "clip_range", 0.2)
    hyper["clip_range_vf"] = schedule_constant(archive, "clip_range_vf", None)
    hyper["stats_window_size"] = archive.data.get("_stats_window_size", 100)
    kwargs = policy_kwargs(archive, fallback_kwargs)
    use_sde = hyper.get("use_sde", False)
    if not isinstance(use_sde, bool):
        raise _bad(path, f"field 'use_sde' is {str(use_sde)[:30]!r}; allowed: true or false")
    expected = expected_state(path, _policy_class(archive), env.observation_space, env.action_space, use_sde, kwargs)
    params = {
        Path(name).stem: archive.tensors(name)
        for name in archive.names
        if name.endswith(".pth") and name != "pytorch_variables.pth"
    }
    check_state(path, params.get("policy"), expected)  # all before the network is built
    model = algorithm(
        alias,
        env,
        policy_kwargs=kwargs,
        device="cpu",
        **{k: v for k, v in hyper.items() if v is not None or k == "clip_range_vf"},
        **overrides,
    )
    try:
        model.set_parameters(params, exact_match=True, device="cpu")
    except (RuntimeError, ValueError) as error:
        raise ConfigError(f"model file {str(path)!r}: its weights do not fit: {str(error).splitlines()[0]}") from None
    for key in COUNTERS:
        value = archive.data.get(key)
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            setattr(model, key, value)
    return model


# --- RLlib checkpoints ---------------------------------------------------------------------------
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


def folder_digest(folder: Path) -> str:
    digest = hashlib.sha256()
    for file in sorted(f for f in Path(folder).rglob("*") if f.is_file()):
        digest.update(str(file.relative_to(folder)).encode() + b"\0" + file_sha256(file).encode())
    return digest.hexdigest()


def sign_checkpoint(folder: str | Path) -> Path:
    """Signs an RLlib checkpoint folder this machine wrote (the signature goes beside it)."""
    folder = Path(folder)
    signature = hmac.new(_key(), folder_digest(folder).encode(), hashlib.sha256).hexdigest()
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
    expected = hmac.new(key, folder_digest(folder).encode(), hashlib.sha256).hexdigest()
    return hmac.compare_digest(stored, expected)


def check_rllib_checkpoint(folder: str | Path, trust: bool | None = None) -> None:
    """Refuses to load an RLlib checkpoint (pickles) that is neither trusted nor signed here."""
    if trusted(trust) or signed_here(folder):
        return
    raise UntrustedModel(
        f"RLlib checkpoint {str(folder)!r} is made of pickles, which run code as they load, and it does not carry "
        f"this machine's signature ({SIGNATURE}, written when aaai train --backend rllib saved it here); refused. "
        f"If you trust it, pass {TRUST_FLAG}"
    )


class RLlibPolicy:
    """A policy trained by ``aaai train --backend rllib``, acting deterministically (the mean
    action), as the scoreboard's policies do: ``policy(observation) -> action`` for an environment
    with the run's observations. The observation is flattened as RLlib's FlattenObservations
    connector does it."""

    def __init__(self, checkpoint: str | Path, env, trust: bool | None = None):
        import torch
        from ray.rllib.core.rl_module.rl_module import RLModule
        from ray.rllib.utils.spaces.space_utils import get_base_struct_from_space

        self.torch = torch
        folder = rllib_checkpoint(checkpoint)
        check_rllib_checkpoint(folder, trust)  # pickles: only trusted or signed on this machine
        self.module = RLModule.from_checkpoint(str((folder / MODULE_PATH).absolute()))
        self.dtype = np.float32
        if isinstance(self.module, torch.nn.Module):
            self.module.eval()  # inference: as RLlib's own inference does
            in_float64(self.module)
            self.dtype = np.float64
        self.structure = get_base_struct_from_space(env.observation_space)
        self.space = env.action_space

    def reset(self, seed: int) -> None:
        pass

    def __call__(self, observation):
        from ray.rllib.utils.numpy import flatten_inputs_to_1d_tensor

        flat = flatten_inputs_to_1d_tensor(observation, spaces_struct=self.structure, batch_axis=False)
        with self.torch.no_grad():
            out = self.module.forward_inference({"obs": self.torch.as_tensor(np.asarray(flat, self.dtype)[None])})
        mean = out["action_dist_inputs"][0].numpy()[: self.space.shape[0]]  # a diagonal Gaussian: means, log stds
        squashed = np.clip(mean, -1.0, 1.0)  # RLlib's unsquash_action: [-1, 1] onto the space's bounds
        return self.space.low + (squashed + 1.0) * (self.space.high - self.space.low) / 2.0  # float64: put on the grid
