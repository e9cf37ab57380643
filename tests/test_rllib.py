"""RLlib PPO training with the curriculum sampler as one Ray actor (aaai/train/rllib_learner.py).

Ray runs in a child process (its global state stays out of the test session) with a private Ray
temp folder, whose path every Ray process inherits in its environment: after the child exits, no
process may still hold it.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

import pytest
import yaml
from conftest import processes_holding

pytest.importorskip("ray.rllib", reason="needs the ray extra, which make test installs")

# A run of 1024 steps (iterations of 2 x 256 steps, one remote EnvRunner with two environments),
# checkpoints every 512; then, as after a kill just past step 512, final/ and the newer checkpoint
# are taken away and the run is resumed with its end moved to 1536. Then the run is scored by the
# command a user types (`aaai eval --policy RUN`), in the same child.
CHILD = """
import json, shutil, sys
from pathlib import Path
import ray
from aaai.config import load_config
from aaai.train.rllib_learner import train_rllib
from aaai.scoring.runs import run_backend

run = Path(sys.argv[1])
config = load_config(None, max_steps=100, levels=[0], difficulties=[0, 1], total_steps=1024, num_envs=2,
                     checkpoint_every=512, heatmap_every=512, n_steps=256, batch_size=128, n_epochs=2,
                     net_width=32)
first = train_rllib(run, config, env_runners=1, say=print)
shutil.rmtree(run / "final")
shutil.rmtree(run / "checkpoints" / "step_000000001024")
resumed = train_rllib(run, resume=True, total_steps=1536, env_runners=1, say=print)

# The trained policy, as the scoreboard would play it: deterministic, actions in the space.
from aaai.config import env_part
from aaai.env import AnimalAIEnv
from aaai.scoring.evaluation import run_episode
from aaai.scoring.rllib_policy import RLlibPolicy
from aaai.scoring.runs import RunFolder
env = AnimalAIEnv(config=env_part(RunFolder(run).read_config(), shaping=0.0))
from aaai.scoring.policies import OnGrid
policy = OnGrid(RLlibPolicy(run, env))  # as the scoreboard plays it: float64, on the grid
observation, _ = env.reset(seed=3)
assert env.action_space.contains(policy(observation))
plays = [run_episode(env, policy, 0, 1, 7) for _ in range(2)]
env.close()
initialized = ray.is_initialized()

from click.testing import CliRunner
from aaai_cli.main import cli
scored = CliRunner().invoke(cli, ["eval", "--policy", str(run), "-k", "2", "--levels", "0", "--difficulty", "1",
                                  "--out", sys.argv[2]])
print("RESULT " + json.dumps({"first": [first.steps, first.episodes], "resumed": [resumed.steps, resumed.episodes,
                              resumed.resumed_from], "backend": run_backend(run), "initialized": initialized,
                              "plays": [{k: v for k, v in p.items() if k != "wall_seconds"} for p in plays],
                              "eval": [scored.exit_code, scored.output[-3000:]]}))
"""


@pytest.mark.long  # about 40 s (Ray and RLlib start twice): in make test-long, with the RLlib kill tests
def test_rllib_run_writes_its_folder_and_resumes(tmp_path):
    ray_tmp = tempfile.mkdtemp(prefix="aaairl", dir="/tmp")  # short: Ray's socket paths live here
    run, board = tmp_path / "run", tmp_path / "board.csv"
    env = {**os.environ, "RAY_AUTH_MODE": "disabled", "RAY_TMPDIR": ray_tmp, "PYTHONUNBUFFERED": "1"}

    try:
        with open(tmp_path / "stderr.txt", "w") as stderr:  # a file: a leftover process may hold a pipe open
            child = subprocess.run(
                # the run folder relative, as the default runs/...: RLlib is given it absolute
                [sys.executable, "-c", CHILD, "run", str(board)],
                cwd=tmp_path,
                env=env,
                stdout=subprocess.PIPE,
                stderr=stderr,
                text=True,
                timeout=600,
            )
        log = child.stdout[-3000:] + (tmp_path / "stderr.txt").read_text()[-3000:]
        assert child.returncode == 0, log
        deadline = time.time() + 20
        while (left := processes_holding(ray_tmp)) and time.time() < deadline:
            time.sleep(0.5)
        assert not left, f"Ray processes outlived the run: {sorted(left)}"
    finally:
        shutil.rmtree(ray_tmp, ignore_errors=True)
    result = json.loads([line for line in child.stdout.splitlines() if line.startswith("RESULT ")][-1][7:])
    assert result["first"][0] == 1024 and result["resumed"][:1] == [1536] and result["resumed"][2] == 512
    assert result["backend"] == "rllib" and not result["initialized"]
    assert result["plays"][0] == result["plays"][1] and result["plays"][0]["steps"] <= 100

    # The local trainer's layout: config, versions, episodes, heatmap, checkpoints with the sampler's state.
    assert (run / "config.yaml").is_file() and (run / "versions.json").is_file() and (run / "curriculum.png").is_file()
    config = yaml.safe_load((run / "config.yaml").read_text())
    assert config["train"]["total_steps"] == 1536 and config["sensors"]["joint_velocities"]
    assert sorted(p.name for p in (run / "checkpoints").iterdir()) == [f"step_{s:012d}" for s in (512, 1024, 1536)]
    saved = json.loads((run / "checkpoints" / "step_000000000512" / "state.json").read_text())
    final = json.loads((run / "final" / "state.json").read_text())
    assert final["step"] == 1536 and final["agent"] == {"backend": "rllib"}
    assert (run / "final" / "rllib").is_dir() and (run / "checkpoints" / "step_000000000512" / "rllib").is_dir()
    assert [tuple(cell) for cell in final["curriculum"]["cells"]] == [(0, 0), (0, 1)]
    before, after = saved["curriculum"]["episodes"], final["curriculum"]["episodes"]
    assert all(later >= earlier for earlier, later in zip(before, after)) and sum(after) > sum(before)
    with open(run / "episodes.csv") as handle:
        episodes = list(csv.DictReader(handle))
    steps = [int(e["step"]) for e in episodes]
    assert steps == sorted(steps) and steps[-1] <= 1536  # those logged after 512 and lost were dropped
    assert len(episodes) == sum(final["curriculum"]["episodes"]) >= 12  # 100-step episodes: ~15 in 1536 steps
    assert sum(int(e["step"]) <= 512 for e in episodes) == sum(saved["curriculum"]["episodes"])
    for episode in episodes:
        assert (int(episode["level"]), int(episode["difficulty"])) in {(0, 0), (0, 1)}
        assert 1 <= int(episode["length"]) <= 100
        assert 0 <= int(episode["seed"]) < 1288490240  # training seeds only
        assert float(episode["task_return"]) != float(episode["episode_return"])  # shaping was on, and left out

    # Scored like any run, by the command a user types; the record names the RLlib checkpoint.
    assert result["eval"][0] == 0, result["eval"][1]
    with open(board) as handle:
        rows = list(csv.DictReader(handle))
    assert [(r["level"], r["difficulty"]) for r in rows] == [("0", "1"), ("0", "1")]
    record = json.loads((tmp_path / "board_scored_with.json").read_text())
    assert record["model"].endswith("final/rllib") and len(record["model_sha256"]) == 64


KILL_CHILD = """
import json, os, signal, sys
from pathlib import Path
from aaai.config import load_config
from aaai.train.rllib_learner import train_rllib

run, ray_tmp = Path(sys.argv[1]), sys.argv[2]
config = load_config(None, max_steps=100, levels=[0], difficulties=[0], total_steps=2560, num_envs=2,
                     checkpoint_every=100000, heatmap_every=100000, n_steps=256, batch_size=128, n_epochs=1,
                     net_width=16)
killed, seen = [], []

def env_runners():
    for entry in Path("/proc").iterdir():
        try:
            title = (entry / "cmdline").read_bytes() if entry.name.isdigit() else b""
            if (title.startswith(b"ray::") and b"EnvRunner" in title
                    and ray_tmp.encode() in (entry / "environ").read_bytes()):
                yield int(entry.name)
        except OSError:
            continue

def kill_one_runner(steps):
    if not killed:  # after the first iteration: one of the two EnvRunner processes dies
        pid = next(env_runners())
        os.kill(pid, signal.SIGKILL)
        killed.append(pid)
    else:
        seen.append(sorted(env_runners()))

result = train_rllib(run, config, env_runners=2, progress=kill_one_runner, say=print)
print("RESULT", json.dumps({"steps": result.steps, "killed": killed, "seen": seen}))
"""


@pytest.mark.long  # about 1-2 minutes on 2 cores: in make test-long
def test_a_killed_env_runner_is_replaced_and_training_goes_on(tmp_path):
    ray_tmp = tempfile.mkdtemp(prefix="aaairk", dir="/tmp")
    env = {**os.environ, "RAY_AUTH_MODE": "disabled", "RAY_TMPDIR": ray_tmp, "PYTHONUNBUFFERED": "1"}
    try:
        child = subprocess.run(
            [sys.executable, "-c", KILL_CHILD, str(tmp_path / "run"), ray_tmp],
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
        )
    finally:
        shutil.rmtree(ray_tmp, ignore_errors=True)
    assert child.returncode == 0, child.stdout[-2000:] + child.stderr[-3000:]
    result = json.loads([line for line in child.stdout.splitlines() if line.startswith("RESULT ")][-1][7:])
    assert result["steps"] >= 2560  # the run reached its end after losing a runner ...
    assert len(result["killed"]) == 1 and len(result["seen"][-1]) == 2  # ... which was replaced
    assert result["killed"][0] not in result["seen"][-1]
    assert json.loads((tmp_path / "run" / "final" / "state.json").read_text())["step"] == result["steps"]
