"""AnimalAIEnv: the quadruped in one level of the test bench, as a Gymnasium environment."""
from __future__ import annotations

import math
import os
import sys
from typing import Any

import gymnasium as gym
import numpy as np
import pybullet as p
from gymnasium import spaces

from aaai import validate
from aaai.agent.body import Quadruped
from aaai.config import ConfigError, env_keywords, load_config
from aaai.kinds import KIND_INDEX
from aaai.levels import check_difficulty, episode_rngs, generate, get_level
from aaai.rewards import TERMS, StepEvents, limb_eats, step_reward
from aaai.seeds import TRAIN_SEEDS
from aaai.spec import LevelSpec
from aaai.sensors import Camera, Rays, render_rgb
from aaai.world import World, missing_floor

FLOOR = KIND_INDEX["floor"]
WALL = KIND_INDEX["wall"]
DEADLY = KIND_INDEX["deadly_floor"]
GREEN = KIND_INDEX["food_green"]
YELLOW = KIND_INDEX["food_yellow"]
RESET_OPTIONS = ("level", "difficulty", "spec", "check")
RENDER_SIZE = (320, 240)
SCORE_ALLOWANCE = 0.5  # max_reward = best food reward - this, allowing for step costs
BLOWUP_JOINT_SPEED = 90.0  # rad/s; Bullet clamps joint speeds at 100
BLOWUP_MARGIN = 20.0  # how far beyond the arena's half-size a body may be before it "flew off"


def display_available() -> bool:
    return os.name != "posix" or sys.platform == "darwin" or bool(os.environ.get("DISPLAY"))


class AnimalAIEnv(gym.Env):
    """A limbed agent that must find food in a seeded, difficulty-scaled level.

    Args:
        level: level id 0..12, label ("L1", "L2b") or name ("food_retrieval").
        difficulty: 0..10.
        config: a YAML path or nested mapping overriding configs/default.yaml.
        render_mode: None, "rgb_array" (a third-person view) or "human" (PyBullet's GUI).
        **overrides: any configuration key by its short name, e.g. ``camera=True``,
            ``camera_resolution=64``, ``max_steps=500``, ``body="quadruped16"``.
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 50}

    def __init__(self, level: int | str | None = None, difficulty: int | None = None,
                 config: Any = None, render_mode: str | None = None, **overrides: Any):
        unexpected = sorted(set(overrides) - env_keywords())
        if unexpected:  # worded as Python's own error, which libraries that probe keywords expect
            raise TypeError(f"AnimalAIEnv.__init__() got an unexpected keyword argument '{unexpected[0]}'; allowed: "
                            f"level, difficulty, config, render_mode, {', '.join(sorted(env_keywords()))}")
        if level is not None:
            overrides["level"] = get_level(level).id
        if difficulty is not None:
            overrides["difficulty"] = check_difficulty(difficulty)
        self.config = cfg = load_config(config, **overrides)
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ConfigError(f"render_mode: got {render_mode!r}; allowed: None, 'rgb_array', 'human'")
        self.render_mode = render_mode
        # Instance metadata lists the modes this machine can show: no "human" without a display.
        self.metadata = {**self.metadata, "render_modes": ["rgb_array"] + (["human"] if display_available() else [])}
        self.level, self.difficulty = cfg["level"], cfg["difficulty"]
        self.max_steps_setting = cfg["episode"]["max_steps"]  # "auto": the level's own time limit
        self.max_steps = 0  # T of the current episode, set by reset
        self.ground_penalty = cfg["episode"]["ground_penalty"]
        self.shaping = cfg["episode"]["shaping"]
        self.shaping_gamma = cfg["episode"]["shaping_gamma"]
        self.limb_food_reward = cfg["agent"]["limb_food_reward"]
        self.control_dt = cfg["physics"]["timestep"] * cfg["physics"]["action_repeat"]  # simulated s per step
        self._blowup_speed_sq = cfg["physics"]["blowup_speed"] ** 2
        self.client = self._connect(render_mode)

        agent, sensors = cfg["agent"], cfg["sensors"]
        self.visuals = sensors["camera"] or render_mode is not None  # visual shapes only if anything draws
        self.body = Quadruped(self.client, agent["body"], agent["action_mode"], agent["max_force"],
                              agent["max_joint_velocity"], agent["friction"], self.visuals,
                              agent["position_gain"], agent["velocity_gain"])
        self.rays = Rays(self.client, sensors["rays_per_side"], sensors["ray_max_angle"],
                         sensors["ray_length"], sensors["rays_flat"]) if sensors["rays"] else None
        self.camera = Camera(self.client, sensors["camera_resolution"],
                             sensors["camera_grayscale"]) if sensors["camera"] else None

        n = self.body.n_axes
        self.action_space = spaces.Box(-1.0, 1.0, (n,), np.float32)
        observation = {"joints": spaces.Box(-1.0, 1.0, (n,), np.float32)}
        if self.rays:
            observation["rays"] = self.rays.space
        if self.camera:
            observation["camera"] = self.camera.space
        if sensors["joint_velocities"]:
            observation["joint_velocities"] = spaces.Box(-np.inf, np.inf, (n,), np.float32)
        if sensors["head_orientation"]:
            observation["head_orientation"] = spaces.Box(-1.0, 1.0, (3,), np.float32)
        if sensors["foot_contacts"]:
            observation["foot_contacts"] = spaces.Box(0.0, 1.0, (len(self.body.foot_links),), np.float32)
        self.observation_space = spaces.Dict(observation)
        self.level_spec = None  # the LevelSpec of the current episode
        self.world: World | None = None

    # --- set-up ---------------------------------------------------------------------
    @staticmethod
    def _connect(render_mode: str | None) -> int:
        if render_mode != "human":
            return p.connect(p.DIRECT)
        if not display_available():
            raise RuntimeError(
                "render_mode='human' opens PyBullet's GUI window, which needs a display, and none was "
                "found (DISPLAY is not set). On a headless machine use render_mode='rgb_array'."
            )
        return p.connect(p.GUI)

    def _reset_physics(self) -> None:
        c, physics = self.client, self.config["physics"]
        p.resetSimulation(physicsClientId=c)
        p.setGravity(0, 0, -physics["gravity"], physicsClientId=c)
        p.setPhysicsEngineParameter(
            fixedTimeStep=physics["timestep"] * physics["action_repeat"],
            numSubSteps=physics["action_repeat"],
            numSolverIterations=physics["solver_iterations"],
            deterministicOverlappingPairs=1,
            physicsClientId=c,
        )

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
                raise ConfigError("reset option 'spec': the level is not valid: " + "; ".join(problems)
                                  + " (options={'check': False} runs it all the same)")
        else:
            spec = generate(self.level, self.difficulty, episode_seed)
        self.level_spec = spec
        self.max_steps = self.episode_steps(spec)
        _, motion_rng = episode_rngs(spec.level, spec.difficulty, spec.seed)

        self._reset_physics()
        self.world = World(self.client, spec, motion_rng, self.visuals)
        if self.rays:
            self.rays.set_holes(missing_floor(spec))
        self._blackout = self._blackout_steps(spec)
        self.body.load(spec.agent.x, spec.agent.y, spec.agent.yaw)
        self.steps = 0
        self.wall_contacts: set[tuple[int, int]] = set()
        self.food_eaten = 0
        self.wall_hits = 0
        self.foot_contact = np.zeros(len(self.body.foot_links), np.float32)
        angles, speeds = self.body.joint_state()
        position, orientation = p.getBasePositionAndOrientation(self.body.id, physicsClientId=self.client)
        self._head = position
        self.food_distance = self._nearest_food_distance(position) if self.shaping else 0.0
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
            raise ValueError(f"action: got non-finite values {action}; allowed: numbers in [-1, 1]")
        self.body.apply(np.minimum(np.maximum(action, -1.0), 1.0))
        self.world.advance(self.control_dt, self._head[:2])  # the head as the last step left it
        p.stepSimulation(physicsClientId=self.client)
        self.steps += 1

        events, green_eaten = self._contact_events()
        angles, speeds = self.body.joint_state()
        position, orientation = p.getBasePositionAndOrientation(self.body.id, physicsClientId=self.client)
        blew_up = self._blew_up(speeds, position)
        terms = step_reward(events, self.max_steps, self.ground_penalty, self.limb_food_reward)
        if self.shaping:
            terms["shaping"] = self._shaping_reward(position)
        # the episode also ends when no food is left that the agent can still reach
        terminated = green_eaten or events.fell or self.world.all_eaten()
        truncated = not terminated and (blew_up or self.steps >= self.max_steps)
        self._head = position
        observation = self._observe(angles, speeds, position, orientation)
        info = self._info(terms, fell=events.fell, blew_up=blew_up)
        return observation, float(sum(terms.values())), terminated, truncated, info

    def episode_steps(self, spec: LevelSpec) -> int:
        """T for a level instance: episode.max_steps, or with "auto" the level's time limit in steps."""
        if self.max_steps_setting != "auto":
            return self.max_steps_setting
        return max(1, round(spec.time_limit / self.control_dt))

    def _nearest_food_distance(self, head: tuple[float, float, float]) -> float:
        """Horizontal distance from the head to the nearest food piece still in the world (0 if none)."""
        distances = [math.dist(head[:2], p.getBasePositionAndOrientation(body, physicsClientId=self.client)[0][:2])
                     for body in self.world.food]
        return min(distances, default=0.0)

    def _shaping_reward(self, head: tuple[float, float, float]) -> float:
        """Potential-based shaping, gamma x potential(now) - potential(before), with potential =
        -shaping x distance to the nearest food (Ng, Harada and Russell, 1999). With gamma 1 (the
        default) an episode's shaping adds up to shaping x (start distance - end distance); with
        gamma < 1, standing far from the food pays a little every step."""
        distance = self._nearest_food_distance(head)
        reward = self.shaping * (self.food_distance - self.shaping_gamma * distance)
        self.food_distance = distance
        return reward

    def _contact_events(self) -> tuple[StepEvents, bool]:
        """Reads the agent's contacts once and turns them into reward events."""
        world, body = self.world, self.body
        events = StepEvents()
        touching: dict[int, bool] = {}  # food body -> touched by the head
        walls_now: set[tuple[int, int]] = set()
        self.foot_contact[:] = 0.0
        foot_slot = body.foot_slot
        for contact in p.getContactPoints(bodyA=body.id, physicsClientId=self.client):
            other, link = contact[2], contact[3]
            if link in foot_slot:
                self.foot_contact[foot_slot[link]] = 1.0
            kind = world.kind_index[other] if other < len(world.kind_index) else -1
            if kind == FLOOR:
                events.head_on_floor |= link == -1
            elif kind == WALL:
                walls_now.add((link, other))
            elif kind == DEADLY:
                events.fell = True
            elif kind in (GREEN, YELLOW):
                touching[other] = touching.get(other, False) or link == -1
        events.new_wall_hits = len(walls_now - self.wall_contacts)
        self.wall_contacts = walls_now
        self.wall_hits += events.new_wall_hits

        green_eaten = False
        limbs_eat = limb_eats(self.limb_food_reward)
        for food_body, by_head in sorted(touching.items()):
            if not (by_head or limbs_eat):
                continue
            food = world.food[food_body]
            events.eaten.append((food, by_head))
            self.food_eaten += 1
            if food.kind == "food_green":
                green_eaten = True
            else:
                world.remove(food_body)
        return events, green_eaten

    def _blackout_steps(self, spec: LevelSpec) -> tuple[int, int] | None:
        """(light steps, cycle steps) of an L7 blackout schedule, in whole control steps, or None."""
        schedule = spec.extras.get("blackout")
        if not schedule:
            return None
        light = round(schedule["light"] / self.control_dt)
        return light, light + round(schedule["dark"] / self.control_dt)

    @property
    def dark(self) -> bool:
        """Is the camera blacked out now (L7: light for a while, then dark, repeating)?"""
        return self._blackout is not None and self.steps % self._blackout[1] >= self._blackout[0]

    def _blew_up(self, joint_speeds: np.ndarray, position: tuple[float, float, float]) -> bool:
        """Catches a physics blow-up: a non-finite state, a body moving impossibly fast or far.

        Comparisons are written so that NaN fails them (NaN compares False with everything).
        """
        (vx, vy, vz), _ = p.getBaseVelocity(self.body.id, physicsClientId=self.client)
        fastest_joint = float(np.abs(joint_speeds).max())
        bound = max(self.level_spec.arena_size) / 2 + BLOWUP_MARGIN
        x, y, z = position
        healthy = (vx * vx + vy * vy + vz * vz <= self._blowup_speed_sq and fastest_joint <= BLOWUP_JOINT_SPEED
                   and -bound <= x <= bound and -bound <= y <= bound and z <= bound)
        return not healthy

    def _observe(self, angles: np.ndarray, speeds: np.ndarray, position, orientation) -> dict[str, np.ndarray]:
        observation = {"joints": angles.astype(np.float32)}
        if self.rays or self.camera or "head_orientation" in self.observation_space.spaces:
            head_pos = np.array(position)
            head_rot = np.array(p.getMatrixFromQuaternion(orientation)).reshape(3, 3)
        if self.rays:
            observation["rays"] = self.rays.observe(head_pos, head_rot, self.world.kind_index)
        if self.camera:
            observation["camera"] = self.camera.blank() if self.dark else self.camera.observe(head_pos, head_rot)
        if "joint_velocities" in self.observation_space.spaces:
            observation["joint_velocities"] = speeds.astype(np.float32)
        if "head_orientation" in self.observation_space.spaces:
            observation["head_orientation"] = (-head_rot[2, :]).astype(np.float32)  # gravity in the head frame
        if "foot_contacts" in self.observation_space.spaces:
            observation["foot_contacts"] = self.foot_contact.copy()
        return observation

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
            "food_eaten": self.food_eaten,
            "wall_hits": self.wall_hits,
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

    def _check_open(self) -> None:
        if self.client is None:
            raise gym.error.ClosedEnvironmentError("the environment is closed; make a new one to go on")

    # --- copies ---------------------------------------------------------------------
    def __getstate__(self) -> dict:
        """A pickled environment is its configuration (at its current level and difficulty): the
        PyBullet client cannot travel. The copy is a new environment; reset it before stepping."""
        return {"config": self.config, "level": self.level, "difficulty": self.difficulty,
                "render_mode": self.render_mode}

    def __setstate__(self, state: dict) -> None:
        self.__init__(level=state["level"], difficulty=state["difficulty"], config=state["config"],
                      render_mode=state["render_mode"])

    def close(self):
        if getattr(self, "client", None) is not None and p.isConnected(self.client):
            p.disconnect(self.client)
        self.client = None
