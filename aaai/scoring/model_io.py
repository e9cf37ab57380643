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
loads such a checkpoint's policy for scoring.
"""

from __future__ import annotations

import contextlib
import contextvars
import hashlib
import hmac
import importlib
import io
import json
import os
import re
import secrets
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aaai.config import ConfigError
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


# --- the archive ------------------------------------------------------------------------------
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
        """A .pth member, read with ``torch.load(weights_only=True)`` (tensors and plain containers only)."""
        import torch

        try:
            with zipfile.ZipFile(self.path) as archive:
                blob = archive.read(name)
            return torch.load(io.BytesIO(blob), map_location="cpu", weights_only=True)
        except KeyError:
            raise ConfigError(f"model file {str(self.path)!r} lacks {name}") from None
        except Exception as error:  # noqa: BLE001 - weights_only refuses anything but tensors: the file's fault
            raise _refuse(
                self.path,
                name,
                f"is not plain tensors ({type(error).__name__}: {str(error).splitlines()[0] if str(error) else ''})",
            ) from None


def read_archive(path: str | Path) -> Archive:
    """Opens a model file and parses its data part as JSON only."""
    path = Path(path)
    try:
        with zipfile.ZipFile(path) as archive:
            names = archive.namelist()
            text = archive.read("data").decode("utf-8")
    except KeyError:
        raise ConfigError(f"model file {str(path)!r} is not a stable-baselines3 model (it has no data part)") from None
    except (zipfile.BadZipFile, OSError, EOFError, UnicodeDecodeError) as error:
        raise ConfigError(f"model file {str(path)!r} cannot be read: {error}") from None
    try:
        data = json.loads(text)
    except ValueError as error:
        raise ConfigError(
            f"model file {str(path)!r} cannot be loaded by stable-baselines3: its data part is not JSON ({error})"
        ) from None
    if not isinstance(data, dict):
        raise ConfigError(f"model file {str(path)!r}: its data part is not a JSON object")
    return Archive(path, _strip_pickles(data), names)


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
        raise _refuse(archive.path, "policy_class", "is missing or not the description of a class")
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
        raise _refuse(archive.path, "policy_kwargs", "is not a mapping")
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
            raise _refuse(archive.path, field, f"holds {str(value)[:80]!r}, which is not a plain setting we know")
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
    raise _refuse(archive.path, field, "is a schedule that is not a constant")


# --- spaces -------------------------------------------------------------------------------------
def _space_parts(text: str) -> dict[str, str]:
    """A Dict space's repr ``{'a': Box(...), 'b': Box(...)}`` as {key: repr}."""
    found = list(re.finditer(r"'([^']+)': ", text))
    parts = {}
    for i, match in enumerate(found):
        end = found[i + 1].start() if i + 1 < len(found) else len(text)
        parts[match.group(1)] = text[match.end() : end].rstrip(" ,}")
    return parts


def stored_space(archive: Archive, field: str) -> dict[str, str] | None:
    """The readable description a file keeps of a space: {key: repr} for a Dict space, {"": repr}
    for a Box; None when the file keeps none."""
    entry = archive.data.get(field)
    if not isinstance(entry, dict):
        return None
    kind = str(entry.get(":type:", ""))
    if kind.endswith(".Dict'>") and isinstance(entry.get("spaces"), str):
        return _space_parts(entry["spaces"])
    if kind.endswith(".Box'>") and isinstance(entry.get("_shape"), list):
        return {
            "": f"Box({entry.get('low_repr')}, {entry.get('high_repr')}, {tuple(entry['_shape'])}, "
            f"{entry.get('dtype')})"
        }
    if kind.endswith(".Discrete'>"):
        return {"": f"Discrete({entry.get('n')})"}
    return None


def describe_space(space) -> dict[str, str]:
    """:func:`stored_space` for a live gymnasium space."""
    from gymnasium import spaces

    if isinstance(space, spaces.Dict):
        return {key: repr(sub) for key, sub in space.spaces.items()}
    if isinstance(space, spaces.Box):
        return {"": f"Box({space.low_repr}, {space.high_repr}, {space.shape}, {space.dtype})"}
    return {"": repr(space)}


def space_problems(archive: Archive, observation_space, action_space) -> list[str]:
    """How the file's spaces differ from the environment's, one line each (empty: they agree)."""
    problems = []
    for field, space, name in (
        ("observation_space", observation_space, "observation"),
        ("action_space", action_space, "action"),
    ):
        stored = stored_space(archive, field)
        if stored is None:
            raise _refuse(archive.path, field, "keeps no readable description of the space")
        live = describe_space(space)
        for key in sorted(set(stored) | set(live)):
            label = f"{name} {key!r}" if key else f"{name} space"
            if stored.get(key) != live.get(key):
                problems.append(f"{label}: model {stored.get(key, 'absent')}, environment {live.get(key, 'absent')}")
    return problems


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
    _algorithm(archive)  # the library is there
    module = (
        "sb3_contrib.common.recurrent.policies" if name.startswith("Recurrent") else "stable_baselines3.common.policies"
    )
    cls = getattr(importlib.import_module(module), name)
    kwargs = policy_kwargs(archive, fallback_kwargs)
    use_sde = archive.data.get("use_sde", False)
    if not isinstance(use_sde, bool):
        raise _refuse(archive.path, "use_sde", "is not true or false")
    learning_rate = schedule_constant(archive, "learning_rate", 0.0)
    try:
        policy = cls(observation_space, action_space, _constant(learning_rate), use_sde=use_sde, **kwargs)
    except (TypeError, ValueError, KeyError, AssertionError) as error:
        raise ConfigError(
            f"model file {str(archive.path)!r}: its policy cannot be built for this environment "
            f"({type(error).__name__}: {error})"
        ) from None
    state = archive.tensors("policy.pth")
    if not isinstance(state, dict):
        raise _refuse(archive.path, "policy.pth", "is not a state dict")
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
    model = algorithm(
        alias,
        env,
        policy_kwargs=policy_kwargs(archive, fallback_kwargs),
        device="cpu",
        **{k: v for k, v in hyper.items() if v is not None or k == "clip_range_vf"},
        **overrides,
    )
    params = {
        Path(name).stem: archive.tensors(name)
        for name in archive.names
        if name.endswith(".pth") and name != "pytorch_variables.pth"
    }
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


def _key() -> bytes:
    """This machine's signing key (created on first use, owner-only)."""
    path = key_path()
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        try:
            descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        except FileExistsError:
            pass  # made by another process meanwhile
        else:
            with os.fdopen(descriptor, "wb") as handle:
                handle.write(secrets.token_hex(32).encode())
    return path.read_bytes().strip()


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
    target.write_text(signature + "\n")
    return target


def signed_here(folder: str | Path) -> bool:
    """Whether an RLlib checkpoint carries this machine's signature over its present files."""
    folder = Path(folder)
    try:
        stored = (folder.parent / SIGNATURE).read_text().strip()
        key = _key() if key_path().exists() else None
    except OSError:
        return False
    if key is None:
        return False
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
