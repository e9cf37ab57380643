"""The environment config a model file carries (``aaai_config.yaml`` beside stable-baselines3's members).

A model file is scored in its own environment on its own: :func:`save_model` writes the config into
the file, :func:`model_config` reads it back as data (checked as any config, within the safe YAML
reader's limits), and :func:`start_config_problems` compares it with a new run's for
``aaai train --init-from``.
"""

from __future__ import annotations

import zipfile
from pathlib import Path

from aaai import safe_yaml
from aaai.config import Config, ConfigError, load_config
from aaai.files import atomic_path

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


def start_config_problems(path: str | Path, config: Config) -> list[str]:
    """``aaai train --init-from``: how the environment the model's carried config
    (:data:`CONFIG_MEMBER`) describes differs from the new run's, one entry per differing key
    (body, action mode, senses and their layout; a sensor's settings count only where it is on at
    either side). Empty for a file that carries no config."""
    carried = model_config(path)
    if carried is None:
        return []
    there, here = carried.flat(), config.flat()
    off = {
        name
        for name in ("camera", "rays")
        if there[f"sensors.{name}"] is not True and here[f"sensors.{name}"] is not True
    }
    keys = ["agent.body", "agent.action_mode"] + [
        key
        for key in here
        if key.startswith("sensors.")
        and ("camera" if key.startswith("sensors.camera") else "rays" if key.startswith("sensors.ray") else "")
        not in off
    ]
    return [f"{key}: {there[key]!r} there, {here[key]!r} here" for key in keys if there[key] != here[key]]
