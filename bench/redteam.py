"""Red-team attacks on the command line, the environment, the files it reads and the play server.

Each attack is a small data case: a command (``aaai ...``, or a few lines of Python for the
environment and the play server) with the files it is given, made in a fresh folder. Every
attack runs in its own process with a time limit and a memory cap, and is classified:

* CLEAN: it exits with a clear error (no Python traceback), or it succeeds as it should, within
  the time and memory limits, leaving nothing outside its folder (a file ``outside/`` holds is
  unchanged) and running no code (a payload would create the canary file ``CANARY``);
* FAIL, with the reason, otherwise.

Results go to ``bench/redteam.csv`` (one row per attack, rewritten atomically after each), so a
killed run resumes where it stopped; ``--rerun`` runs every attack again, ``--only GROUP`` one
group. ``python bench/redteam.py`` prints the counts by group.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import io
import json
import os
import resource
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import zipfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
BIN = Path(sys.executable).parent
AAAI = str(BIN / "aaai")
PY = sys.executable
CSV_PATH = HERE / "redteam.csv"
BASE = Path(os.environ.get("AAAI_REDTEAM_DIR", Path(tempfile.gettempdir()) / "aaai-redteam"))
MEMORY = 3 << 30  # address space of one attack (torch and PyBullet fit well within it)
TIMEOUT = 60.0
COLUMNS = ["id", "group", "command", "outcome", "reason", "seconds"]

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
        _run_prep(
            [
                AAAI,
                "eval",
                "--policy",
                "random",
                "--levels",
                "0",
                "-k",
                "2",
                "--seeds",
                "train",
                "--config",
                str(b / "short.yaml"),
                "--out",
                str(b / "board.csv"),
                "--save-replays",
                str(b / "rep"),
            ]
        )
    if not (b / "run" / "episodes.csv").is_file():
        shutil.rmtree(b / "run", ignore_errors=True)
        _run_prep(
            [
                AAAI,
                "train",
                "--agent",
                "random",
                "--steps",
                "200",
                "--run",
                str(b / "run"),
                "--levels",
                "0",
                "--difficulty",
                "0",
                "--config",
                str(b / "short.yaml"),
            ]
        )
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


# --- setup helpers ------------------------------------------------------------------------
def text(name, content, encoding="utf-8"):
    def make(w: Path):
        path = w / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_bytes(content.encode(encoding))

    return make


def both(*makers):
    def make(w: Path):
        for m in makers:
            m(w)

    return make


def fifo(name):
    return lambda w: os.mkfifo(w / name)


def folder(name):
    return lambda w: (w / name).mkdir(parents=True, exist_ok=True)


def link(name, target):
    def make(w: Path):
        (w / name).parent.mkdir(parents=True, exist_ok=True)
        os.symlink(target.format(W=w, O=w.parent / "outside"), w / name)

    return make


def copy(source: str, name: str):
    def make(w: Path):
        src = base() / source
        if src.is_dir():
            shutil.copytree(src, w / name, symlinks=True)
        else:
            shutil.copy(src, w / name)

    return make


def victim(name="victim.txt", content="precious data\n"):
    return lambda w: (w.parent / "outside" / name).write_text(content)


def replay_file(name, change):
    def make(w: Path):
        data = replay_data()
        out = change(data, w)
        (w / name).write_text(out if isinstance(out, str) else json.dumps(data))

    return make


def board_file(name, change):
    def make(w: Path):
        raw = (base() / "board.csv").read_bytes()
        (w / name).write_bytes(change(raw))
        shutil.copy(base() / "board_scored_with.json", w / (Path(name).stem + "_scored_with.json"))

    return make


def model_file(name, change):
    def make(w: Path):
        with zipfile.ZipFile(base() / "model.zip") as z:
            members = [(i.filename, z.read(i.filename)) for i in z.infolist()]
        change(w / name, members, w)

    return make


def write_zip(path, members, compression=zipfile.ZIP_DEFLATED, **kw):
    with zipfile.ZipFile(path, "w", compression) as z:
        for name, data in members:
            info = name if isinstance(name, zipfile.ZipInfo) else zipfile.ZipInfo(name)
            info.compress_type = compression
            for key, value in kw.items():
                setattr(info, key, value)
            z.writestr(info, data)


def canary_pickle(w: Path) -> bytes:
    """A pickle that, unpickled, creates the canary."""
    import pickle

    class Payload:
        def __reduce__(self):
            return (os.system, (f"touch {shlex.quote(str(w.parent / 'CANARY'))}",))

    return pickle.dumps(Payload())


# --- checks -------------------------------------------------------------------------------
def unchanged(name="victim.txt", content="precious data\n"):
    def check(w: Path, r: Result):
        path = w.parent / "outside" / name
        if not path.is_file() or path.is_symlink() or path.read_text() != content:
            return f"outside/{name} was changed"
        return None

    return check


def stdout_lacks(word):
    return lambda w, r: f"output holds {word!r}" if word in r.stdout else None


# --- the attacks ----------------------------------------------------------------------------
def run_replay(name):
    return [AAAI, "run", "--replay", name]


def replay_attacks():
    g = "replay"

    def set_(key, value, rehash=False):
        def change(d, w):
            d[key] = value
            if rehash:
                d["config_digest"] = digest(d["config"])

        return change

    def conf(path, value):
        def change(d, w):
            section, key = path.split(".") if "." in path else (None, path)
            if section:
                d["config"][section][key] = value
            else:
                d["config"][key] = value
            d["config_digest"] = digest(d["config"])

        return change

    def actions(runs, steps=None):
        def change(d, w):
            d["actions"] = runs
            d["steps"] = steps if steps is not None else sum(r[0] for r in runs)

        return change

    cases = [
        ("deep-nesting", lambda d, w: "[" * 200000 + "]" * 200000, "error"),
        ("deep-object", lambda d, w: '{"a":' * 100000 + "1" + "}" * 100000, "error"),
        ("billion-steps", actions([[10**9, [0.0] * 8]]), "error"),
        ("huge-count-mismatch", actions([[10**18, [0.0] * 8]], 3), "error"),
        ("short-action", actions([[20, [0.0] * 3]]), "error"),
        ("long-action", actions([[20, [0.0] * 40]]), "error"),
        ("empty-action", actions([[20, []]]), "error"),
        ("extreme-action-values", actions([[20, [1e308, -1e308] * 4]]), "any"),
        ("no-actions", actions([], 0), "any"),
        ("level-99", set_("level", 99), "error"),
        ("level-huge", set_("level", 2**70), "error"),
        ("difficulty-11", set_("difficulty", 11), "error"),
        ("difficulty-huge", set_("difficulty", 10**30), "error"),
        ("seed-2-64", set_("seed", 2**64), "any"),
        ("seed-2-200", set_("seed", 2**200), "any"),
        ("return-nan", lambda d, w: json.dumps({**d, "return": float("nan")}), "error"),
        (
            "pose-infinity",
            lambda d, w: json.dumps({**d, "final_pose": {**d["final_pose"], "x": float("inf")}}),
            "error",
        ),
        ("config-list", set_("config", [1, 2], rehash=True), "error"),
        ("config-unknown-key", conf("evil", 1), "error"),
        ("config-body-16", conf("agent.body", "quadruped16"), "any"),
        ("config-max-steps-string", conf("episode.max_steps", "1e400"), "error"),
        ("config-timestep-tiny", conf("physics.timestep", 1e-300), "error"),
        ("config-section-null", conf("sensors", None), "error"),
        (
            "arena-etc-passwd",
            lambda d, w: json.dumps(
                {
                    **d,
                    "arena": {
                        "name": "x.yaml",
                        "path": "/etc/passwd",
                        "sha256": hashlib.sha256(Path("/etc/passwd").read_bytes()).hexdigest(),
                    },
                }
            ),
            "error",
        ),
        ("arena-dev-zero", set_("arena", {"name": "z", "path": "/dev/zero", "sha256": "0" * 64}), "error"),
        ("arena-folder", set_("arena", {"name": "z", "path": "/", "sha256": "0" * 64}), "error"),
        (
            "arena-name-traversal",
            lambda d, w: (
                shutil.copy(base() / "arena.yaml", w / "a.yaml"),
                json.dumps(
                    {
                        **d,
                        "arena": {
                            "name": "../../../../tmp/x",
                            "path": str(w / "a.yaml"),
                            "sha256": hashlib.sha256((w / "a.yaml").read_bytes()).hexdigest(),
                        },
                    }
                ),
            )[1],
            "any",
        ),
        ("arena-number-fields", set_("arena", {"name": 1, "path": 2, "sha256": 3}), "error"),
        ("level-bool", set_("level", True), "error"),
        ("count-float", actions([[20.0, [0.0] * 8]], 20), "error"),
        ("count-zero", actions([[0, [0.0] * 8], [20, [0.0] * 8]], 20), "error"),
        ("duplicate-keys", lambda d, w: json.dumps(d)[:-1] + ',"level":5}', "any"),
        ("policy-10mb", set_("policy", "p" * 10_000_000), "any"),
        ("policy-dict", set_("policy", {"evil": [1, 2]}), "any"),
        ("end-object", set_("end", {"x": 1}), "any"),
        ("spec-digest-number", set_("spec_digest", 12), "any"),
        ("version-string", set_("version", "1"), "error"),
        ("top-array", lambda d, w: "[1,2,3]", "error"),
        ("bom", lambda d, w: "\ufeff" + json.dumps(d), "any"),
        ("nul-bytes", lambda d, w: json.dumps(d)[:50] + "\x00" + json.dumps(d)[50:], "error"),
        (
            "huge-int-digits",
            lambda d, w: json.dumps(d).replace('"seed":', '"seed":' + "9" * 5000 + ',"x":', 1),
            "error",
        ),
        ("lone-surrogate", set_("policy", "\ud800"), "any"),
    ]
    for name, change, expect in cases:
        attack(f"replay-{name}", g, run_replay("r.json"), replay_file("r.json", change), expect)
    attack(
        "replay-utf16",
        g,
        run_replay("r.json"),
        lambda w: (w / "r.json").write_bytes(json.dumps(replay_data()).encode("utf-16")),
        "error",
    )
    for kind, setup in [
        ("dir", folder("r.json")),
        ("fifo", fifo("r.json")),
        ("empty", text("r.json", "")),
        ("loop", link("r.json", "{W}/r.json")),
        ("devzero", link("r.json", "/dev/zero")),
    ]:
        attack(f"replay-file-{kind}", g, run_replay("r.json"), setup, "error", timeout=30)
    # the video path of show --replay
    attack(
        "replay-show-billion",
        g,
        [AAAI, "show", "--replay", "r.json", "--video", "v.mp4"],
        replay_file("r.json", actions([[10**9, [0.0] * 8]])),
        "error",
    )
    attack(
        "replay-show-deep",
        g,
        [AAAI, "show", "--replay", "r.json", "--video", "v.mp4"],
        replay_file("r.json", lambda d, w: "[" * 200000),
        "error",
    )
    attack(
        "replay-show-short-action",
        g,
        [AAAI, "show", "--replay", "r.json", "--video", "v.mp4"],
        replay_file("r.json", actions([[20, [0.0] * 3]])),
        "error",
    )
    attack(
        "replay-show-video-fifo",
        g,
        [AAAI, "show", "--replay", "r.json", "--video", "v.mp4"],
        both(replay_file("r.json", lambda d, w: None), fifo("v.mp4")),
        "any",
        timeout=30,
    )


def run_config(setup, expect="any", extra=()):
    return (
        [AAAI, "run", "--levels", "0", "--max-steps", "10", "--no-camera", "--config", "c.yaml", *extra],
        setup,
        expect,
    )


def config_attacks():
    g = "config"
    cases = [
        ("section-scalar", "agent: walker\n", "error"),
        ("section-list", "agent: [1, 2]\n", "error"),
        ("section-null", "agent: null\n", "any"),
        ("rays-string-yes", "sensors: {rays: 'yes'}\n", "error"),
        ("rays-yaml11-on", "sensors: {rays: on}\n", "any"),
        ("rays-per-side-float", "sensors: {rays_per_side: 8.5}\n", "error"),
        ("rays-per-side-string", "sensors: {rays_per_side: '8'}\n", "any"),
        ("rays-per-side-bool", "sensors: {rays_per_side: true}\n", "error"),
        ("max-steps-auto-space", "episode: {max_steps: 'auto '}\n", "any"),
        ("max-steps-AUTO", "episode: {max_steps: AUTO}\n", "any"),
        ("max-steps-float", "episode: {max_steps: 100.0}\n", "any"),
        ("max-steps-float-frac", "episode: {max_steps: 100.5}\n", "error"),
        ("level-label", "level: L0\n", "any"),
        ("level-hex", "level: 0x0\n", "any"),
        ("level-octal", "level: 0o17\n", "error"),
        ("difficulty-underscore", "difficulty: 1_0\n", "any"),
        ("sexagesimal", "difficulty: 1:20\n", "any"),
        ("unicode-key", "agent: {bödy: quadruped}\n", "error"),
        ("int-key", "1: 2\n", "error"),
        ("dunder-key", "__class__: {x: 1}\n", "error"),
        ("dotted-top-key", "agent.body: quadruped16\n", "any"),
        ("empty-key", "'': 1\n", "error"),
        ("date-number", "physics: {gravity: 2020-01-01}\n", "error"),
        ("shaping-inf", "episode: {shaping: .inf}\n", "error"),
        ("shaping-nan", "episode: {shaping: -.nan}\n", "error"),
        ("body-900kb", "agent: {body: " + "q" * 900_000 + "}\n", "error"),
        ("bom", "\ufeffepisode: {max_steps: 20}\n", "any"),
        ("crlf", "episode:\r\n  max_steps: 20\r\n", "any"),
        ("tabs", "episode:\n\tmax_steps: 20\n", "error"),
        ("empty", "", "any"),
        ("comments-only", "# nothing\n", "any"),
        ("document-marker-only", "---\n", "any"),
        ("top-null", "null\n", "any"),
        ("top-list", "- 1\n- 2\n", "error"),
        ("top-scalar", "hello\n", "error"),
        ("gravity-negative-zero", "physics: {gravity: -0.0}\n", "any"),
        ("solver-iterations-huge", "physics: {solver_iterations: 1000000}\n", "error"),
        ("action-repeat-zero", "physics: {action_repeat: 0}\n", "error"),
        ("ray-length-tiny", "sensors: {ray_length: 1.0e-300}\n", "any"),
        ("action-mode-unicode", "agent: {action_mode: rotatіon}\n", "error"),
        ("nested-extra-section", "sensors: {rays: {deep: {deeper: 1}}}\n", "error"),
        ("train-section-junk", "train: {learning_rate: [1, 2]}\n", "error"),
        ("curriculum-levels-int", "curriculum: {levels: 5}\n", "any"),
        ("curriculum-levels-huge-range", "curriculum: {levels: '0-99999999999'}\n", "error"),
    ]
    for name, content, expect in cases:
        argv, setup, expect = run_config(text("c.yaml", content), expect)
        attack(f"config-{name}", g, argv, setup, expect)
    attack("config-utf16", g, *run_config(text("c.yaml", "episode: {max_steps: 20}\n", "utf-16"), "error")[:2], "error")
    attack(
        "config-latin1",
        g,
        *run_config(text("c.yaml", "# café\nepisode: {max_steps: 20}\n", "latin-1"), "error")[:2],
        "error",
    )
    attack(
        "config-train-curriculum-huge",
        g,
        [AAAI, "train", "--agent", "random", "--steps", "50", "--config", "c.yaml", "--run", "r"],
        text("c.yaml", "curriculum: {levels: '0-99999999999'}\n"),
        "error",
    )
    attack(
        "config-train-window-zero",
        g,
        [AAAI, "train", "--agent", "random", "--steps", "50", "--config", "c.yaml", "--run", "r"],
        text("c.yaml", "curriculum: {window: 0}\n"),
        "any",
    )


def env_code(kwargs: str, steps: int = 3, make: str = "gym.make('aaai/L0-FoodContact-v0', {kw})") -> str:
    return (
        "import sys\nimport gymnasium as gym\nimport aaai\n"
        "try:\n"
        f"    env = {make.format(kw=kwargs)}\n"
        "    env.reset(seed=0)\n"
        f"    for _ in range({steps}):\n"
        "        env.step(env.action_space.sample())\n"
        "    env.close()\n"
        "except (ValueError, TypeError, gym.error.Error) as error:\n"
        "    print(f'Error: {type(error).__name__}: {error}'[:300], file=sys.stderr)\n"
        "    sys.exit(1)\n"
    )


def env_attacks():
    g = "env-kwargs"
    cases = [
        ("config-etc-passwd", "config='/etc/passwd'", "error"),
        ("config-dev-zero", "config='/dev/zero'", "error"),
        ("config-fifo", "config='{W}/f.yaml'", "error"),
        ("config-int", "config=123", "error"),
        ("config-bytes", "config=b'episode: {max_steps: 20}'", "error"),
        ("config-nested-list", "config={'agent': [1]}", "error"),
        ("config-object", "config=object()", "error"),
        ("render-mode-evil", "render_mode='evil'", "error"),
        ("render-mode-list", "render_mode=['rgb_array']", "error"),
        ("level-99", "level=99", "error"),
        ("level-path", "level='../../etc/passwd'", "error"),
        ("level-float", "level=0.5", "error"),
        ("level-bool", "level=True", "error"),
        ("difficulty-negative", "difficulty=-1", "error"),
        ("difficulty-1e308", "difficulty=1e308", "error"),
        ("difficulty-nan", "difficulty=float('nan')", "error"),
        ("max-episode-steps-negative", "max_episode_steps=-1", "any"),
        ("camera-resolution-huge", "camera_resolution=10**9", "error"),
        ("camera-resolution-float", "camera_resolution=64.5", "error"),
        ("rays-per-side-numpy", "rays_per_side=__import__('numpy').int64(4)", "any"),
        ("max-force-numpy-nan", "max_force=__import__('numpy').float64('nan')", "error"),
        ("sensors-not-mapping", "sensors='camera'", "error"),
        ("sensors-unknown", "sensors={'evil': 1}", "error"),
        ("arena-int", "arena=5", "error"),
        ("arena-dev-zero", "arena='/dev/zero'", "error"),
        ("arena-folder", "arena='/'", "error"),
        ("arena-fifo", "arena='{W}/f.yaml'", "error"),
        ("unknown-kwarg", "evil=1", "error"),
        ("kwarg-dunder", "**{'__class__': 1}", "error"),
        ("gravity-string", "gravity='9.81'", "any"),
        ("timestep-tiny", "timestep=1e-9", "error"),
        ("body-path", "body='../../../etc/passwd'", "error"),
        ("action-mode-none", "action_mode=None", "error"),
    ]
    for name, kw, expect in cases:
        setup = fifo("f.yaml") if "f.yaml" in kw else None
        attack(f"env-{name}", g, [PY, "-c", env_code(kw)], setup, expect, timeout=40)
    attack(
        "env-step-nan-action",
        g,
        [
            PY,
            "-c",
            env_code("", make="gym.make('aaai/L0-FoodContact-v0')").replace(
                "env.action_space.sample()", "[float('nan')] * 8"
            ),
        ],
        None,
        "any",
    )
    attack(
        "env-step-wrong-shape",
        g,
        [
            PY,
            "-c",
            env_code("", make="gym.make('aaai/L0-FoodContact-v0')").replace("env.action_space.sample()", "[0.0] * 3"),
        ],
        None,
        "error",
    )
    attack(
        "env-reset-huge-seed",
        g,
        [
            PY,
            "-c",
            env_code("", make="gym.make('aaai/L0-FoodContact-v0')").replace(
                "env.reset(seed=0)", "env.reset(seed=2**80)"
            ),
        ],
        None,
        "error",
    )
    attack(
        "env-reset-bad-options",
        g,
        [
            PY,
            "-c",
            env_code("", make="gym.make('aaai/L0-FoodContact-v0')").replace(
                "env.reset(seed=0)", "env.reset(seed=0, options={'level': 'evil', 'difficulty': [1]})"
            ),
        ],
        None,
        "error",
    )


FILE_KINDS = {
    "dir": lambda n: folder(n),
    "fifo": lambda n: fifo(n),
    "devzero": lambda n: link(n, "/dev/zero"),
    "broken-link": lambda n: link(n, "{W}/nowhere"),
    "link-loop": lambda n: link(n, "{W}/" + n),
    "binary": lambda n: text(n, bytes(range(256)) * 64),
}


def file_flag_attacks():
    g = "file-flags"
    flags = {
        "run-config": ([AAAI, "run", "--levels", "0", "--max-steps", "10", "--config", "F"], ".yaml"),
        "run-arena": ([AAAI, "run", "--max-steps", "10", "--arena", "F"], ".yaml"),
        "show-arena": ([AAAI, "show", "--arena", "F", "-o", "o.png"], ".yaml"),
        "eval-seed-key": (
            [
                AAAI,
                "eval",
                "--policy",
                "random",
                "--levels",
                "0",
                "-k",
                "1",
                "--config",
                str(base() / "short.yaml"),
                "--seed-key-file",
                "F",
                "--out",
                "s.csv",
            ],
            ".key",
        ),
        "seeds-seed-key": ([AAAI, "seeds", "--levels", "0", "--difficulty", "0", "--seed-key-file", "F"], ".key"),
        "eval-policy-zip": (
            [
                AAAI,
                "eval",
                "--policy",
                "F",
                "--levels",
                "0",
                "-k",
                "1",
                "--seeds",
                "train",
                "--config",
                str(base() / "short.yaml"),
                "--out",
                "s.csv",
            ],
            ".zip",
        ),
        "eval-arenas": (
            [
                AAAI,
                "eval",
                "--policy",
                "random",
                "--arenas",
                "F",
                "-k",
                "1",
                "--config",
                str(base() / "short.yaml"),
                "--out",
                "s.csv",
            ],
            ".yaml",
        ),
        "validate-arena": ([AAAI, "validate", "--arena", "F"], ".yaml"),
        "train-init-from": (
            [AAAI, "train", "--steps", "64", "--run", "r", "--init-from", "F", "--config", str(base() / "short.yaml")],
            ".zip",
        ),
        "import-source": ([AAAI, "import-animalai", "F", "--out", "out"], ".yaml"),
        "plot-run": ([AAAI, "plot", "F", "--out", "p.png"], ""),
    }
    for flag, (argv, ext) in flags.items():
        for kind, make in FILE_KINDS.items():
            if kind == "dir" and flag in ("eval-arenas", "validate-arena", "plot-run", "import-source"):
                continue  # a folder is allowed there
            name = "F" + ext
            attack(f"file-{flag}-{kind}", g, [name if a == "F" else a for a in argv], make(name), "error", timeout=30)
    # unicode and odd names holding good content: must work
    odd = {"unicode": "конфиг ü.yaml", "newline": "a\nb.yaml", "dash": "-c.yaml", "rtl": "a\u202eLMAY.yaml"}
    for kind, name in odd.items():
        argv = [AAAI, "run", "--levels", "0", "--max-steps", "10", "--no-camera", "--config", "./" + name]
        attack(f"file-run-config-name-{kind}", g, argv, text(name, SHORT_YAML), "ok")
        argv = [AAAI, "run", "--max-steps", "10", "--no-camera", "--arena", "./" + name]
        attack(f"file-run-arena-name-{kind}", g, argv, text(name, ARENA), "ok")
    attack("file-show-output-dir", g, [AAAI, "show", "0", "-o", "o.png"], folder("o.png"), "error")
    attack("file-show-output-fifo", g, [AAAI, "show", "0", "-o", "o.png"], fifo("o.png"), "any", timeout=30)
    attack("file-show-output-dev-full", g, [AAAI, "show", "0", "-o", "/dev/full"], None, "error")
    attack("file-show-video-odd-ext", g, [AAAI, "show", "0", "--video", "v.exe", "--steps", "5"], None, "error")
    attack("file-show-output-missing-dir", g, [AAAI, "show", "0", "-o", "no/such/o.png"], None, "any")
    attack(
        "file-eval-out-dev-full",
        g,
        [
            AAAI,
            "eval",
            "--policy",
            "random",
            "--levels",
            "0",
            "-k",
            "1",
            "--seeds",
            "train",
            "--config",
            str(base() / "short.yaml"),
            "--out",
            "/dev/full",
        ],
        None,
        "error",
    )
    attack(
        "file-eval-out-dir",
        g,
        [
            AAAI,
            "eval",
            "--policy",
            "random",
            "--levels",
            "0",
            "-k",
            "1",
            "--seeds",
            "train",
            "--config",
            str(base() / "short.yaml"),
            "--out",
            "s.csv",
        ],
        folder("s.csv"),
        "error",
    )
    attack(
        "file-eval-out-fifo",
        g,
        [
            AAAI,
            "eval",
            "--policy",
            "random",
            "--levels",
            "0",
            "-k",
            "1",
            "--seeds",
            "train",
            "--config",
            str(base() / "short.yaml"),
            "--out",
            "s.csv",
        ],
        fifo("s.csv"),
        "error",
        timeout=30,
    )
    attack(
        "file-eval-save-replays-file",
        g,
        [
            AAAI,
            "eval",
            "--policy",
            "random",
            "--levels",
            "0",
            "-k",
            "1",
            "--seeds",
            "train",
            "--config",
            str(base() / "short.yaml"),
            "--out",
            "s.csv",
            "--save-replays",
            "rp",
        ],
        text("rp", "x"),
        "error",
    )


def eval_argv(out="s.csv", policy="random", extra=()):
    return [
        AAAI,
        "eval",
        "--policy",
        policy,
        "--levels",
        "0",
        "-k",
        "2",
        "--seeds",
        "train",
        "--config",
        str(base() / "short.yaml"),
        "--out",
        out,
        *extra,
    ]


def folder_attacks():
    g = "run-folders"
    resume = [AAAI, "train", "--steps", "300", "--resume", "run"]
    attack(
        "runs-resume-episodes-symlink-out",
        g,
        resume,
        both(
            copy("run", "run"),
            victim(),
            lambda w: (
                (w / "run" / "episodes.csv").unlink(),
                os.symlink(w.parent / "outside" / "victim.txt", w / "run" / "episodes.csv"),
            ),
        ),
        "any",
        check=unchanged(),
    )
    attack(
        "runs-resume-lock-symlink-out",
        g,
        resume,
        both(copy("run", "run"), victim(), link("run/.lock", "{O}/victim.txt")),
        "any",
        check=unchanged(),
    )
    attack(
        "runs-resume-config-etc-passwd",
        g,
        resume,
        both(
            copy("run", "run"),
            lambda w: ((w / "run" / "config.yaml").unlink(), os.symlink("/etc/passwd", w / "run" / "config.yaml")),
        ),
        "error",
    )
    attack(
        "runs-resume-config-fifo",
        g,
        resume,
        both(
            copy("run", "run"), lambda w: ((w / "run" / "config.yaml").unlink(), os.mkfifo(w / "run" / "config.yaml"))
        ),
        "error",
        timeout=30,
    )
    attack(
        "runs-resume-staging-symlink-out",
        g,
        resume,
        both(
            copy("run", "run"),
            lambda w: (
                (w.parent / "outside" / "keep").mkdir(),
                (w.parent / "outside" / "keep" / "victim.txt").write_text("x\n"),
            ),
            link("run/checkpoints/.staging-evil", "{O}/keep"),
        ),
        "any",
        check=lambda w, r: None if (w.parent / "outside" / "keep" / "victim.txt").is_file() else "outside file removed",
    )
    attack(
        "runs-resume-state-json-deep",
        g,
        resume,
        both(copy("run", "run"), lambda w: [p.write_text("[" * 100000) for p in (w / "run").rglob("state.json")]),
        "error",
    )
    attack(
        "runs-resume-state-json-nan",
        g,
        resume,
        both(
            copy("run", "run"),
            lambda w: [p.write_text(p.read_text().replace("0", "NaN", 3)) for p in (w / "run").rglob("state.json")],
        ),
        "any",
    )
    attack(
        "runs-resume-episodes-fifo",
        g,
        resume,
        both(
            copy("run", "run"), lambda w: ((w / "run" / "episodes.csv").unlink(), os.mkfifo(w / "run" / "episodes.csv"))
        ),
        "error",
        timeout=30,
    )
    attack(
        "runs-resume-episodes-binary",
        g,
        resume,
        both(copy("run", "run"), text("run/episodes.csv", bytes(range(256)) * 10)),
        "any",
    )
    attack(
        "runs-run-is-file",
        g,
        [AAAI, "train", "--agent", "random", "--steps", "50", "--run", "r"],
        text("r", "x"),
        "error",
    )
    attack(
        "runs-run-unicode",
        g,
        [
            AAAI,
            "train",
            "--agent",
            "random",
            "--steps",
            "50",
            "--config",
            str(base() / "short.yaml"),
            "--run",
            "прогон ü",
        ],
        None,
        "ok",
    )
    attack(
        "runs-run-symlink-to-file-out",
        g,
        [AAAI, "train", "--agent", "random", "--steps", "50", "--run", "r"],
        both(victim(), link("r", "{O}/victim.txt")),
        "error",
        check=unchanged(),
    )
    attack(
        "runs-eval-lock-symlink-out",
        g,
        eval_argv(),
        both(victim(), link(".s.csv.lock", "{O}/victim.txt")),
        "any",
        check=unchanged(),
    )
    attack(
        "runs-eval-summary-symlink-out",
        g,
        eval_argv(),
        both(victim(), link("s_summary.md", "{O}/victim.txt")),
        "any",
        check=unchanged(),
    )
    attack(
        "runs-eval-replay-name-symlink-out",
        g,
        eval_argv(extra=["--save-replays", "rp"]),
        both(
            victim(),
            lambda w: (
                [(w / "rp").mkdir()]
                + [
                    os.symlink(w.parent / "outside" / "victim.txt", w / "rp" / p.name)
                    for p in (base() / "rep").glob("*.json")
                ]
            ),
        ),
        "ok",
        check=unchanged(),
    )
    attack(
        "runs-plot-episodes-fifo",
        g,
        [AAAI, "plot", "run", "--out", "p.png"],
        both(
            copy("run", "run"), lambda w: ((w / "run" / "episodes.csv").unlink(), os.mkfifo(w / "run" / "episodes.csv"))
        ),
        "any",
        timeout=30,
    )
    attack(
        "runs-import-out-is-file",
        g,
        [AAAI, "import-animalai", str(ROOT / "tests/fixtures/animalai"), "--out", "o"],
        text("o", "x"),
        "error",
    )


def board_attacks():
    g = "scoreboard"

    def lines(f):
        return lambda raw: f(raw.decode().splitlines(keepends=True)).encode()

    cases = {
        "torn-header": lambda raw: raw[:20],
        "header-only": lambda raw: raw.split(b"\n")[0] + b"\n",
        "columns-reordered": lines(lambda ls: ",".join(reversed(ls[0].strip().split(","))) + "\n" + "".join(ls[1:])),
        "extra-column": lines(lambda ls: ls[0].strip() + ",evil\n" + "".join(x.strip() + ",1\n" for x in ls[1:])),
        "missing-column": lines(lambda ls: "".join(",".join(x.strip().split(",")[1:]) + "\n" for x in ls)),
        "return-nan": lines(lambda ls: ls[0] + ls[1].replace(ls[1].split(",")[4], "nan", 1) + "".join(ls[2:])),
        "seed-foreign": lines(lambda ls: ls[0] + ls[1].replace(ls[1].split(",")[3], "12345", 1) + "".join(ls[2:])),
        "duplicate-rows": lines(lambda ls: ls[0] + ls[1] + ls[1] + "".join(ls[2:])),
        "crlf": lambda raw: raw.replace(b"\n", b"\r\n"),
        "bom": lambda raw: b"\xef\xbb\xbf" + raw,
        "nul-middle": lambda raw: raw[:60] + b"\x00" * 10 + raw[60:],
        "binary": lambda raw: bytes(range(256)) * 8,
        "empty": lambda raw: b"",
        "newline-only": lambda raw: b"\n",
        "thousand-columns": lines(lambda ls: ls[0] + ls[1].strip() + ",x" * 1000 + "\n"),
        "long-line": lines(lambda ls: ls[0] + "0," + "9" * 5_000_000 + "\n"),
        "unbalanced-quote": lines(lambda ls: ls[0] + '"' + ls[1]),
        "other-tool-header": lambda raw: b"a,b,c\n1,2,3\n",
        "utf16": lambda raw: raw.decode().encode("utf-16"),
        "latin1-name": lambda raw: raw.replace(b"food_contact", b"f\xe9od"),
        "level-99": lines(lambda ls: ls[0] + "99" + ls[1][1:] + "".join(ls[2:])),
        "steps-negative": lines(lambda ls: ls[0] + ls[1].replace(",20,20,", ",-20,20,", 1) + "".join(ls[2:])),
        "arena-traversal": lines(
            lambda ls: ls[0] + ls[1].replace(",False,,", ",False,../../../etc/passwd,", 1) + "".join(ls[2:])
        ),
        "row-of-commas": lines(lambda ls: ls[0] + "," * 14 + "\n"),
    }
    for name, change in cases.items():
        attack(f"board-{name}", g, eval_argv(), board_file("s.csv", change), "any", check=board_check)


def board_check(w: Path, r: Result) -> str | None:
    if r.code == 0:  # every planned episode is there once (a row a user added by hand is kept as it is)
        rows = list(csv.DictReader(io.StringIO((w / "s.csv").read_text(errors="replace"))))
        base_rows = list(csv.DictReader((base() / "board.csv").open()))
        planned = {(x["level"], x["difficulty"], x["seed"]) for x in base_rows}
        got = [(x.get("level"), x.get("difficulty"), x.get("seed")) for x in rows]
        if not planned <= set(got):
            return f"the resumed scoreboard lacks {len(planned - set(got))} planned episodes"
    return None


def model_attacks():
    g = "model-zip"

    def add(name, data):
        def change(path, members, w):
            write_zip(path, members + [(name, data)])

        return change

    def rename(old, new):
        def change(path, members, w):
            write_zip(path, [(new if n == old else n, d) for n, d in members])

        return change

    def evil_first(name):
        def change(path, members, w):
            write_zip(path, [(name, b"{}" if name == "data" else b"garbage")] + members)

        return change

    def canary_member(name):
        def change(path, members, w):
            write_zip(path, [(n, canary_pickle(w) if n == name else d) for n, d in members])

        return change

    cases = {
        "member-traversal": (add("../../outside/evil.txt", b"x"), "any"),
        "member-absolute": (add("/tmp/aaai-redteam-evil.txt", b"x"), "any"),
        "member-nul-name": (add("data\x00.txt", b"x"), "any"),
        "member-unicode": (add("dätä/ü.txt", b"x"), "any"),
        "member-backslash": (add("..\\..\\evil.txt", b"x"), "any"),
        "member-dir-entry": (add("data/", b""), "any"),
        "member-long-name": (add("a" * 60000, b"x"), "any"),
        "duplicate-data-first-evil": (evil_first("data"), "any"),
        "duplicate-policy-first-evil": (evil_first("policy.pth"), "any"),
        "data-uppercase-only": (rename("data", "DATA"), "error"),
        "policy-renamed": (rename("policy.pth", "policy.pt"), "error"),
        "variables-pickle-canary": (canary_member("pytorch_variables.pth"), "any"),
        "optimizer-pickle-canary": (canary_member("policy.optimizer.pth"), "any"),
        "policy-pickle-canary": (canary_member("policy.pth"), "error"),
        "version-10mb": (
            lambda p, m, w: write_zip(
                p, [(n, b"9" * 10_000_000 if n == "_stable_baselines3_version" else d) for n, d in m]
            ),
            "any",
        ),
        "system-info-binary": (
            lambda p, m, w: write_zip(p, [(n, bytes(range(256)) * 100 if n == "system_info.txt" else d) for n, d in m]),
            "any",
        ),
        "sixty-four-members": (lambda p, m, w: write_zip(p, m + [(f"x{i}", b"") for i in range(64 - len(m))]), "any"),
        "sixty-five-members": (lambda p, m, w: write_zip(p, m + [(f"x{i}", b"") for i in range(65 - len(m))]), "error"),
        "symlink-member-data": (
            lambda p, m, w: write_zip(
                p, [(n, b"/etc/passwd" if n == "data" else d) for n, d in m], external_attr=0o120777 << 16
            ),
            "error",
        ),
        "encrypted-flag": (lambda p, m, w: _flag_encrypted(p, m), "error"),
        "prefixed-sfx": (
            lambda p, m, w: (write_zip(p, m), p.write_bytes(b"#!/bin/sh\ntouch CANARY\n" + p.read_bytes())),
            "any",
        ),
        "comment-64k": (lambda p, m, w: _with_comment(p, m), "any"),
        "stored-not-deflated": (lambda p, m, w: write_zip(p, m, zipfile.ZIP_STORED), "any"),
        "bzip2": (lambda p, m, w: write_zip(p, m, zipfile.ZIP_BZIP2), "any"),
        "lzma": (lambda p, m, w: write_zip(p, m, zipfile.ZIP_LZMA), "any"),
    }
    for name, (change, expect) in cases.items():
        attack(
            f"model-{name}",
            g,
            eval_argv(policy="m.zip"),
            model_file("m.zip", change),
            expect,
            check=lambda w, r: "a file appeared outside" if any((w.parent / "outside").iterdir()) else None,
        )
    attack("model-unicode-name", g, eval_argv(policy="мод ü.zip"), copy("model.zip", "мод ü.zip"), "ok")
    attack("model-no-zip-extension", g, eval_argv(policy="model"), copy("model.zip", "model"), "any")


def _flag_encrypted(path, members):
    write_zip(path, members)
    raw = bytearray(path.read_bytes())
    i = 0
    while (i := raw.find(b"PK\x03\x04", i)) >= 0:
        raw[i + 6] |= 1
        i += 4
    i = 0
    while (i := raw.find(b"PK\x01\x02", i)) >= 0:
        raw[i + 8] |= 1
        i += 4
    path.write_bytes(bytes(raw))


def _with_comment(path, members):
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for n, d in members:
            z.writestr(n, d)
        z.comment = b"c" * 65535


def animalai_attacks():
    g = "import-animalai"
    good = (ROOT / "tests/fixtures/animalai").glob("*.y*ml")
    sample = next(iter(sorted(good))).read_text()
    names = {
        "unicode": "арена ü.yaml",
        "newline": "a\nb.yaml",
        "rtl": "x\u202elmay.yaml",
        "dash": "-x.yaml",
        "dots": "...yaml",
        "spaces": "   .yaml",
    }
    for kind, name in names.items():
        attack(
            f"import-name-{kind}",
            g,
            [AAAI, "import-animalai", "src", "--out", "out"],
            text("src/" + name, sample),
            "any",
            check=lambda w, r: (
                None
                if all(p.resolve().is_relative_to((w / "out").resolve()) for p in (w / "out").rglob("*"))
                else "wrote outside --out"
            ),
        )
    attack(
        "import-symlink-dir-loop",
        g,
        [AAAI, "import-animalai", "src", "--out", "out"],
        both(text("src/a.yaml", sample), link("src/loop", "{W}/src")),
        "any",
        timeout=30,
    )
    attack(
        "import-symlink-file-out",
        g,
        [AAAI, "import-animalai", "src", "--out", "out"],
        both(victim("secret.yaml", sample), link("src/a.yaml", "{O}/secret.yaml")),
        "any",
        check=unchanged("secret.yaml", sample),
    )
    attack(
        "import-fifo-in-folder",
        g,
        [AAAI, "import-animalai", "src", "--out", "out"],
        both(text("src/a.yaml", sample), fifo("src/b.yaml")),
        "any",
        timeout=30,
    )
    attack(
        "import-sparse-2gb",
        g,
        [AAAI, "import-animalai", "big.yaml", "--out", "out"],
        lambda w: ((w / "big.yaml").touch(), os.truncate(w / "big.yaml", 2 << 30)),
        "error",
    )
    attack(
        "import-utf16",
        g,
        [AAAI, "import-animalai", "a.yaml", "--out", "out"],
        text("a.yaml", sample, "utf-16"),
        "error",
    )
    attack(
        "import-bom", g, [AAAI, "import-animalai", "a.yaml", "--out", "out"], text("a.yaml", "\ufeff" + sample), "any"
    )
    attack(
        "import-python-tag-canary",
        g,
        [AAAI, "import-animalai", "a.yaml", "--out", "out"],
        lambda w: (w / "a.yaml").write_text(f"!!python/object/apply:os.system ['touch {w.parent}/CANARY']\n"),
        "error",
    )


def l11_heightfield(n: int) -> str:
    """L11's own arena file with its heightfield resampled to n x n heights."""
    import yaml

    done = subprocess.run([AAAI, "spec", "11", "--yaml"], capture_output=True, text=True, check=True)
    data = yaml.safe_load(done.stdout)
    rows = data["heightfield"]
    data["heightfield"] = [[rows[i * len(rows) // n][j * len(rows[0]) // n] for j in range(n)] for i in range(n)]
    return yaml.safe_dump(data, default_flow_style=None, width=10**6)


def arena_attacks():
    g = "arena-extremes"
    agent = "agent: {x: 0, y: -18, yaw: 1.5707963267948966}\n"
    food = "  - {kind: food_green, position: [0, 5, 1.5], size: [3, 3, 3]}\n"

    def arena(body, objects=food, head=agent):
        return head + body + "objects:\n" + objects

    checker = "".join(  # 10,000 single holes, none near the start (tiles of 2.5 units)
        f"  - [{i}, {j}]\n" for i in range(0, 400, 4) for j in range(0, 400, 4) if not (150 < i < 250 and 150 < j < 250)
    )
    many = "".join(
        f"  - {{kind: food_green, position: [{-435 + (i % 30) * 30}, {-435 + (i // 30) * 30}, 0.25],"
        " size: [0.5, 0.5, 0.5]}\n"
        for i in range(900)
    )
    movers = "".join(
        f"  - {{kind: food_green, position: [{-40 + (i % 20) * 4}, {-10 + (i // 20) * 4}, 1], size: [1, 1, 1],"
        " behaviour: {type: random_walk, speed: 100.0}}\n"
        for i in range(200)
    )
    cases = {
        "huge-arena-checker-holes": arena("arena_size: [1000, 1000]\ntiles: [400, 400]\nholes:\n" + checker),
        "huge-arena-few-tiles": arena("arena_size: [1000, 1000]\ntiles: [1, 1]\n"),
        "tiny-arena": arena("arena_size: [0.001, 0.001]\n", objects=food, head="agent: {x: 0, y: 0}\n"),
        "heightfield-300x300": l11_heightfield(300),
        "heightfield-ragged": arena("heightfield:\n  - [0, 1, 2]\n  - [0]\n"),
        "heightfield-huge-values": arena("heightfield:\n  - [1.0e+300, -1.0e+300]\n  - [0, 1.0e+300]\n"),
        "900-small-foods": arena("arena_size: [1000, 1000]\n", objects=many),
        "200-fast-movers": arena("", objects=movers),
        "mass-1e30": arena(
            "", objects=food + "  - {kind: wall, position: [5, 0, 1], size: [1, 1, 1], mass: 1.0e+30}\n"
        ),
        "yaw-1e300": arena(
            "", objects="  - {kind: food_green, position: [0, 5, 1.5], size: [3, 3, 3], yaw: 1.0e+300}\n"
        ),
        "wall-height-tiny": arena("wall_height: 1.0e-9\n"),
        "wall-height-huge": arena("wall_height: 1000\n"),
        "time-limit-200": arena("time_limit: 200\n"),
        "time-limit-0.2": arena("time_limit: 0.2\n"),
        "blackout-tiny": arena("blackout: {light: 1.0e-300, dark: 1.0e-300}\n"),
        "colours-extreme": arena("colours: {food_green: [1.0e+308, -1.0e+308, .nan, 2]}\n"),
        "object-size-1000": arena(
            "arena_size: [1000, 1000]\n",
            objects=food + "  - {kind: wall, position: [450, 0, 500], size: [1, 900, 1000]}\n",
        ),
        "agent-corner": arena("", head="agent: {x: 19.99, y: -19.99, yaw: 0}\n"),
        "agent-yaw-huge": arena("", head="agent: {x: 0, y: -18, yaw: 1.0e+300}\n"),
        "description-900kb": "description: " + "d" * 900_000 + "\n" + arena(""),
        "inner-seed-huge": arena("inner: {level: 0, name: x, difficulty: 0, seed: 18446744073709551617}\n"),
        "extras-deep": arena("extras: " + "{a: " * 19 + "1" + "}" * 19 + "\n"),
        "uniform-huge-range": arena(
            "",
            objects="  - {kind: food_green, position: [{uniform: [-1.0e+308, 1.0e+308]}, 5, 1.5], size: [3, 3, 3]}\n",
        ),
        "choice-10000": arena(
            "",
            objects="  - {kind: food_green, position: [{choice: ["
            + ",".join(["1"] * 10000)
            + "]}, 5, 1.5], size: [3, 3, 3]}\n",
        ),
        "max-food-reward-huge": arena("max_food_reward: 1.0e+308\n"),
        "integers-huge-range": arena(
            "", objects="  - {kind: food_green, position: [{integers: [-1.0e+30, 1.0e+30]}, 5, 1.5], size: [3, 3, 3]}\n"
        ),
    }
    for name, content in cases.items():
        attack(
            f"arena-{name}-run",
            g,
            [AAAI, "run", "--arena", "a.yaml", "--max-steps", "10", "--no-camera"],
            text("a.yaml", content),
            "any",
        )
    for name in ("huge-arena-checker-holes", "heightfield-300x300", "900-small-foods", "colours-extreme"):
        attack(
            f"arena-{name}-show",
            g,
            [AAAI, "show", "--arena", "a.yaml", "-o", "o.png"],
            text("a.yaml", cases[name]),
            "any",
        )


def cli_number_attacks():
    g = "cli-numbers"
    cases = {
        "steps-negative": [AAAI, "train", "--agent", "random", "--steps", "-1", "--run", "r"],
        "seed-2-64": [AAAI, "spec", "0", "-s", str(2**64)],
        "difficulty-huge": [AAAI, "spec", "0", "-d", "1000000000"],
        "show-seed-negative": [AAAI, "show", "0", "-s", "-5", "-o", "o.png"],
        "envs-zero": [AAAI, "train", "--agent", "random", "--steps", "10", "--envs", "0", "--run", "r"],
        "camera-resolution-huge": [
            AAAI,
            "train",
            "--agent",
            "random",
            "--steps",
            "10",
            "--camera",
            "--camera-resolution",
            "100000",
            "--run",
            "r",
        ],
        "max-steps-negative": [AAAI, "run", "--max-steps", "-10"],
        "import-scale-nan": [
            AAAI,
            "import-animalai",
            str(ROOT / "tests/fixtures/animalai"),
            "--out",
            "o",
            "--scale",
            "nan",
        ],
        "import-scale-zero": [
            AAAI,
            "import-animalai",
            str(ROOT / "tests/fixtures/animalai"),
            "--out",
            "o",
            "--scale",
            "0",
        ],
        "run-max-steps-huge": [AAAI, "run", "--max-steps", str(10**30)],
    }
    for name, argv in cases.items():
        attack(f"cli-{name}", g, argv, None, "error")


# --- the play server (one, on loopback, for the whole group) --------------------------------
HTTP_CLIENT = r"""
import socket, sys, os
port = int(os.environ["PORT"])
request = open(sys.argv[1], "rb").read().replace(b"PORT", str(port).encode())
s = socket.create_connection(("127.0.0.1", port), timeout=10)
try:
    s.sendall(request)
    if os.environ.get("HALF"):
        s.shutdown(socket.SHUT_WR)
    data = b""
    while len(data) < 2_000_000:
        chunk = s.recv(65536)
        if not chunk:
            break
        data += chunk
        if b"\r\n\r\n" in data and not os.environ.get("READ_ALL"):
            head, _, body = data.partition(b"\r\n\r\n")
            length = [l for l in head.split(b"\r\n") if l.lower().startswith(b"content-length:")]
            if not length or len(body) >= int(length[0].split(b":")[1]):
                break
except socket.timeout:
    pass
status = data.split(b"\r\n", 1)[0].decode(errors="replace")
print(status)
if b"root:" in data or b"def create_app" in data:
    print("Error: the answer holds a file of this machine", file=sys.stderr); sys.exit(3)
code = int(status.split()[1]) if status.startswith("HTTP/") else 0
if code >= 500:
    print(f"Error: server error {status}", file=sys.stderr); sys.exit(4)
"""

WS_CLIENT = r"""
import json, os, sys, asyncio
from websockets.asyncio.client import connect
port = int(os.environ["PORT"])
script = json.loads(sys.argv[1])

async def main():
    async with connect(f"ws://127.0.0.1:{port}/ws", origin=f"http://127.0.0.1:{port}", max_size=None,
                       open_timeout=10) as ws:
        await asyncio.wait_for(ws.recv(), 10)  # hello
        for message in script:
            await ws.send(message if isinstance(message, str) else bytes.fromhex(message["hex"]))
        await ws.send(json.dumps({"type": "focus", "focused": True}))
        try:
            while True:
                answer = await asyncio.wait_for(ws.recv(), 5)
                if isinstance(answer, str) and '"error"' in answer:
                    break
        except asyncio.TimeoutError:
            pass
        except Exception as error:
            print(f"closed: {error}"[:200])

asyncio.run(main())
"""


def play_attacks():
    g = "play-http"

    def http(name, request: bytes, **env):
        attack(
            f"play-{name}",
            g,
            [PY, "-c", HTTP_CLIENT, "request.bin"],
            text("request.bin", request),
            "any",
            timeout=30,
            **env,
        )

    H = b"Host: 127.0.0.1:PORT\r\n"
    for method in (b"POST", b"PUT", b"DELETE", b"TRACE", b"OPTIONS", b"PATCH", b"FOO", b"get"):
        http(f"method-{method.decode().lower()}", method + b" / HTTP/1.1\r\n" + H + b"Content-Length: 0\r\n\r\n")
    http("connect", b"CONNECT 127.0.0.1:22 HTTP/1.1\r\n" + H + b"\r\n")
    paths = {
        "static-dotdot": b"/static/../../../../etc/passwd",
        "static-encoded-dotdot": b"/static/%2e%2e/%2e%2e/%2e%2e/etc/passwd",
        "static-encoded-slash": b"/static/..%2f..%2fserver.py",
        "static-double-encoded": b"/static/%252e%252e/server.py",
        "static-backslash": b"/static/..\\..\\server.py",
        "double-slash": b"//etc/passwd",
        "static-nul": b"/static/index.html%00.png",
        "raw-nul": b"/\x00",
        "static-dir": b"/static/",
        "static-dotdot-end": b"/static/..",
        "ws-plain-get": b"/ws",
        "long-path": b"/" + b"a" * 100_000,
        "unicode-path": "/static/ü\u202e.js".encode(),
        "overlong-utf8": b"/static/%c0%ae%c0%ae/server.py",
        "absolute-uri": b"http://evil.example/etc/passwd",
        "asterisk": b"*",
        "query-1mb": b"/api/sessions?x=" + b"a" * 1_000_000,
        "static-server-py": b"/static/../server.py",
    }
    for name, path in paths.items():
        http(f"path-{name}", b"GET " + path + b" HTTP/1.1\r\n" + H + b"\r\n")
    headers = {
        "host-unicode": b"GET / HTTP/1.1\r\nHost: 127.0.0.1\xc3\xbc:PORT\r\n\r\n",
        "host-duplicate": b"GET /api/sessions HTTP/1.1\r\nHost: evil.example\r\n" + H + b"\r\n",
        "host-duplicate-good-first": b"GET /api/sessions HTTP/1.1\r\n" + H + b"Host: evil.example\r\n\r\n",
        "host-missing-http10": b"GET /api/sessions HTTP/1.0\r\n\r\n",
        "origin-suffix": b"GET /api/sessions HTTP/1.1\r\n" + H + b"Origin: http://127.0.0.1:PORT.evil.example\r\n\r\n",
        "origin-upper": b"GET /api/sessions HTTP/1.1\r\n" + H + b"Origin: HTTP://127.0.0.1:PORT\r\n\r\n",
        "origin-userinfo": b"GET /api/sessions HTTP/1.1\r\n" + H + b"Origin: http://evil@127.0.0.1:PORT\r\n\r\n",
        "many-headers": b"GET / HTTP/1.1\r\n" + H + b"".join(b"X-%d: v\r\n" % i for i in range(500)) + b"\r\n",
        "header-100kb": b"GET / HTTP/1.1\r\n" + H + b"X-Big: " + b"v" * 100_000 + b"\r\n\r\n",
        "chunked-smuggle": b"POST / HTTP/1.1\r\n" + H + b"Content-Length: 6\r\nTransfer-Encoding: chunked\r\n\r\n"
        b"0\r\n\r\nGET /api/sessions HTTP/1.1\r\nHost: evil.example\r\n\r\n",
        "content-length-huge": b"POST / HTTP/1.1\r\n" + H + b"Content-Length: 99999999999\r\n\r\nabc",
        "content-length-negative": b"POST / HTTP/1.1\r\n" + H + b"Content-Length: -5\r\n\r\n",
        "http09": b"GET /\r\n\r\n",
        "http2-preface": b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n",
        "garbage": bytes(range(256)),
        "empty": b"",
        "bad-cookie": b"GET / HTTP/1.1\r\n" + H + b'Cookie: aaai_play=\xff\xfe; ===; "\r\n\r\n',
        "token-query-surrogate": b"GET /?token=%ED%A0%80 HTTP/1.1\r\n" + H + b"\r\n",
        "ws-upgrade-no-origin": b"GET /ws HTTP/1.1\r\n" + H + b"Upgrade: websocket\r\nConnection: Upgrade\r\n"
        b"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n",
        "ws-upgrade-bad-version": b"GET /ws HTTP/1.1\r\n"
        + H
        + b"Origin: http://127.0.0.1:PORT\r\nUpgrade: websocket\r\n"
        b"Connection: Upgrade\r\nSec-WebSocket-Key: x\r\nSec-WebSocket-Version: 99\r\n\r\n",
        "pipelined-100": (b"GET /api/sessions HTTP/1.1\r\n" + H + b"\r\n") * 100,
    }
    for name, request in headers.items():
        http(f"header-{name}", request, **({"HALF": "1"} if name in ("empty", "http09", "garbage") else {}))

    def ws(name, messages):
        attack(f"play-ws-{name}", g, [PY, "-c", WS_CLIENT, json.dumps(messages)], None, "any", timeout=30)

    join = json.dumps({"type": "join", "player": "tester"})
    ws("join-unicode-player", [json.dumps({"type": "join", "player": "тест\u202e"})])
    ws("join-player-number", [json.dumps({"type": "join", "player": 10**400 if False else 1e308})])
    ws("join-token-object", [json.dumps({"type": "join", "player": "a", "token": {"x": [1]}})])
    ws("join-twice", [join, join])
    ws("key-flood", [join] + [json.dumps({"type": "key", "key": "ArrowUp", "down": i % 2 == 0}) for i in range(500)])
    ws("ack-huge-frame", [join, json.dumps({"type": "ack", "frame": 10**300})])
    ws("ack-negative-frame", [join, json.dumps({"type": "ack", "frame": -1})])
    ws("focus-string", [join, json.dumps({"type": "focus", "focused": "yes"})])
    ws("type-unicode", [json.dumps({"type": "jöin"})])
    ws("nan-json", ['{"type": "key", "key": "ArrowUp", "down": NaN}'])
    ws("duplicate-keys", ['{"type": "join", "type": "key", "player": "a"}'])
    ws("binary-invalid-utf8", [{"hex": "ff" * 100}])
    ws("deep-json", ["[" * 900 + "]" * 900])


def play_server(w: Path):
    """Starts one aaai play on a free loopback port; returns (process, port, stderr path)."""
    w.mkdir(parents=True, exist_ok=True)
    err = open(w / "server.err", "wb")
    proc = subprocess.Popen(
        [
            "nice",
            "-n",
            "10",
            AAAI,
            "play",
            "--port",
            "0",
            "--host",
            "127.0.0.1",
            "--out",
            str(w / "play_{player}.csv"),
            "--max-sessions",
            "4",
            "--grace",
            "0.5",
        ],
        stdout=subprocess.PIPE,
        stderr=err,
        cwd=w,
        preexec_fn=limit,
        text=True,
    )
    line = proc.stdout.readline()
    port = int(line.split("http://127.0.0.1:")[1].split("/")[0])
    threading.Thread(target=proc.stdout.read, daemon=True).start()
    return proc, port, w / "server.err"


def server_alive(port: int) -> bool:
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
            s.sendall(f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n".encode())
            return s.recv(100).startswith(b"HTTP/1.1 200")
    except OSError:
        return False


# --- running and classifying ---------------------------------------------------------------
def limit():
    os.setsid()
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY, MEMORY))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def snapshot(path: Path) -> dict:
    out = {}
    for p in sorted(path.rglob("*")):
        try:
            out[str(p)] = (
                p.is_symlink(),
                p.lstat().st_size,
                p.read_bytes() if p.is_file() and not p.is_symlink() else b"",
            )
        except OSError:
            out[str(p)] = None
    return out


def execute(a: Attack, extra_env: dict | None = None) -> tuple[str, str, float]:
    try:
        return _execute(a, extra_env)
    except Exception as error:  # a fault of this script, not of the command: shown, never counted clean
        return "ERROR", f"the attack itself failed: {type(error).__name__}: {error}"[:200], 0.0


def _execute(a: Attack, extra_env: dict | None = None) -> tuple[str, str, float]:
    top = BASE / a.id
    shutil.rmtree(top, ignore_errors=True)
    w, outside = top / "work", top / "outside"
    for d in (w, outside, top / "home"):
        d.mkdir(parents=True)
    if a.setup:
        a.setup(w)
    before = snapshot(outside)
    argv = [x.replace("{W}", str(w)) for x in a.argv]
    env = {
        **os.environ,
        "HOME": str(top / "home"),
        "MPLBACKEND": "Agg",
        "PYTHONWARNINGS": "ignore",
        "AAAI_CHECKPOINT_KEY": str(top / "home" / "key"),
        **a.env,
        **(extra_env or {}),
    }
    start = time.monotonic()
    proc = subprocess.Popen(
        ["nice", "-n", "10", *argv], cwd=w, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, preexec_fn=limit
    )
    try:
        out, err = proc.communicate(timeout=a.timeout)
        code = proc.returncode
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        code = None
    seconds = time.monotonic() - start
    try:
        os.killpg(proc.pid, signal.SIGKILL)  # anything it left behind
    except ProcessLookupError:
        pass
    r = Result(code, out.decode(errors="replace"), err.decode(errors="replace"), seconds)
    outcome, reason = classify(a, r, w, before, outside, top)
    if outcome == "CLEAN":
        shutil.rmtree(top, ignore_errors=True)
    else:
        (top / "stderr.txt").write_text(r.stderr)
        (top / "stdout.txt").write_text(r.stdout[-100_000:])
    return outcome, reason, seconds


def last_line(s: str) -> str:
    lines = [x for x in s.strip().splitlines() if x.strip()]
    return lines[-1][:200] if lines else ""


def classify(a: Attack, r: Result, w: Path, before, outside, top) -> tuple[str, str]:
    if r.code is None:
        return "FAIL", f"no answer within {a.timeout:g} s"
    if (top / "CANARY").exists():
        return "FAIL", "a payload ran (the canary file exists)"
    if "Traceback (most recent call last)" in r.stderr + r.stdout:
        return "FAIL", "traceback: " + last_line(r.stderr.split("Traceback (most recent call last)")[-1])
    if r.code < 0:
        return "FAIL", f"killed by signal {-r.code}"
    if "MemoryError" in r.stderr or "Segmentation" in r.stderr:
        return "FAIL", last_line(r.stderr)
    if snapshot(outside) != before:
        return "FAIL", "something outside its folder was changed"
    if a.check:
        problem = a.check(w, r)
        if problem:
            return "FAIL", problem
    if r.code != 0:
        line = last_line(r.stderr) or last_line(r.stdout)  # import-animalai says SKIPPED on stdout
        if not line:
            return "FAIL", f"exit {r.code} with no message"
        if a.expect == "ok":
            return "FAIL", f"refused: {line}"
        return "CLEAN", f"refused: {line}"
    if a.expect == "error":
        return "FAIL", "accepted (exit 0); expected a refusal"
    return "CLEAN", "ok" + (f": {last_line(r.stdout)}" if a.group == "play-http" else "")


def read_rows() -> dict[str, dict]:
    if not CSV_PATH.is_file():
        return {}
    try:
        return {row["id"]: row for row in csv.DictReader(CSV_PATH.open(newline=""))}
    except (csv.Error, KeyError):
        return {}


def write_rows(rows: dict[str, dict]) -> None:
    order = {a.id: i for i, a in enumerate(ATTACKS)}
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in sorted(rows.values(), key=lambda r: order.get(r["id"], 10**6)):
        writer.writerow({k: row.get(k, "") for k in COLUMNS})
    temp = CSV_PATH.with_suffix(".csv.tmp")
    with open(temp, "w", newline="") as f:
        f.write(buffer.getvalue())
        f.flush()
        os.fsync(f.fileno())
    os.replace(temp, CSV_PATH)


def shown_command(a: Attack) -> str:
    argv = ["aaai" if x == AAAI else "python" if x == PY else x for x in a.argv]
    if argv[0] == "python" and len(argv) > 2:
        argv = argv[:2] + [f"<{a.group} script>"] + [x if len(x) < 80 else x[:77] + "..." for x in argv[3:]]
    s = shlex.join(argv)
    return s if len(s) <= 300 else s[:297] + "..."


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rerun", action="store_true", help="run every attack again")
    parser.add_argument("--only", help="only this group (or an attack id prefix)")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--list", action="store_true")
    args = parser.parse_args()
    BASE.mkdir(parents=True, exist_ok=True)
    prepare()
    for make in (
        replay_attacks,
        config_attacks,
        env_attacks,
        file_flag_attacks,
        folder_attacks,
        board_attacks,
        model_attacks,
        animalai_attacks,
        arena_attacks,
        cli_number_attacks,
        play_attacks,
    ):
        make()
    if args.list:
        for a in ATTACKS:
            print(a.id, a.group, shown_command(a))
        print(len(ATTACKS), "attacks")
        return
    rows = {} if args.rerun and not args.only else read_rows()
    chosen = [a for a in ATTACKS if not args.only or a.group == args.only or a.id.startswith(args.only)]
    todo = [a for a in chosen if args.rerun or a.id not in rows]
    lock = threading.Lock()

    def record(a: Attack, outcome: str, reason: str, seconds: float) -> None:
        with lock:
            rows[a.id] = {
                "id": a.id,
                "group": a.group,
                "command": shown_command(a),
                "outcome": outcome,
                "reason": reason,
                "seconds": f"{seconds:.2f}",
            }
            write_rows(rows)
            print(f"{outcome:5} {seconds:6.1f}s {a.id}: {reason}"[:220], flush=True)

    plain = [a for a in todo if a.group != "play-http"]
    with ThreadPoolExecutor(args.jobs) as pool:
        for a, (outcome, reason, seconds) in zip(plain, pool.map(execute, plain)):
            record(a, outcome, reason, seconds)
    web = [a for a in todo if a.group == "play-http"]
    if web:
        proc, port, err = play_server(BASE / "_play")
        try:
            for a in web:
                seen = err.stat().st_size
                outcome, reason, seconds = execute(a, {"PORT": str(port)})
                new = err.read_bytes()[seen:].decode(errors="replace")
                if outcome == "CLEAN" and "Traceback" in new:
                    outcome, reason = "FAIL", "server traceback: " + last_line(new)
                if outcome == "CLEAN" and not server_alive(port):
                    outcome, reason = "FAIL", "the server stopped answering its page"
                record(a, outcome, reason, seconds)
        finally:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(20)
            except subprocess.TimeoutExpired:
                proc.kill()
    groups: dict[str, list[int]] = {}
    for row in rows.values():
        counts = groups.setdefault(row["group"], [0, 0])
        counts[0] += 1
        counts[1] += row["outcome"] == "CLEAN"
    total, clean = sum(c[0] for c in groups.values()), sum(c[1] for c in groups.values())
    for group, (n, c) in sorted(groups.items()):
        print(f"{group:16} {c:4} / {n:4} clean")
    print(f"{'all':16} {clean:4} / {total:4} clean ({100 * clean / max(total, 1):.1f} %)")
    for row in rows.values():
        if row["outcome"] != "CLEAN":
            print(f"FAIL {row['id']}: {row['reason']}")


if __name__ == "__main__":
    main()
