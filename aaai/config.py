"""Loads and validates configuration: configs/default.yaml, then a user YAML, then keywords.

Every value is checked against RULES; a bad key or value raises ConfigError with one
message that names the key, the value and what is allowed.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, Callable, Mapping

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
RULES: dict[str, Rule] = {
    "level": Rule("int", 0, MAX_LEVEL_ID, levels=True),  # a registered level's id (aaai.levels); 12 is L2b
    "difficulty": Rule("int", 0, 10),
    "agent.body": Rule("choice", choices=BODIES),
    "agent.action_mode": Rule("choice", choices=("rotation", "velocity", "gait")),
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
    "sensors.ray_kinds": Rule("choice", choices=("classic", "all")),  # aaai.sim.kinds.ray_channels
    "sensors.ray_max_angle": Rule("float", 5, 180),
    "sensors.ray_length": Rule("float", 1, 100),
    "sensors.ray_memory": Rule("int", 0, 10),  # earlier food sightings 1, 2, 4 .. 2^(n-1) steps back (0: none)
    "sensors.ray_down_fan": Rule("float", 0, 45),  # degrees: a second fan pitched down (0: none)
    "sensors.ray_width": Rule("float", 0, 5),  # aaai.sim.sensors.Rays: 0 thin lines; w: two more rays +-w/2 aside
    "sensors.camera": Rule("bool"),
    "sensors.camera_resolution": Rule("int", 8, 512),
    "sensors.camera_grayscale": Rule("bool"),
    "sensors.camera_look": Rule("choice", choices=("classic", "task")),  # aaai.sim.kinds.CAMERA_HIDDEN
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
    "train.teacher": Rule("choice", choices=("none", "reference")),
    "train.dagger_iterations": Rule("int", 1, 1000),
    "train.dagger_episodes": Rule("int", 1, 10**6),
    "train.dagger_beta": Rule("float", 0, 1),
    "train.dagger_epochs": Rule("int", 1, 1000),
    "train.dagger_episode_cap": Rule("int", 1, 10**6),
    "eval.seeds_per_cell": Rule("int", 1, 1000),
}


TRAINING_SECTIONS = ("curriculum", "train", "eval")


def env_part(config: dict, shaping: float) -> dict:
    """The environment's part of a resolved config (no training sections), with this reward shaping."""
    part = {key: value for key, value in config.items() if key not in TRAINING_SECTIONS}
    part["episode"] = {**part["episode"], "shaping": shaping}
    return part


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


def _unflatten(flat: Mapping[str, Any]) -> dict:
    tree: dict = {}
    for key, value in flat.items():
        *sections, leaf = key.split(".")
        node = tree
        for section in sections:
            node = node.setdefault(section, {})
        node[leaf] = value
    return tree


def load_config(config: str | Path | Mapping | None = None, **keywords: Any) -> dict:
    """The resolved configuration as a nested dict.

    ``config`` is a YAML path or a nested mapping of overrides. ``keywords`` use either
    the short name of a key (``camera_resolution=64``) or, for a whole section, its name
    with a mapping (``sensors={"camera": True}``).
    """
    flat: dict[str, Any] = {}
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
    return _unflatten(flat)


RAY_OPTIONS = ("sensors.ray_memory", "sensors.ray_down_fan", "sensors.ray_width")


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
