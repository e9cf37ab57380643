"""A training run's folder: resolved config, versions, episode log and checkpoints.

runs/NAME/
  config.yaml         the resolved configuration the run uses (resume reads it back)
  versions.json       Python and package versions
  episodes.csv        one row per finished training episode, flushed as it finishes
  curriculum.png      heatmap of mean return, z and p per cell
  checkpoints/step_000020000/{state.json, model.zip}
  final/{state.json, model.zip}
  tb/                 TensorBoard logs (PPO)
"""
from __future__ import annotations

import csv
import io
import json
import os
import platform
import shutil
import tempfile
from dataclasses import asdict, fields
from importlib import metadata
from pathlib import Path

import yaml

from aaai.config import ConfigError

from aaai.vector import Episode

PACKAGES = ("aaai", "pybullet", "numpy", "gymnasium", "stable-baselines3", "torch", "opencv-python-headless")
EPISODE_COLUMNS = ["step"] + [f.name for f in fields(Episode)]


def write_atomic(path: Path, text: str) -> None:
    """Writes a file so that a reader (or a crash) sees either the old or the new whole file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.NamedTemporaryFile("w", dir=path.parent, delete=False, suffix=".tmp") as handle:
        handle.write(text)
        handle.flush()
        os.fsync(handle.fileno())
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(handle.name, 0o666 & ~umask)  # as open() would make it, not the temporary file's 0600
    os.replace(handle.name, path)


def check_writable(path: Path, option: str, folder: bool = False) -> None:
    """Refuses, before any work, an output that cannot be written: a file that is a folder (or a
    folder that is a file), or a place without write permission."""
    path = Path(path)
    if path.exists() and path.is_dir() != folder:
        raise ConfigError(f"{option}: got {str(path)!r}, which is a {'file' if folder else 'folder'}; "
                          f"allowed: {'a folder' if folder else 'a file'} path")
    existing = path if path.exists() else next((p for p in path.absolute().parents if p.exists()), Path("/"))
    if not os.access(existing, os.W_OK) or (existing.is_dir() and not os.access(existing, os.X_OK)):
        raise ConfigError(f"{option}: got {str(path)!r}; {str(existing)!r} cannot be written to")
    for inside in ((path / "checkpoints", path / "episodes.csv") if folder and path.exists() else ()):
        if inside.exists() and not os.access(inside, os.W_OK):
            raise ConfigError(f"{option}: got {str(path)!r}; {str(inside)!r} cannot be written to")


def package_versions() -> dict[str, str]:
    versions = {"python": platform.python_version()}
    for name in PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


class RunFolder:
    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.checkpoints = self.path / "checkpoints"
        self.final = self.path / "final"

    @property
    def config_path(self) -> Path:
        return self.path / "config.yaml"

    def create(self, config: dict) -> None:
        if self.config_path.exists():
            raise FileExistsError(f"run folder {str(self.path)!r} already holds a run; use --resume to continue it")
        self.path.mkdir(parents=True, exist_ok=True)
        write_atomic(self.config_path, yaml.safe_dump(config, sort_keys=False))
        write_atomic(self.path / "versions.json", json.dumps(package_versions(), indent=2) + "\n")

    def update_config(self, config: dict) -> None:
        write_atomic(self.config_path, yaml.safe_dump(config, sort_keys=False))

    def read_config(self) -> dict:
        if not self.config_path.is_file():
            raise FileNotFoundError(f"{str(self.path)!r} is not a run folder: {self.config_path.name} is missing")
        return yaml.safe_load(self.config_path.read_text())

    # --- episodes -------------------------------------------------------------------
    def log_episodes(self, step: int, episodes: list[Episode]) -> None:
        path = self.path / "episodes.csv"
        new = not path.exists()
        with open(path, "a", newline="") as handle:
            writer = csv.writer(handle)
            if new:
                writer.writerow(EPISODE_COLUMNS)
            for episode in episodes:
                writer.writerow([step] + list(asdict(episode).values()))
            handle.flush()

    def trim_episodes(self, last_step: int) -> None:
        """On resume: forgets episodes logged after the checkpoint the run continues from."""
        path = self.path / "episodes.csv"
        if not path.exists():
            return
        with open(path, newline="") as handle:
            rows = list(csv.reader(handle))
        kept = [rows[0]] + [row for row in rows[1:] if len(row) == len(EPISODE_COLUMNS) and int(row[0]) <= last_step]
        text = io.StringIO()
        csv.writer(text).writerows(kept)
        write_atomic(path, text.getvalue())

    # --- checkpoints ----------------------------------------------------------------
    def save_checkpoint(self, step: int, state: dict, save_model=None, final: bool = False) -> Path:
        """Writes state.json (and model.zip via ``save_model(path)``) into a folder that appears whole."""
        target = self.final if final else self.checkpoints / f"step_{step:012d}"
        target.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(dir=target.parent, prefix=".staging-"))
        if save_model is not None:
            save_model(staging / "model.zip")
        write_atomic(staging / "state.json", json.dumps({"step": step, **state}) + "\n")
        if target.exists():
            shutil.rmtree(target)
        os.replace(staging, target)
        return target

    def latest_checkpoint(self) -> Path | None:
        found = sorted(self.checkpoints.glob("step_*")) if self.checkpoints.exists() else []
        return found[-1] if found else None

    @staticmethod
    def read_state(checkpoint: Path) -> dict:
        return json.loads((checkpoint / "state.json").read_text())
