"""Pictures of a level: a top-down map drawn from its spec (and a snapshot of a running one) and the
agent's camera view beside it. Pure drawing with OpenCV; images are H x W x 3 uint8 RGB (written to
files by aaai.tools.media).

World to picture: x grows to the right, y grows upward (north at the top); ``Mapping``
(from ``mapping_for``) turns world coordinates into pixel (column, row).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import cv2
import numpy as np

from aaai.agent.urdf_writer import COLOURS as BODY_COLOURS
from aaai.agent.urdf_writer import HEAD_RADIUS, LEG_REACH, LEGS, SEGMENT_RADIUS
from aaai.sim.snapshot import Snapshot
from aaai.spec import LevelSpec, ObjectSpec
from aaai.spec.behaviours import behaviour_class
from aaai.spec.kinds import COLOURS, kind_class

LEG_WIDTH = 2 * SEGMENT_RADIUS  # a leg capsule's diameter
LEG_ANGLES = tuple(angle for _, angle in LEGS)  # fl, fr, bl, br, degrees from the heading
HEADING_LENGTH = 7.5  # the heading arrow's length from the head's centre

MARGIN = 2.5  # world units shown around the arena (walls are 1 thick outside it)
TITLE_PX = 30
FOOTER_PX = 34
LABEL_PX = 24
FONT = cv2.FONT_HERSHEY_SIMPLEX
SHIFT = 4  # sub-pixel bits for OpenCV drawing
ONE = 1 << SHIFT

Colour = tuple[int, int, int]  # RGB, 0..255
BACKGROUND = (32, 32, 36)
TEXT = (235, 235, 235)
HEADING_COLOUR = (20, 60, 210)
MOVING_COLOUR = (255, 255, 255)
BACKGROUND_RGBA = tuple(c / 255 for c in BACKGROUND) + (1.0,)
HOLE_SHADE = 0.35  # a hole shows the deadly floor's red this bright
TILE_LINE_SHADE = 0.9


def rgb(colour: Sequence[float]) -> tuple[int, int, int]:
    """An RGB(A) colour in [0, 1] as a uint8 RGB triple."""
    r, g, b = (int(round(255 * max(0.0, min(1.0, c)))) for c in colour[:3])
    return r, g, b


HEAD_COLOUR = rgb(tuple(map(float, BODY_COLOURS["head"].split())))  # as the URDF's head: (217, 140, 64)
LEG_COLOUR = rgb(tuple(map(float, BODY_COLOURS["shin"].split())))  # as the URDF's shins: (153, 89, 38)


@dataclass(frozen=True)
class Mapping:
    """World (x, y) to picture (column, row): ``scale`` pixels per world unit."""

    scale: float
    origin: tuple[float, float]  # the pixel of world (0, 0)
    width: int
    height: int

    def to_px(self, x: float, y: float) -> tuple[int, int]:
        """The pixel (column, row) holding world point (x, y)."""
        col, row = self.to_float(x, y)
        return int(round(col)), int(round(row))

    def to_float(self, x: float, y: float) -> tuple[float, float]:
        """Continuous pixel coordinates (OpenCV's: pixel (c, r) is centred on (c, r))."""
        return self.origin[0] + x * self.scale, self.origin[1] - y * self.scale

    def fixed(self, x: float, y: float) -> tuple[int, int]:
        """Fixed-point pixel coordinates for OpenCV's ``shift`` argument."""
        col, row = self.to_float(x, y)
        return int(round(col * ONE)), int(round(row * ONE))

    def length(self, units: float) -> float:
        return units * self.scale


def mapping_for(spec: LevelSpec, size_px: int = 640) -> Mapping:
    """The world-to-pixel mapping of ``draw_top_down(spec, size_px)``: the longer side of the
    arena (plus a margin) spans ``size_px`` pixels; a title line sits above, a scale below."""
    extent_x = spec.arena_size[0] + 2 * MARGIN
    extent_y = spec.arena_size[1] + 2 * MARGIN
    scale = size_px / max(extent_x, extent_y)
    width = int(round(extent_x * scale))
    map_height = int(round(extent_y * scale))
    origin = (width / 2, TITLE_PX + map_height / 2)
    return Mapping(scale, origin, width, TITLE_PX + map_height + FOOTER_PX)


# --- the agent -------------------------------------------------------------------------
@dataclass(frozen=True)
class AgentShape:
    """The agent seen from above: head centre, heading (radians) and each leg as a polyline."""

    x: float
    y: float
    heading: float
    legs: tuple[tuple[tuple[float, float], ...], ...]
    radius: float = HEAD_RADIUS  # the head's; the sphere's own (agent.body: sphere)


def resting_agent(x: float, y: float, yaw: float) -> AgentShape:
    """The flat X of a resting agent: legs from the head's centre to 4.5 along the diagonals."""
    legs = []
    for angle in LEG_ANGLES:
        a = yaw + math.radians(angle)
        legs.append(((x, y), (x + LEG_REACH * math.cos(a), y + LEG_REACH * math.sin(a))))
    return AgentShape(x, y, yaw, tuple(legs))


def live_agent(snapshot: Snapshot) -> AgentShape:
    """The agent of a snapshot: head pose and each leg from the head's centre through its hip and
    knee to its foot (a resting X if the snapshot has no legs)."""
    head = snapshot.head
    if snapshot.radius is not None:  # the sphere: a disc, no legs
        return AgentShape(head.x, head.y, head.yaw, (), snapshot.radius)
    if not snapshot.legs:
        return resting_agent(head.x, head.y, head.yaw)
    legs = tuple(((head.x, head.y), leg.hip[:2], leg.knee[:2], leg.foot[:2]) for leg in snapshot.legs)
    return AgentShape(head.x, head.y, head.yaw, legs)


# --- drawing -----------------------------------------------------------------------------
def draw_top_down(
    spec: LevelSpec,
    size_px: int = 640,
    agent: AgentShape | None = None,
    objects: list[ObjectSpec] | None = None,
    note: str = "",
) -> np.ndarray:
    """The level seen from above, from the spec alone (no physics): H x W x 3 uint8 RGB.

    ``agent`` and ``objects`` replace the spec's agent pose and objects (``draw_snapshot`` passes
    the current ones: then an object whose top is below the floor is shown as a dashed outline,
    as a door is in the spec's own picture); ``note`` is appended to the title line.
    """
    m = mapping_for(spec, size_px)
    image = np.full((m.height, m.width, 3), BACKGROUND, np.uint8)
    _draw_floor(image, m, spec)
    live = objects is not None
    objects = list(spec.objects) if objects is None else list(objects)
    # Low things first so that tall ones cover them; food on top of everything but the agent.
    for obj in sorted(objects, key=lambda o: (o.is_food, o.position[2] + o.size[2] / 2)):
        _draw_object(image, m, obj, live)
    _draw_agent(image, m, agent or resting_agent(spec.agent.x, spec.agent.y, spec.agent.yaw))
    _draw_title(image, spec, note)
    _draw_footer(image, m, spec, objects, live)
    return image


def draw_snapshot(spec: LevelSpec, snapshot: Snapshot, size_px: int = 640) -> np.ndarray:
    """``draw_top_down`` of a level as a snapshot of it has it: objects and food where they are
    (eaten pieces gone), the agent's head and legs as they are; the title shows the simulated time."""
    objects = [
        replace(obj, position=(pose.x, pose.y, pose.z), yaw=pose.yaw)
        for obj, pose in zip(spec.objects, snapshot.objects)
        if pose is not None
    ]
    note = f"t {snapshot.time:5.2f} s"
    return draw_top_down(spec, size_px, agent=live_agent(snapshot), objects=objects, note=note)


def draw_world(env, size_px: int = 640) -> np.ndarray:
    """``draw_snapshot`` of a running environment as it is now (``env.snapshot()``)."""
    base = env.unwrapped
    if base.level_spec is None:
        raise RuntimeError("draw_world needs an environment that has been reset")
    return draw_snapshot(base.level_spec, base.snapshot(), size_px)


def _arena_corners(m: Mapping, spec: LevelSpec) -> tuple[tuple[int, int], tuple[int, int]]:
    hx, hy = spec.arena_size[0] / 2, spec.arena_size[1] / 2
    return m.fixed(-hx, hy), m.fixed(hx, -hy)


def _draw_floor(image: np.ndarray, m: Mapping, spec: LevelSpec) -> None:
    hx, hy = spec.arena_size[0] / 2, spec.arena_size[1] / 2
    top_left, bottom_right = _arena_corners(m, spec)
    if spec.heightfield is not None:
        _draw_heightfield(image, m, spec)
    else:
        cv2.rectangle(image, top_left, bottom_right, rgb(COLOURS["floor"]), -1, cv2.LINE_AA, SHIFT)
    nx, ny = spec.tiles
    tile_x, tile_y = spec.arena_size[0] / nx, spec.arena_size[1] / ny
    if spec.heightfield is None and nx * ny > 1:  # faint tile lines
        line = rgb([c * TILE_LINE_SHADE for c in COLOURS["floor"]])
        for i in range(1, nx):
            x = -hx + i * tile_x
            cv2.line(image, m.fixed(x, -hy), m.fixed(x, hy), line, 1, cv2.LINE_AA, SHIFT)
        for j in range(1, ny):
            y = -hy + j * tile_y
            cv2.line(image, m.fixed(-hx, y), m.fixed(hx, y), line, 1, cv2.LINE_AA, SHIFT)
    hole = rgb([c * HOLE_SHADE for c in COLOURS["deadly_floor"]])
    for i, j in spec.holes:
        x0, y0 = -hx + i * tile_x, -hy + j * tile_y
        cv2.rectangle(image, m.fixed(x0, y0 + tile_y), m.fixed(x0 + tile_x, y0), hole, -1, cv2.LINE_AA, SHIFT)


def _draw_heightfield(image: np.ndarray, m: Mapping, spec: LevelSpec) -> None:
    """Heights (rows along y from the south edge, columns along x from the west) as grey."""
    heights = np.asarray(spec.heightfield, dtype=np.float64)
    low, high = float(heights.min()), float(heights.max())
    grey = 70 + 170 * (heights - low) / (high - low) if high > low else np.full_like(heights, 155)
    grey = np.flipud(grey).astype(np.float32)  # row 0 is the south edge: the picture's bottom
    (c0, r0), (c1, r1) = (
        m.to_px(-spec.arena_size[0] / 2, spec.arena_size[1] / 2),
        m.to_px(spec.arena_size[0] / 2, -spec.arena_size[1] / 2),
    )
    c1, r1 = min(c1, m.width), min(r1, m.height)
    shade = cv2.resize(grey, (c1 - c0, r1 - r0), interpolation=cv2.INTER_LINEAR)
    image[r0:r1, c0:c1] = np.clip(shade, 0, 255).astype(np.uint8)[:, :, None]


def _box_corners(m: Mapping, obj: ObjectSpec) -> np.ndarray:
    cx, cy = obj.position[:2]
    hx, hy = obj.size[0] / 2, obj.size[1] / 2
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    corners = [(cx + c * dx - s * dy, cy + s * dx + c * dy) for dx, dy in ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy))]
    return np.array([m.fixed(x, y) for x, y in corners], np.int32)


def _dashed(image: np.ndarray, points: list[tuple[float, float]], colour: Colour, closed: bool = True) -> None:
    """A dashed polyline through continuous pixel coordinates."""
    dash = 6.0
    pairs = list(zip(points, points[1:] + points[:1] if closed else points[1:]))
    for (x0, y0), (x1, y1) in pairs:
        length = math.hypot(x1 - x0, y1 - y0)
        for k in range(int(length // (2 * dash)) + 1):
            a, b = 2 * k * dash / max(length, 1e-9), min(1.0, (2 * k + 1) * dash / max(length, 1e-9))
            if a >= 1.0:
                break
            start = (int(round((x0 + a * (x1 - x0)) * ONE)), int(round((y0 + a * (y1 - y0)) * ONE)))
            stop = (int(round((x0 + b * (x1 - x0)) * ONE)), int(round((y0 + b * (y1 - y0)) * ONE)))
            cv2.line(image, start, stop, colour, 1, cv2.LINE_AA, SHIFT)


def _outline_points(m: Mapping, obj: ObjectSpec) -> list[tuple[float, float]]:
    if obj.shape == "box":
        return [(c / ONE, r / ONE) for c, r in _box_corners(m, obj)]
    radius = obj.size[0] / 2
    return [
        m.to_float(obj.position[0] + radius * math.cos(a), obj.position[1] + radius * math.sin(a))
        for a in np.linspace(0, 2 * math.pi, 24, endpoint=False)
    ]


def _is_hidden(obj: ObjectSpec, live: bool) -> bool:
    """Not standing in the arena: a door before it rises (the spec gives where it will stand),
    or, in a running world, anything whose top is below the floor."""
    if live:
        return obj.position[2] + obj.size[2] / 2 <= 0.0
    moving = behaviour_class(obj)
    return bool(moving and moving.starts_hidden)


def _draw_object(image: np.ndarray, m: Mapping, obj: ObjectSpec, live: bool = False) -> None:
    r, g, b, alpha = obj.rgba
    colour = rgb((r, g, b))
    moving = behaviour_class(obj)
    if _is_hidden(obj, live):  # only a dashed outline where it will appear
        _dashed(image, _outline_points(m, obj), colour)
        return
    outline = rgb((0.6 * r, 0.6 * g, 0.6 * b))
    cls = kind_class(obj.kind)
    if cls is not None and cls.parts(obj):  # a tunnel's arch, an L block: each box it is built of
        from aaai.levels.validate import pieces

        for piece in sorted(pieces(obj), key=lambda o: o.position[2] + o.size[2] / 2):
            corners = _box_corners(m, piece)
            cv2.fillPoly(image, [corners], colour, cv2.LINE_AA, SHIFT)
            cv2.polylines(image, [corners], True, outline, 1, cv2.LINE_AA, SHIFT)
        _mark(image, m, obj, cls.mark)
        return
    layer = image.copy() if alpha < 1.0 else image
    centre = m.fixed(*obj.position[:2])
    radius = int(round(m.length(obj.size[0] / 2) * ONE))
    if obj.shape == "box":
        corners = _box_corners(m, obj)
        cv2.fillPoly(layer, [corners], colour, cv2.LINE_AA, SHIFT)
    else:
        cv2.circle(layer, centre, radius, colour, -1, cv2.LINE_AA, SHIFT)
    if alpha < 1.0:  # see-through: blended lightly over what is below, then outlined
        shown = max(alpha, 0.45)
        image[:] = cv2.addWeighted(layer, shown, image, 1.0 - shown, 0.0)
        outline = rgb((0.45 * r, 0.6 * g, 0.8 * b))
    thickness = 2 if alpha < 1.0 else 1
    if obj.shape == "box":
        cv2.polylines(image, [corners], True, outline, thickness, cv2.LINE_AA, SHIFT)
    else:
        cv2.circle(image, centre, radius, outline, thickness, cv2.LINE_AA, SHIFT)
    target = moving.heading_to(obj) if moving else None
    if target is not None:  # where it is heading
        tx, ty = target
        x, y = obj.position[:2]
        distance = math.hypot(tx - x, ty - y)
        reach = math.hypot(obj.size[0], obj.size[1]) / 2 if obj.shape == "box" else obj.size[0] / 2
        if distance > reach + 0.6:
            edge = (reach + 0.6) / distance
            start = m.to_float(x + edge * (tx - x), y + edge * (ty - y))
            _dashed(image, [start, m.to_float(tx, ty)], MOVING_COLOUR, closed=False)
            cv2.drawMarker(image, m.to_px(tx, ty), MOVING_COLOUR, cv2.MARKER_TILTED_CROSS, 8, 1, cv2.LINE_AA)
    if cls is not None:
        _mark(image, m, obj, cls.mark)
    if moving and moving.marked:  # a moving part: a white ring
        reach = math.hypot(obj.size[0], obj.size[1]) / 2 if obj.shape == "box" else obj.size[0] / 2
        ring = int(round(m.length(reach + 0.6) * ONE))
        cv2.circle(image, centre, ring, MOVING_COLOUR, 1, cv2.LINE_AA, SHIFT)


MARK_COLOUR = (255, 255, 255)


def _mark(image: np.ndarray, m: Mapping, obj: ObjectSpec, mark: str) -> None:
    """A newer kind's mark (aaai.spec.kinds): cross (bad food), dot (multi food, decoy), clock (food that
    ripens, decays, grows or shrinks), stripes (floor areas), arrow (a ramp, uphill), rim (a tunnel: its
    way through, dashed; a block: nothing more)."""
    x, y = obj.position[:2]
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    if mark == "cross":
        half = obj.size[0] / 2 * 0.6
        for dx, dy in ((half, half), (half, -half)):
            cv2.line(image, m.fixed(x - dx, y - dy), m.fixed(x + dx, y + dy), MARK_COLOUR, 2, cv2.LINE_AA, SHIFT)
    elif mark == "dot":
        cv2.circle(
            image,
            m.fixed(x, y),
            int(round(max(1.5, m.length(obj.size[0] / 6)) * ONE)),
            MARK_COLOUR,
            -1,
            cv2.LINE_AA,
            SHIFT,
        )
    elif mark == "stripes":  # diagonal hatching inside the area
        hx, hy = obj.size[0] / 2, obj.size[1] / 2
        step = max(1.0, min(hx, hy) / 3)
        shade = rgb(tuple(0.55 * v for v in obj.rgba[:3]))
        for k in range(-int((hx + hy) / step), int((hx + hy) / step) + 1):
            offset = k * step  # the line u - v = offset, clipped to the rectangle
            u0, u1 = max(-hx, -hy + offset), min(hx, hy + offset)
            if u0 >= u1:
                continue
            points = [(u, u - offset) for u in (u0, u1)]
            ends = [m.fixed(x + c * u - s * v, y + s * u + c * v) for u, v in points]
            cv2.line(image, ends[0], ends[1], shade, 1, cv2.LINE_AA, SHIFT)
    elif mark == "arrow":  # uphill
        half = obj.size[0] / 2 * 0.7
        start, end = m.fixed(x - c * half, y - s * half), m.fixed(x + c * half, y + s * half)
        cv2.arrowedLine(image, start, end, MARK_COLOUR, 2, cv2.LINE_AA, SHIFT, 0.25)
    elif mark == "symbol":  # a sign board: its 5 x 5 symbol laid flat over it, as seen from its -x side
        from aaai.spec.kinds import REGISTRY, SYMBOLS, Sign

        cell = max(obj.size[1], 3.0) / 5
        sign = REGISTRY[obj.kind]
        assert issubclass(sign, Sign)  # the kinds marked "symbol" are the sign boards
        for row, line in enumerate(SYMBOLS[sign.symbol]):
            for column, pixel in enumerate(line):
                u, v = -cell * (row - 2), cell * (2 - column)  # the picture's top away from the viewer
                px, py = x + c * u - s * v, y + s * u + c * v
                colour = (20, 20, 20) if pixel == "#" else (235, 235, 225)
                half = cell / 2
                corners = np.array(
                    [
                        m.fixed(px + dx, py + dy)
                        for dx, dy in ((-half, -half), (half, -half), (half, half), (-half, half))
                    ],
                    np.int32,
                )
                cv2.fillPoly(image, [corners], colour, cv2.LINE_AA, SHIFT)
    elif mark == "clock":  # food whose value changes over time: a white ring and one hand
        radius = max(1.5, m.length(obj.size[0] / 3))
        cv2.circle(image, m.fixed(x, y), int(round(radius * ONE)), MARK_COLOUR, 1, cv2.LINE_AA, SHIFT)
        cv2.line(image, m.fixed(x, y), m.fixed(x, y + obj.size[0] / 3), MARK_COLOUR, 2, cv2.LINE_AA, SHIFT)
    elif mark in ("rim",) and "tunnel" in obj.kind:  # the way through, along its axis
        half = obj.size[0] / 2 + 1.5
        _dashed(
            image,
            [m.to_float(x - c * half, y - s * half), m.to_float(x + c * half, y + s * half)],
            MARK_COLOUR,
            closed=False,
        )


def _draw_agent(image: np.ndarray, m: Mapping, agent: AgentShape) -> None:
    width = max(1, int(round(m.length(LEG_WIDTH))))
    for leg in agent.legs:
        points = np.array([m.fixed(x, y) for x, y in leg], np.int32)
        cv2.polylines(image, [points], False, LEG_COLOUR, width, cv2.LINE_AA, SHIFT)
    centre = m.fixed(agent.x, agent.y)
    cv2.circle(image, centre, int(round(m.length(agent.radius) * ONE)), HEAD_COLOUR, -1, cv2.LINE_AA, SHIFT)
    # The heading arrow from the head's rim, so that the head stays visible.
    c, s = math.cos(agent.heading), math.sin(agent.heading)
    start = m.to_float(agent.x + agent.radius * c, agent.y + agent.radius * s)
    end = m.to_float(agent.x + HEADING_LENGTH * c, agent.y + HEADING_LENGTH * s)
    cv2.arrowedLine(
        image,
        tuple(int(round(v * ONE)) for v in start),
        tuple(int(round(v * ONE)) for v in end),
        HEADING_COLOUR,
        max(2, width // 2),
        cv2.LINE_AA,
        SHIFT,
        0.3,
    )


def _text(image: np.ndarray, text: str, x: int, y: int, scale: float = 0.5, colour: Colour = TEXT) -> int:
    """Writes text with its baseline at y; returns the x just after it."""
    cv2.putText(image, text, (x, y), FONT, scale, colour, 1, cv2.LINE_AA)
    return x + cv2.getTextSize(text, FONT, scale, 1)[0][0]


def _title(spec: LevelSpec) -> str:
    from aaai.levels import all_levels

    level = all_levels().get(spec.level)
    if level is not None and level.name == spec.name:
        label, name = getattr(level, "label", f"L{level.id}"), f"{level.title} ({spec.name})"
    else:
        label, name = f"L{spec.level}", spec.name
    return f"{label} {name}   difficulty {spec.difficulty}   seed {spec.seed}"


def _draw_title(image: np.ndarray, spec: LevelSpec, note: str) -> None:
    text = _title(spec) + (f"   {note}" if note else "")
    scale = 0.5
    while scale > 0.3 and cv2.getTextSize(text, FONT, scale, 1)[0][0] > image.shape[1] - 16:
        scale -= 0.05
    _text(image, text, 8, TITLE_PX - 10, scale)


def _draw_footer(image: np.ndarray, m: Mapping, spec: LevelSpec, objects: list[ObjectSpec], live: bool) -> None:
    """A scale bar of 10 units and a key to the kinds shown."""
    y = m.height - FOOTER_PX // 2 + 5
    bar = m.length(10.0)
    x0 = 8
    cv2.line(image, (x0, y - 4), (int(x0 + bar), y - 4), TEXT, 2)
    for x in (x0, int(x0 + bar)):
        cv2.line(image, (x, y - 9), (x, y + 1), TEXT, 1)
    x = _text(image, f"10  (arena {spec.arena_size[0]:g} x {spec.arena_size[1]:g})", int(x0 + bar) + 6, y, 0.4)
    if spec.heightfield is not None:
        heights = np.asarray(spec.heightfield, dtype=np.float64)
        x = _text(image, f"  height {heights.min():.1f}..{heights.max():.1f}", x, y, 0.4)
    # The key: food, moving parts and holes first, as space may run out.
    shown: dict[str, tuple] = {}
    for obj in sorted(objects, key=lambda o: not o.is_food):
        shown.setdefault(obj.kind, obj.rgba)
        moving = behaviour_class(obj)
        if moving and moving.marked:
            shown.setdefault("moving (ring)", (1.0, 1.0, 1.0, 1.0))
        if _is_hidden(obj, live):
            shown.setdefault("hidden (dashed)", BACKGROUND_RGBA)
    if spec.holes:
        shown = {"hole": tuple(c * HOLE_SHADE for c in COLOURS["deadly_floor"][:3]) + (1.0,), **shown}
    x += 12
    for kind, colour in shown.items():
        label = kind.replace("_", " ")
        needed = 16 + cv2.getTextSize(label, FONT, 0.4, 1)[0][0] + 12
        if x + needed > image.shape[1]:
            break
        cv2.rectangle(image, (x, y - 10), (x + 11, y + 1), rgb(colour), -1)
        cv2.rectangle(image, (x, y - 10), (x + 11, y + 1), TEXT, 1)
        x = _text(image, label, x + 16, y, 0.4) + 12


def camera_image(frame: np.ndarray) -> np.ndarray:
    """A camera observation (r x r x 3, or r x r x 1 in grey) as r x r x 3 RGB."""
    frame = np.asarray(frame, np.uint8)
    if frame.ndim == 2:
        frame = frame[:, :, None]
    return np.repeat(frame, 3, axis=2) if frame.shape[2] == 1 else frame[:, :, :3]


def _labelled(image: np.ndarray, label: str) -> np.ndarray:
    strip = np.full((LABEL_PX, image.shape[1], 3), BACKGROUND, np.uint8)
    _text(strip, label, 8, LABEL_PX - 8, 0.5)
    return np.vstack([strip, image])


def compose(top_down: np.ndarray, camera_view: np.ndarray, labels: tuple[str, str] | None = None) -> np.ndarray:
    """The top-down picture and the camera view side by side, the camera scaled (nearest
    neighbour, so its pixels stay visible) to the same height, each under a label."""
    camera_view = camera_image(camera_view)
    height = top_down.shape[0]
    width = max(1, int(round(camera_view.shape[1] * height / camera_view.shape[0])))
    scaled = cv2.resize(camera_view, (width, height), interpolation=cv2.INTER_NEAREST)
    if labels is None:
        size = camera_view.shape
        labels = ("top view (north up)", f"agent camera ({size[1]} x {size[0]})")
    gap = np.full((height + LABEL_PX, 6, 3), BACKGROUND, np.uint8)
    return np.hstack([_labelled(top_down, labels[0]), gap, _labelled(scaled, labels[1])])
