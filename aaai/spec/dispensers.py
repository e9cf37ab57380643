"""Reward dispensers and buttons (Animal-AI 3's spawners and SpawnerButton): two kinds of object,
and two behaviours of the food they give.

- ``spawner``: a dispenser's or a tree's body, a static solid (validate: blocked, like a wall); seen
  on the classic rays as a pillar, with ``ray_kinds: all`` on a channel of its own; the viewer rims
  it; the head camera draws it in its colour.
- ``button``: a static solid pillar the agent presses by touching it with its head; seen as a
  pillar on the classic rays, its own channel with ``all``; the viewer puts a dot on it.
- food a dispenser gives has ``behaviour: {type: release, after: SECONDS}``: it waits out of sight
  and reach below the arena (as an open door does) and appears at its position ``after`` seconds
  into the episode, to be eaten under its own kind's reward rule;
- food a button gives has ``behaviour: {type: press, button: [x, y], reach: R}``: it appears at its
  position the first time the agent's head comes within ``R`` of the button's centre (x, y).

The food itself keeps its kind's rule (a green ends the episode, a multi_food is taken out, bad food
costs its size). aaai.levels.validate checks it where it will appear; Animal-AI's items are mapped
by aaai.tools.animalai_arena.
"""

from __future__ import annotations

import math


def define(kind: type, register_kind, behaviour: type, register_behaviour) -> None:
    """Makes and registers the two kinds and two behaviours. Called once by aaai.spec, with
    aaai.spec.kinds's Kind and register and aaai.spec.behaviours's Behaviour and register (this
    module imports neither, so no module of aaai.spec imports another but through the package)."""

    @register_kind
    class Spawner(kind):
        name = "spawner"
        colour = (0.45, 0.3, 0.2, 1.0)
        classic = "pillar"
        shape, shapes = "box", ("box", "cylinder")
        solid = True
        mark = "rim"
        camera = "a brown box or cylinder"
        rule = "a dispenser's body: an obstacle; the food it gives appears by it at set times (SpawnerDispenser, Tree)"

    @register_kind
    class Button(kind):
        name = "button"
        colour = (0.3, 0.7, 0.95, 1.0)
        classic = "pillar"
        shape, shapes = "cylinder", ("box", "cylinder")
        solid = True
        mark = "dot"
        camera = "a light-blue pillar"
        rule = "touched by the head: the food it guards appears (SpawnerButton)"

    class Hidden(behaviour):
        """Food that waits below the arena, then stands at its position for good."""

        starts_hidden = True

        def due(self, world, head: tuple[float, float] | None) -> bool:
            raise NotImplementedError

        def advance(self, world, body: int, dt: float, head) -> bool:
            if not self.due(world, head):
                return False
            world.place(body, self.obj.position, self.obj.yaw)
            return True

    @register_behaviour
    class Release(Hidden):
        """Appears ``after`` seconds into the episode (a dispenser's food)."""

        name = "release"
        fields = ("after",)

        def due(self, world, head) -> bool:
            return world.time >= float(self.obj.behaviour["after"]) - 1e-9

    @register_behaviour
    class Press(Hidden):
        """Appears the first time the agent's head is within ``reach`` of ``button`` (x, y)."""

        name = "press"
        fields = ("button", "reach")

        @staticmethod
        def heading_to(obj) -> tuple[float, float] | None:
            button = obj.behaviour.get("button")
            return tuple(button[:2]) if isinstance(button, (list, tuple)) and len(button) >= 2 else None

        def due(self, world, head) -> bool:
            if head is None:
                return False
            x, y = self.obj.behaviour["button"][:2]
            return math.hypot(head[0] - x, head[1] - y) <= float(self.obj.behaviour["reach"])
