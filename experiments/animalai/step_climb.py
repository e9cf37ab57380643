"""Does the quadruped's gait walk on to a low box, along its top and off it? (experiments/animalai/steps.md)

A wall H high and 60 long (180 across, as an imported Animal-AI wall used as a bridge), its near face
12 ahead of the body's start in an arena 200 across; food on the floor 20 beyond its far end. The
body walks at the gait's full forward command, steered back on to the line y = 0 along +x (the turn
command 1.5 x the heading error plus 0.05 a unit off the line, clipped to -1..1; no crouch), for up
to 60 s. Prints, per height,
the head's highest point, whether it walked off the far end (its head beyond it), whether it ate
the food and the wall hits the reward counted (touching a wall's side; standing on its top is not
one).

    python experiments/animalai/step_climb.py
"""

import numpy as np
import pybullet as p

from aaai.env import AnimalAIEnv
from aaai.spec import AgentPose, LevelSpec, ObjectSpec

LENGTH = 60.0


def wall_and_food(name: str, near: float, height: float, beyond: float = 20.0) -> LevelSpec:
    """A wall ``height`` high, LENGTH long and 180 across from x = ``near`` on, food on the floor
    ``beyond`` its far end, the body at the origin facing it, in an arena 200 across (also step_down.py's)."""
    objects = (
        ObjectSpec("wall", "box", (near + LENGTH / 2, 0.0, height / 2), (LENGTH, 180.0, height)),
        ObjectSpec("food_green", "sphere", (near + LENGTH + beyond, 0.0, 1.5), (3.0, 3.0, 3.0)),
    )
    return LevelSpec(
        level=0,
        name=name,
        difficulty=0,
        seed=0,
        agent=AgentPose(0.0, 0.0, 0.0),
        objects=objects,
        max_food_reward=objects[1].food_value,
        arena_size=(200.0, 200.0),
        time_limit=200.0,
    )


def trial(height: float, seconds: float = 60.0) -> dict:
    spec = wall_and_food("step", 12.0, height)
    env = AnimalAIEnv(action_mode="gait", rays=False)
    env.reset(seed=0, options={"spec": spec, "check": False})
    top, hits, end = -1e9, 0, "time"
    turn = 0.0
    for step in range(int(seconds / 0.1)):
        _, _, term, trunc, info = env.step(np.array([1.0, turn, 0.0]))
        pos, orientation = p.getBasePositionAndOrientation(env.body.id, physicsClientId=env.body.client)
        yaw = p.getEulerFromQuaternion(orientation)[2]
        turn = float(np.clip(-1.5 * yaw - 0.05 * pos[1], -1.0, 1.0))  # positive: to the left
        top = max(top, pos[2])
        hits = info["wall_hits"]  # so far this episode
        if term or trunc:
            end = "ate" if term and not info.get("fell") else ("fell" if info.get("fell") else "truncated")
            break
    x = pos[0]
    env.close()
    return dict(
        H=height,
        head_top=round(top, 2),
        x_end=round(x, 1),
        off_far_end=x > LENGTH + 12,
        end=end,
        wall_hits=hits,
        steps=step + 1,
    )


if __name__ == "__main__":
    for height in (0.3, 0.5, 0.7, 0.9, 1.1, 1.3):
        print(trial(height), flush=True)
