"""A newcomer's first commands: an agent module in the current folder, and a command whose optional
extra is not installed."""

from __future__ import annotations

import sys

import pytest
from click.testing import CliRunner

from aaai_cli.main import cli

AGENT = (
    "import numpy as np\ndef make(env):\n    return lambda observation: np.zeros(env.action_space.shape, np.float32)\n"
)


def test_a_module_callable_in_the_current_folder_is_found_without_pythonpath(tmp_path, monkeypatch):
    (tmp_path / "myagent.py").write_text(AGENT)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p not in ("", str(tmp_path))])
    before = list(sys.path)
    try:
        result = CliRunner().invoke(
            cli, ["run", "--policy", "myagent:make", "--max-steps", "10", "--no-rays"], catch_exceptions=False
        )
    finally:
        sys.modules.pop("myagent", None)
    assert result.exit_code == 0, result.output
    assert sys.path == before  # the folder was importable for that import only


def _without(monkeypatch, package: str, *importers: str) -> None:
    """As if ``package`` were not installed: its import fails (modules that import it at their top,
    ``importers``, are imported again)."""
    for name in [m for m in sys.modules if m == package or m.startswith(package + ".")] or [package]:
        monkeypatch.setitem(sys.modules, name, None)
    for name in importers:
        monkeypatch.delitem(sys.modules, name, raising=False)


@pytest.mark.parametrize(
    "args, package, importers, extra",
    [
        (["demos", "--levels", "0", "--difficulty", "0", "--out", "{tmp}/demos"], "minari", (), "demos"),
        (["play", "L1", "--port", "0"], "fastapi", ("aaai.tools.play.server",), "play"),
        (
            ["eval", "--backend", "ray", "--levels", "0", "--difficulty", "0", "--seeds", "1", "--out", "{tmp}/b.csv"],
            "ray",
            ("aaai.scoring.distributed", "aaai.scoring.ray_session"),
            "ray",
        ),
    ],
    ids=["demos", "play", "eval-ray"],
)
def test_a_command_without_its_extra_says_in_one_line_which_to_install(
    tmp_path, monkeypatch, args, package, importers, extra
):
    _without(monkeypatch, package, *importers)
    result = CliRunner().invoke(cli, [a.format(tmp=tmp_path) for a in args])
    assert result.exit_code == 1, result.output
    command = "aaai " + args[0]
    assert result.output == (
        f"Error: {command} needs the {extra} extra ({package} is not installed): "
        f'pip install -e ".[{extra}]" in a checkout (make install-all installs every extra)\n'
    )


def test_tuning_the_gait_without_the_tune_extra_says_which_to_install(monkeypatch):
    from aaai.sim.gait import load_parameters
    from aaai.tools.gait_tuning import tune

    _without(monkeypatch, "cma")
    with pytest.raises(SystemExit, match=r"^tuning the gait needs the tune extra \(cma is not installed\): "):
        tune(1, False, 0, load_parameters())


def test_a_camera_model_is_scored_and_resumed(tmp_path):
    """training.md trains with --camera: its model (camera channel-first, as stable-baselines3 keeps
    it) is scored and trained on against the environment's channel-last camera."""
    pytest.importorskip("stable_baselines3", reason="needs the train extra")
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    from aaai.config import load_config
    from aaai.env import AnimalAIEnv
    from aaai.scoring.model_io import load_for_training
    from aaai.scoring.policies import resolve

    config = load_config({"episode": {"max_steps": 20}, "sensors": {"camera": True, "camera_resolution": 36}})
    env = AnimalAIEnv(config=config)
    try:
        assert env.observation_space["camera"].shape == (36, 36, 3)
        model = PPO("MultiInputPolicy", env, n_steps=16, batch_size=16, device="cpu", policy_kwargs={"net_arch": [8]})
        model.save(tmp_path / "model.zip")
        policy = resolve(str(tmp_path / "model.zip")).build(env)
        observation, _ = env.reset(seed=1)
        assert env.action_space.contains(policy(observation))
        resumed = load_for_training(tmp_path / "model.zip", DummyVecEnv([lambda: env]))
        assert resumed.observation_space["camera"].shape == (3, 36, 36)
    finally:
        env.close()
