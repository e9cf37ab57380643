"""Where a student is when L8's food goes out of sight, and which side it walks round the occluder.

For each L8 episode (the first K reserved seeds of each difficulty) a student plays as `aaai eval`
plays it, and at every step this reads whether its rays show food (aaai.scoring.diagnose.food_in_view,
as `aaai diagnose` reads it) and where its head is. It writes one row per episode:
  food_side     +1 east, -1 west (the level's draw; the pit is on the other side)
  hidden_step   the first decision, after the food was seen, from which no ray hits it for 10 decisions (1 s)
  heading_side  the side the head faces at that decision (its forward x-component beyond 0.2; 0: ahead)
  moved_side    the side the head has moved to from its start by then (beyond 1 unit; 0: not so far)
  round_side    the side of the head's x when it first passes the occluder's line (y = 0)
  (the three sides are relative to the food's: +1 its side, -1 the pit's)
  seen_share    the share of its decisions at which a ray hit the food
  seen_before_round  whether a ray hit the food in the 10 decisions (1 s) before it passed y = 0
  passed        the episode's outcome (ratio >= 0.8)

    python experiments/students/l8_side.py MODEL.zip OUT.csv [-k 4]
"""

from __future__ import annotations

import argparse
import csv

import numpy as np

from aaai.config import env_part
from aaai.env import AnimalAIEnv
from aaai.levels.seeds import reserved_seeds
from aaai.scoring.diagnose import food_in_view
from aaai.scoring.episodes import outcome, play
from aaai.scoring.policies import resolve

HIDDEN_RUN = 10  # decisions (0.1 s each in gait mode): 1 s with no ray on the food
FACING = 0.2  # a heading whose x-component is smaller than this faces neither side (0)


def sign(value: float, dead: float = 1e-9) -> int:
    return 0 if abs(value) < dead else (1 if value > 0 else -1)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("model")
    parser.add_argument("out")
    parser.add_argument("-k", type=int, default=4)
    args = parser.parse_args()
    policy_spec = resolve(args.model)
    env = AnimalAIEnv(config=env_part(policy_spec.play_config(), shaping=0.0))  # as aaai eval scores
    acting = policy_spec.build(env)
    rows = []
    for difficulty in range(11):
        for seed in reserved_seeds(8, difficulty, args.k):
            trace: list[tuple[bool, np.ndarray, np.ndarray]] = []

            def look(observation, trace=trace) -> None:  # what each decision sees, and where the head is
                head, rotation = env.body.head_pose()
                trace.append((food_in_view(observation), head.copy(), rotation[:, 0].copy()))

            result = play(
                env,
                acting,
                seed,
                options={"level": 8, "difficulty": difficulty},
                on_reset=lambda observation, info: look(observation),
                on_step=lambda step, observation, reward, info: look(observation),
            )
            info = result.info
            ratio = result.episode_return / info["max_reward"]
            side = 1 if env.world.spec.extras["food_side"] == "east" else -1
            seen = [s for s, _, _ in trace]
            hidden = next(
                (
                    i
                    for i in range(len(seen))
                    if any(seen[:i]) and not any(seen[i : i + HIDDEN_RUN]) and i + HIDDEN_RUN <= len(seen)
                ),
                None,
            )
            start = trace[0][1]
            heading = moved = None
            if hidden is not None:
                heading = sign(trace[hidden][2][0], FACING)
                moved = sign(trace[hidden][1][0] - start[0], 1.0)
            crossing_step = next((i for i, (_, h, _) in enumerate(trace) if h[1] > 0.0), None)
            crossing = None if crossing_step is None else trace[crossing_step][1]
            seen_before = (
                "" if crossing_step is None else int(any(seen[max(0, crossing_step - HIDDEN_RUN) : crossing_step + 1]))
            )
            rows.append(
                {
                    "difficulty": difficulty,
                    "seed": seed,
                    "food_side": side,
                    "hidden_step": hidden if hidden is not None else "",
                    "heading_side": "" if heading is None else heading * side,
                    "moved_side": "" if moved is None else moved * side,
                    "round_side": "" if crossing is None else sign(crossing[0]) * side,
                    "seen_share": round(sum(seen) / len(seen), 3),
                    "seen_before_round": seen_before,
                    "passed": int(outcome(ratio, result.episode_return, None) != "failed"),
                    "steps": result.steps,
                }
            )
            print(rows[-1], flush=True)
    env.close()
    with open(args.out, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    passed = [r for r in rows if r["passed"]]
    for key in ("heading_side", "moved_side", "round_side", "seen_before_round"):
        counts = {value: sum(r[key] == value for r in rows) for value in (1, 0, -1, "")}
        won = {value: sum(r[key] == value for r in passed) for value in (1, 0, -1, "")}
        print(f"{key}: food's side / neither / pit's side / never: {counts}; of the passed: {won}")
    print(f"passed {len(passed)} of {len(rows)}")


if __name__ == "__main__":
    main()
