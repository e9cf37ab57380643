"""AnimalAIEnv: the quadruped in one level of the test bench, as a Gymnasium environment.

The class wires small parts together, one job each: a PyBullet client (aaai.sim.simulation), the
body (aaai.agent.body), the level's bodies (aaai.sim.world), the senses (aaai.sim.sensors) and the task,
which turns contacts into rewards and ends episodes (aaai.task.rewards).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping, TypedDict, Unpack

import gymnasium as gym
import numpy as np
import pybullet as p
from gymnasium import spaces

from aaai.agent.body import Quadruped
from aaai.agent.sphere import Sphere, SphereCommands
from aaai.config import ActionMode, Config, ConfigError, env_keywords, load_config
from aaai.levels import check_difficulty, episode_rngs, generate, get_level, validate
from aaai.levels.seeds import TRAIN_SEEDS
from aaai.sim.gait import DISCRETE_CHOICES, SineGait, command_of_choice
from aaai.sim.sensors import Senses, render_rgb
from aaai.sim.simulation import Simulation, display_available
from aaai.sim.snapshot import Leg, Pose, Snapshot
from aaai.sim.world import World
from aaai.spec import LevelSpec
from aaai.task.arena import footprint_for, load_arena
from aaai.task.rewards import TERMS, FoodTask

RESET_OPTIONS = ("level", "difficulty", "spec", "check", "arena_file")
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


def _point(values: Any) -> tuple[float, float, float]:
    x, y, z = (float(v) for v in values)
    return x, y, z


class EnvKeywords(TypedDict, total=False):
    """The environment's configuration keywords (``AnimalAIEnv(camera=True)``, ``gym.make(..., camera=True)``):
    each key of configs/default.yaml's environment sections by its short name, or a section by its
    name with a mapping. Checked against the key's rule on construction (aaai.config.RULES)."""

    # agent
    body: str
    action_mode: ActionMode
    decision_interval: float
    max_force: float
    position_gain: float
    velocity_gain: float
    max_joint_velocity: float
    friction: float
    limb_food_reward: str
    agent: Mapping[str, Any]  # the whole section
    # sensors
    rays: bool
    rays_per_side: int
    rays_flat: bool
    ray_kinds: str
    ray_max_angle: float
    ray_length: float
    ray_memory: int
    food_memory: int
    sweep_memory: int
    sweep_map: int
    ray_down_fan: float
    ray_width: float
    camera: bool
    camera_resolution: int
    camera_grayscale: bool
    camera_look: str
    joint_velocities: bool
    head_orientation: bool
    foot_contacts: bool
    sensors: Mapping[str, Any]  # the whole section
    # episode
    max_steps: int | str
    ground_penalty: bool
    shaping: float
    shaping_gamma: float
    episode: Mapping[str, Any]  # the whole section
    # physics
    timestep: float
    action_repeat: int
    solver_iterations: int
    gravity: float
    blowup_speed: float
    physics: Mapping[str, Any]  # the whole section


class AnimalAIEnv(gym.Env):
    """A limbed agent that must find food in a seeded, difficulty-scaled level.

    Actions: Box(-1, 1, (8,)): a target angle (``action_mode: rotation``, the default) or speed
    (``velocity``) for each of the eight joints, scaled to the joint's range, one per control step
    (0.02 s). With ``action_mode: gait``, Box([-1, -1, 0], [1, 1, 1]): the forward, turn and
    crouch commands of the tuned steerable gait (aaai.sim.gait), each held for ``decision_interval``
    seconds (default 0.1 s, 5 control steps); reward and reward terms are summed over the held
    steps and ``info["steps"]`` still counts control steps. With ``action_mode: discrete``,
    MultiDiscrete([3, 3, 2]): Animal-AI's actions, forward (0 none, 1 forward, 2 backward) and turn
    (0 none, 1 right, 2 left), and a crouch (0 stand, 1 crouch), each the gait's command at full
    strength, held as in gait mode.

    Observations: a Dict: ``joints`` (8,) always; ``rays``, ``camera``, ``joint_velocities``,
    ``head_orientation`` and ``foot_contacts`` as the ``sensors`` config turns them on (docs/environment.md,
    "Observations").

    Rewards: the sum of the terms in ``info["reward_terms"]`` (step, ground, food, wall, fall,
    shaping); see aaai.task.rewards.

    Episode end: terminated when the green food is eaten, the agent falls, or no food it can reach
    is left; truncated at T steps (``max_steps``; "auto": the level's time limit) or on a physics
    blow-up (``info["blew_up"]``).

    Arguments: every configuration key of the environment is a keyword, by its short name, typed
    (``EnvKeywords``) and checked against its rule (aaai.config); a whole section may be given as
    a mapping (``sensors={"camera": True}``). They pass through ``gymnasium.make`` unchanged:

    ```python
    gymnasium.make("aaai/AnimalAI-v0", level=3, difficulty=5, action_mode="gait", camera=True)
    ```

    Level and files:

    - ``level`` (int or str, default ``0``): level id 0..12, label ("L1", "L2b") or name ("food_retrieval")
    - ``difficulty`` (int, default ``0``): 0..10
    - ``arena`` (str, default ``None``): an arena file (aaai.task.arena, docs/writing-levels.md): every reset loads
      it with the episode's seed instead of generating ``level`` (a reset with ``options={"spec": ...}`` still runs
      that spec; with ``"arena_file": True`` beside it, the spec is an arena file's, aaai.task.arena.load_arena, and
      is run as the ``arena`` one is: the sphere, ``agent.body: sphere``, sized to its arena)
    - ``config`` (str, Path, mapping or Config, default ``None``): a YAML path, a nested mapping or a ``Config``
      (``aaai.config.load_config``) overriding configs/default.yaml; the keywords override it in turn
    - ``render_mode`` (str, default ``None``): None, "rgb_array" (a third-person view) or "human" (PyBullet's GUI)

    Agent (``agent.*``): the body and what an action means.

    - ``body`` (str, default ``quadruped``): quadruped (8 axes), quadruped16 (16 axes) or sphere (Animal-AI's
      own body, aaai.agent.sphere: its actions are always the gait mode's forward, turn and crouch commands,
      or their choices in discrete mode, crouch ignored, held for decision_interval) (one of quadruped,
      quadruped16, sphere)
    - ``action_mode`` (str, default ``rotation``): rotation: action -> target angle; velocity: action -> target
      speed (8 joints, each control step); gait: action -> forward, turn, crouch of the tuned steerable gait
      (aaai/sim/gait.py), held for decision_interval; discrete: Animal-AI's choices, forward/backward and right/left,
      and a crouch, as the gait's commands (one of rotation, velocity, gait, discrete)
    - ``decision_interval`` (float, default ``0.1``): gait mode: seconds each action is held (a whole number of
      control steps of physics.timestep x action_repeat = 0.02 s); 0.1 = 5 steps (a number from 0.0001 to 10000)
    - ``max_force`` (float, default ``93.58``): motor force limit per axis (N m) (a number from 0.001 to 100000)
    - ``position_gain`` (float, default ``0.0798``): rotation mode: the motor's gain on the angle error (PyBullet's
      kp) (a number from 0.0001 to 10)
    - ``velocity_gain`` (float, default ``0.8606``): rotation mode: the motor's gain on the speed error (PyBullet's
      kd) (a number from 0 to 10)
    - ``max_joint_velocity`` (float, default ``10.0``): rad/s at abs(action) = 1 in velocity mode (a number from
      0.001 to 100)
    - ``friction`` (float, default ``1.0``): lateral friction of the body parts (a number from 0 to 10)
    - ``limb_food_reward`` (str, default ``none``): food touched by a leg: none (legs do not eat) or flat (+1 green,
      +0.5 yellow, as the original build) or size (as the head) (one of flat, size, none)

    Sensors (``sensors.*``): the observation's keys.

    - ``rays`` (bool, default ``true``): rayTestBatch vision from the head (true or false)
    - ``rays_per_side`` (int, default ``8``): 1..20, plus one forward ray (an integer from 1 to 20)
    - ``rays_flat`` (bool, default ``false``): rays as one vector ((2k+1) x 11) instead of a (2k+1, 11) grid, for
      libraries whose checkers want 1-D vectors (true or false)
    - ``ray_kinds`` (str, default ``classic``): classic: the 9 kind channels of 11-wide rays (a newer kind is seen
      on its nearest classic kind's channel, docs: Levels, Object kinds) or all: one channel per kind a policy must
      tell apart (one of classic, all)
    - ``ray_max_angle`` (float, default ``45.0``): degrees per side, 5..180 (180 = all round) (a number from 5 to
      180)
    - ``ray_length`` (float, default ``15.0``): how far a ray sees (a number from 1 to 100)
    - ``ray_memory`` (int, default ``0``): 0..10: n earlier sightings of food in the rays, 1, 2, 4 .. 2^(n-1) steps
      back (observation key ray_memory: n x rays x 3: green, yellow, distance) (an integer from 0 to 10)
    - ``food_memory`` (int, default ``0``): 0..16: the n nearest pieces of food the rays have shown, carried with the
      body (observation key food_memory: n x 7: present, green, yellow, ahead, left, size, age; docs: Environment) (an
      integer from 0 to 16)
    - ``sweep_memory`` (int, default ``0``): 0..36: where the rays have looked, in n sectors round the body
      (observation key sweep_memory: n x 3, the share of the floor not yet looked over within 1, 2 and 4 ray lengths;
      docs: Environment) (an integer from 0 to 36)
    - ``sweep_map`` (int, default ``0``): 0..32: the same as an n x n map turned with the head, 2 ray lengths each way
      (observation key sweep_map: 2 x n x n: the share of a block's floor not yet looked over, and 1 where a ray has
      met something; docs: Environment) (an integer from 0 to 32)
    - ``ray_down_fan`` (float, default ``0.0``): degrees, 0..45: the same fan again, pitched this far below the
      head's plane (0: none). The head walks about 2.3 high, so level rays pass over food smaller than that; a fan 8
      degrees down sees size-2 food 2 to 16 away (a number from 0 to 45)
    - ``ray_width`` (float, default ``0.0``): 0: thin lines or w (0..5): each ray also cast w/2 to its left and
      right, the nearest hit wins (Animal-AI's 0.5 sphere casts: 1.0); 3x the rays' cost (a number from 0 to 5)
    - ``camera`` (bool, default ``false``): TinyRenderer camera in the head (true or false)
    - ``camera_resolution`` (int, default ``84``): square, 8..512 (an integer from 8 to 512)
    - ``camera_grayscale`` (bool, default ``false``):  (true or false)
    - ``camera_look`` (str, default ``task``): task: the camera agrees with the task (transparent walls unseen,
      L11's terrain in the floor's colour) or classic: as before this key (a transparent wall drawn solid, the
      terrain in a checker texture) (one of classic, task)
    - ``joint_velocities`` (bool, default ``false``): extra proprioception, off by default (true or false)
    - ``head_orientation`` (bool, default ``false``): gravity in the head's frame (true or false)
    - ``foot_contacts`` (bool, default ``false``):  (true or false)

    Episode (``episode.*``): its length and the reward's optional terms.

    - ``max_steps`` (int or "auto", default ``auto``): T: auto (the level's own time limit, configs/levels/*.yaml)
      or 10..10000 (auto or an integer from 10 to 10000)
    - ``ground_penalty`` (bool, default ``true``): extra -0.5/T per step while the head touches the floor (true or
      false)
    - ``shaping`` (float, default ``0.0``): k > 0 adds k x (how much nearer the nearest food came): a training aid;
      evaluation always uses 0 (see train.reward_shaping) (a number from 0 to 1000)
    - ``shaping_gamma`` (float, default ``1.0``): shaping = k x (distance before - shaping_gamma x distance now); 1:
      the shaping of an episode adds up to k x (start distance - end distance) (a number from 0 to 1)

    Physics (``physics.*``): the simulation's clock and solver.

    - ``timestep`` (float, default ``0.01``): seconds per physics step (a number from 0.0001 to 0.05)
    - ``action_repeat`` (int, default ``2``): physics steps per control step (0.02 s by default) (an integer from 1
      to 50)
    - ``solver_iterations`` (int, default ``10``): PyBullet's solver iterations per physics step (an integer from 1
      to 500)
    - ``gravity`` (float, default ``9.81``): the downward pull, m/s^2 (a number from 0 to 100)
    - ``blowup_speed`` (float, default ``60.0``): a head faster than this (units/s) counts as a blow-up (walking: <
      12) (a number from 1 to 100000)

    The training sections (``curriculum``, ``train``, ``eval``) are no keywords of the environment;
    they come in a ``config``.
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 50}

    def __init__(
        self,
        level: int | str | None = None,
        difficulty: int | None = None,
        config: str | Path | Mapping[str, Any] | Config | None = None,
        render_mode: str | None = None,
        arena: str | None = None,
        **overrides: Unpack[EnvKeywords],
    ):
        unexpected = sorted(set(overrides) - env_keywords())
        if unexpected:  # worded as Python's own error, which libraries that probe keywords expect
            raise TypeError(
                f"AnimalAIEnv.__init__() got an unexpected keyword argument '{unexpected[0]}'; allowed: "
                + ", ".join(["config", "render_mode", "arena", *sorted(env_keywords() | {"level", "difficulty"})])
            )
        keywords: dict[str, Any] = dict(overrides)
        if level is not None:
            keywords["level"] = get_level(level).id
        if difficulty is not None:
            keywords["difficulty"] = check_difficulty(difficulty)
        self.config: Config = load_config(config, **keywords)
        cfg = self.config
        self.arena = None
        if arena is not None:  # checked now (its seed-0 instance), so that a bad file fails here
            if not isinstance(arena, (str, Path)):
                raise ConfigError(f"arena: got {arena!r}; allowed: an arena file's path")
            load_arena(arena, 0, body=cfg.agent.body)  # for this body's footprint
            self.arena = str(arena)
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ConfigError(f"render_mode: got {render_mode!r}; allowed: None, 'rgb_array', 'human'")
        self.render_mode = render_mode
        # Instance metadata lists the modes this machine can show: no "human" without a display.
        self.metadata = {**self.metadata, "render_modes": ["rgb_array"] + (["human"] if display_available() else [])}
        self.level, self.difficulty = cfg.level, cfg.difficulty
        self._blowup_speed_sq = cfg.physics.blowup_speed**2
        self.sim = Simulation(cfg.physics, gui=render_mode == "human")
        self.client: int | None = self.sim.client  # None once closed
        self.control_dt = self.sim.control_dt  # simulated s per step
        client = self._live_client()
        agent = cfg.agent
        self.action_mode: ActionMode = agent.action_mode
        # visual shapes only if anything draws ("": none), and the camera's look (aaai.sim.world.World)
        self.visuals = cfg.sensors.camera_look if cfg.sensors.camera or render_mode is not None else ""
        self.body: Quadruped | Sphere
        # the gait's commands, or the sphere's (aaai.agent.sphere): forward, turn, crouch held per action
        self.gait: SineGait | SphereCommands | None
        if agent.body == "sphere":  # Animal-AI's body: its actions are always forward and turn commands
            self.body = Sphere(client, self.control_dt, visuals=self.visuals != "")
        else:
            self.body = Quadruped(
                client,
                agent.body,
                drive="velocity" if self.action_mode == "velocity" else "angle",  # the gait sends joint angles
                max_force=agent.max_force,
                max_joint_velocity=agent.max_joint_velocity,
                friction=agent.friction,
                visuals=self.visuals != "",
                position_gain=agent.position_gain,
                velocity_gain=agent.velocity_gain,
            )
        self.senses = Senses(client, cfg.sensors, self.body)
        self.rays, self.camera = self.senses.rays, self.senses.camera
        # the sphere rests on its head: the floor under it is no head on the floor
        self.task = FoodTask(
            cfg.episode, agent.limb_food_reward, self.control_dt, head_rests=isinstance(self.body, Sphere)
        )
        self.action_space: spaces.Box | spaces.MultiDiscrete
        if isinstance(self.body, Sphere) or self.action_mode in ("gait", "discrete"):
            sphere = isinstance(self.body, Sphere)
            self.gait = SphereCommands() if sphere else SineGait(self.body.joint_names, control_dt=self.control_dt)
            self.hold = hold_steps(agent.decision_interval, self.control_dt)
            self.action_space = spaces.Box(np.array(GAIT_LOW, np.float32), np.array(GAIT_HIGH, np.float32))
        else:
            self.gait, self.hold = None, 1
            self.action_space = spaces.Box(-1.0, 1.0, (self.body.n_axes,), np.float32)
        self._low = self.action_space.low.astype(np.float64)
        self._high = self.action_space.high.astype(np.float64)
        if self.action_mode == "discrete":  # Animal-AI's choices, each standing for gait commands (aaai.sim.gait)
            self.action_space = spaces.MultiDiscrete(list(DISCRETE_CHOICES))
        self.observation_space: spaces.Dict = self.senses.space
        self.level_spec: LevelSpec | None = None  # the LevelSpec of the current episode
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
            # the body's footprint, at the scale the sphere takes (aaai.agent.sphere): an arena file's, or the levels'
            footprint = footprint_for(self.config.agent.body, spec.arena_size if options.get("arena_file") else None)
            problems = validate.check(spec, False, footprint) if options.get("check", True) else []
            if problems:
                raise ConfigError(
                    "reset option 'spec': the level is not valid: "
                    + "; ".join(problems)
                    + " (options={'check': False} runs it all the same)"
                )
        elif self.arena is not None:
            spec = load_arena(self.arena, episode_seed, body=self.config.agent.body)
        else:
            spec = generate(self.level, self.difficulty, episode_seed)
        self.level_spec = spec
        _, motion_rng = episode_rngs(spec.level, spec.difficulty, spec.seed)
        self.sim.reset()
        self.world = World(self._live_client(), spec, motion_rng, self.visuals)
        # an arena file's arena sets the sphere's scale; the generated levels share one (aaai.agent.sphere)
        arena_file = self.arena is not None and "spec" not in options or bool(options.get("arena_file"))
        self.body.load(spec.agent.x, spec.agent.y, spec.agent.yaw, spec.arena_size if arena_file else None)
        self.world.stand(self.body.id)  # on the ledge a start may stand on (aaai.levels.validate.start_ledge)
        self.senses.start(spec, self.control_dt)
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

    def _choice(self, action: np.ndarray) -> np.ndarray:
        """A discrete action as the gait commands it stands for; anything but one whole choice per
        part, within its count, is refused naming what is allowed."""
        nvec = np.asarray(DISCRETE_CHOICES)
        if (
            action.shape != nvec.shape
            or not np.isfinite(action).all()
            or (action != np.rint(action)).any()
            or (action < 0).any()
            or (action >= nvec).any()
        ):
            raise ValueError(
                f"action: got {action.tolist()!r}; allowed in action_mode discrete: 3 whole numbers, forward "
                "(0 none, 1 forward, 2 backward), turn (0 none, 1 right, 2 left), crouch (0 stand, 1 crouch)"
            )
        return command_of_choice(action).astype(np.float64)

    def step(self, action):
        self._check_open()
        if self.world is None:
            raise gym.error.ResetNeeded("step() before reset(): call reset() to build a level first")
        action = np.asarray(action, dtype=np.float64)
        if self.action_mode == "discrete":
            action = self._choice(action)
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
        world = self._live_world()
        self.body.apply(action)
        world.advance(self.control_dt, self._head[:2])  # the head as the last step left it
        self.sim.step()
        self.steps += 1

        contacts = self.body.contacts()
        events = self.task.after_step(contacts, world.kind_index, world.food)
        world.eat(events.eaten)
        self.senses.feel(contacts)
        angles, speeds = self.body.joint_state()
        position, orientation = p.getBasePositionAndOrientation(self.body.id, physicsClientId=self.client)
        blew_up = self.body.blew_up(speeds, position, self._bound, self._blowup_speed_sq)
        terms = self.task.get_reward(events, position, world.food_positions)
        terminated = self.task.should_terminate(events, world.all_eaten())
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
        now = self.steps * self.control_dt
        return self.senses.observe(angles, speeds, position, orientation, self._live_world().kind_index, self.dark, now)

    def _info(self, terms: dict[str, float], fell: bool, blew_up: bool) -> dict[str, Any]:
        spec = self.level_spec
        if spec is None:
            raise gym.error.ResetNeeded("no episode yet: call reset() to build a level first")
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
        return render_rgb(self._live_client(), width, height, view, projection)

    def snapshot(self) -> Snapshot:
        """The episode as it is now, as plain data (aaai.sim.snapshot) to draw with ``level_spec``: the
        simulated time, the head's pose, each leg's hip, knee and foot, where every object of the
        spec is (None once eaten) and which doors have risen."""
        self._check_open()
        if self.world is None:
            raise gym.error.ResetNeeded("snapshot() before reset(): call reset() to build a level first")
        position, rotation = self.body.head_pose()
        x, y, z = (float(v) for v in position)
        head = Pose(x, y, z, math.atan2(rotation[1, 0], rotation[0, 0]))
        legs = tuple(Leg(*(_point(point) for point in leg)) for leg in self.body.leg_points())
        objects, closed_doors = self.world.object_poses()
        radius = self.body.radius if isinstance(self.body, Sphere) else None
        return Snapshot(self.steps * self.control_dt, head, legs, tuple(objects), frozenset(closed_doors), radius)

    def _check_open(self) -> None:
        self.sim.check_open()

    def _live_client(self) -> int:
        """The PyBullet client, or the closed environment's error."""
        self.sim.check_open()
        assert self.client is not None, "an open simulation has its client"
        return self.client

    def _live_world(self) -> World:
        if self.world is None:
            raise gym.error.ResetNeeded("step() before reset(): call reset() to build a level first")
        return self.world

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
        AnimalAIEnv.__init__(
            self,
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
