"""The sphere (agent.body: sphere) on imported Animal-AI arenas: validation follows the body's own
footprint (``aaai validate --arena --body``, the environment's check, the scoring loop), and its
environment runs every imported arena valid for it, sized to that arena."""

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import AAI_AGENT, AAI_GOAL, AAI_WALL

from aaai.config import ConfigError
from aaai.env import AnimalAIEnv
from aaai.scoring.episodes import run_episode
from aaai.task.arena import footprint_for, load_arena
from aaai.tools.animalai import import_animalai
from aaai_cli.main import cli

HEAD = "!ArenaConfig\narenas:\n  0: !Arena\n    t: 250\n    items:\n"
AGENT = AAI_AGENT.replace("{r}", "0")
WALL, GOAL = AAI_WALL, AAI_GOAL
# A handful of Animal-AI arenas (its units: 40 across, the agent 1 across), as the competition's are
# written: one valid for both bodies, two for the sphere only, one for neither.
ARENAS = {
    # the agent in the open, food ahead
    "01-01-01.yaml": AGENT.format(x=20, z=10) + GOAL.format(x=20, z=30),
    # Animal-AI's agent 0.8 units from a wall behind it: our quadruped's footprint (radius 5 = 1 unit at
    # scale 5) does not fit there; the sphere, 1 across as Animal-AI's, does
    "01-02-01.yaml": AGENT.format(x=20, z=5) + WALL.format(x=20, z=3.7, sx=10, sz=1) + GOAL.format(x=20, z=30),
    # a passage 1.6 units wide (8 here) to the food: narrower than the quadruped, wider than the sphere
    "03-01-01.yaml": AGENT.format(x=20, z=5)
    + WALL.format(x=9.6, z=20, sx=19.2, sz=1)
    + WALL.format(x=30.4, z=20, sx=19.2, sz=1)
    + GOAL.format(x=20, z=30),
    # food inside a wall: valid for no body
    "04-01-01.yaml": AGENT.format(x=20, z=5) + WALL.format(x=20, z=30, sx=4, sz=4) + GOAL.format(x=20, z=30),
}
VALID = {"quadruped": {"01-01-01.yaml"}, "sphere": {"01-01-01.yaml", "01-02-01.yaml", "03-01-01.yaml"}}


@pytest.fixture(scope="module")
def battery(tmp_path_factory):
    """The handful imported as Animal-AI wrote them (not fitted to the quadruped: no start moved)."""
    folder = tmp_path_factory.mktemp("battery")
    source = folder / "src"
    source.mkdir()
    for name, items in ARENAS.items():
        (source / name).write_text(HEAD + items)
    import_animalai(source, folder / "out", echo=lambda line: None, fitted=False)
    return folder / "out"


@pytest.fixture(scope="module")
def sphere_env():
    environment = AnimalAIEnv(body="sphere")
    yield environment
    environment.close()


def _valid(path, body) -> bool:
    try:
        load_arena(path, 0, body=body)
    except ConfigError:
        return False
    return True


def test_an_imported_arena_is_validated_with_the_bodys_own_footprint(battery):
    assert footprint_for("quadruped", (200.0, 200.0)) == 5.0
    assert footprint_for("sphere", (200.0, 200.0)) == 3.0  # radius 2.5 (5 across) plus the grid's 0.5
    assert footprint_for("sphere") == 1.125  # the generated levels' sphere, 1.25 across
    for body, names in VALID.items():
        assert {path.name for path in sorted(battery.glob("*.yaml")) if _valid(path, body)} == names


def test_aaai_validate_arena_takes_the_body(battery):
    runner = CliRunner()
    start = str(battery / "01-02-01.yaml")
    refused = runner.invoke(cli, ["validate", "--arena", start, "--seeds", "1"])
    assert refused.exit_code == 1 and "a body of radius 5.0 there meets" in refused.output
    accepted = runner.invoke(cli, ["validate", "--arena", start, "--seeds", "1", "--body", "sphere"])
    assert accepted.exit_code == 0, accepted.output
    assert "1 arena files, 0 with problems" in accepted.output
    wrong = runner.invoke(cli, ["validate", "--arena", start, "--body", "blob"])
    assert wrong.exit_code == 2 and "'blob' is not one of" in wrong.output and "sphere" in wrong.output
    levels = runner.invoke(cli, ["validate", "--levels", "0", "--seeds", "1", "--body", "sphere"])
    assert levels.exit_code == 2 and "--body applies to --arena files only" in levels.output


def test_the_environment_checks_an_arena_for_its_own_body(battery, sphere_env):
    passage = str(battery / "03-01-01.yaml")
    with pytest.raises(ConfigError, match="cannot be reached|pass mark"):
        AnimalAIEnv(arena=passage)  # the quadruped's env refuses it on construction
    env = AnimalAIEnv(body="sphere", arena=passage)
    try:
        env.reset(seed=0)
        assert env.body.radius == pytest.approx(2.5)
    finally:
        env.close()
    # a reset with an arena file's spec checks it for the body at that arena's scale
    near_wall = load_arena(battery / "01-02-01.yaml", 0, body="sphere")
    sphere_env.reset(seed=0, options={"spec": near_wall, "arena_file": True})
    with pytest.raises(ConfigError, match="radius 5.0"):
        quadruped = AnimalAIEnv()
        try:
            quadruped.reset(seed=0, options={"spec": near_wall, "arena_file": True})
        finally:
            quadruped.close()


def test_the_spheres_environment_runs_every_imported_arena_valid_for_it_sized_to_it(battery, sphere_env):
    for name in sorted(VALID["sphere"]):
        spec = load_arena(battery / name, 0, body="sphere")
        sphere_env.reset(seed=0, options={"spec": spec, "check": False, "arena_file": True})
        assert sphere_env.body.radius == pytest.approx(2.5)  # 5 across in the arena 200 across
        for _ in range(5):
            observation, *_ = sphere_env.step(np.array([1.0, 0.0, 0.0], np.float32))
            assert all(np.all(np.isfinite(value)) for value in observation.values())
    # the scoring loop sizes it so too (it passes the arena's spec to reset), and refuses nothing valid for it
    ahead = np.array([1.0, 0.0, 0.0], np.float32)  # the food lies straight ahead
    row = run_episode(sphere_env, lambda observation: ahead, 0, 0, 0, battery / "01-02-01.yaml")
    assert sphere_env.body.radius == pytest.approx(2.5)
    assert row["food_eaten"] == 1 and row["steps"] < 200  # 145 units in under 4 s: the sphere's speed there
