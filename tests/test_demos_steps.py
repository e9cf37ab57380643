"""`aaai demos`: every step an episode took is in its Minari dataset.

Minari's episode holds the observations after reset and after every step (the terminal one
included: one more than the actions), and one action, reward, termination and truncation per step,
with only the last step ending the episode. The steps are counted at the environment itself, while
the command records, so a recording that drops or adds a step cannot agree with itself by replaying
its own actions.
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from aaai.env import AnimalAIEnv

minari = pytest.importorskip("minari", reason="needs the demos extra")


@pytest.fixture
def counted_steps(monkeypatch):
    """The steps and ends of every episode the environment plays, as the environment saw them."""
    episodes: list[dict] = []
    reset, step = AnimalAIEnv.reset, AnimalAIEnv.step

    def counting_reset(self, *args, **kwargs):
        episodes.append({"steps": 0, "terminated": False, "truncated": False})
        return reset(self, *args, **kwargs)

    def counting_step(self, action):
        result = step(self, action)
        episodes[-1]["steps"] += 1
        episodes[-1]["terminated"], episodes[-1]["truncated"] = bool(result[2]), bool(result[3])
        return result

    monkeypatch.setattr(AnimalAIEnv, "reset", counting_reset)
    monkeypatch.setattr(AnimalAIEnv, "step", counting_step)
    return episodes


def test_each_minari_episode_holds_every_step_the_env_took(tmp_path, counted_steps):
    from aaai.scoring.demos import datasets_path
    from aaai_cli.main import cli

    config = tmp_path / "config.yaml"
    config.write_text(yaml.safe_dump({"episode": {"max_steps": 150}}))
    out = tmp_path / "demos"
    # L0 at difficulty 0: the reference controller reaches the food (terminated) within 150 steps;
    # L3 at 10 it does not (truncated at 150): one episode of each end
    command = ["demos", "--policy", "reference", "--levels", "0,3", "--difficulty", "0,10", "-k", "1"]
    command += ["--seeds", "5", "--action-mode", "gait", "--config", str(config), "--out", str(out)]
    result = CliRunner().invoke(cli, command)
    assert result.exit_code == 0, result.output
    played = [e for e in counted_steps if e["steps"]]  # the command may reset once before playing
    with datasets_path(out):
        dataset = minari.load_dataset("aaai/reference-v0")
        assert dataset.total_episodes == len(played) == 4
        ends = set()
        for index, env_saw in enumerate(played):
            episode = dataset[index]
            steps = env_saw["steps"]
            assert len(episode.actions) == len(episode.rewards) == steps
            assert len(episode.terminations) == len(episode.truncations) == steps
            for key, value in episode.observations.items():
                assert len(value) == steps + 1, key  # after reset, then after each step (the terminal one too)
            assert bool(episode.terminations[-1]) == env_saw["terminated"]
            assert bool(episode.truncations[-1]) == env_saw["truncated"]
            assert not np.any(episode.terminations[:-1]) and not np.any(episode.truncations[:-1])
            ends.add("terminated" if env_saw["terminated"] else "truncated")
        assert ends == {"terminated", "truncated"}
        assert dataset.total_steps == sum(e["steps"] for e in played)
