"""Smoke tests of examples/: each quick start runs for a few hundred env steps and does its job.

Each test skips only when its RL library is not installed (`make test` installs them all).
"""

from __future__ import annotations

import importlib.util
import inspect
import json
import math
import os
import runpy
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
ENV_ID = "aaai/L0-FoodContact-v0"
# No example may reach the network: no Hub, no Weights & Biases.
OFFLINE_ENV = {**os.environ, "HF_HUB_OFFLINE": "1", "WANDB_MODE": "disabled", "PYTHONUNBUFFERED": "1"}


@pytest.fixture(autouse=True)
def _restore_torch_threads():
    """The examples set torch to one thread; give the rest of the session its setting back."""
    if importlib.util.find_spec("torch") is None:
        yield
        return
    import torch

    threads = torch.get_num_threads()
    yield
    torch.set_num_threads(threads)


def load_example(name: str):
    """Import examples/<name>.py as a module (examples/ is not a package)."""
    spec = importlib.util.spec_from_file_location(f"aaai_example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while the class is built
    spec.loader.exec_module(module)
    return module


def test_sb3_ppo(tmp_path):
    pytest.importorskip("stable_baselines3", reason="needs the train extra, which make test installs")
    import gymnasium as gym
    from stable_baselines3 import PPO

    example = load_example("sb3_ppo")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        path, mean, std = example.main(steps=256, out=str(tmp_path), max_steps=100, eval_episodes=2)
    checker = [w for w in caught if "env_checker" in w.filename]
    assert not checker, [str(w.message) for w in checker]  # rays_flat=True: check_env is silent
    assert Path(path).is_file() and Path(path).parent == tmp_path
    assert math.isfinite(mean) and math.isfinite(std)

    model = PPO.load(path, device="cpu")
    assert model.num_timesteps >= 256
    env = gym.make(ENV_ID, rays_flat=True, max_steps=100)
    observation, _ = env.reset(seed=3)
    action, _ = model.predict(observation, deterministic=True)
    assert env.action_space.contains(action.astype(np.float32))
    env.step(action)
    env.close()


def ray_processes() -> set[int]:
    """Pids of Ray's own processes (raylet, GCS, workers) on this machine (Linux /proc)."""
    from pathlib import Path

    pids = set()
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ")
        except OSError:
            continue
        if any(
            tag in cmdline
            for tag in (b"raylet", b"gcs_server", b"ray::", b"default_worker.py", b"ray/_private", b"ray/dashboard")
        ):
            pids.add(int(entry.name))
    return pids


# Run in a child process, so that Ray's global state stays out of the test session.
RLLIB_CHILD = """
import json, sys, time
sys.path.insert(0, {examples!r})
import ray
import rllib_ppo
before = ray_processes() if sys.platform == "linux" else set()
result = rllib_ppo.main(iterations=1, batch={batch}, max_steps=100, env_runners=0, checkpoint={checkpoint!r})
left = set()
if sys.platform == "linux":  # ray.shutdown() took its processes with it
    deadline = time.time() + 20
    while (left := ray_processes() - before) and time.time() < deadline:
        time.sleep(0.5)
runners, learner = result["env_runners"], result["learners"]["default_policy"]
print("RESULT " + json.dumps({{
    "sampled": runners["num_env_steps_sampled_lifetime"], "episodes": runners["num_episodes_lifetime"],
    "policy_loss": learner["policy_loss"], "vf_loss": learner["vf_loss"],
    "initialized": ray.is_initialized(), "left": sorted(left)}}))
"""


@pytest.mark.long  # about 30 s (Ray starts, RLlib builds PPO): in make test-long, as are test_rllib's runs
def test_rllib_ppo(tmp_path):
    pytest.importorskip("ray.rllib", reason="needs the ray extra, which make test installs")
    batch, checkpoint = 256, tmp_path / "checkpoint"
    code = inspect.getsource(ray_processes) + RLLIB_CHILD.format(
        examples=str(EXAMPLES), batch=batch, checkpoint=str(checkpoint)
    )
    run = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, env=OFFLINE_ENV, capture_output=True, text=True, timeout=300
    )
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    lines = [line for line in run.stdout.splitlines() if line.startswith("RESULT ")]
    assert lines, run.stdout[-3000:] + run.stderr[-3000:]
    result = json.loads(lines[-1][len("RESULT ") :])
    assert result["sampled"] >= batch
    assert result["episodes"] >= 1  # episodes of 100 steps ended inside the batch
    assert math.isfinite(result["policy_loss"]) and math.isfinite(result["vf_loss"])
    assert checkpoint.is_dir() and any(checkpoint.iterdir())
    assert not result["initialized"]
    assert not result["left"], f"Ray processes still running after ray.shutdown(): {result['left']}"


def test_torchrl_rollout():
    pytest.importorskip("torchrl", reason="needs the torchrl extra, which make test installs")
    example = load_example("torchrl_rollout")
    steps, max_steps = 300, 100
    rollout = example.main(steps=steps, max_steps=max_steps)  # runs check_env_specs (raises on a mismatch)
    assert tuple(rollout.batch_size) == (steps,)
    assert tuple(rollout["joints"].shape) == (steps, 8)
    assert tuple(rollout["rays"].shape) == (steps, 17, 11)
    assert tuple(rollout["action"].shape) == (steps, 8)
    assert float(rollout["action"].abs().max()) <= 1.0
    assert tuple(rollout["next", "reward"].shape) == (steps, 1)
    assert int(rollout["next", "done"].sum()) >= steps // max_steps  # rolled on across episode ends
    assert int(rollout["next", "step_count"].max()) <= max_steps


def test_cleanrl_ppo():
    pytest.importorskip("torch", reason="needs the train extra, which make test installs")
    example = load_example("cleanrl_ppo")
    args = example.parse_args(
        [
            "--total-timesteps",
            "512",
            "--num-steps",
            "128",
            "--max-steps",
            "100",
            "--num-minibatches",
            "4",
            "--update-epochs",
            "2",
        ]
    )
    assert (args.num_envs, args.num_steps, args.max_steps) == (2, 128, 100)
    history = example.main(args)
    assert [h["iteration"] for h in history] == [1, 2]
    assert history[-1]["global_step"] == 512
    for h in history:
        for key in ("policy_loss", "value_loss", "entropy", "approx_kl"):
            assert math.isfinite(h[key]), (key, h)
    # Episodes of 100 steps end inside each 128-step rollout; the reset-only step after each
    # end is masked, one per ended episode.
    assert history[0]["episodes"] >= 2 and history[0]["masked_steps"] == history[0]["episodes"]
    assert math.isfinite(history[0]["mean_return"])


def test_rl_zoo3_ppo(tmp_path):
    pytest.importorskip("rl_zoo3", reason="needs the zoo extra, which make test installs")
    import gymnasium as gym
    import yaml
    from stable_baselines3 import PPO

    conf = EXAMPLES / "rl_zoo3" / "ppo.yml"
    hyperparams = yaml.safe_load(conf.read_text())
    assert list(hyperparams) == [ENV_ID] and hyperparams[ENV_ID]["policy"] == "MultiInputPolicy"
    command = [
        sys.executable,
        "-m",
        "rl_zoo3.train",
        "--algo",
        "ppo",
        "--env",
        ENV_ID,
        "--gym-packages",
        "aaai",
        "--conf-file",
        str(conf),
        "-n",
        "256",
        "--eval-freq",
        "-1",
        "--seed",
        "0",
        "--log-folder",
        str(tmp_path),
        "--num-threads",
        "1",
        "-params",
        "n_steps:128",
        "batch_size:64",
        "n_epochs:2",
    ]
    run = subprocess.run(command, cwd=ROOT, env=OFFLINE_ENV, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]

    run_dir = tmp_path / "ppo" / "aaai-L0-FoodContact-v0_1"
    model_path = run_dir / "aaai-L0-FoodContact-v0.zip"
    assert model_path.is_file(), sorted(str(p) for p in tmp_path.rglob("*"))
    assert (run_dir / "aaai-L0-FoodContact-v0" / "vecnormalize.pkl").is_file()
    assert (run_dir / "aaai-L0-FoodContact-v0" / "config.yml").is_file()

    model = PPO.load(model_path, device="cpu")
    assert model.num_timesteps >= 256
    env = gym.make(ENV_ID, **hyperparams[ENV_ID]["env_kwargs"])
    assert model.observation_space == env.observation_space
    observation, _ = env.reset(seed=0)
    action, _ = model.predict(observation, deterministic=True)
    assert env.action_space.contains(action.astype(np.float32))
    env.close()


@pytest.mark.parametrize("script", ["sb3_ppo.py", "rllib_ppo.py", "torchrl_rollout.py", "cleanrl_ppo.py"])
def test_example_command_line(script, monkeypatch, capsys):
    """Each script's command line parses (its --help runs) and names its --steps-like option.

    Run as `python examples/<script> --help` runs it (as __main__, its folder first on the path), but
    in this process: a new one would spend seconds importing torch or torchrl again for --help."""
    library = {
        "sb3_ppo.py": "stable_baselines3",
        "rllib_ppo.py": "ray.rllib",
        "torchrl_rollout.py": "torchrl",
        "cleanrl_ppo.py": "torch",
    }[script]
    pytest.importorskip(library, reason="needs its library's extra, which make test installs")
    monkeypatch.setattr(sys, "argv", [str(EXAMPLES / script), "--help"])
    monkeypatch.syspath_prepend(str(EXAMPLES))
    with pytest.raises(SystemExit) as ended:
        runpy.run_path(str(EXAMPLES / script), run_name="__main__")
    assert ended.value.code == 0
    out = capsys.readouterr().out
    assert any(option in out for option in ("--steps", "--iterations", "--total-timesteps")), out


def test_an_example_runs_as_a_script_from_the_shell():
    """The scripts run as the README says, `python examples/<script>`: a new process, from the checkout."""
    run = subprocess.run(
        [sys.executable, str(EXAMPLES / "rllib_ppo.py"), "--help"],  # the one that imports nothing heavy for --help
        cwd=ROOT,
        env=OFFLINE_ENV,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    assert "--iterations" in run.stdout


def test_examples_are_documented():
    """examples/README.md and the docs' library page (docs/rl-libraries.md) list every example and its extra."""
    files = sorted(
        str(p.relative_to(EXAMPLES))
        for p in EXAMPLES.rglob("*")
        if p.suffix in (".py", ".yml") and "__pycache__" not in p.parts
    )
    assert files == ["cleanrl_ppo.py", "rl_zoo3/ppo.yml", "rllib_ppo.py", "sb3_ppo.py", "torchrl_rollout.py"]
    table = (EXAMPLES / "README.md").read_text()
    section = (ROOT / "docs" / "rl-libraries.md").read_text()
    for name in files:
        assert name in table
        assert f"examples/{name}" in section
    for extra in ("[train]", "[ray]", "[torchrl]", "[zoo]"):
        assert extra in section
