"""A PyBullet client for one environment: connect (headless or windowed), reset its physics, close."""

from __future__ import annotations

import os
import sys

import gymnasium as gym
import pybullet as p

from aaai.config import PhysicsConfig


def display_available() -> bool:
    return os.name != "posix" or sys.platform == "darwin" or bool(os.environ.get("DISPLAY"))


class Simulation:
    """One physics client, set up from the config's ``physics`` section.

    A control step is ``action_repeat`` Bullet sub-steps of ``timestep`` seconds, taken by one
    ``stepSimulation`` call; ``control_dt`` is its length in simulated seconds.
    """

    def __init__(self, physics: PhysicsConfig, gui: bool = False):
        self.physics = physics
        self.control_dt = physics.control_dt
        if gui and not display_available():
            raise RuntimeError(
                "render_mode='human' opens PyBullet's GUI window, which needs a display, and none was "
                "found (DISPLAY is not set). On a headless machine use render_mode='rgb_array'."
            )
        self.client: int | None = p.connect(p.GUI if gui else p.DIRECT)

    def reset(self) -> None:
        """Empties the client and sets gravity, the step and the solver; build the level after it."""
        c, physics = self.client, self.physics
        p.resetSimulation(physicsClientId=c)
        p.setGravity(0, 0, -physics.gravity, physicsClientId=c)
        p.setPhysicsEngineParameter(
            fixedTimeStep=self.control_dt,
            numSubSteps=physics.action_repeat,
            numSolverIterations=physics.solver_iterations,
            deterministicOverlappingPairs=1,
            physicsClientId=c,
        )

    def step(self) -> None:
        p.stepSimulation(physicsClientId=self.client)

    def check_open(self) -> None:
        if self.client is None:
            raise gym.error.ClosedEnvironmentError("the environment is closed; make a new one to go on")

    def close(self) -> None:
        if self.client is not None and p.isConnected(self.client):
            p.disconnect(self.client)
        self.client = None
