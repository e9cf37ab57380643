"""The reference controller crosses the L10 trench by walking round behind the standing plank and
pushing it over as a bridge. Without the push its planner still knocks the plank down sooner or
later, so only time tells them apart: on this pinned reserved seed the reference passes in 1,687
control steps with the push and needs 4,857 without it (measured; the episode repeats bit for bit)."""

import math

import pybullet as p

from aaai.env import AnimalAIEnv
from aaai.task.reference import ReferenceController

LEVEL, DIFFICULTY, SEED = 10, 0, 1400196827  # a reserved seed: food across the trench, a standing plank


def test_the_reference_pushes_the_plank_over_and_crosses_on_it_in_time():
    env = AnimalAIEnv()
    try:
        controller = ReferenceController(env)
        observation, _ = env.reset(seed=SEED, options={"level": LEVEL, "difficulty": DIFFICULTY})
        controller.reset()
        (plank,) = [body for body, obj in env.world.objects.items() if obj.kind == "plank" and obj.mass > 0]
        trench_far_y = env.level_spec.extras["trench"][1]
        fell_at = crossed_at = None
        total, steps, done = 0.0, 0, False
        while not done:
            observation, reward, terminated, truncated, _ = env.step(controller(observation))
            total, steps, done = total + reward, steps + 1, terminated or truncated
            orientation = p.getBasePositionAndOrientation(plank, physicsClientId=env.client)[1]
            if fell_at is None and p.getMatrixFromQuaternion(orientation)[8] < math.cos(math.radians(60)):
                fell_at = steps
            if crossed_at is None and env.body.head_pose()[0][1] > trench_far_y:
                crossed_at = steps
        assert terminated and total > 0  # the food eaten
        assert fell_at is not None and crossed_at is not None and fell_at < crossed_at  # over the plank, once down
        assert steps < 2500  # pushed, not bumped into: 1,687 steps with the push, 4,857 without
    finally:
        env.close()
