"""What every attack is made of: the paths and limits, the ``Attack`` and its registry, the shared inputs
(a real replay, scoreboard, run folder and model zip, made once) and the command lines several groups run."""

from __future__ import annotations

import hashlib
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

HERE = Path(__file__).resolve().parent.parent
ROOT = HERE.parent
BIN = Path(sys.executable).parent
AAAI = str(BIN / "aaai")
PY = sys.executable
BASE = Path(os.environ.get("AAAI_REDTEAM_DIR", Path(tempfile.gettempdir()) / "aaai-redteam"))
MEMORY = 3 << 30  # address space of one attack (torch and PyBullet fit well within it)
TIMEOUT = 60.0

SHORT = {"episode": {"max_steps": 20}, "sensors": {"camera": False}}
SHORT_YAML = "episode: {max_steps: 20}\nsensors: {camera: false}\n"
ARENA = (
    "agent: {x: 0, y: -18, yaw: 1.5707963267948966}\ntime_limit: 5\n"
    "objects:\n  - {kind: food_green, position: [0, 5, 1.5], size: [3, 3, 3]}\n"
)


@dataclass
class Attack:
    id: str
    group: str
    argv: list[str]  # {W}: the work folder (also the cwd); {O}: the outside folder; {C}: the canary
    setup: Callable[[Path], None] | None = None
    expect: str = "any"  # error: must be refused; ok: must succeed; any: either, cleanly
    check: Callable[[Path, "Result"], str | None] | None = None
    timeout: float = TIMEOUT
    env: dict = field(default_factory=dict)


@dataclass
class Result:
    code: int | None
    stdout: str
    stderr: str
    seconds: float


ATTACKS: list[Attack] = []


def attack(id, group, argv, setup=None, expect="any", check=None, timeout=TIMEOUT, **env):
    if any(a.id == id for a in ATTACKS):
        raise ValueError(f"two attacks named {id}")
    ATTACKS.append(Attack(id, group, argv, setup, expect, check, timeout, env))


def limit():
    """The limits of an attack's process (and of the play server): its own session, the memory cap, no core."""
    os.setsid()
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY, MEMORY))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


# --- shared inputs (made once, in BASE/_base) ------------------------------------------------
def base() -> Path:
    return BASE / "_base"


def prepare() -> None:
    """A real replay, scoreboard, run folder and model zip to mutate."""
    b = base()
    b.mkdir(parents=True, exist_ok=True)
    (b / "short.yaml").write_text(SHORT_YAML)
    (b / "arena.yaml").write_text(ARENA)
    if not (b / "rep").is_dir() or not (b / "board.csv").is_file():
        shutil.rmtree(b / "rep", ignore_errors=True)
        (b / "board.csv").unlink(missing_ok=True)
        _run_prep(eval_argv(str(b / "board.csv"), extra=["--save-replays", str(b / "rep")]))
    if not (b / "run" / "episodes.csv").is_file():
        shutil.rmtree(b / "run", ignore_errors=True)
        level = ["--levels", "0", "--difficulty", "0"]
        _run_prep(train_argv("200", "--run", str(b / "run"), *level, "--config", str(b / "short.yaml")))
    if not (b / "model.zip").is_file():
        code = (
            "from stable_baselines3 import PPO\nfrom aaai.env import AnimalAIEnv\nfrom aaai.config import load_config\n"
            f"env = AnimalAIEnv(config=load_config({SHORT!r}))\n"
            "PPO('MultiInputPolicy', env, n_steps=64, batch_size=32, device='cpu', seed=0,"
            " policy_kwargs={'net_arch': [16, 16]}).save(" + repr(str(b / "model.zip")) + ")\n"
        )
        _run_prep([PY, "-c", code])


def _run_prep(argv):
    done = subprocess.run(argv, capture_output=True, text=True, cwd=base())
    if done.returncode:
        sys.exit(f"preparing {argv[:3]} failed:\n{done.stderr[-2000:]}")


def replay_data() -> dict:
    return json.loads(next((base() / "rep").glob("*.json")).read_text())


def digest(config) -> str:
    return hashlib.sha256(json.dumps(config, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


# --- command lines several groups run ---------------------------------------------------------
def eval_argv(out="s.csv", policy="random", extra=(), k="2"):
    """``aaai eval`` of ``policy`` on level 0, ``k`` training seeds a cell, the short config, into ``out``."""
    seeds = ["--levels", "0", "-k", k, "--seeds", "train"]
    return [AAAI, "eval", "--policy", policy, *seeds, "--config", str(base() / "short.yaml"), "--out", out, *extra]


def train_argv(steps="50", *extra):
    """``aaai train`` of the random agent for ``steps`` steps."""
    return [AAAI, "train", "--agent", "random", "--steps", steps, *extra]
