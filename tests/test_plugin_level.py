"""Levels are plug-ins: a 14th level made of a generator module and a level file outside the
package runs through every tool with no other change."""

import csv
import json
import os
import subprocess
import sys
import textwrap

import gymnasium as gym
import numpy as np
import pytest
from click.testing import CliRunner

from aaai.config import ConfigError, load_config
from aaai.env import AnimalAIEnv
from aaai.levels import all_levels, generate, get_level, validate
from aaai.registration import register_envs
from aaai_cli.main import cli

GENERATOR = '''
"""A test level: the food straight ahead of the agent, farther with the difficulty."""
from aaai.levels.common import arena_walls, sphere

PARAMETERS = ("distance",)


def generate(p, rng):
    yaw = float(rng.uniform(-3.14, 3.14))
    import math
    distance = float(p["distance"])
    food = sphere("food_green", distance * math.cos(yaw), distance * math.sin(yaw), 2.0)
    return {"agent": (0.0, 0.0, yaw), "objects": arena_walls((40.0, 40.0), 3.0) + [food],
            "max_food_reward": food.food_value, "arena_size": (40.0, 40.0)}
'''

LEVEL_FILE = """
id: 13
name: straight_ahead
title: Straight ahead
label: L13
generator: plugin_levels_straight
time_limit: 30
params:
  distance: "8 + d"
"""


@pytest.fixture
def plugin(tmp_path, monkeypatch):
    code, levels = tmp_path / "code", tmp_path / "levels"
    code.mkdir()
    levels.mkdir()
    (code / "plugin_levels_straight.py").write_text(textwrap.dedent(GENERATOR))
    (levels / "L13.yaml").write_text(textwrap.dedent(LEVEL_FILE))
    monkeypatch.syspath_prepend(str(code))
    monkeypatch.setenv("AAAI_LEVELS", str(levels))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(code), os.environ.get("PYTHONPATH", "")]))
    register_envs()
    return tmp_path


def aaai(*args, cwd):
    result = subprocess.run(
        [sys.executable, "-m", "aaai_cli.main", *map(str, args)], capture_output=True, text=True, cwd=cwd
    )
    assert result.returncode == 0, f"aaai {' '.join(map(str, args))}:\n{result.stdout}\n{result.stderr}"
    return result.stdout


def aaai_here(*args):
    """``aaai(*args)`` in this process (click's runner), where the fixture has put AAAI_LEVELS and the
    generator's folder on the path: no interpreter and imports to start again for each command."""
    result = CliRunner().invoke(cli, list(map(str, args)))
    assert result.exit_code == 0, f"aaai {' '.join(map(str, args))}:\n{result.output}"
    return result.stdout


def test_a_fourteenth_level_runs_in_python(plugin):
    assert sorted(all_levels()) == list(range(14)) and get_level("straight_ahead").id == 13
    spec = generate(13, 4, 99)
    assert spec == generate(13, 4, 99) and validate.check(spec) == []
    food = next(o for o in spec.objects if o.is_food)
    assert np.hypot(*food.position[:2]) == pytest.approx(12.0)  # "8 + d" at d = 4
    assert load_config(level=13).level == 13
    env = AnimalAIEnv(level=13, difficulty=4)
    try:
        _, info = env.reset(seed=5)
        assert info["level_name"] == "straight_ahead" and info["max_steps"] == 1500  # 30 s of 0.02 s steps
        assert env.step(env.action_space.sample())[4]["level"] == 13
    finally:
        env.close()
    made = gym.make("aaai/L13-StraightAhead-v0")
    assert made.reset(seed=1)[1]["level"] == 13
    made.close()


def test_a_fourteenth_level_runs_through_every_command(plugin, monkeypatch):
    # a new process finds the level by AAAI_LEVELS and PYTHONPATH alone; the other commands run here
    listing = aaai("levels", cwd=plugin)
    assert "L13" in listing and "aaai/L13-StraightAhead-v0" in listing
    monkeypatch.chdir(plugin)
    spec = json.loads(aaai_here("spec", "L13", "-d", "2", "--json"))
    assert spec["name"] == "straight_ahead"
    total = aaai_here("validate", "--levels", "13", "--seeds", "3").splitlines()[-1].split()
    assert total == ["total", "33", "0", "0"]  # 11 difficulties x 3 seeds checked, none regenerated or failed
    aaai_here("show", "13", "-o", plugin / "l13.png")
    assert (plugin / "l13.png").stat().st_size > 1000
    assert "straight_ahead" in aaai_here("run", "--levels", "13", "--episodes", "1", "--max-steps", "20")
    aaai_here(
        "eval",
        "--seeds",
        "reserved",
        "--policy",
        "reference",
        "--levels",
        "13",
        "--difficulty",
        "0",
        "-k",
        "2",
        "--out",
        plugin / "board.csv",
    )
    with open(plugin / "board.csv") as handle:
        rows = list(csv.DictReader(handle))
    assert [row["level"] for row in rows] == ["13", "13"]
    assert all(row["outcome"] in ("passed", "succeeded") for row in rows)  # the reference walks to it


def test_plugin_level_files_are_checked(tmp_path, monkeypatch):
    folder = tmp_path / "levels"
    folder.mkdir()
    (folder / "L5.yaml").write_text(
        textwrap.dedent(LEVEL_FILE)
        .replace("id: 13", "id: 5")
        .replace("plugin_levels_straight", "food_contact")
        .replace("distance", "x")
    )
    taken = get_level(5).name
    monkeypatch.setenv("AAAI_LEVELS", str(folder))
    with pytest.raises(ConfigError, match=r"levels/L5.yaml: level id 5 is taken by L5.yaml \(" + taken):
        all_levels()
    (folder / "L5.yaml").write_text(textwrap.dedent(LEVEL_FILE).replace("plugin_levels_straight", "no_such_module"))
    with pytest.raises(ConfigError, match=r"generator 'no_such_module' cannot be imported"):
        all_levels()
    monkeypatch.setenv("AAAI_LEVELS", str(tmp_path / "missing"))
    with pytest.raises(ConfigError, match="AAAI_LEVELS: got .*missing.*not a folder"):
        all_levels()


def test_an_unregistered_level_id_is_refused_with_the_registered_ones():
    with pytest.raises(
        ConfigError,
        match=r"config key 'level': got 13, and level 13 does not exist; allowed: "
        r"registered level ids 0 to 12",
    ):
        load_config(level=13)
