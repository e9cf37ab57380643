"""What a ``--policy`` string names, resolved once into a :class:`Policy` that builds it on any worker.

A ``--policy`` is ``random``, ``reference`` (the privileged reference controller), ``search`` (the
reference acting only on the food the agent's rays have shown it), ``gait`` (the
example trot), a stable-baselines3 model ``.zip``, a run folder (its newest saved model, its RLlib
checkpoint, or random actions for a run of the random agent) or ``module:callable`` (called with the
environment to make the policy). :func:`resolve` looks at the disk once and returns a frozen, plain
:class:`Policy`: its kind, its files, the config of the run it comes from, its record (what a
scoreboard is scored with) and :meth:`Policy.build`, which makes the acting policy for an
environment. Being plain data it pickles, so a Ray task gets it and builds the policy there.

A model file is read without unpickling anything (:mod:`aaai.scoring.model_io`) unless ``trust``
(``--trust-model``); an RLlib checkpoint loads only if signed on this machine or trusted.
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import os
import sys
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping

import numpy as np

from aaai.config import TEACHERS, Config, ConfigError, env_part, load_config
from aaai.env import AnimalAIEnv
from aaai.files import file_sha256, folder_sha256
from aaai.scoring.runs import RunFolder, model_problem, rllib_checkpoint, run_backend
from aaai.sim.gait import gait_policy

BUILT_IN = ("random", *TEACHERS, "gait")  # TEACHERS: reference and the searching references
# How a scoreboard's actions are computed (recorded with it): a learned policy's forward pass in
# float64, and the action that a learned policy or the reference hands to the environment put on a
# grid of 2**-20 (the nearest multiple, then float32, which holds it exactly), so that last-bit
# differences between CPUs' code paths (MKL's kernels, vector maths) do not reach the physics.
NUMERICS = "f64-grid2^-20"
GRID = 2.0**-20
ON_GRID = (*TEACHERS, "model", "rllib")  # the kinds whose actions are put on the grid
KINDS = (*BUILT_IN, "model", "rllib", "callable", "external")
ALLOWED = f"{', '.join(BUILT_IN)}, a model .zip, a run folder, module:callable"


@dataclass(frozen=True)
class Policy:
    """A resolved ``--policy``: plain data (it pickles), built into an acting policy by :meth:`build`.

    ``kind``: random, reference, gait, model (a stable-baselines3 .zip), rllib (an RLlib checkpoint
    folder), callable (module:callable) or external (a policy its caller makes, e.g. a human's).
    ``file``: the model file or checkpoint folder. ``run``: the run folder named (None for a model
    file named directly). ``run_config``: the config of the run the model comes from, None outside a
    run folder: the model is checked against it, and scored with it unless a config is given. ``record``: the
    policy's part of a scoreboard's record. ``trust``: load with code from the file (--trust-model).
    """

    name: str
    kind: str
    file: str | None = None
    run: str | None = None
    run_config: Config | None = field(default=None, compare=False, repr=False)
    record: dict = field(default_factory=dict, compare=False)
    trust: bool = False

    def config(self, config_path: str | None = None) -> Config:
        """The config the policy is scored with: ``config_path`` if given, else its run's own (the
        senses it was trained with: the run folder named, or the run a model file sits in, e.g. a
        checkpoint's model.zip), else the defaults."""
        if config_path or self.run_config is None:
            return load_config(config_path)
        return self.run_config

    def play_config(self, config_path: str | None = None) -> Config:
        """The config ``aaai run`` and ``aaai show`` play the policy in: :meth:`config`, and for a
        trained run's policy its environment part without shaping, as scores count its reward."""
        config = self.config(config_path)
        return env_part(config, shaping=0.0) if self.run_config else config

    @property
    def key(self) -> str:
        """Tells policies apart within a worker: the model's digest, else the name."""
        return self.record.get("model_sha256") or self.name

    def with_file(self, file: str | Path) -> "Policy":
        """The same policy with its model read from ``file`` (a worker's copy of the bytes)."""
        return dataclasses.replace(self, file=str(file))

    @property
    def numerics(self) -> str | None:
        """How its actions are computed (:data:`NUMERICS`), None for those handed on as they are
        (random actions, the gait, a callable's, a human's)."""
        return NUMERICS if self.kind in ON_GRID else None

    def build(self, env: Any, extra_keys: tuple = ()) -> Callable:
        """The acting policy for ``env``: ``policy(observation) -> action``. A model is checked
        against ``env`` first; ``extra_keys``: observation keys the caller added for itself. The
        actions of the reference and of a learned policy are put on the grid (:class:`OnGrid`)."""
        acting = self._acting(env, extra_keys)
        return OnGrid(acting) if self.numerics else acting

    def _acting(self, env: Any, extra_keys: tuple) -> Callable:
        if self.kind == "random":
            return RandomPolicy(env)
        if self.kind in TEACHERS:
            from aaai.task.search import teacher

            return teacher(self.kind, env)
        if self.kind == "gait":
            return gait_policy(env)
        if self.kind == "model":
            return ModelPolicy(Path(str(self.file)), env, self.trust, extra_keys, self.run_config)
        if self.kind == "rllib":
            from aaai.scoring.rllib_policy import RLlibPolicy

            return RLlibPolicy(str(self.file), env, trust=self.trust)
        if self.kind == "callable":
            try:
                return factory(self.name)(env)
            except TypeError as error:  # a callable that does not take the env (os:system, a class of other arguments)
                raise ConfigError(
                    f"--policy: {self.name!r} could not be called with the environment ({error}); allowed: a "
                    "module:callable that takes the env and returns the policy"
                ) from None
        raise ConfigError(f"--policy: {self.name!r} is made by its caller and cannot be built here")


def external(name: str) -> Policy:
    """A policy its caller makes (a human at the keys): recorded by name only."""
    return Policy(name, "external", record={"policy": name})


def as_policy(policy: Policy | str, trust: bool = False) -> Policy:
    """``policy`` itself, or the Policy a --policy string names (:func:`resolve`)."""
    return policy if isinstance(policy, Policy) else resolve(policy, trust)


def resolve(policy: str, trust: bool = False) -> Policy:
    """The one place a --policy string is read: a missing, damaged or unknown policy is refused
    here, naming it, before any episode."""
    if policy in BUILT_IN:
        return Policy(policy, policy, record={"policy": policy}, trust=trust)
    path = Path(policy)
    if path.suffix == ".zip":
        if not path.is_file():
            raise ConfigError(f"--policy: model file {policy!r} does not exist")
        problem = _zip_problem(path)
        if problem:
            raise ConfigError(f"--policy: model file {policy!r} cannot be loaded: {problem}")
        from aaai.scoring.model_config import model_config

        trained = model_run_config(path)  # a run's saved point: its run's config; else the one the file carries
        return _model(policy, path, None, trained if trained is not None else model_config(path), trust)
    if path.is_dir():
        run = RunFolder(path)
        config = load_config(run.read_config())
        if run_backend(path) == "rllib":
            checkpoint = rllib_checkpoint(path)
            identity = {"policy": policy, "model": str(checkpoint), "model_sha256": folder_sha256(checkpoint)}
            return Policy(policy, "rllib", str(checkpoint), policy, config, identity, trust)
        if config.train.agent == "random":  # a run of the random agent: scored with random actions
            return Policy(policy, "random", None, policy, config, {"policy": policy}, trust)
        return _model(policy, _newest_model(run, policy), policy, config, trust)
    if ":" not in policy:  # not module:callable, so a path that is not there
        raise ConfigError(f"--policy: {policy!r} is no run folder or model file here; allowed: {ALLOWED}")
    factory(policy)  # importable here (and so, with the same packages, on every worker)
    record: dict[str, Any] = {"policy": policy}
    source = _module_file(policy.partition(":")[0])
    if source is not None:  # the identity of its source file, where it has one
        record["policy_source_sha256"] = file_sha256(source)
    return Policy(policy, "callable", record=record, trust=trust)


def _model(policy: str, path: Path, run: str | None, run_config: Config | None, trust: bool) -> Policy:
    record = {"policy": policy, "model": str(path), "model_sha256": file_sha256(path)}
    return Policy(policy, "model", str(path), run, run_config, record, trust)


def _newest_model(run: RunFolder, policy: str) -> Path:
    """A run folder's newest saved model (final/ when it is the newest). A damaged model is
    refused, never swapped for an older one."""
    newest = run.latest_checkpoint()
    if newest is None:
        raise ConfigError(f"--policy: run folder {policy!r} holds no model (final/ or checkpoints/*/model.zip)")
    problem = _zip_problem(newest / "model.zip")
    if problem:
        older = next((f for f in run.saved()[1:] if _zip_problem(f / "model.zip") is None), None)
        hint = f"; to score an older one, pass --policy {older / 'model.zip'}" if older else ""
        raise ConfigError(
            f"--policy: the newest model of run {policy!r} ({newest.relative_to(run.path)}) cannot be "
            f"loaded: {problem}{hint}"
        )
    return newest / "model.zip"


def _zip_problem(path: Path) -> str | None:
    """Why a model .zip cannot be loaded: beyond the size budgets (from its declared sizes, before
    anything is inflated), else not a whole stable-baselines3 archive."""
    from aaai.scoring.model_archive import size_problem

    return size_problem(path) or model_problem(path)


def factory(policy: str) -> Callable:
    """The callable a 'module:callable' policy names (called with the env to make the policy)."""
    module_name, _, attribute = policy.partition(":")
    if not attribute:
        raise ConfigError(f"--policy: got {policy!r}; allowed: {ALLOWED}")
    try:
        with _cwd_importable():
            target: Any = importlib.import_module(module_name)
        for part in attribute.split("."):
            target = getattr(target, part)
    except (ImportError, AttributeError) as error:
        raise ConfigError(f"--policy: cannot load {policy!r}: {error}") from None
    return target


@contextmanager
def _cwd_importable() -> Iterator[None]:
    """The current folder importable first, as ``python -m`` makes it, for one import of a policy's module."""
    cwd = os.getcwd()
    added = cwd not in sys.path
    if added:
        sys.path.insert(0, cwd)
    try:
        yield
    finally:
        if added and cwd in sys.path:
            sys.path.remove(cwd)


def _module_file(name: str) -> Path | None:
    try:
        with _cwd_importable():
            spec = importlib.util.find_spec(name)
    except (ImportError, ValueError):
        return None
    origin = getattr(spec, "origin", None)
    return Path(origin) if origin and Path(origin).is_file() else None


# --- the acting policies ----------------------------------------------------------------
def on_grid(action) -> np.ndarray:
    """``action`` rounded to the nearest multiple of :data:`GRID`, as float32 (exact: every
    multiple of 2**-20 below 16 is a float32). Each step is exact arithmetic, the same on any CPU."""
    return (np.rint(np.asarray(action, np.float64) / GRID) * GRID).astype(np.float32)


class OnGrid:
    """A policy whose actions are put on the grid (:func:`on_grid`); anything else is the policy's own
    (``reset``, ``end_episode``, a controller's ``command``)."""

    def __init__(self, policy: Callable):
        self.policy = policy

    def __call__(self, observation):
        return on_grid(self.policy(observation))

    def __getattr__(self, name: str):
        if name == "policy":  # not set yet (e.g. while unpickling): no recursion
            raise AttributeError(name)
        return getattr(self.policy, name)


class RandomPolicy:
    """Uniform random actions, seeded per episode so that a scoreboard repeats exactly."""

    def __init__(self, env: AnimalAIEnv):
        self.space = env.action_space

    def reset(self, seed: int) -> None:
        self.space.seed(seed)

    def __call__(self, observation):
        return self.space.sample()


class ModelPolicy:
    """A stable-baselines3 model, acting deterministically, its forward pass in float64
    (:func:`aaai.scoring.model_io.in_float64`).

    By default the file is read without unpickling anything (aaai.scoring.model_io): its policy is rebuilt
    from our registry and the environment's spaces, its weights read with weights_only. ``trust``
    (--trust-model) uses stable-baselines3's own loader, which runs whatever the file's pickles hold.
    Either way the model is checked against the environment first, and against ``run_config``,
    the config of the run it was trained in (:func:`check_model`)."""

    def __init__(
        self,
        path: Path,
        env: AnimalAIEnv | None = None,
        trust: bool = False,
        extra_keys: tuple = (),
        run_config: Config | None = None,
    ):
        from aaai.scoring import model_archive, model_io, model_spaces

        path = Path(path)
        self.state: Any = None
        self.start, self.extra_keys = True, tuple(extra_keys)
        seen: _Seen | None = None
        if env is not None:
            check_model(path, env, self.extra_keys, run_config)
            seen = _Seen(env, self.extra_keys)
        if trust:
            self.model: Any = _trusted_load(path)
            model_io.in_float64(self.model.policy)
            if seen is not None:
                problems = _space_problems(self.model.observation_space, self.model.action_space, seen)
                if problems:
                    raise ConfigError(_misfit(path, problems, seen))
            self.recurrent = hasattr(self.model, "_last_lstm_states")
            return
        archive = model_archive.read_archive(path)
        if seen is None:
            raise ConfigError(f"--policy: model file {str(path)!r}: an environment is needed to load it")
        problems = model_spaces.space_problems(archive, seen.observation_space, seen.action_space)
        if problems:
            raise ConfigError(_misfit(path, problems, seen))
        self.model = model_io.load_policy_network(
            path,
            model_spaces.as_model_sees(seen.observation_space),  # images channel-first; the policy transposes them
            seen.action_space,
            fallback_kwargs=_run_policy_kwargs(run_config),
            archive=archive,
        )
        model_io.in_float64(self.model.policy)
        self.recurrent = self.model.recurrent

    def reset(self, seed: int) -> None:
        self.state, self.start = None, True

    def __call__(self, observation):
        if self.extra_keys:
            observation = {k: v for k, v in observation.items() if k not in self.extra_keys}
        if self.recurrent:
            action, self.state = self.model.predict(
                observation, state=self.state, episode_start=np.array([self.start]), deterministic=True
            )
            self.start = False
            return action
        action, _ = self.model.predict(observation, deterministic=True)
        return action


def _trusted_load(path: Path):
    """stable-baselines3's own loader (it unpickles the file's fields): only with --trust-model."""
    from stable_baselines3 import PPO

    from aaai.scoring import model_io
    from aaai.scoring.model_archive import read_archive

    algorithm: Any = PPO
    try:
        if model_io.policy_class_name(read_archive(path)).startswith("Recurrent"):
            from sb3_contrib import RecurrentPPO

            algorithm = RecurrentPPO
    except ConfigError:
        pass  # a class outside our registry: PPO's loader decides
    model_io.check_before_trusted_load(path)  # trust lets pickles run, not sizes pass
    try:
        model = algorithm.load(path, device="cpu")
    except Exception as error:  # noqa: BLE001 - any failure inside the archive is the file's fault
        raise ConfigError(
            f"--policy: model file {str(path)!r} cannot be loaded by stable-baselines3: {type(error).__name__}: {error}"
        ) from None
    model_io.check_trusted_model(path, model)  # nor NaN weights or an oversized network
    return model


class _Seen:
    """An environment as a model sees it: without the observation keys its caller added for itself
    (``aaai show`` turns the camera on to draw it)."""

    def __init__(self, env: AnimalAIEnv, extra_keys: tuple):
        from gymnasium import spaces

        self.config, self.action_space = env.config, env.action_space
        self.observation_space: Any = env.observation_space
        if extra_keys and isinstance(env.observation_space, spaces.Dict):
            self.observation_space = spaces.Dict(
                {k: v for k, v in env.observation_space.spaces.items() if k not in extra_keys}
            )


def _space_problems(observation_space, action_space, env: _Seen) -> list[str]:
    """How a loaded model's spaces differ from the environment's, by value (images as the model sees them)."""
    from aaai.scoring.model_spaces import as_model_sees, compare_spaces, describe_space

    return compare_spaces(
        "observation", describe_space(observation_space), describe_space(as_model_sees(env.observation_space))
    ) + compare_spaces("action", describe_space(action_space), describe_space(env.action_space))


# The config keys a model depends on beyond its spaces: compared with its run's config when the
# model file lies in a run folder (final/model.zip, checkpoints/step_N/model.zip).
MODEL_KEYS = ("agent.body", "agent.action_mode", "agent.decision_interval", "physics.action_repeat", "physics.timestep")


def model_run_config(path: Path) -> Config | None:
    """The config of the run a model file belongs to (RUN/final/model.zip or
    RUN/checkpoints/step_*/model.zip beside RUN/config.yaml), or None for a file outside a run
    folder. A run config that cannot be read is refused, naming it: the model is scored with it."""
    path = Path(path).absolute()
    point = path.parent
    if path.name != "model.zip":
        return None
    if point.name == "final":
        folder = point.parent
    elif point.parent.name == "checkpoints" and point.name.startswith("step_"):
        folder = point.parent.parent
    else:
        return None
    if not (folder / "config.yaml").is_file():
        return None
    try:
        return load_config(RunFolder(folder).read_config())
    except (ConfigError, OSError, ValueError) as error:
        raise ConfigError(
            f"--policy: model file {str(path)!r} belongs to run {str(folder)!r}, whose config cannot be read "
            f"({error}); allowed: a run whose config.yaml loads (or a copy of the model file outside the run, "
            "scored with --config)"
        ) from None


def _dotted(config: Mapping[str, Any], key: str) -> Any:
    value: Any = config
    for part in key.split("."):
        if not isinstance(value, Mapping) or part not in value:
            return "absent"
        value = value[part]
    return value


def check_model(
    path: Path, env: AnimalAIEnv, extra_keys: tuple = (), trained: Config | Mapping[str, Any] | None = None
) -> None:
    """Refuses, before any episode, a model whose run (config ``trained``) was trained with another
    action mode, body or sensor config than ``env`` has (each differing key named with both values).
    The settings of a sensor that is off on both sides, or that the caller added for itself
    (``extra_keys``), do not count."""
    if trained is None:
        return
    if isinstance(trained, Config):
        trained = trained.to_dict()
    seen = env.config.to_dict()  # compared key by dotted key, as the message names them
    sensors = sorted(set(trained.get("sensors", {})) | set(seen["sensors"]))
    off = {
        name
        for name in ("camera", "rays")
        if name in extra_keys
        or not (_dotted(trained, f"sensors.{name}") is True or _dotted(seen, f"sensors.{name}") is True)
    }
    keys = list(MODEL_KEYS) + [
        f"sensors.{key}"
        for key in sensors
        if ("camera" if key.startswith("camera") else "rays" if key.startswith("ray") else key) not in off
    ]
    differing = [
        f"{key}: model {_dotted(trained, key)!r}, environment {_dotted(seen, key)!r}"
        for key in keys
        if _dotted(trained, key) != _dotted(seen, key)
    ]
    if differing:
        point = Path(path).absolute().parent
        in_run = point.name == "final" or (point.parent.name == "checkpoints" and point.name.startswith("step_"))
        run = point.parent.parent if point.parent.name == "checkpoints" else point.parent
        hint = (
            f"its run's config (--config {run / 'config.yaml'}, or --policy with the run folder)"
            if in_run
            else "the config the file carries (leave out --config)"
        )
        raise ConfigError(
            f"--policy: model file {str(path)!r} was trained with another environment than this one: "
            + "; ".join(differing)
            + f". Score it with {hint}"
        )


def _misfit(path: Path, problems: list[str], env: _Seen) -> str:
    mode = env.config.agent.action_mode
    return (
        f"--policy: model file {str(path)!r} does not fit this environment (action mode {mode!r}): "
        + "; ".join(problems)
        + ". Score it with the config it was trained with (--config)"
    )


def _run_policy_kwargs(config: Config | None) -> dict | None:
    """policy_kwargs as our trainer builds them from its run's config (for a file that lacks them)."""
    if config is None:
        return None
    train = config.train
    return {"net_arch": [train.net_width, train.net_width], "log_std_init": train.log_std_init}
