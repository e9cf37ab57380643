"""AnimalAIEnv: the quadruped in one level of the test bench, as a Gymnasium environment.

The class wires small parts together, one job each: a PyBullet client (aaai.sim.simulation), the
body (aaai.agent.body), the level's bodies (aaai.sim.world), the senses (aaai.sim.sensors) and the task,
which turns contacts into rewards and ends episodes (aaai.task.rewards).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pybullet as p
from gymnasium import spaces

from aaai.agent.body import Quadruped
from aaai.config import ConfigError, env_keywords, load_config
from aaai.levels import check_difficulty, episode_rngs, generate, get_level
from aaai.sim.gait import SineGait
from aaai.sim.sensors import Senses, render_rgb
from aaai.sim.simulation import Simulation, display_available
from aaai.sim.snapshot import Leg, Pose, Snapshot
from aaai.sim.world import World
from aaai.spec import LevelSpec
from aaai.task import validate
from aaai.task.arena import load_arena
from aaai.task.rewards import TERMS, FoodTask
from aaai.task.seeds import TRAIN_SEEDS

RESET_OPTIONS = ("level", "difficulty", "spec", "check")
RENDER_SIZE = (320, 240)
SCORE_ALLOWANCE = 0.5  # max_reward = best food reward - this, allowing for step costs
BLOWUP_MARGIN = 20.0  # how far beyond the arena's half-size a body may be before it "flew off"


GAIT_LOW, GAIT_HIGH = (-1.0, -1.0, 0.0), (1.0, 1.0, 1.0)  # gait mode: forward, turn, crouch


def hold_steps(decision_interval: float, control_dt: float) -> int:
    """Control steps per gait-mode action: ``decision_interval`` as a whole number of control steps."""
    steps = decision_interval / control_dt
    if not math.isfinite(steps) or steps < 1 - 1e-9 or abs(steps - round(steps)) > 1e-6:
        raise ConfigError(
            f"config key 'agent.decision_interval': got {decision_interval!r} s; allowed: a whole number "
            f"of control steps of {control_dt:g} s (physics.timestep x physics.action_repeat), "
            f"e.g. {control_dt:g}, {2 * control_dt:g} or {5 * control_dt:g}"
        )
    return int(round(steps))


class AnimalAIEnv(gym.Env):
    """A limbed agent that must find food in a seeded, difficulty-scaled level.

    Actions: Box(-1, 1, (8,)): a target angle (``action_mode: rotation``, the default) or speed
    (``velocity``) for each of the eight joints, scaled to the joint's range, one per control step
    (0.02 s). With ``action_mode: gait``, Box([-1, -1, 0], [1, 1, 1]): the forward, turn and
    crouch commands of the tuned steerable gait (aaai.sim.gait), each held for ``decision_interval``
    seconds (default 0.1 s, 5 control steps); reward and reward terms are summed over the held
    steps and ``info["steps"]`` still counts control steps.

    Observations: a Dict: ``joints`` (8,) always; ``rays``, ``camera``, ``joint_velocities``,
    ``head_orientation`` and ``foot_contacts`` as the ``sensors`` config turns them on (docs/environment.md,
    "Observations").

    Rewards: the sum of the terms in ``info["reward_terms"]`` (step, ground, food, wall, fall,
    shaping); see aaai.task.rewards.

    Episode end: terminated when the green food is eaten, the agent falls, or no food it can reach
    is left; truncated at T steps (``max_steps``; "auto": the level's time limit) or on a physics
    blow-up (``info["blew_up"]``).

    Args:
        level: level id 0..12, label ("L1", "L2b") or name ("food_retrieval").
        difficulty: 0..10.
        arena: an arena file (aaai.task.arena, docs/writing-levels.md): every reset loads it with
            the episode's seed instead of generating ``level`` (a reset with ``options={"spec": …}``
            still runs that spec).
        config: a YAML path or nested mapping overriding configs/default.yaml.
        render_mode: None, "rgb_array" (a third-person view) or "human" (PyBullet's GUI).
        **overrides: any configuration key by its short name, e.g. ``camera=True``,
            ``camera_resolution=64``, ``max_steps=500``, ``body="quadruped16"``.
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 50}

    def __init__(
        self,
        level: int | str | None = None,
        difficulty: int | None = None,
        config: Any = None,
        render_mode: str | None = None,
        arena: str | None = None,
        **overrides: Any,
    ):
        unexpected = sorted(set(overrides) - env_keywords())
        if unexpected:  # worded as Python's own error, which libraries that probe keywords expect
            raise TypeError(
                f"AnimalAIEnv.__init__() got an unexpected keyword argument '{unexpected[0]}'; allowed: "
                + ", ".join(["config", "render_mode", "arena", *sorted(env_keywords() | {"level", "difficulty"})])
            )
        if level is not None:
            overrides["level"] = get_level(level).id
        if difficulty is not None:
            overrides["difficulty"] = check_difficulty(difficulty)
        self.config = cfg = load_config(config, **overrides)
        self.arena = None
        if arena is not None:  # checked now (its seed-0 instance), so that a bad file fails here
            if not isinstance(arena, (str, Path)):
                raise ConfigError(f"arena: got {arena!r}; allowed: an arena file's path")
            load_arena(arena, 0)
            self.arena = str(arena)
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ConfigError(f"render_mode: got {render_mode!r}; allowed: None, 'rgb_array', 'human'")
        self.render_mode = render_mode
        # Instance metadata lists the modes this machine can show: no "human" without a display.
        self.metadata = {**self.metadata, "render_modes": ["rgb_array"] + (["human"] if display_available() else [])}
        self.level, self.difficulty = cfg["level"], cfg["difficulty"]
        self._blowup_speed_sq = cfg["physics"]["blowup_speed"] ** 2
        self.sim = Simulation(cfg["physics"], gui=render_mode == "human")
        self.client, self.control_dt = self.sim.client, self.sim.control_dt  # simulated s per step
        agent = cfg["agent"]
        self.action_mode = agent["action_mode"]
        # visual shapes only if anything draws ("": none), and the camera's look (aaai.sim.world.World)
        self.visuals = cfg["sensors"]["camera_look"] if cfg["sensors"]["camera"] or render_mode is not None else ""
        drive = "rotation" if self.action_mode == "gait" else self.action_mode  # the gait sends joint angles
        self.body = Quadruped(
            self.client,
            agent["body"],
            drive,
            agent["max_force"],
            agent["max_joint_velocity"],
            agent["friction"],
            self.visuals,
            agent["position_gain"],
            agent["velocity_gain"],
        )
        self.senses = Senses(self.client, cfg["sensors"], self.body)
        self.rays, self.camera = self.senses.rays, self.senses.camera
        self.task = FoodTask(cfg["episode"], agent["limb_food_reward"], self.control_dt)
        if self.action_mode == "gait":
            self.gait: SineGait | None = SineGait(self.body.joint_names, control_dt=self.control_dt)
            self.hold = hold_steps(agent["decision_interval"], self.control_dt)
            self.action_space = spaces.Box(np.array(GAIT_LOW, np.float32), np.array(GAIT_HIGH, np.float32))
        else:
            self.gait, self.hold = None, 1
            self.action_space = spaces.Box(-1.0, 1.0, (self.body.n_axes,), np.float32)
        self._low = self.action_space.low.astype(np.float64)
        self._high = self.action_space.high.astype(np.float64)
        self.observation_space = self.senses.space
        self.level_spec = None  # the LevelSpec of the current episode
        self.world: World | None = None
        self.steps = 0

    # --- the Gymnasium API ------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        self._check_open()
        super().reset(seed=seed)
        options = dict(options or {})
        unknown = sorted(set(options) - set(RESET_OPTIONS))
        if unknown:
            raise ConfigError(f"reset option '{unknown[0]}' does not exist; allowed: {', '.join(RESET_OPTIONS)}")
        if "level" in options:
            self.level = get_level(options["level"]).id
        if "difficulty" in options:
            self.difficulty = check_difficulty(options["difficulty"])
        episode_seed = seed if seed is not None else int(self.np_random.integers(TRAIN_SEEDS.start, TRAIN_SEEDS.stop))
        if "spec" in options:  # a hand-made level, checked as a generated one is unless check=False
            if not isinstance(options["spec"], LevelSpec):
                raise ConfigError(f"reset option 'spec': got {type(options['spec']).__name__}; allowed: a LevelSpec")
            spec = options["spec"]
            problems = validate.check(spec, require_food=False) if options.get("check", True) else []
            if problems:
                raise ConfigError(
                    "reset option 'spec': the level is not valid: "
                    + "; ".join(problems)
                    + " (options={'check': False} runs it all the same)"
                )
        elif self.arena is not None:
            spec = load_arena(self.arena, episode_seed)
        else:
            spec = generate(self.level, self.difficulty, episode_seed)
        self.level_spec = spec
        _, motion_rng = episode_rngs(spec.level, spec.difficulty, spec.seed)
        self.sim.reset()
        self.world = World(self.client, spec, motion_rng, self.visuals)
        self.senses.start(spec, self.control_dt)
        self.body.load(spec.agent.x, spec.agent.y, spec.agent.yaw)
        self.steps = 0
        if self.gait is not None:
            self.gait.reset()
            self.gait.forward = self.gait.turn = 0.0  # the gait starts at rest: stepping on the spot
            self.gait.command(0.0, 0.0, 0.0)
        self._bound = max(spec.arena_size) / 2 + BLOWUP_MARGIN
        angles, speeds = self.body.joint_state()
        position, orientation = p.getBasePositionAndOrientation(self.body.id, physicsClientId=self.client)
        self._head = position
        self.task.initialize_episode(spec, position, self.world.food_positions)
        if self.hold > self.max_steps:
            raise ConfigError(
                f"config key 'agent.decision_interval': got {self.hold * self.control_dt:g} s "
                f"({self.hold} control steps), longer than this episode's {self.max_steps} steps; allowed: "
                f"at most the episode's length ({self.max_steps * self.control_dt:g} s)"
            )
        info = self._info({term: 0.0 for term in TERMS}, fell=False, blew_up=False)
        return self._observe(angles, speeds, position, orientation), info

    def step(self, action):
        self._check_open()
        if self.world is None:
            raise gym.error.ResetNeeded("step() before reset(): call reset() to build a level first")
        action = np.asarray(action, dtype=np.float64)
        if action.shape != self.action_space.shape:
            raise ValueError(f"action: got shape {action.shape}; allowed: shape {self.action_space.shape}")
        if not np.isfinite(action).all():
            raise ValueError(
                f"action: got non-finite values {action}; allowed: numbers in "
                f"[{', '.join(f'{v:g}' for v in self._low)}] .. [{', '.join(f'{v:g}' for v in self._high)}]"
            )
        action = np.minimum(np.maximum(action, self._low), self._high)
        if self.gait is None:
            return self._control_step(action, observe=True)
        self.gait.command(*action)
        reward, terms, fell, blew_up = 0.0, dict.fromkeys(TERMS, 0.0), False, False
        for k in range(self.hold):
            observation, r, terminated, truncated, info = self._control_step(self.gait(), observe=k == self.hold - 1)
            reward += r
            for term, value in info["reward_terms"].items():
                terms[term] += value
            fell, blew_up = fell or info["fell"], blew_up or info["blew_up"]
            if terminated or truncated:
                break
        if observation is None:  # the episode ended before the held action's last step
            observation = self._observe(*self._state)
        info.update(reward_terms=terms, fell=fell, blew_up=blew_up)
        return observation, reward, terminated, truncated, info

    def _control_step(self, action: np.ndarray, observe: bool):
        """One control step with joint action ``action``; the observation only if ``observe``."""
        self.body.apply(action)
        self.world.advance(self.control_dt, self._head[:2])  # the head as the last step left it
        self.sim.step()
        self.steps += 1

        contacts = self.body.contacts()
        events = self.task.after_step(contacts, self.world.kind_index, self.world.food)
        self.world.eat(events.eaten)
        self.senses.feel(contacts)
        angles, speeds = self.body.joint_state()
        position, orientation = p.getBasePositionAndOrientation(self.body.id, physicsClientId=self.client)
        blew_up = self.body.blew_up(speeds, position, self._bound, self._blowup_speed_sq)
        terms = self.task.get_reward(events, position, self.world.food_positions)
        terminated = self.task.should_terminate(events, self.world.all_eaten())
        truncated = not terminated and self.task.should_truncate(self.steps, blew_up)
        self._head = position
        self._state = (angles, speeds, position, orientation)
        observation = self._observe(angles, speeds, position, orientation) if observe else None
        info = self._info(terms, fell=events.fell, blew_up=blew_up)
        return observation, float(sum(terms.values())), terminated, truncated, info

    # --- what the parts report ------------------------------------------------------
    @property
    def max_steps(self) -> int:
        """T of the current episode (0 before the first reset)."""
        return self.task.max_steps

    def episode_steps(self, spec: LevelSpec) -> int:
        """T for a level instance: episode.max_steps, or with "auto" the level's time limit in steps."""
        return self.task.episode_steps(spec)

    @property
    def dark(self) -> bool:
        """Is the camera blacked out now (L7: light for a while, then dark, repeating)?"""
        return self.senses.blackout.dark(self.steps)

    def _observe(self, angles, speeds, position, orientation) -> dict[str, np.ndarray]:
        return self.senses.observe(angles, speeds, position, orientation, self.world.kind_index, self.dark)

    def _info(self, terms: dict[str, float], fell: bool, blew_up: bool) -> dict[str, Any]:
        spec = self.level_spec
        return {
            "level": spec.level,
            "level_name": spec.name,
            "difficulty": spec.difficulty,
            "seed": spec.seed,
            "max_food_reward": spec.max_food_reward,
            "max_reward": spec.max_food_reward - SCORE_ALLOWANCE,
            "max_steps": self.max_steps,
            "reward_terms": terms,
            "food_eaten": self.task.food_eaten,
            "wall_hits": self.task.wall_hits,
            "fell": fell,
            "blew_up": blew_up,
            "dark": self.dark,
            "steps": self.steps,
            "sim_time": self.steps * self.control_dt,
        }

    def render(self):
        self._check_open()
        if self.render_mode != "rgb_array" or self.world is None:
            return None
        head_pos, head_rot = self.body.head_pose()
        forward = head_rot[:, 0] * np.array([1.0, 1.0, 0.0])
        forward /= max(np.linalg.norm(forward), 1e-6)
        eye = head_pos - 10.0 * forward + np.array([0.0, 0.0, 9.0])
        width, height = RENDER_SIZE
        view = p.computeViewMatrix(eye.tolist(), head_pos.tolist(), [0, 0, 1])
        projection = p.computeProjectionMatrixFOV(60.0, width / height, 0.1, 200.0)
        return render_rgb(self.client, width, height, view, projection)

    def snapshot(self) -> Snapshot:
        """The episode as it is now, as plain data (aaai.sim.snapshot) to draw with ``level_spec``: the
        simulated time, the head's pose, each leg's hip, knee and foot, where every object of the
        spec is (None once eaten) and which doors have risen."""
        self._check_open()
        if self.world is None:
            raise gym.error.ResetNeeded("snapshot() before reset(): call reset() to build a level first")
        position, rotation = self.body.head_pose()
        head = Pose(*(float(v) for v in position), math.atan2(rotation[1, 0], rotation[0, 0]))
        legs = tuple(Leg(*(tuple(float(v) for v in point) for point in leg)) for leg in self.body.leg_points())
        objects, closed_doors = self.world.object_poses()
        return Snapshot(self.steps * self.control_dt, head, legs, tuple(objects), frozenset(closed_doors))

    def _check_open(self) -> None:
        self.sim.check_open()

    # --- copies ---------------------------------------------------------------------
    def __getstate__(self) -> dict:
        """A pickled environment is its configuration (at its current level and difficulty): the
        PyBullet client cannot travel. The copy is a new environment; reset it before stepping."""
        return {
            "config": self.config,
            "level": self.level,
            "difficulty": self.difficulty,
            "render_mode": self.render_mode,
            "arena": self.arena,
        }

    def __setstate__(self, state: dict) -> None:
        self.__init__(
            level=state["level"],
            difficulty=state["difficulty"],
            config=state["config"],
            render_mode=state["render_mode"],
            arena=state.get("arena"),
        )

    def close(self):
        if getattr(self, "sim", None) is not None:
            self.sim.close()
        self.client = None
