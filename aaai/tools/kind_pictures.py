"""The docs' pictures of the object kinds: each newer kind in a small arena, the top view beside the
agent's head camera (``python -c "from aaai.tools.kind_pictures import write_kind_pictures as w;
w('docs/kinds')"``)."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from aaai.spec import AgentPose, LevelSpec, ObjectSpec
from aaai.tools.media import save_png
from aaai.tools.viewer import compose, draw_top_down


def kind_example(kind: str) -> ObjectSpec:
    """An object of a newer kind (aaai.spec.kinds) as the docs' pictures show it: 12 ahead of the agent."""
    from aaai.spec.kinds import REGISTRY, ZONE_THICKNESS

    cls = REGISTRY[kind]
    if cls.zone:
        return ObjectSpec(kind, "box", (12.0, 0.0, ZONE_THICKNESS / 2), (8.0, 10.0, ZONE_THICKNESS))
    if cls.shape == "sphere":
        return ObjectSpec(kind, "sphere", (12.0, 0.0, 1.5), (3.0, 3.0, 3.0))
    if "tunnel" in kind:
        return ObjectSpec(kind, "box", (14.0, 0.0, 4.5), (8.0, 16.0, 9.0))
    if kind.startswith("sign_"):
        return ObjectSpec(kind, "box", (12.0, 0.0, 3.0), (0.4, 6.0, 6.0))
    if kind == "ramp":
        return ObjectSpec(kind, "box", (14.0, 0.0, 1.0), (8.0, 8.0, 2.0), math.pi)
    return ObjectSpec(kind, "box", (14.0, 0.0, 1.5), (8.0, 8.0, 3.0), math.pi / 2)


def draw_kind(kind: str, size_px: int = 320, camera_px: int = 96) -> np.ndarray:
    """One kind in a 40 x 40 arena, the agent facing it: the top view beside the head camera's view
    (sensors.camera_look: task)."""
    from aaai.env import AnimalAIEnv
    from aaai.levels.common import arena_walls

    objects = tuple(arena_walls((40.0, 40.0), 4.0)) + (kind_example(kind),)
    spec = LevelSpec(
        level=0,
        name=kind,
        difficulty=0,
        seed=0,
        agent=AgentPose(-4.0, 0.0, 0.0),
        objects=objects,
        arena_size=(40.0, 40.0),
    )
    env = AnimalAIEnv(camera=True, camera_resolution=camera_px, camera_look="task", rays=False)
    try:
        observation, _ = env.reset(seed=0, options={"spec": spec, "check": False})
    finally:
        env.close()
    return compose(draw_top_down(spec, size_px), observation["camera"], (kind.replace("_", " "), "head camera"))


def write_kind_pictures(folder: str | os.PathLike) -> list[Path]:
    """docs/kinds/KIND.png for every newer kind, written atomically (aaai.tools.media)."""
    from aaai.spec.kinds import REGISTRY

    Path(folder).mkdir(parents=True, exist_ok=True)
    return [save_png(draw_kind(kind), Path(folder) / f"{kind}.png") for kind in REGISTRY]
