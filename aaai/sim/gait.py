"""A steerable trot from phase-shifted sinusoids, sent as ordinary actions.

Diagonal legs (front-left with back-right, front-right with back-left) move together. Each
leg's hip up/down axis presses it down in the stance half of the cycle and lifts it in the
swing; its knee sideways axis sweeps the foot to and fro, which pushes the body along. Three
commands steer it: ``forward`` (-1 backward .. 1 forward) sweeps the feet the way that carries
the body along its heading, ``turn`` (-1 right .. 1 left) sweeps every foot the same way round,
which turns it on the spot, and ``crouch`` (0 .. 1) presses the hips down less, which lowers the
head to reach food on the floor. Commands are blended: each moves toward its new value at
``GaitParameters.blend_rate`` per second, and the cycle's phase runs on without a jump, so a new
command never jerks the legs.

The parameters (configs/gait.yaml) come from ``python -m aaai.tools.gait_tuning`` (CMA-ES over them and
the joint drive, scored by how fast the body eats its way along random courses of food); the
docs (The environment, The body) give the speeds they reach.
"""

from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path

import numpy as np

from aaai.config import ConfigError, config_dir, read_yaml

LEG_PHASE = {"fl": 0.0, "br": 0.0, "fr": math.pi, "bl": math.pi}
# +1 where a growing sideways angle moves that foot backward (legs lie on the diagonals).
BACKWARD_SIGN = {"fl": 1.0, "fr": -1.0, "bl": 1.0, "br": -1.0}
STEER_SHARPNESS = 2  # steer: forward = cos(heading error) ** this; turning while walking skids
BACK_UP = 4.0  # steer: a point this close behind is reached walking backward
DIRECTIONS = {"forward": (1.0, 0.0), "backward": (-1.0, 0.0), "left": (0.0, 1.0), "right": (0.0, -1.0)}


@dataclass(frozen=True)
class GaitParameters:
    """The trot's shape. Hip values are actions of the hip up/down axes (+ is down), sweeps are
    actions of the knee sideways axes; all in [-1, 1] action units."""

    frequency: float = 1.6
    """Cycles per second."""
    stance_down: float = 0.8
    """Hip action in the stance: how hard the foot presses down (lifting the head)."""
    lift: float = 0.6
    """How far the hip rises from ``stance_down`` in the middle of the swing."""
    sweep: float = 0.9
    """Knee sweep amplitude at ``forward`` = 1."""
    turn_sweep: float = 0.9
    """Knee sweep amplitude at ``turn`` = 1."""
    sweep_lead: float = 0.5
    """Phase (rad) by which the sweep leads the lift: where in the swing the foot travels."""
    blend_rate: float = 4.0
    """How fast (per second) a command's effect follows a changed command."""
    crouch_stance: float = 0.6
    """Hip action in the stance when crouching (``crouch`` = 1): a lower head, to reach food."""
    crouch_distance: float = 5.0
    """``approach`` crouches with the food's surface nearer than this (units) to the head's."""
    approach_speed: float = 0.5
    """``approach`` walks at this fraction of full speed while crouching."""

    def to_dict(self) -> dict:
        return asdict(self)


@functools.cache
def load_parameters(path: Path | None = None) -> GaitParameters:
    """Gait parameters from a YAML file; by default the shipped ones, configs/gait.yaml (written
    by ``python -m aaai.tools.gait_tuning --write``)."""
    path = config_dir() / "gait.yaml" if path is None else Path(path)
    data = read_yaml(path, "gait file")
    allowed = [f.name for f in fields(GaitParameters)]
    for key, value in data.items():
        if key not in allowed:
            raise ConfigError(f"{path.name}: key '{key}' does not exist; allowed: {', '.join(allowed)}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(f"{path.name}: key '{key}': got {value!r}; allowed: a finite number")
    return GaitParameters(**{key: float(value) for key, value in data.items()})


class SineGait:
    """Callable policy: ``action = gait(observation)``; ``command(forward, turn)`` steers it and
    ``reset()`` restarts the cycle at each episode start."""

    def __init__(
        self,
        joint_names: list[str],
        direction: str = "forward",
        control_dt: float = 0.02,
        parameters: GaitParameters | None = None,
        **overrides: float,
    ):
        if direction not in DIRECTIONS:
            raise ValueError(f"direction: got {direction!r}; allowed: one of {', '.join(DIRECTIONS)}")
        self.joint_names = list(joint_names)
        self.control_dt = control_dt
        self.parameters = replace(parameters or load_parameters(), **overrides)
        self.initial_command = DIRECTIONS[direction]
        hip, knee = [], []
        for i, name in enumerate(self.joint_names):
            leg, joint = name.split("_")[:2]
            if joint == "hip" and not name.endswith("_sideways"):  # hip up/down: press and lift
                hip.append((i, LEG_PHASE[leg]))
            elif joint == "knee" and not name.endswith("_updown"):  # knee sideways: sweep the foot
                knee.append((i, LEG_PHASE[leg], BACKWARD_SIGN[leg]))
        self._hip, self._knee = hip, knee
        self.reset()

    @classmethod
    def for_env(cls, env, direction: str = "forward", **kwargs) -> "SineGait":
        base = env.unwrapped
        return cls(base.body.joint_names, direction, base.control_dt, **kwargs)

    def reset(self, seed: int | None = None) -> None:
        """Restarts the cycle and the initial command (the seed is unused: the gait has no randomness)."""
        self.phase = 0.0
        self.forward, self.turn = self.initial_command  # the commands in use
        self.crouch = 0.0
        self.command(*self.initial_command)

    def command(self, forward: float, turn: float, crouch: float = 0.0) -> None:
        """Steers: forward in [-1, 1] (+ forward), turn in [-1, 1] (+ left, anticlockwise),
        crouch in [0, 1] (1: the head low)."""
        self.target = (
            _clamp(float(forward), -1.0, 1.0),
            _clamp(float(turn), -1.0, 1.0),
            _clamp(float(crouch), 0.0, 1.0),
        )

    def stand(self) -> np.ndarray:
        """The action that stands still: every hip pressing down as in the stance, knees at rest."""
        action = np.zeros(len(self.joint_names), np.float32)
        for i, _ in self._hip:
            action[i] = self.parameters.stance_down
        return action

    def __call__(self, observation=None) -> np.ndarray:
        g, dt = self.parameters, self.control_dt
        step = g.blend_rate * dt
        self.forward += _clamp(self.target[0] - self.forward, -step, step)
        self.turn += _clamp(self.target[1] - self.turn, -step, step)
        self.crouch += _clamp(self.target[2] - self.crouch, -step, step)
        stance = g.stance_down + self.crouch * (g.crouch_stance - g.stance_down)
        phase = self.phase
        self.phase = (phase + 2 * math.pi * g.frequency * dt) % (2 * math.pi)
        action = np.zeros(len(self.joint_names), np.float32)
        for i, offset in self._hip:
            action[i] = stance - g.lift * max(0.0, math.sin(phase + offset))
        along, around = g.sweep * self.forward, g.turn_sweep * self.turn
        for i, offset, backward in self._knee:
            action[i] = (backward * along - around) * math.cos(phase + offset + g.sweep_lead)
        return np.clip(action, -1.0, 1.0)


def _clamp(value: float, low: float, high: float) -> float:
    return min(max(value, low), high)


def steer(
    heading_error: float, distance: float, arrive: float = 0.0, reverse: bool | None = None
) -> tuple[float, float]:
    """(forward, turn) commands toward a point ``heading_error`` rad to the left and ``distance``
    away: turn in proportion to the error (full at 45 degrees), walk forward only while facing
    within 90 degrees of it, slowing within ``arrive`` of it. A point close behind (within
    BACK_UP, more than 120 degrees off) is reached walking backward; ``reverse`` overrides that
    choice (e.g. False when the point is only the next step of a long way)."""
    if (distance < BACK_UP if reverse is None else reverse) and abs(heading_error) > 2 * math.pi / 3:
        behind = (heading_error % (2 * math.pi)) - math.pi  # the error as seen from the tail
        return -(math.cos(behind) ** 2), _clamp(behind / (math.pi / 4), -1.0, 1.0)
    turn = _clamp(heading_error / (math.pi / 4), -1.0, 1.0)
    forward = max(0.0, math.cos(heading_error)) ** STEER_SHARPNESS
    if arrive > 0:
        forward *= min(1.0, distance / arrive)
    return forward, turn


def approach(
    parameters: GaitParameters, heading_error: float, distance: float, food_radius: float
) -> tuple[float, float, float]:
    """(forward, turn, crouch) commands toward a piece of food ``heading_error`` rad to the left
    whose centre is ``distance`` from the head's: steered as ``steer``, crouching and slowing
    near it so that the head gets down to the piece past the legs."""
    forward, turn = steer(heading_error, distance)
    if distance - food_radius < parameters.crouch_distance:
        return forward * parameters.approach_speed, turn, 1.0
    return forward, turn, 0.0


# --- action_mode: discrete -------------------------------------------------------------------
# Animal-AI's actions, with a crouch: three choices, each an index. Forward: 0 none, 1 forward,
# 2 backward; turn: 0 none, 1 right, 2 left (Animal-AI's coding of its MultiDiscrete([3, 3])); crouch:
# 0 stand, 1 crouch. Each choice is the gait's command at full strength, held as a gait-mode action is.
DISCRETE_CHOICES = (3, 3, 2)
FORWARD_OF_CHOICE = (0.0, 1.0, -1.0)
TURN_OF_CHOICE = (0.0, -1.0, 1.0)  # turn: -1 right .. 1 left
CHOICE_THRESHOLD = 1.0 / 3.0  # a command nearer 0 than this is "none" (aaai.sim.gait.choice_of_command)


def command_of_choice(choice) -> np.ndarray:
    """The gait commands (forward, turn, crouch) a discrete action ``choice`` stands for."""
    forward, turn, crouch = (int(c) for c in choice)
    return np.array([FORWARD_OF_CHOICE[forward], TURN_OF_CHOICE[turn], float(crouch)], np.float32)


def choice_of_command(command) -> np.ndarray:
    """The discrete action nearest the gait commands ``command`` (forward, turn, crouch): a forward
    or turn command nearer 0 than CHOICE_THRESHOLD is none, else its direction at full strength;
    crouch from 0.5 up is a crouch. How a teacher of gait commands labels a discrete student."""
    forward, turn, crouch = (float(c) for c in command)

    def direction(value: float, positive: int, negative: int) -> int:
        return 0 if abs(value) < CHOICE_THRESHOLD else positive if value > 0 else negative

    return np.array([direction(forward, 1, 2), direction(turn, 2, 1), int(crouch >= 0.5)], np.int64)


def as_command(env, action) -> np.ndarray:
    """A gait- or discrete-mode ``action`` of ``env`` as its gait commands (forward, turn, crouch)."""
    if getattr(env.unwrapped, "action_mode", None) == "discrete":
        return command_of_choice(action)
    return np.asarray(action, np.float32)


class WalkForward:
    """``--policy gait`` in gait mode: the command to walk straight ahead, every decision (in
    discrete mode its choice: forward, no turn, standing)."""

    def __init__(self, discrete: bool = False) -> None:
        self.discrete = discrete

    def reset(self, seed: int | None = None) -> None:
        pass

    def __call__(self, observation=None) -> np.ndarray:
        if self.discrete:
            return np.array([1, 0, 0], np.int64)
        return np.array([1.0, 0.0, 0.0], np.float32)


def gait_policy(env, direction: str = "forward"):
    """The ``gait`` policy for an env in any action mode: the trot's joint targets in the joint
    modes, its straight-ahead command in gait and discrete mode."""
    if getattr(env.unwrapped, "gait", None) is not None:
        return WalkForward(discrete=getattr(env.unwrapped, "action_mode", None) == "discrete")
    return SineGait.for_env(env, direction)
