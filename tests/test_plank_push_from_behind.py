"""L10: the reference controller pushes the standing plank over squarely, facing the trench, and
crosses on it to the food. Tested by running physics from the level's own start and from set-ups
with the body teleported beside or behind the plank. Without the deliberate push the body only
knocks the plank over on its way (at a slant, or too late to reach the food in time)."""

import math
from dataclasses import replace

import pybullet as p
import pytest

from aaai.env import AnimalAIEnv
from aaai.levels import generate
from aaai.levels.seeds import reserved_seeds
from aaai.spec import AgentPose
from aaai.task.reference import PUSH_ALIGN, ReferenceController

STEPS = 2000  # 200 simulated seconds: the reference crosses in 110 to 160 from these starts
TIPPED = math.cos(math.radians(20))  # the plank's up axis this far from vertical: it is falling


@pytest.fixture(scope="module")
def reference():
    env = AnimalAIEnv(max_steps=STEPS)
    yield env, ReferenceController(env)
    env.close()


def start(spec, where: str) -> AgentPose:
    plank = next(o for o in spec.objects if o.kind == "plank")
    x, face = plank.position[0], spec.bridge[1]
    if where == "level":
        return spec.agent
    if where == "beside":  # 12 to the side of the plank's middle, 10 short of it, facing the trench
        return AgentPose(x + 12.0 if x < 0 else x - 12.0, face - 10.0, math.pi / 2)
    return AgentPose(x, face - 6.0, -math.pi / 2)  # "behind": right behind it, facing away


@pytest.mark.parametrize("where", ["level", "beside", "behind"])
def test_the_reference_pushes_the_l10_plank_over_squarely_and_crosses_on_it(reference, where):
    env, controller = reference
    spec = generate(10, 2, reserved_seeds(10, 2, 1)[0])
    observation, _ = env.reset(options={"spec": replace(spec, agent=start(spec, where)), "check": False})
    controller.reset()
    plank = next(body for body, obj in env.world.objects.items() if obj.kind == "plank")
    facing = None  # the body's heading when the plank began to fall
    for _ in range(STEPS):
        observation, _, terminated, truncated, info = env.step(controller(observation))
        orientation = p.getBasePositionAndOrientation(plank, physicsClientId=env.client)[1]
        if facing is None and p.getMatrixFromQuaternion(orientation)[8] < TIPPED:
            rotation = env.body.head_pose()[1]
            facing = math.atan2(rotation[1, 0], rotation[0, 0])
        if terminated or truncated:
            break
    assert facing is not None, "the plank never fell"
    assert abs(facing - math.pi / 2) < PUSH_ALIGN / 2, math.degrees(facing)  # pushed facing the trench
    assert info["food_eaten"] == 1 and not info["fell"] and not truncated  # across on it, in time
