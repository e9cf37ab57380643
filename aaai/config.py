"""Loads and validates configuration: configs/default.yaml, then a user YAML, then keywords.

Every value is checked against RULES; a bad key or value raises ConfigError with one
message that names the key, the value and what is allowed. ``load_config`` gives back one frozen,
typed ``Config`` (a dataclass per section: ``config.train.num_envs``); its ``to_yaml()`` is the
dotted-key YAML that run folders and model files hold.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, fields
from importlib import resources
from pathlib import Path
from typing import Any, Callable, Literal, Mapping

import yaml

from aaai import safe_yaml
from aaai.agent.urdf_writer import BODIES
from aaai.errors import ConfigError as ConfigError  # where users and modules import it from

_level_ids: Callable[[], list[int]] | None = None  # the level registry's ids, once aaai.levels is imported


def use_level_ids(provider: Callable[[], list[int]]) -> None:
    """Lets the level registry (which imports this module) say which level ids exist."""
    global _level_ids
    _level_ids = provider


def describe_ids(ids: list[int]) -> str:
    """[0, 1, 2, 5] -> '0 to 2, 5'."""
    parts, start = [], None
    for i, value in enumerate(ids):
        if start is None:
            start = value
        if i + 1 == len(ids) or ids[i + 1] != value + 1:
            parts.append(f"{start}" if start == value else f"{start} to {value}")
            start = None
    return ", ".join(parts)


@dataclass(frozen=True)
class Rule:
    kind: str  # int | float | bool | choice | set (integers, written "0-3,5") | path (a file or folder, or null)
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] = ()  # for int and float: words allowed besides the numbers
    levels: bool = False  # the values are level ids: each must be a registered level

    def describe(self) -> str:
        if self.kind == "bool":
            return "true or false"
        if self.kind == "path":
            return "null or a file or folder's path"
        if self.kind == "choice":
            return "one of " + ", ".join(self.choices)
        if self.kind == "set":
            return f"integers from {self.low:g} to {self.high:g}, as a list or ranges like '0-3,5'"
        noun = "an integer" if self.kind == "int" else "a number"
        words = "".join(f"{word} or " for word in self.choices)
        return f"{words}{noun} from {self.low:g} to {self.high:g}"

    def check(self, key: str, value: Any) -> Any:
        checked = self._check(key, value)
        if self.levels and _level_ids is not None:
            known = _level_ids()
            missing = [v for v in (checked if isinstance(checked, list) else [checked]) if v not in known]
            if missing:
                raise ConfigError(
                    f"config key '{key}': got {value!r}, and level {missing[0]} does not exist; "
                    f"allowed: registered level ids {describe_ids(known)}"
                )
        return checked

    def _check(self, key: str, value: Any) -> Any:
        if self.kind == "set":
            assert self.low is not None and self.high is not None, "a set rule has its bounds"
            return parse_int_set(value, key, int(self.low), int(self.high))
        if self.kind == "path":
            if value is None or (isinstance(value, str) and value.strip() and len(value) <= 4096 and "\0" not in value):
                return value
            raise ConfigError(f"config key '{key}': got {value!r}; allowed: {self.describe()}")
        if self.kind == "bool":
            ok = isinstance(value, bool)
        elif self.kind == "choice" or isinstance(value, str):
            ok = isinstance(value, str) and value in self.choices
        else:
            is_number = isinstance(value, (int, float)) and not isinstance(value, bool)
            if self.kind == "int":  # an int is whole however large (float() of 10**500 overflows)
                is_number = is_number and (isinstance(value, int) or float(value).is_integer())
            ok = is_number and self.low <= value <= self.high
            if ok:
                value = int(value) if self.kind == "int" else float(value)
        if not ok:
            raise ConfigError(f"config key '{key}': got {value!r}; allowed: {self.describe()}")
        return value


def parse_int_set(value: Any, key: str, low: int, high: int) -> list[int]:
    """'0-3,5', 4 or [0, 2] -> a sorted list of distinct integers, each checked to lie in low..high."""
    allowed = f"integers from {low} to {high}, as a list or ranges like '0-3,5'"
    values: list[int] = []
    try:
        parts = value if isinstance(value, list) else str(value).split(",")
        for part in parts:
            if isinstance(part, bool):
                raise ValueError
            if isinstance(part, int):
                values.append(part)
                continue
            first, _, last = str(part).strip().partition("-")
            start, stop = int(first), int(last or first)
            if not low <= start <= stop <= high:  # checked before a list is built: '0-3000000000' is refused
                raise ValueError
            values.extend(range(start, stop + 1))
    except ValueError:
        raise ConfigError(f"config key '{key}': got {value!r}; allowed: {allowed} (a range runs low to high)") from None
    if not values or any(not low <= v <= high for v in values):
        raise ConfigError(f"config key '{key}': got {value!r}; allowed: {allowed}")
    return sorted(set(values))


MAX_LEVEL_ID = 999  # level ids are 0..999; which exist, the level registry says (aaai.levels)
# the controllers a DAgger student learns from (train.teacher; aaai.task.search.teacher builds each)
TEACHERS = ("reference", "search", "search_strict", "search_thorough")
RULES: dict[str, Rule] = {
    "level": Rule("int", 0, MAX_LEVEL_ID, levels=True),  # a registered level's id (aaai.levels); 12 is L2b
    "difficulty": Rule("int", 0, 10),
    "agent.body": Rule("choice", choices=(*BODIES, "sphere")),  # sphere: Animal-AI's body (aaai.agent.sphere)
    # discrete: Animal-AI's actions (forward/backward, right/left) and a crouch, as the gait's commands
    "agent.action_mode": Rule("choice", choices=("rotation", "velocity", "gait", "discrete")),
    "agent.decision_interval": Rule("float", 1e-4, 1e4),  # gait mode: seconds an action is held
    "agent.max_force": Rule("float", 1e-3, 1e5),
    "agent.position_gain": Rule("float", 1e-4, 10),
    "agent.velocity_gain": Rule("float", 0, 10),
    "agent.max_joint_velocity": Rule("float", 1e-3, 100),
    "agent.friction": Rule("float", 0, 10),
    "agent.limb_food_reward": Rule("choice", choices=("flat", "size", "none")),
    "sensors.rays": Rule("bool"),
    "sensors.rays_per_side": Rule("int", 1, 20),
    "sensors.rays_flat": Rule("bool"),
    "sensors.ray_kinds": Rule("choice", choices=("classic", "all")),  # aaai.spec.kinds.ray_channels
    "sensors.ray_max_angle": Rule("float", 5, 180),
    "sensors.ray_length": Rule("float", 1, 100),
    "sensors.ray_memory": Rule("int", 0, 10),  # earlier food sightings 1, 2, 4 .. 2^(n-1) steps back (0: none)
    "sensors.food_memory": Rule("int", 0, 16),  # the n nearest pieces of food the rays have shown (0: none)
    "sensors.sweep_memory": Rule("int", 0, 36),  # where the rays have looked, in n sectors round the body (0: none)
    "sensors.sweep_map": Rule("int", 0, 32),  # where the rays have looked and met something, an n x n map (0: none)
    "sensors.ray_down_fan": Rule("float", 0, 45),  # degrees: a second fan pitched down (0: none)
    "sensors.ray_width": Rule("float", 0, 5),  # aaai.sim.sensors.Rays: 0 thin lines; w: two more rays +-w/2 aside
    "sensors.camera": Rule("bool"),
    "sensors.camera_resolution": Rule("int", 8, 512),
    "sensors.camera_grayscale": Rule("bool"),
    "sensors.camera_look": Rule("choice", choices=("classic", "task")),  # aaai.spec.kinds.CAMERA_HIDDEN
    "sensors.joint_velocities": Rule("bool"),
    "sensors.head_orientation": Rule("bool"),
    "sensors.foot_contacts": Rule("bool"),
    "episode.max_steps": Rule("int", 10, 10000, choices=("auto",)),
    "episode.ground_penalty": Rule("bool"),
    "episode.shaping": Rule("float", 0, 1e3),
    "episode.shaping_gamma": Rule("float", 0, 1),
    "physics.timestep": Rule("float", 1e-4, 0.05),
    "physics.action_repeat": Rule("int", 1, 50),
    "physics.solver_iterations": Rule("int", 1, 500),
    "physics.gravity": Rule("float", 0, 100),
    "physics.blowup_speed": Rule("float", 1, 1e5),
    "curriculum.mode": Rule("choice", choices=("curriculum", "random")),
    "curriculum.sampler": Rule("choice", choices=("paper", "uniform", "learnability", "plr")),
    "curriculum.warmup": Rule("int", 0, 1000),
    "curriculum.plr_temperature": Rule("float", 1e-3, 100),
    "curriculum.plr_staleness": Rule("float", 0, 1),
    "curriculum.levels": Rule("set", 0, MAX_LEVEL_ID, levels=True),  # registered levels' ids
    "curriculum.difficulties": Rule("set", 0, 10),
    "curriculum.window": Rule("int", 2, 1000),
    "curriculum.c": Rule("float", 1e-9, 1e3),
    "curriculum.spread": Rule("choice", choices=("std", "variance")),
    "train.agent": Rule("choice", choices=("ppo", "random")),
    "train.total_steps": Rule("int", 1, 10**10),
    "train.num_envs": Rule("int", 1, 256),
    "train.vector": Rule("choice", choices=("auto", "sync", "async")),  # aaai.train.vector.runs_in_process
    "train.processes": Rule("int", 0, 256),  # aaai.train.vector.worker_processes; 0 = auto
    "train.seed": Rule("int", 0, 2**32 - 1),
    "train.checkpoint_every": Rule("int", 1, 10**10),
    "train.heatmap_every": Rule("int", 1, 10**10),
    "train.learning_rate": Rule("float", 1e-7, 1.0),
    "train.n_steps": Rule("int", 8, 100000),
    "train.batch_size": Rule("int", 8, 100000),
    "train.n_epochs": Rule("int", 1, 100),
    "train.gamma": Rule("float", 0.0, 1.0),
    "train.gae_lambda": Rule("float", 0.0, 1.0),
    "train.ent_coef": Rule("float", 0.0, 1.0),
    "train.net_width": Rule("int", 4, 4096),
    "train.log_std_init": Rule("float", -5, 2),
    "train.proprioception": Rule("bool"),
    "train.reward_shaping": Rule("float", 0, 1e3),
    "train.init_from": Rule("path"),
    "train.value_warmup_steps": Rule("int", 0, 10**10),  # aaai.train.finetune: decisions fitting only the value
    "train.value_warmup_epochs": Rule("int", 1, 1000),
    "train.bc_coef": Rule("float", 0, 1e6),  # aaai.train.finetune: the anchor to the student (0: none)
    "train.bc_decay_steps": Rule("int", 1, 10**10),
    "train.teacher": Rule("choice", choices=("none", *TEACHERS)),
    "train.dagger_iterations": Rule("int", 1, 1000),
    "train.dagger_episodes": Rule("int", 1, 10**6),
    "train.dagger_beta": Rule("float", 0, 1),
    "train.dagger_epochs": Rule("int", 1, 1000),
    "train.dagger_episode_cap": Rule("int", 0, 10**6),  # 0: each episode to its own end
    "train.dagger_max_decisions": Rule("int", 0, 10**9),  # aaai.train.camera_student.Dataset; 0: no cap
    "train.student_policy": Rule("choice", choices=("mlp", "lstm")),
    "train.dagger_sequence": Rule("int", 2, 10**4),
    "train.dagger_chunks": Rule("choice", choices=("shuffled", "episodes")),  # aaai.train.recurrent_student
    "train.dagger_learning_rate_end": Rule("float", 1e-7, 1.0),  # a refit's step size, from 0.001 to this (cosine)
    "train.dagger_data_from": Rule("path"),  # aaai.train.student.import_rounds: another run's rounds to start from
    "train.max_minutes": Rule("float", 0, 10**7),  # aaai.train.training.Tracker: wall-clock budget (0: none)
    "eval.seeds_per_cell": Rule("int", 1, 1000),
}


ActionMode = Literal["rotation", "velocity", "gait", "discrete"]  # what the env's actions mean (agent.action_mode)
ACTION_MODES: tuple[str, ...] = RULES["agent.action_mode"].choices  # the CLI's --action-mode choices


# --- the typed configuration: one frozen dataclass per section of configs/default.yaml ----------
# The fields run in the order of configs/default.yaml, so that Config.to_yaml() writes the file
# as it was always written (run folders, model files and provenance hashes depend on its bytes).


@dataclass(frozen=True)
class AgentConfig:
    """``agent.*``: the body and how actions drive it."""

    body: str
    action_mode: ActionMode
    decision_interval: float
    max_force: float
    position_gain: float
    velocity_gain: float
    max_joint_velocity: float
    friction: float
    limb_food_reward: str


@dataclass(frozen=True)
class SensorsConfig:
    """``sensors.*``: the senses and the observation's keys."""

    rays: bool
    rays_per_side: int
    ray_max_angle: float
    ray_length: float
    ray_down_fan: float
    ray_memory: int
    food_memory: int
    sweep_memory: int
    sweep_map: int
    rays_flat: bool
    ray_kinds: str
    ray_width: float
    camera: bool
    camera_resolution: int
    camera_grayscale: bool
    camera_look: str
    joint_velocities: bool
    head_orientation: bool
    foot_contacts: bool


@dataclass(frozen=True)
class EpisodeConfig:
    """``episode.*``: its length and the reward's optional terms."""

    max_steps: int | str  # "auto" or a number of steps
    ground_penalty: bool
    shaping: float
    shaping_gamma: float


@dataclass(frozen=True)
class PhysicsConfig:
    """``physics.*``: the PyBullet client's settings."""

    timestep: float
    action_repeat: int
    solver_iterations: int
    gravity: float
    blowup_speed: float

    @property
    def control_dt(self) -> float:
        """Simulated seconds per control step (``timestep x action_repeat``)."""
        return self.timestep * self.action_repeat


@dataclass(frozen=True)
class CurriculumConfig:
    """``curriculum.*``: which cells training draws, and how."""

    mode: str
    sampler: str
    warmup: int
    plr_temperature: float
    plr_staleness: float
    levels: tuple[int, ...]
    difficulties: tuple[int, ...]
    window: int
    c: float
    spread: str


@dataclass(frozen=True)
class TrainConfig:
    """``train.*``: the learner and its run."""

    agent: str
    total_steps: int
    num_envs: int
    vector: str
    processes: int
    seed: int
    checkpoint_every: int
    heatmap_every: int
    learning_rate: float
    n_steps: int
    batch_size: int
    n_epochs: int
    gamma: float
    gae_lambda: float
    ent_coef: float
    net_width: int
    log_std_init: float
    proprioception: bool
    reward_shaping: float
    init_from: str | None
    value_warmup_steps: int
    value_warmup_epochs: int
    bc_coef: float
    bc_decay_steps: int
    teacher: str
    dagger_iterations: int
    dagger_episodes: int
    dagger_beta: float
    dagger_epochs: int
    dagger_episode_cap: int
    dagger_max_decisions: int
    student_policy: str
    dagger_sequence: int
    dagger_chunks: str
    dagger_learning_rate_end: float
    dagger_data_from: str | None
    max_minutes: float


@dataclass(frozen=True)
class EvalConfig:
    """``eval.*``: scoring."""

    seeds_per_cell: int


SECTIONS: dict[str, type] = {
    "agent": AgentConfig,
    "sensors": SensorsConfig,
    "episode": EpisodeConfig,
    "physics": PhysicsConfig,
    "curriculum": CurriculumConfig,
    "train": TrainConfig,
    "eval": EvalConfig,
}


@dataclass(frozen=True)
class Config:
    """The whole configuration, checked: ``load_config(...)`` builds it (configs/default.yaml, then a
    user YAML, then keywords) and every part reads its values as attributes,
    ``config.train.num_envs``, ``config.sensors.camera``. It is frozen: ``config.replace(num_envs=2)``
    (keywords as ``load_config`` takes them) gives a checked copy. The file format stays the dotted
    keys' YAML: ``to_dict()``, ``flat()`` and ``to_yaml()`` give it back as it is written."""

    level: int
    difficulty: int
    agent: AgentConfig
    sensors: SensorsConfig
    episode: EpisodeConfig
    physics: PhysicsConfig
    curriculum: CurriculumConfig
    train: TrainConfig
    eval: EvalConfig

    @classmethod
    def from_flat(cls, flat: Mapping[str, Any]) -> Config:
        """A Config of checked values by dotted key (``"train.seed"``); lists become tuples."""
        parts = {
            name: section(**{f.name: _frozen(flat[f"{name}.{f.name}"]) for f in fields(section)})
            for name, section in SECTIONS.items()
        }
        return cls(level=flat["level"], difficulty=flat["difficulty"], **parts)

    def flat(self) -> dict[str, Any]:
        """Every value by its dotted key, in the order of configs/default.yaml (sets as lists)."""
        out: dict[str, Any] = {"level": self.level, "difficulty": self.difficulty}
        for name in SECTIONS:
            section = getattr(self, name)
            out.update({f"{name}.{f.name}": _plain(getattr(section, f.name)) for f in fields(section)})
        return out

    def to_dict(self) -> dict[str, Any]:
        """The nested mapping of sections and keys, as written to a run's config file."""
        tree: dict[str, Any] = {}
        for key, value in self.flat().items():
            section, _, leaf = key.rpartition(".")
            (tree.setdefault(section, {}) if section else tree)[leaf] = value
        return tree

    def env_dict(self) -> dict[str, Any]:
        """The environment's part of ``to_dict()``: every section but the training ones."""
        return {key: value for key, value in self.to_dict().items() if key not in TRAINING_SECTIONS}

    def to_yaml(self) -> str:
        """The YAML of ``to_dict()``, as the run folder's ``config.yaml`` and a model's carried
        ``aaai_config.yaml`` hold it."""
        return yaml.safe_dump(self.to_dict(), sort_keys=False)

    def replace(self, config: Mapping[str, Any] | None = None, **keywords: Any) -> Config:
        """A checked copy with these values changed: a nested mapping and/or keywords as
        ``load_config`` takes them (``replace(num_envs=2)``, ``replace({"train": {"seed": 3}})``)."""
        if config is None:
            return load_config(self, **keywords)
        return load_config(_deep_merge(self.to_dict(), config), **keywords)


def _frozen(value: Any) -> Any:
    return tuple(value) if isinstance(value, list) else value


def _plain(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


def _deep_merge(tree: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    merged = dict(tree)
    for key, value in overrides.items():
        if isinstance(value, Mapping) and isinstance(merged.get(key), Mapping):
            merged[key] = _deep_merge(merged[key], value)
        else:
            merged[key] = value
    return merged


_TYPED_KEYS = [
    "level",
    "difficulty",
    *(f"{name}.{f.name}" for name, section in SECTIONS.items() for f in fields(section)),
]
assert sorted(_TYPED_KEYS) == sorted(RULES), "the Config's fields and RULES name different keys"


TRAINING_SECTIONS = ("curriculum", "train", "eval")


def env_part(config: Config, shaping: float) -> Config:
    """The configuration an environment of a run gets: the same, with this reward shaping
    (``episode.shaping``); the environment reads no training section."""
    return load_config(config, shaping=shaping)


def env_keywords() -> set[str]:
    """The keyword arguments the environment takes for configuration: the short names of the
    environment's keys and its section names (not the training sections)."""
    env_keys = [key for key in RULES if key.split(".")[0] not in TRAINING_SECTIONS]
    return {key.rsplit(".", 1)[-1] for key in env_keys} | {key.split(".")[0] for key in env_keys if "." in key}


def config_dir() -> Path:
    """The folder holding default.yaml and levels/ (installed as the package aaai_configs)."""
    return Path(str(resources.files("aaai_configs")))


def read_yaml(path: str | Path, what: str = "config file") -> dict:
    """A YAML file's mapping, read as plain data within the project's limits (aaai.safe_yaml: size,
    UTF-8, no aliases or tags, depth, numbers); errors name the file as ``what``."""
    if not isinstance(path, (str, Path)):
        raise ConfigError(f"config: got {path!r}; allowed: a YAML file's path or a mapping of keys")
    return safe_yaml.load_mapping(path, what)


def _flatten(tree: Mapping, prefix: str = "") -> dict[str, Any]:
    flat = {}
    for key, value in tree.items():
        dotted = f"{prefix}{key}"
        if isinstance(value, Mapping):
            flat.update(_flatten(value, dotted + "."))
        else:
            flat[dotted] = value
    return flat


def _leaf_names() -> dict[str, str]:
    """Short keyword names ('camera_resolution') for the dotted keys ('sensors.camera_resolution')."""
    return {key.rsplit(".", 1)[-1]: key for key in RULES}


assert len(_leaf_names()) == len(RULES), "two config keys share a short name"


def _section_names() -> set[str]:
    return {key.rsplit(".", 1)[0] for key in RULES if "." in key}


def _merge(flat: dict[str, Any], overrides: Mapping, source: str) -> None:
    for key, value in _flatten(overrides).items():
        if key not in RULES:
            section = key.rsplit(".", 1)[0] if "." in key else ""
            allowed = sorted(k for k in RULES if section and k.startswith(section + ".")) or sorted(
                {k.split(".")[0] for k in RULES}
            )
            raise ConfigError(f"config key '{key}' ({source}) does not exist; allowed: {', '.join(allowed)}")
        flat[key] = RULES[key].check(key, value)


def load_config(config: str | Path | Mapping[str, Any] | Config | None = None, **keywords: Any) -> Config:
    """The resolved configuration, built and checked once: a frozen ``Config``.

    ``config`` is a YAML path, a nested mapping of overrides, or a ``Config`` to start from (its
    values are already checked). ``keywords`` use either the short name of a key
    (``camera_resolution=64``) or, for a whole section, its name with a mapping
    (``sensors={"camera": True}``).
    """
    flat: dict[str, Any] = {}
    if isinstance(config, Config):
        flat = config.flat()
    else:
        _merge(flat, read_yaml(config_dir() / "default.yaml"), "default.yaml")
        if set(flat) != set(RULES):
            missing = sorted(set(RULES) - set(flat))
            raise ConfigError(f"default.yaml lacks the keys {', '.join(missing)}")
        if config is not None:
            overrides = copy.deepcopy(dict(config)) if isinstance(config, Mapping) else read_yaml(config)
            _merge(flat, overrides, "config" if isinstance(config, Mapping) else str(config))
    leaves = _leaf_names()
    sections = _section_names()
    for name, value in keywords.items():
        if name in sections and isinstance(value, Mapping):
            _merge(flat, {name: value}, "keyword")
        elif name in leaves:
            _merge(flat, {leaves[name]: value}, "keyword")
        else:
            allowed = ", ".join(sorted(set(leaves) | sections))
            raise ConfigError(f"config key '{name}' (keyword) does not exist; allowed: {allowed}")
    _check_ray_options(flat)
    return Config.from_flat(flat)


RAY_OPTIONS = (
    "sensors.ray_memory",
    "sensors.food_memory",
    "sensors.sweep_memory",
    "sensors.sweep_map",
    "sensors.ray_down_fan",
    "sensors.ray_width",
)


def _check_ray_options(flat: Mapping[str, Any]) -> None:
    """An option of the rays set while the rays are off would be silently ignored: refuse it."""
    if flat["sensors.rays"]:
        return
    for key in RAY_OPTIONS:
        if flat[key]:
            raise ConfigError(
                f"config key '{key}': got {flat[key]!r} with 'sensors.rays': false; allowed: 0 when the rays "
                f"are off, or set 'sensors.rays': true"
            )
