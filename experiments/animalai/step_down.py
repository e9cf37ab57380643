"""Does the quadruped land on its feet when it walks off a raised floor? (experiments/animalai/steps.md)

A wall H high, 60 long and 180 across (an imported Animal-AI raised floor) in an arena 200 across; the
body is put on its top 10 from its far edge, facing the edge (or facing away, to go off backwards),
and walks off it holding one gait command (forward or backward, at full or 0.4 speed, crouched or
not) until its body is 15 beyond the edge or 30 s have passed, then stands 5 s with no command. Prints,
per height and way, where it ended, how far its up axis turned from the sky on the way down
(``min_up``: 1 upright, 0 on its side, -1 on its back) and at the end (``up_end``).

    python experiments/animalai/step_down.py
"""

import numpy as np
import pybullet as p
from step_climb import LENGTH, wall_and_food  # this folder's: the same wall and food

from aaai.env import AnimalAIEnv

HEIGHTS = (2.0, 2.5, 5.0, 10.0, 15.0)  # Animal-AI's raised floors: 1, 2 and 3 units at scale 5
WAYS = (  # (forward command, crouch): the gait's commands held while it goes off
    (1.0, 0.0),
    (1.0, 0.5),
    (1.0, 1.0),
    (0.4, 0.0),
    (-1.0, 0.0),
    (-1.0, 1.0),
)


def trial(height: float, forward: float, crouch: float) -> dict:
    spec = wall_and_food("drop", 0.0, height, beyond=30.0)  # the body is put on the top below
    env = AnimalAIEnv(action_mode="gait", rays=False)
    env.reset(seed=0, options={"spec": spec, "check": False})
    client, body = env.body.client, env.body.id
    facing = p.getQuaternionFromEuler((0.0, 0.0, 0.0 if forward > 0 else np.pi))
    p.resetBasePositionAndOrientation(body, (LENGTH - 10.0, 0.0, height + 1.5), facing, physicsClientId=client)
    lowest = 1.0
    for _ in range(300):
        env.step(np.array([forward, 0.0, crouch]))
        pos, orientation = p.getBasePositionAndOrientation(body, physicsClientId=client)
        if pos[0] > LENGTH - 2.0:
            lowest = min(lowest, p.getMatrixFromQuaternion(orientation)[8])
        if pos[0] > LENGTH + 15.0:
            break
    for _ in range(50):
        env.step(np.array([0.0, 0.0, 0.0]))
    pos, orientation = p.getBasePositionAndOrientation(body, physicsClientId=client)
    env.close()
    return dict(
        H=height,
        forward=forward,
        crouch=crouch,
        x_end=round(pos[0] - LENGTH, 1),
        min_up=round(lowest, 2),
        up_end=round(p.getMatrixFromQuaternion(orientation)[8], 2),
    )


if __name__ == "__main__":
    for height in HEIGHTS:
        for forward, crouch in WAYS:
            print(trial(height, forward, crouch), flush=True)
