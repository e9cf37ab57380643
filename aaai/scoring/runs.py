"""A training run's folder: resolved config, versions, episode log and checkpoints.

runs/NAME/
  config.yaml         the resolved configuration the run uses (resume reads it back)
  versions.json       Python and package versions, and MKL's code path (aaai.numerics)
  episodes.csv        one row per finished training episode, flushed as it finishes
  curriculum.png      heatmap of mean return, z and p per cell
  checkpoints/step_000000020000/{state.json, model.zip}   (the step in 12 digits)
  final/{state.json, model.zip}
  resume.log          what a resume skipped (unreadable checkpoints), one line each
  tb/                 TensorBoard logs (PPO)
  .lock               while a process trains the run: its lock, holding its pid (see RunFolder.locked)
"""

from __future__ import annotations

import csv
import io
import json
import os
import platform
import shutil
import tempfile
import zipfile
from contextlib import contextmanager
from dataclasses import asdict, dataclass, fields
from importlib import metadata
from pathlib import Path
from typing import Iterator

from aaai.config import Config, ConfigError, read_yaml
from aaai.files import append_rows, hold, naming, sync_file, write_atomic  # write_atomic also re-exported
from aaai.numerics import mkl_setting

PACKAGES = ("aaai", "pybullet", "numpy", "gymnasium", "stable-baselines3", "torch", "opencv-python-headless")
CHECKPOINT_FOLDER = "rllib"  # an RLlib run's Algorithm checkpoint, inside checkpoints/step_N/ and final/
MODULE_PATH = Path("learner_group", "learner", "rl_module", "default_policy")  # its policy, inside that
LOCK_FILE = ".lock"  # in a run folder while a process writes it
STAGING_PREFIX = ".staging-"  # a checkpoint being written, beside its place (renamed onto it when whole)


@dataclass
class Episode:
    """A finished training episode (a row of episodes.csv)."""

    worker: int
    level: int
    difficulty: int
    seed: int
    episode_return: float  # what the learner got, shaping included
    task_return: float  # the task's own reward: what the curriculum and the scoreboard count
    length: int
    food_eaten: int
    wall_hits: int
    fell: bool
    blew_up: bool
    max_reward: float


EPISODE_COLUMNS = ["step"] + [f.name for f in fields(Episode)]


def check_writable(path: Path, option: str, folder: bool = False) -> None:
    """Refuses, before any work, an output that cannot be written: a file that is a folder (or a
    folder that is a file), or a place without write permission."""
    path = Path(path)
    if path.exists() and path.is_dir() != folder:
        raise ConfigError(
            f"{option}: got {str(path)!r}, which is a {'file' if folder else 'folder'}; "
            f"allowed: {'a folder' if folder else 'a file'} path"
        )
    if not folder and path.exists() and not path.is_file():  # a pipe would block, a device never end
        raise ConfigError(f"{option}: got {str(path)!r}, which is a device or a pipe; allowed: a regular file path")
    existing = path if path.exists() else next((p for p in path.absolute().parents if p.exists()), Path("/"))
    if not os.access(existing, os.W_OK) or (existing.is_dir() and not os.access(existing, os.X_OK)):
        raise ConfigError(f"{option}: got {str(path)!r}; {str(existing)!r} cannot be written to")
    for inside in (path / "checkpoints", path / "episodes.csv") if folder and path.exists() else ():
        if inside.exists() and not os.access(inside, os.W_OK):
            raise ConfigError(f"{option}: got {str(path)!r}; {str(inside)!r} cannot be written to")


def package_versions() -> dict[str, str]:
    versions = {"python": platform.python_version()}
    for name in PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    versions["MKL_CBWR"] = mkl_setting()  # MKL's code path (aaai.numerics): COMPATIBLE trains alike on every CPU
    return versions


class RunFolder:
    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.checkpoints = self.path / "checkpoints"
        self.final = self.path / "final"

    @property
    def config_path(self) -> Path:
        return self.path / "config.yaml"

    @contextmanager
    def locked(self, option: str) -> Iterator[None]:
        """Holds the run folder's lock (``.lock`` inside it; the folder is made if need be) for the
        block: one process at a time trains a run (a new one or a resume). Another process on it
        refuses at once, naming the holder's pid. The operating system releases the lock when the
        holder ends, killed or not. Checkpoints a killed holder was writing (``.staging-*``) are
        removed. Folders this call made that are left empty (a refused config) are removed again."""
        made = [folder for folder in (self.path, *self.path.parents) if not folder.exists()]  # deepest first
        with naming(self.path):
            self.path.mkdir(parents=True, exist_ok=True)
        try:
            lock = hold(
                self.path / LOCK_FILE,
                lambda pid: (
                    f"{option}: run folder {str(self.path)!r} is in use by "
                    + (f"process {pid}" if pid else "another process")
                    + "; allowed: one process at a time per run folder (wait for it to end or stop it, "
                    "or choose another folder)"
                ),
            )
        except BaseException:
            _remove_if_empty(made)
            raise
        try:
            self.remove_staging()
            yield
        finally:
            lock.release()
            _remove_if_empty(made)

    def remove_staging(self) -> None:
        """Removes checkpoints left half-written (``.staging-*``) by a process killed while saving."""
        for parent in (self.path, self.checkpoints):
            for staging in parent.glob(f"{STAGING_PREFIX}*") if parent.is_dir() else ():
                shutil.rmtree(staging, ignore_errors=True)

    def create(self, config: Config) -> None:
        if self.config_path.exists():
            raise FileExistsError(f"run folder {str(self.path)!r} already holds a run; use --resume to continue it")
        self.path.mkdir(parents=True, exist_ok=True)
        write_atomic(self.config_path, config.to_yaml())
        write_atomic(self.path / "versions.json", json.dumps(package_versions(), indent=2) + "\n")

    def update_config(self, config: Config) -> None:
        write_atomic(self.config_path, config.to_yaml())

    def read_config(self) -> dict:
        if not self.config_path.is_file():
            raise FileNotFoundError(f"{str(self.path)!r} is not a run folder: {self.config_path.name} is missing")
        return read_yaml(self.config_path)

    # --- episodes -------------------------------------------------------------------
    @property
    def episodes_path(self) -> Path:
        return self.path / "episodes.csv"

    def log_episodes(self, step: int, episodes: list[Episode]) -> None:
        """Appends finished episodes to episodes.csv (each row whole; on disk at the next checkpoint)."""
        rows = [[step] + list(asdict(episode).values()) for episode in episodes]
        append_rows(self.episodes_path, EPISODE_COLUMNS, rows, sync=False)

    def trim_episodes(self, last_step: int) -> None:
        """On resume: forgets episodes logged after the checkpoint the run continues from (all of
        them, to the header, when it starts again from step 0: killed before its first checkpoint),
        so that the log holds exactly the episodes the checkpoint's curriculum counted."""
        path = self.episodes_path
        if not path.exists():
            return
        if not path.is_file():  # a pipe would wait for a writer for ever
            raise ConfigError(f"--resume: {str(path)!r} is not a regular file; allowed: the run's own episode log")
        try:  # bytes that are not text spoil only their rows, which are cut as torn ones are
            with open(path, newline="", errors="replace") as handle:
                rows = list(csv.reader(handle))
        except csv.Error as error:
            raise ConfigError(f"--resume: {str(path)!r} cannot be read as an episode log ({error})") from None
        whole = [row for row in rows[1:] if len(row) == len(EPISODE_COLUMNS) and row[0].isdigit()]
        kept = [EPISODE_COLUMNS] + [row for row in whole if int(row[0]) <= last_step]
        if kept == rows:
            return
        text = io.StringIO()
        csv.writer(text).writerows(kept)
        write_atomic(path, text.getvalue())

    # --- checkpoints ----------------------------------------------------------------
    def save_checkpoint(self, step: int, state: dict, save_model=None, final: bool = False) -> Path:
        """Writes state.json (and model.zip via ``save_model(path)``) into a folder that appears whole,
        after the episode log it counts is on disk. On an error the half-written folder is removed
        and an OSError names the file of the checkpoint that could not be written."""
        target = self.final if final else self.checkpoints / f"step_{step:012d}"
        sync_file(self.episodes_path)
        with naming(target.parent):
            target.parent.mkdir(parents=True, exist_ok=True)
        try:
            staging = Path(tempfile.mkdtemp(dir=target.parent, prefix=STAGING_PREFIX))
        except OSError as error:  # it names the staging folder it tried: name the checkpoint
            raise OSError(error.errno, error.strerror, str(target)) from error
        try:
            with naming(target, staging):
                if save_model is not None:
                    with naming(target / "model.zip"):
                        save_model(staging / "model.zip")
                write_atomic(staging / "state.json", json.dumps({"step": step, **state}) + "\n")
                if target.exists():
                    shutil.rmtree(target)
                os.replace(staging, target)
        except BaseException:
            shutil.rmtree(staging, ignore_errors=True)
            raise
        return target

    def saved(self) -> list[Path]:
        """Every saved point of the run, newest first: final/ and checkpoints/step_*, ordered by the
        step their state records (final/ first on a tie; one whose state cannot be read is tried
        where its folder name puts it, final/ first)."""
        found = sorted(self.checkpoints.glob("step_*")) if self.checkpoints.exists() else []
        points = [(self._step_of(folder), 1, folder) for folder in found]
        if self.final.is_dir():
            points.append((self._step_of(self.final, unreadable=float("inf")), 2, self.final))
        return [folder for *_, folder in sorted(points, key=lambda p: (p[0], p[1]), reverse=True)]

    @staticmethod
    def _step_of(folder: Path, unreadable: float = -1.0) -> float:
        try:
            return int(json.loads(_state_text(folder))["step"])
        except (OSError, ValueError, KeyError, TypeError, RecursionError):
            if folder.name.startswith("step_") and folder.name[5:].isdigit():
                return int(folder.name[5:])
            return unreadable

    def latest_checkpoint(self) -> Path | None:
        """The newest saved point (final/ included), readable or not."""
        saved = self.saved()
        return saved[0] if saved else None

    def resume_point(self, needs_model: bool, say=print) -> tuple[Path, dict] | None:
        """The newest saved point that can be read, with its state; None for a run with none.

        An unreadable point (a state.json that does not parse, a model.zip that is not a whole
        stable-baselines3 archive) is skipped: ``say`` is told why, and so is resume.log.
        """
        saved = self.saved()
        problems = []
        for folder in saved:
            problem = self.unreadable(folder, needs_model)
            if problem is None:
                return folder, self.read_state(folder)
            problems.append(
                f"{folder.relative_to(self.path)}/{problem}"
                if problem.startswith("model.zip")
                else f"{folder.relative_to(self.path)}: {problem}"
            )
            message = f"skipping {folder.relative_to(self.path)}: {problem}; falling back to an older checkpoint"
            say(message)
            with open(self.path / "resume.log", "a") as log:
                log.write(message + "\n")
        if saved:
            raise ConfigError(
                f"--resume: no checkpoint of {str(self.path)!r} can be read (tried {'; '.join(problems)})"
            )
        return None

    @staticmethod
    def unreadable(folder: Path, needs_model: bool) -> str | None:
        """Why a saved point cannot be resumed from, or None when it can."""
        try:
            state = json.loads(_state_text(folder))
        except FileNotFoundError:
            return "state.json is missing"
        except (OSError, ValueError) as error:
            return f"state.json cannot be read ({error})"
        except RecursionError:
            return "state.json nests too deeply"
        if not isinstance(state, dict) or not isinstance(state.get("step"), int) or "curriculum" not in state:
            return "state.json lacks its step or curriculum"
        if needs_model:
            return model_problem(folder / "model.zip")
        return None

    @staticmethod
    def read_state(checkpoint: Path) -> dict:
        return json.loads((checkpoint / "state.json").read_text())


def _state_text(folder: Path) -> str:
    """A checkpoint's state.json as text; an OSError if it is no regular file (a pipe would block)."""
    path = folder / "state.json"
    if path.exists() and not path.is_file():
        raise OSError(f"{str(path)!r} is not a regular file")
    return path.read_text()


def _remove_if_empty(folders: list[Path]) -> None:
    """Removes the folders (deepest first) that are empty: those made for a run that was refused."""
    for folder in folders:
        try:
            folder.rmdir()
        except OSError:
            return  # not empty: it holds a run


def model_problem(path: Path) -> str | None:
    """Why ``path`` is not a whole stable-baselines3 model archive, or None when it is one. Its
    members' declared sizes are checked against the budgets of a scored model
    (:func:`aaai.scoring.model_archive.size_problem`) before any is inflated; a size that lies is
    then caught by the checksum after inflating no more than it declared."""
    from aaai.scoring.model_archive import size_problem

    if not path.is_file():
        return f"{path.name} is missing"
    if path.stat().st_size == 0:
        return f"{path.name} is empty"
    try:
        with zipfile.ZipFile(path) as archive:
            locked = [info.filename for info in archive.infolist() if info.flag_bits & 0x1]
            if locked:  # zipfile would ask for a password
                return (
                    f"{path.name} has an encrypted member ({locked[0]!r}); "
                    "allowed: members as stable-baselines3 writes them"
                )
            beyond = size_problem(path)  # before testzip inflates every member
            if beyond:
                return f"{path.name}: {beyond}"
            broken = archive.testzip()
            names = set(archive.namelist())
    except (zipfile.BadZipFile, OSError, EOFError) as error:
        return f"{path.name} is not a whole zip archive ({error})"
    except (NotImplementedError, RuntimeError, ValueError) as error:  # a compression zipfile cannot read
        return f"{path.name} cannot be read as a zip archive ({error})"
    if broken is not None:
        return f"{path.name} is damaged ({broken} fails its checksum)"
    if not {"data", "policy.pth"} <= names:
        return f"{path.name} is not a stable-baselines3 model (it lacks data and policy.pth)"
    return None


def run_backend(run_dir: str | Path) -> str:
    """'rllib' for a run folder written by ``aaai train --backend rllib``, else 'sb3' (what
    --resume should use, and how a run's policy is loaded)."""
    run = RunFolder(run_dir)
    for folder in run.saved():
        if (folder / CHECKPOINT_FOLDER).is_dir():
            return "rllib"
        try:
            if json.loads(_state_text(folder)).get("agent", {}).get("backend") == "rllib":
                return "rllib"
        except (OSError, ValueError, AttributeError, RecursionError):
            continue
    return "sb3"


def rllib_checkpoint(path: str | Path) -> Path:
    """The Algorithm checkpoint a path names: a run folder (its newest saved point), a saved point
    (final/, checkpoints/step_N/) or the rllib/ folder itself."""
    path = Path(path)
    if (path / "config.yaml").is_file() and not (path / CHECKPOINT_FOLDER).is_dir():
        saved = [folder for folder in RunFolder(path).saved() if (folder / CHECKPOINT_FOLDER).is_dir()]
        if not saved:
            raise ConfigError(f"--policy: run folder {str(path)!r} holds no RLlib checkpoint")
        path = saved[0]
    if (path / CHECKPOINT_FOLDER).is_dir():
        path = path / CHECKPOINT_FOLDER
    if not (path / MODULE_PATH).is_dir():
        raise ConfigError(f"--policy: {str(path)!r} is not an RLlib checkpoint of aaai (no {MODULE_PATH})")
    return path
