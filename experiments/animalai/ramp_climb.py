"""Which ramps does the quadruped's gait walk up? (experiments/animalai/ramps.md)

A ramp H high over L (180 across, rising along +x) onto a platform H high, in an arena 200 across (an
import's scale); the body starts 12 before the ramp's foot, facing it, and holds the gait's full
forward command (no turn, no crouch) for 60 s. Prints, per ramp, its slope, the head's highest point,
where the head ended and whether it got on to the platform (or ate the food on it).

    python experiments/animalai/ramp_climb.py
    python experiments/animalai/ramp_climb.py --crouch 0.25 0.5 0.75 1.0   # the steep ramps, crouched
    python experiments/animalai/ramp_climb.py --grip 2.0   # the steep ramps, gripping 4 times as hard
"""

import math
import pathlib
import tempfile

import numpy as np
import pybullet as p

from aaai.env import AnimalAIEnv
from aaai.task.arena import parse_arena


def trial(L, H, seconds=60.0, crouch=0.0, grip=None):
    text = f"""description: ramp {L} x {H}
arena_walls: true
arena_size: [200.0, 200.0]
wall_height: 20.0
time_limit: 200
agent: {{x: {-L / 2 - 12:.2f}, y: 0.0, yaw: 0.0}}
objects:
  - {{kind: ramp, position: [0.0, 0.0, {H / 2:.3f}], size: [{L}, 180.0, {H}], yaw: 0.0}}
  - {{kind: wall, position: [{L / 2 + 20:.2f}, 0.0, {H / 2:.3f}], size: [40.0, 180.0, {H}], yaw: 0.0}}
  - {{kind: food_green, shape: sphere, position: [{L / 2 + 30:.2f}, 0.0, {H + 1.5:.2f}], size: [3.0, 3.0, 3.0]}}
"""
    d = pathlib.Path(tempfile.mkdtemp())
    (d / "a.yaml").write_text(text)
    spec, _, _ = parse_arena(d / "a.yaml")
    env = AnimalAIEnv(action_mode="gait", rays=False)
    env.reset(seed=0, options={"spec": spec, "check": False})
    if grip is not None:  # the ramp's own friction (Bullet multiplies it by the feet's 1.0; the default is 0.5)
        for body, obj in env.world.objects.items():
            if obj.kind == "ramp":
                p.changeDynamics(body, -1, lateralFriction=grip, physicsClientId=env.world.client)
    top, xs = -1e9, []
    n = int(seconds / 0.1)
    end = "time"  # out of time, still on the way
    for i in range(n):
        _, _, term, trunc, _ = env.step(np.array([1.0, 0.0, crouch]))
        pos, _ = p.getBasePositionAndOrientation(env.body.id, physicsClientId=env.body.client)
        top = max(top, pos[2])
        xs.append(pos[0])
        if term or trunc:
            end = "ate" if term else "truncated"
            break
    env.close()
    return dict(
        L=L,
        H=H,
        deg=round(math.degrees(math.atan2(H, L)), 1),
        top=round(top, 2),
        x_end=round(xs[-1], 1),
        on_top=xs[-1] > L / 2,
        end=end,
        steps=i + 1,
    )


STEEP = [(17.5, 5), (14, 5), (12.5, 5), (33.3, 10), (25, 10)]  # 15.9° to 21.8°: those it did not climb upright
BATTERY = [(12.5, 5), (10, 5), (9, 5), (7, 5), (5, 5)]  # 21.8° to 45°: the slopes of the ramps the battery needs

if __name__ == "__main__":
    import sys

    if sys.argv[1:2] == ["--crouch"]:
        for crouch in map(float, sys.argv[2:]):
            for L, H in STEEP:
                print({"crouch": crouch, **trial(L, H, crouch=crouch)}, flush=True)
        raise SystemExit
    if sys.argv[1:2] == ["--grip"]:
        for grip in map(float, sys.argv[2:]):
            for crouch in (0.0, 0.5):
                for L, H in BATTERY:
                    print({"grip": grip, "crouch": crouch, **trial(L, H, crouch=crouch, grip=grip)}, flush=True)
        raise SystemExit
    for L, H in [
        (50, 5),
        (35, 5),
        (25, 5),
        (17.5, 5),
        (14, 5),
        (12.5, 5),
        (10, 5),
        (7, 5),
        (5, 5),
        (100, 10),
        (50, 10),
        (33.3, 10),
        (25, 10),
    ]:
        print(trial(L, H), flush=True)
