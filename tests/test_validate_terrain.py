"""Heights the body walks on (aaai.levels.validate.surface_heights): a ramp no steeper than
RAMP_MAX_RISE leads on to a platform and the food on it is in reach, a hair steeper and it is an
obstacle; a start on a raised floor wide enough for the body is clear, and the body stays on it (it
does not step down from it); the rim of a platform is kept clear of, as a wall is."""

import pytest

from aaai.levels.validate import RAMP_MAX_RISE, check

HEIGHT = 5.0


def arena(tmp_path, body: str) -> str:
    path = tmp_path / "a.yaml"
    path.write_text("arena_size: [100.0, 100.0]\ntime_limit: 100\n" + body)
    from aaai.task.arena import parse_arena

    return check(parse_arena(path, 0)[0])


def ramp_to_platform(length: float) -> str:
    """A platform 30 x 40 (x from 15 to 45), HEIGHT high; a ramp 20 wide whose high end meets its
    west side; the start on the floor west of the ramp; food on the platform."""
    return (
        "agent: {x: -40.0, y: 0.0, yaw: 0.0}\nobjects:\n"
        f"  - {{kind: wall, position: [30.0, 0.0, {HEIGHT / 2}], size: [30.0, 40.0, {HEIGHT}]}}\n"
        f"  - {{kind: ramp, position: [{15.0 - length / 2}, 0.0, {HEIGHT / 2}], size: [{length}, 20.0, {HEIGHT}]}}\n"
        f"  - {{kind: food_green, shape: sphere, position: [32.0, 0.0, {HEIGHT + 1.5}], size: [3.0, 3.0, 3.0]}}\n"
    )


@pytest.mark.parametrize("rise, walked", [(RAMP_MAX_RISE, True), (RAMP_MAX_RISE + 0.005, False)])
def test_food_on_a_platform_is_in_reach_up_a_ramp_the_body_climbs(tmp_path, rise, walked):
    problems = arena(tmp_path, ramp_to_platform(HEIGHT / rise))
    assert (problems == []) == walked
    if not walked:
        assert any("cannot be reached" in p for p in problems)


def test_a_platform_without_a_ramp_is_out_of_reach(tmp_path):
    text = ramp_to_platform(HEIGHT / RAMP_MAX_RISE).splitlines()
    text = "\n".join(line for line in text if "ramp" not in line) + "\n"
    assert any("cannot be reached" in p for p in arena(tmp_path, text))


RAISED = (
    "agent: {x: 0.0, y: 0.0, yaw: 0.0}\nobjects:\n"
    "  - {kind: wall, position: [0.0, 0.0, 1.5], size: [WIDE, 40.0, 3.0]}\n"  # a raised floor 3 high
)


def test_a_start_on_a_raised_floor_is_clear_and_its_food_in_reach(tmp_path):
    on_top = "  - {kind: food_green, shape: sphere, position: [10.0, 0.0, 4.5], size: [3.0, 3.0, 3.0]}\n"
    assert arena(tmp_path, RAISED.replace("WIDE", "40.0") + on_top) == []


def test_the_body_does_not_step_down_from_a_raised_floor(tmp_path):
    below = "  - {kind: food_green, shape: sphere, position: [35.0, 0.0, 1.5], size: [3.0, 3.0, 3.0]}\n"
    problems = arena(tmp_path, RAISED.replace("WIDE", "40.0") + below)
    assert len(problems) == 1 and "cannot be reached" in problems[0]


@pytest.mark.parametrize("wide, clear", [(11.5, True), (10.5, False)])
def test_a_raised_floor_must_hold_the_body_clear_of_its_rims(tmp_path, wide, clear):
    # the body needs its footprint (5) clear of the rim: the top's edge cells are the rim
    on_top = "  - {kind: food_green, shape: sphere, position: [0.0, 10.0, 4.5], size: [3.0, 3.0, 3.0]}\n"
    problems = arena(tmp_path, RAISED.replace("WIDE", str(wide)) + on_top)
    assert (not any("is not clear" in p for p in problems)) == clear


def test_the_reference_walks_up_a_ramp_and_eats_the_food_on_the_platform(make_env, tmp_path):
    from conftest import reference_on_arena

    text = "arena_size: [100.0, 100.0]\ntime_limit: 100\n" + ramp_to_platform(HEIGHT / RAMP_MAX_RISE)
    env, controller = reference_on_arena(make_env, tmp_path, text)
    highest = 0.0
    for _ in range(1200):
        _, _, terminated, truncated, info = env.step(controller())
        highest = max(highest, env.body.head_pose()[0][2])
        if terminated or truncated:
            break
    assert terminated and info["food_eaten"] == 1 and info["wall_hits"] == 0
    assert highest > HEIGHT + 1.5, highest  # it stood on the platform
