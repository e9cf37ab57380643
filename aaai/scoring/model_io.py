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

A file that cannot be rebuilt so is refused with :class:`~aaai.scoring.model_archive.UntrustedModel`,
which names the field and the ``--trust-model`` flag; with that flag (``trust=True``)
stable-baselines3's own loader is used. The file is read within its limits by
:mod:`aaai.scoring.model_archive` and its spaces compared by :mod:`aaai.scoring.model_spaces`; the
network it declares (``net_arch``: at most :data:`~aaai.scoring.model_archive.MAX_LAYERS` layers of
at most :data:`~aaai.scoring.model_archive.MAX_WIDTH` units) is sized here without memory (on torch's
``meta`` device) and refused beyond :data:`~aaai.scoring.model_archive.MAX_PARAMETERS` parameters,
and every tensor's name, shape, dtype and finiteness is checked against it, all before the network
is built. RLlib checkpoints (pickles) are :mod:`aaai.scoring.rllib_checkpoints`' and
:mod:`aaai.scoring.rllib_policy`'s.
"""

from __future__ import annotations

import importlib
import re
import threading
from pathlib import Path
from typing import Any

from aaai.config import Config, ConfigError
from aaai.scoring.model_archive import (
    MAX_LAYERS,
    MAX_PARAMETERS,
    MAX_WIDTH,
    Archive,
    _bad,
    _first_line,
    _mib,
    _pickled,
    _refuse,
    _tensor_problem,
    read_archive,
    read_tensors,
    size_problem,
)
from aaai.scoring.model_config import start_config_problems
from aaai.scoring.model_spaces import as_model_sees, space_problems

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


def check_start_weights(
    path: str | Path, observation_space, action_space, kwargs: dict, config: Config | None = None
) -> None:
    """``aaai train --init-from``: the model's weights (only policy.pth is read, never unpickled)
    checked within the budgets against the network a new run builds (a stable-baselines3
    MultiInputPolicy with ``kwargs``), before the run's folder exists; first, the config the file
    carries against the run's ``config`` (:func:`start_config_problems`). A recurrent model's
    weights are checked against sb3-contrib's MultiInputLstmPolicy, which RecurrentPPO fine-tunes."""
    from stable_baselines3.common.policies import MultiInputActorCriticPolicy

    path = Path(path)
    problem = size_problem(path)
    if problem:
        raise _bad(path, problem)
    if config is not None:
        differ = start_config_problems(path, config)
        if differ:
            raise ConfigError(
                f"model file {str(path)!r} was trained in another environment than this run's ({'; '.join(differ)}); "
                "allowed: a model of the same body, action mode and senses"
            )
    state = read_tensors(path, "policy.pth", trust_helps=False)
    cls: Any = MultiInputActorCriticPolicy
    archive = read_archive(path)
    if policy_class_name(archive).startswith("Recurrent"):
        _algorithm(archive)  # sb3-contrib is there, or one line says which package is missing
        from sb3_contrib.common.recurrent.policies import RecurrentMultiInputActorCriticPolicy

        cls = RecurrentMultiInputActorCriticPolicy
    expected = expected_state(path, cls, observation_space, action_space, False, kwargs)
    check_state(path, state, expected)


# --- loading ------------------------------------------------------------------------------------
def _least_parameters(arch: Any) -> int:
    """The fewest parameters a network of ``net_arch`` can have: its hidden layers' weights alone (a
    list is one such network for the policy and one for the value; a dict names each)."""
    parts = [arch.get("pi", []), arch.get("vf", [])] if isinstance(arch, dict) else [arch, arch]
    return sum(a * b for layers in parts if isinstance(layers, list) for a, b in zip(layers, layers[1:]))


def check_before_trusted_load(path: str | Path) -> None:
    """``--trust-model`` lets the file's pickles run, not its sizes pass: before stable-baselines3's
    own loader sees it, the file is held to the size budgets and, when its ``policy_kwargs`` are
    plain JSON, its ``net_arch`` to the limits a network is built within (refusals that do not name
    trust, which would not help)."""
    path = Path(path)
    problem = size_problem(path)
    if problem:
        raise _bad(path, problem)
    try:
        kwargs = read_archive(path).data.get("policy_kwargs")
    except ConfigError:  # a data part that is not JSON: stable-baselines3's loader says what it makes of it
        return
    if not isinstance(kwargs, dict) or _pickled(kwargs):
        return  # pickled: what it holds is known only once loaded (check_trusted_model)
    problem = net_arch_problem(kwargs)
    least = _least_parameters(kwargs.get("net_arch"))
    if not problem and least > MAX_PARAMETERS:
        problem = f"its net_arch has at least {least:,} parameters; allowed: at most {MAX_PARAMETERS:,}"
    if problem:
        raise _bad(path, problem)


def check_trusted_model(path: str | Path, model: Any) -> None:
    """``--trust-model``: a model stable-baselines3 loaded is still checked as one read without
    unpickling is: ``net_arch`` within the limits, at most :data:`MAX_PARAMETERS` parameters, and
    every weight finite (no NaN or infinity)."""
    path = Path(path)
    kwargs = getattr(model, "policy_kwargs", None)
    problem = net_arch_problem(kwargs) if isinstance(kwargs, dict) else None
    if problem:
        raise _bad(path, problem)
    count = sum(parameter.numel() for parameter in model.policy.parameters())
    if count > MAX_PARAMETERS:
        raise _bad(path, f"its network has {count:,} parameters; allowed: at most {MAX_PARAMETERS:,}")
    problem = _tensor_problem(dict(model.policy.state_dict()))
    if problem:
        raise _bad(path, f"its policy's {problem}")


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
    learning_rate = schedule_constant(archive, "learning_rate", 0.0) or 0.0  # a number: its default is one
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


def load_for_training(path: str | Path, env, fallback_kwargs: dict | None = None, trust: bool = False, **overrides):
    """A whole model (weights, optimiser state, step counters) to go on training in ``env``; the
    same as ``PPO.load(path, env=env, **overrides)`` but without unpickling (unless trusted)."""
    path = Path(path)
    if trust:
        from stable_baselines3 import PPO

        check_before_trusted_load(path)
        algorithm: Any = PPO
        try:
            algorithm = _algorithm(read_archive(path))[0]  # RecurrentPPO for a recurrent model
        except ConfigError:
            pass  # a class outside our registry: PPO's loader decides
        model = algorithm.load(path, env=env, device="cpu", **overrides)
        check_trusted_model(path, model)
        return model
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
