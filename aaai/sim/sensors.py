"""What the agent senses: rays (one rayTestBatch per step) and a camera in its head, its joints,
feet and tilt; gathered each step into one Dict observation."""

from __future__ import annotations

import bisect
import math

import cv2
import numpy as np
import pybullet as p
from gymnasium import spaces

from aaai.agent.body import RAY_MASK, Quadruped
from aaai.agent.sphere import Sphere
from aaai.agent.urdf_writer import HEAD_RADIUS
from aaai.config import SensorsConfig
from aaai.sim.geometry import missing_floor
from aaai.spec import Blackout as SpecBlackout
from aaai.spec import LevelSpec
from aaai.spec.kinds import KIND_INDEX, kind_class, ray_channels

HOLE = KIND_INDEX["hole"]

CAMERA_FOV = 60.0
CAMERA_NEAR, CAMERA_FAR = 0.05, 120.0
EYE_OFFSET = HEAD_RADIUS + 0.05  # eye and ray origins sit just outside the head


class Rays:
    """2n+1 rays in the head's horizontal plane, from -max_angle (right) to +max_angle (left); with
    ``down_fan`` > 0 degrees, the same 2n+1 again pitched that far below the plane (rows 2n+1 on),
    for food lower than the head (the level rays pass over it).

    Each ray reports a one-hot of the kind hit (aaai.spec.kinds.KINDS order), a hit-nothing flag,
    and the hit distance over the ray length (1 when nothing is hit).

    Holes: rays in the head's plane pass over missing floor, so the level's holes, pits and
    trenches (``set_holes``: rectangles of missing tiles) are cast against analytically, in the
    floor plane: a ray whose ground track enters missing floor before anything stops it reports
    the kind ``hole`` at that distance (0 once the head is over the gap). Rays are lines, not the
    original's sphere casts of radius 0.5: an object narrower than the gap between two rays at its
    distance can lie unseen between them.

    Kinds (``ray_kinds``, aaai.spec.kinds.ray_channels): ``classic`` has the nine classic channels, a
    newer kind seen on its nearest classic one; ``all`` adds a channel per newer kind a policy
    must tell apart. Floor areas (hot and death zones, ``set_zones``) are seen along the ground
    track as holes are.
    """

    def __init__(
        self,
        client: int,
        rays_per_side: int,
        max_angle: float,
        length: float,
        flat: bool = False,
        ray_kinds: str = "classic",
        down_fan: float = 0.0,
        width: float = 0.0,
    ):
        self.client = client
        self.flat = flat
        self.length = length
        self.eye = EYE_OFFSET  # from the head's centre to where the rays start (the body's, Senses.start)
        angles = np.radians(np.linspace(-max_angle, max_angle, 2 * rays_per_side + 1))
        self.local_dirs = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
        self.level_rays = len(angles)  # the rows of the level fan (the down fan's follow)
        if down_fan > 0:  # the same fan again, pitched down_fan degrees below the head's plane
            pitch = np.radians(down_fan)
            lower = np.stack(
                [np.cos(angles) * np.cos(pitch), np.sin(angles) * np.cos(pitch), np.full_like(angles, -np.sin(pitch))],
                axis=1,
            )
            self.local_dirs = np.concatenate([self.local_dirs, lower])
        self.n_rays = len(self.local_dirs)
        # ray_width > 0: two more rays beside each, width / 2 to its left and right (level, across
        # it), in the same batch; the nearest of the three hits is the ray's (a sphere cast, roughly)
        self.width = width
        across = np.stack([-self.local_dirs[:, 1], self.local_dirs[:, 0], np.zeros(self.n_rays)], axis=1)
        self.local_sides = across / np.linalg.norm(across, axis=1, keepdims=True) * width / 2
        self.channels, self.column = ray_channels(ray_kinds)  # channel names; kind index -> column
        self.n_kinds = len(self.channels)
        self.grid_shape = (self.n_rays, self.n_kinds + 2)
        shape = (self.n_rays * (self.n_kinds + 2),) if flat else self.grid_shape
        self.space = spaces.Box(0.0, 1.0, shape, np.float32)
        self._nothing = self.n_kinds
        self._holes: np.ndarray | None = None  # (m, 4) rectangles x0, y0, x1, y1 of missing floor, or None
        self._zones: np.ndarray | None = None  # (m, 7) floor areas: centre x y, cos, sin of yaw, half x y, column
        self.threads = 1  # rayTestBatch's numThreads (0: all cores); the hits are the same for any
        self.last: tuple = (np.zeros((0, 3)), np.zeros((0, 3)), [])  # the last cast: starts, directions, hits
        self._reach: np.ndarray | None = None  # the last cast's reach, worked out when first asked for

    def set_holes(self, rectangles) -> None:
        """The level's missing floor as world rectangles (x0, y0, x1, y1); empty for none."""
        rectangles = np.asarray(rectangles, dtype=np.float64).reshape(-1, 4)
        self._holes = rectangles if len(rectangles) else None

    def set_zones(self, zones) -> None:
        """The level's floor areas as rows (centre x, y, yaw, half x, half y, kind index); empty for none."""
        zones = np.asarray(zones, dtype=np.float64).reshape(-1, 6)
        if not len(zones):
            self._zones = None
            return
        columns = [self.column[int(kind)] for kind in zones[:, 5]]
        self._zones = np.column_stack([zones[:, :2], np.cos(zones[:, 2]), np.sin(zones[:, 2]), zones[:, 3:5], columns])

    def observe(self, head_pos: np.ndarray, head_rot: np.ndarray, kind_index: np.ndarray) -> np.ndarray:
        dirs = self.local_dirs @ head_rot.T
        starts = head_pos + dirs * self.eye
        ends = starts + dirs * self.length
        if self.width:
            sides = self.local_sides @ head_rot.T
            batch_starts = np.concatenate([starts, starts + sides, starts - sides])
            batch_ends = np.concatenate([ends, ends + sides, ends - sides])
        else:
            batch_starts, batch_ends = starts, ends
        hits = p.rayTestBatch(
            batch_starts.tolist(),
            batch_ends.tolist(),
            numThreads=self.threads,
            collisionFilterMask=RAY_MASK,
            physicsClientId=self.client,
        )
        if self.width:
            hits = self._nearest(hits, kind_index)
        self.last = starts, dirs, hits  # what the rays reported, by body (aaai.task.search reads it)
        self._reach = None
        # A plain loop: for a few dozen rays it is several times faster than numpy's fancy indexing.
        obs = np.zeros(self.grid_shape, np.float32)
        known = len(kind_index)
        column = self.column
        for row, hit in enumerate(hits):
            body = hit[0]
            kind = kind_index[body] if 0 <= body < known else -1
            if kind >= 0:
                obs[row, column[kind]] = 1.0
                obs[row, -1] = hit[2]
            else:
                obs[row, self._nothing] = 1.0
                obs[row, -1] = 1.0
        if self._holes is not None:
            self._see_holes(obs, starts, dirs)
        if self._zones is not None:
            self._see_zones(obs, starts, dirs)
        return obs.reshape(-1) if self.flat else obs

    def reach(self) -> np.ndarray:
        """How far along each ray of the last cast it went before it hit something (its length when it hit
        nothing), from where it starts; worked out once a cast for the memories and the searching teacher."""
        if self._reach is None:
            self._reach = np.array([hit[2] for hit in self.last[2]]) * self.length
            self._reach.setflags(write=False)  # shared by its readers
        return self._reach

    def _nearest(self, hits, kind_index) -> list:
        """Of each ray's three hits (centre, left, right), the nearest of a known kind."""
        n, known = self.n_rays, len(kind_index)
        nearest = []
        for row in range(n):
            best = hits[row]
            for hit in (hits[row + n], hits[row + 2 * n]):
                if (
                    0 <= hit[0] < known
                    and kind_index[hit[0]] >= 0
                    and (not (0 <= best[0] < known and kind_index[best[0]] >= 0) or hit[2] < best[2])
                ):
                    best = hit
            nearest.append(best)
        return nearest

    def _see_zones(self, obs: np.ndarray, starts: np.ndarray, dirs: np.ndarray) -> None:
        """Marks each ray whose ground track enters a floor area before its hit as seeing that area's
        kind: the slab method in each area's own frame."""
        assert self._zones is not None  # observe calls it only when the level has floor areas
        cx, cy, cos, sin, hx, hy, columns = self._zones.T  # (m,)
        dx, dy = starts[:, 0:1] - cx, starts[:, 1:2] - cy  # (n, m)
        u0, v0 = dx * cos + dy * sin, -dx * sin + dy * cos
        du = dirs[:, 0:1] * cos + dirs[:, 1:2] * sin
        dv = -dirs[:, 0:1] * sin + dirs[:, 1:2] * cos
        du = np.where(du == 0.0, 1e-12, du)
        dv = np.where(dv == 0.0, 1e-12, dv)
        tu0, tu1 = (-hx - u0) / du, (hx - u0) / du
        tv0, tv1 = (-hy - v0) / dv, (hy - v0) / dv
        enter = np.maximum(np.maximum(np.minimum(tu0, tu1), np.minimum(tv0, tv1)), 0.0)
        leave = np.minimum(np.maximum(tu0, tu1), np.maximum(tv0, tv1))
        distance = np.where(leave >= enter, enter, np.inf) / self.length  # (n, m)
        nearest = distance.argmin(axis=1)
        distance = distance[np.arange(len(distance)), nearest]
        for row in np.flatnonzero(distance < obs[:, -1]):
            obs[row, :-1] = 0.0
            obs[row, int(columns[nearest[row]])] = 1.0
            obs[row, -1] = distance[row]

    def _see_holes(self, obs: np.ndarray, starts: np.ndarray, dirs: np.ndarray) -> None:
        """Marks each ray whose ground track enters missing floor before its hit as seeing a hole."""
        assert self._holes is not None  # observe calls it only when the level has missing floor
        x0, y0, x1, y1 = self._holes.T  # (m,)
        ground = dirs[:, :2].copy()
        ground[ground == 0.0] = 1e-12  # no division by zero: a ray parallel to a side meets it 'very far'
        inverse = 1.0 / ground
        tx0, tx1 = (x0 - starts[:, 0:1]) * inverse[:, 0:1], (x1 - starts[:, 0:1]) * inverse[:, 0:1]  # (n, m)
        ty0, ty1 = (y0 - starts[:, 1:2]) * inverse[:, 1:2], (y1 - starts[:, 1:2]) * inverse[:, 1:2]
        enter = np.maximum(np.minimum(tx0, tx1), np.minimum(ty0, ty1))  # the slab method
        leave = np.minimum(np.maximum(tx0, tx1), np.maximum(ty0, ty1))
        enter = np.maximum(enter, 0.0)  # a head over the gap sees it at once
        distance = np.where(leave >= enter, enter, np.inf).min(axis=1) / self.length  # (n,)
        rows = distance < obs[:, -1]
        if rows.any():
            obs[rows, :-1] = 0.0
            obs[rows, HOLE] = 1.0
            obs[rows, -1] = distance[rows]


class Camera:
    """A TinyRenderer camera in the head, looking forward: uint8 H x W x C (C = 3, or 1 in grey)."""

    def __init__(self, client: int, resolution: int, grayscale: bool):
        self.client = client
        self.eye = EYE_OFFSET  # from the head's centre to the eye (the body's, Senses.start)
        self.resolution = resolution
        self.grayscale = grayscale
        self.space = spaces.Box(0, 255, (resolution, resolution, 1 if grayscale else 3), np.uint8)
        self.projection = p.computeProjectionMatrixFOV(CAMERA_FOV, 1.0, CAMERA_NEAR, CAMERA_FAR)

    def observe(self, head_pos: np.ndarray, head_rot: np.ndarray) -> np.ndarray:
        forward, up = head_rot[:, 0], head_rot[:, 2]
        eye = head_pos + forward * self.eye
        return self.render(eye, eye + forward, up)

    def render(self, eye, target, up) -> np.ndarray:
        view = p.computeViewMatrix(eye.tolist(), target.tolist(), up.tolist())
        return render_rgb(self.client, self.resolution, self.resolution, view, self.projection, self.grayscale)

    def blank(self) -> np.ndarray:
        return np.zeros(self.space.shape, np.uint8)


class Blackout:
    """L7's schedule: the camera sees for ``light`` seconds, then is dark for ``dark``, repeating
    (or it switches at the listed ``switches``, dark after the first). Held in whole control steps;
    a level without one is never dark."""

    def __init__(self, schedule: SpecBlackout | None = None, control_dt: float = 1.0):
        self.steps = None
        self.switches: list[int] = []  # the steps at which the light switches, when listed
        if schedule and schedule.switches:
            self.switches = [round(t / control_dt) for t in schedule.switches]
        elif schedule:
            light = round(schedule.light / control_dt)
            # at least one step a cycle (light and dark shorter than half a step: dark throughout)
            self.steps = light, max(light + round(schedule.dark / control_dt), 1)

    def dark(self, step: int) -> bool:
        if self.switches:
            return bisect.bisect_right(self.switches, step) % 2 == 1
        return self.steps is not None and step % self.steps[1] >= self.steps[0]


class RayMemory:
    """What the rays showed of food before: ``depth`` earlier observations, 1, 2, 4 ... 2^(depth-1)
    observations (env steps) back, each ray's green-food and yellow-food flags and its distance (a
    ray that saw no food reads 0, 0, 1; so do the steps before the episode began).

    Rays are lines through the present: food that slides behind an occluder, or that the body
    turns away from, leaves them at once. This is the short memory of it, in the rays' own frame
    at the time (the frames are not turned with the body)."""

    def __init__(self, rays: Rays, depth: int):
        self.lags = 2 ** np.arange(depth)
        self.columns = [rays.column[KIND_INDEX["food_green"]], rays.column[KIND_INDEX["food_yellow"]]]
        self.grid_shape = rays.grid_shape
        self.space = spaces.Box(0.0, 1.0, (depth, rays.n_rays, 3), np.float32)
        self._frames = np.zeros((int(self.lags[-1]), rays.n_rays, 3), np.float32)  # a ring, newest at _newest
        self._newest = -1
        self.clear()

    def clear(self) -> None:
        self._frames[:] = 0.0
        self._frames[:, :, 2] = 1.0
        self._newest = -1

    def recall(self, rays: np.ndarray) -> np.ndarray:
        """The memory as it stands before ``rays`` (this step's), then ``rays`` remembered."""
        size = len(self._frames)
        recalled = self._frames[(self._newest - self.lags + 1) % size]
        grid = rays.reshape(self.grid_shape)
        self._newest = (self._newest + 1) % size
        frame = self._frames[self._newest]
        frame[:, :2] = grid[:, self.columns]
        frame[:, 2] = np.where(frame[:, :2].any(axis=1), grid[:, -1], 1.0)
        return recalled


FOOD_MEMORY_FIELDS = 7  # present, green, yellow, ahead, left, size, age
FOOD_MEMORY_SIZE = 10.0  # units: the size field reads 1 from this diameter on
FOOD_MEMORY_AGE = 60.0  # seconds: the age field reads 1 from this on
FOOD_PREDICT = 3.0  # seconds: a remembered piece is carried along its seen motion for at most this long
FOOD_MOTION_GAP = 1.0  # seconds: two sightings this close in time give a velocity
FOOD_MISS = 0.5  # a ray passing within this fraction of a piece's radius of where it should be would have hit it


class FoodMemory:
    """Where the rays last showed each piece of food, carried with the body (path integration).

    A piece becomes remembered when one of the rays hits it: its position at that moment, and how
    fast it moved between two sightings less than FOOD_MOTION_GAP apart (a piece out of view is
    expected where that motion carries it, for at most FOOD_PREDICT seconds). It is forgotten when
    it is eaten, or when a ray that would have hit it where it should be (passing within half its
    radius of that place, unblocked before it) shows something else. The observation holds the
    ``slots`` nearest remembered pieces, nearest first, each as ``present, green, yellow, ahead,
    left, size, age``: where it should be in the head's frame turned by its yaw only (units over the
    rays' length, clipped to -1..1), its width over FOOD_MEMORY_SIZE (clipped to 1) and the seconds
    since it was last seen over FOOD_MEMORY_AGE (clipped to 1); empty slots read 0. Pieces in view
    read age 0. Perception of a piece seen is exact; what is limited is which pieces the rays see (the
    same rule as ``--policy search``)."""

    def __init__(self, rays: Rays, slots: int):
        self.rays = rays
        self.slots = slots
        self.kinds = {KIND_INDEX["food_green"]: 1, KIND_INDEX["food_yellow"]: 2}  # kind index -> field
        self.space = spaces.Box(-1.0, 1.0, (slots, FOOD_MEMORY_FIELDS), np.float32)
        self.pieces: dict[int, list] = {}  # body -> [field, (x, y, z), (vx, vy), time seen, radius]

    def clear(self) -> None:
        self.pieces = {}

    def where(self, body: int, now: float) -> tuple[float, float, float]:
        """Where a remembered piece should be at ``now``."""
        _, (x, y, z), (vx, vy), seen, _ = self.pieces[body]
        lapse = min(max(now - seen, 0.0), FOOD_PREDICT)
        return x + vx * lapse, y + vy * lapse, z

    def recall(self, head_pos: np.ndarray, head_rot: np.ndarray, kind_index: np.ndarray, now: float) -> np.ndarray:
        """Updates the memory from the rays' last cast, then reads it as the observation."""
        client = self.rays.client
        starts, dirs, hits = self.rays.last
        known = len(kind_index)
        seen = set()
        for hit in hits:
            body = hit[0]
            if 0 <= body < known and kind_index[body] in self.kinds and body not in seen:
                seen.add(body)
                position = p.getBasePositionAndOrientation(body, physicsClientId=client)[0]
                before = self.pieces.get(body)
                if before is None:
                    low, high = p.getAABB(body, physicsClientId=client)
                    radius = max(high[0] - low[0], high[1] - low[1]) / 2
                else:
                    radius = before[4]
                velocity = sighting_velocity(before[1:4] if before else None, position, now)
                self.pieces[body] = [self.kinds[int(kind_index[body])], tuple(position), velocity, now, radius]
        unseen = [body for body in self.pieces if body not in seen]
        if unseen and len(hits):
            reach = self.rays.reach()
            for body in unseen:
                if not (0 <= body < known and kind_index[body] in self.kinds):  # eaten
                    del self.pieces[body]
                elif would_hit(starts, dirs, reach, self.where(body, now), self.pieces[body][4]):
                    del self.pieces[body]
        out = np.zeros((self.slots, FOOD_MEMORY_FIELDS), np.float32)
        if not self.pieces:
            return out
        yaw = math.atan2(head_rot[1, 0], head_rot[0, 0])
        cos, sin = math.cos(yaw), math.sin(yaw)
        rows = []
        for body, (field, _, _, seen_at, radius) in self.pieces.items():
            x, y, _ = self.where(body, now)
            dx, dy = x - head_pos[0], y - head_pos[1]
            ahead, left = cos * dx + sin * dy, -sin * dx + cos * dy
            rows.append((dx * dx + dy * dy, body, field, ahead, left, now - seen_at, radius))
        rows.sort()
        scale = self.rays.length
        for slot, (_, _, field, ahead, left, age, radius) in enumerate(rows[: self.slots]):
            out[slot, 0] = 1.0
            out[slot, field] = 1.0
            out[slot, 3] = min(max(ahead / scale, -1.0), 1.0)
            out[slot, 4] = min(max(left / scale, -1.0), 1.0)
            out[slot, 5] = min(2 * radius / FOOD_MEMORY_SIZE, 1.0)
            out[slot, 6] = min(age / FOOD_MEMORY_AGE, 1.0)
        return out


SWEEP_CELLS = 15  # cells of the sweep memory's map of the floor to a ray's length (1 unit for the default 15)
SWEEP_RINGS = (1.0, 2.0, 4.0)  # its rings' outer radii, in ray lengths: near, middle, far
SWEEP_BODY = 2.0  # floor this close to the head counts as looked over (the body stands there)
SWEEP_MAP_REACH = 2.0  # ray lengths: the sweep map reaches this far ahead, behind and to either side


class SweepMemory:
    """Where the rays have looked: a map of the arena's floor in square cells (SWEEP_CELLS of them to
    a ray's length), each marked once the level fan has passed over its centre (nearer than what the
    rays hit at its bearing: the reach of the two rays either side, interpolated) or the head has
    been within SWEEP_BODY of it.

    The observation, shape (sectors, 3), says how much of the floor round the body is still unlooked
    at: ``sectors`` equal sectors of directions, the first centred straight ahead and the rest going
    round to the left, each cut into three rings (out to 1, 2 and 4 ray lengths); each reads the share
    of that ring-sector's cells, inside the arena, not yet looked over (0 when it holds none). A cell
    is placed by its offset from the cell the head is in (to within half a cell). It is the searching
    teacher's map of where it has looked (aaai.task.search), as a sense: unexplored space lies where it
    reads high. The arena's size is the one fact it takes from the level; what is in the arena comes
    from the rays alone (the inside of a wall is never looked over)."""

    def __init__(self, rays: Rays, sectors: int, map_cells: int = 0):
        self.rays = rays
        self.sectors = sectors
        self.space = spaces.Box(0.0, 1.0, (sectors, len(SWEEP_RINGS)), np.float32)
        self.map_cells = map_cells
        self.map_space = spaces.Box(0.0, 1.0, (2, map_cells, map_cells), np.float32)
        self.map_reach = SWEEP_MAP_REACH * rays.length
        fan = rays.local_dirs[: rays.level_rays]
        self.angles = np.arctan2(fan[:, 1], fan[:, 0])  # the level fan's bearings, right to left
        self.all_round = self.angles[-1] - self.angles[0] >= 2 * math.pi - 1e-6
        self.cell = rays.length / SWEEP_CELLS
        self.pad = pad = int(math.ceil(SWEEP_RINGS[-1] * SWEEP_CELLS))  # the read's window: 2 pad + 1 cells a side
        offsets = np.arange(-pad, pad + 1) * self.cell
        distance = np.hypot(offsets[None, :], offsets[:, None])
        ring = np.searchsorted(np.array(SWEEP_RINGS) * rays.length, distance)
        self.keep = ring < len(SWEEP_RINGS)  # the window's cells in some ring
        self.ring = ring[self.keep]
        self.bearing = np.arctan2(offsets[:, None], offsets[None, :])[self.keep]
        near = int(math.ceil(SWEEP_CELLS + rays.eye / self.cell)) + 1  # the update's window: 2 near + 1 cells a side
        self.near = np.arange(-near, near + 1)
        self.map_pad = int(math.ceil(self.map_reach * math.sqrt(2) / self.cell))  # the map's window (turned square)
        assert self.map_pad <= pad
        self.map_offsets = np.arange(-self.map_pad, self.map_pad + 1)  # the map window's cells from the head's
        self.floor = self.seen = self.hit = np.zeros((0, 0), bool)
        self.x0 = self.y0 = 0.0
        self.cols = self.rows = 0  # the arena's cells, unpadded
        self._where = (0.0, 0.0, 0.0, 0, 0)  # the head's x, y, yaw and cell at the last mark (the reads read it)

    def start(self, arena_size) -> None:
        """A new, unlooked-at map of an arena ``arena_size`` (x, y) across, centred on the origin."""
        cols, rows = (max(1, int(math.ceil(side / self.cell))) for side in arena_size[:2])
        pad = self.pad
        self.floor = np.zeros((rows + 2 * pad, cols + 2 * pad), bool)  # padded all round with cells of no floor
        self.floor[pad:-pad, pad:-pad] = True
        self.seen = np.zeros_like(self.floor)
        self.hit = np.zeros_like(self.floor)
        self.x0, self.y0 = -cols * self.cell / 2, -rows * self.cell / 2
        self.cols, self.rows = cols, rows

    def mark(self, head_pos: np.ndarray, head_rot: np.ndarray) -> None:
        """Marks what the rays' last cast looked over (and, with a map, where they stopped), from the
        head's place, which :meth:`read_sectors` and :meth:`read_map` then read round."""
        yaw = math.atan2(head_rot[1, 0], head_rot[0, 0])
        pad, cell = self.pad, self.cell
        col = min(max(int((head_pos[0] - self.x0) // cell), 0), self.cols - 1)
        row = min(max(int((head_pos[1] - self.y0) // cell), 0), self.rows - 1)
        self._where = (float(head_pos[0]), float(head_pos[1]), yaw, row, col)
        # the update, on the exact head position, over the cells a ray can reach
        index, near = self.near, int(self.near[-1])
        x = self.x0 + (col + index + 0.5) * cell
        y = self.y0 + (row + index + 0.5) * cell
        dx, dy = x[None, :] - head_pos[0], y[:, None] - head_pos[1]
        distance = np.hypot(dx, dy)
        looked = distance <= SWEEP_BODY
        reach = self.rays.reach()[: len(self.angles)] + self.rays.eye
        if len(reach):
            bearing = (np.arctan2(dy, dx) - yaw + math.pi) % (2 * math.pi) - math.pi
            if self.all_round:
                limit = np.interp(bearing, self.angles, reach, period=2 * math.pi)
                looked |= distance <= limit
            else:
                inside = (bearing >= self.angles[0]) & (bearing <= self.angles[-1])
                looked |= inside & (distance <= np.interp(bearing, self.angles, reach))
        self.seen[pad + row - near : pad + row + near + 1, pad + col - near : pad + col + near + 1] |= looked
        if self.map_cells and len(reach):  # where a ray of the level fan stopped short of its length
            short = reach < self.rays.length + self.rays.eye - 1e-6
            ends_x = head_pos[0] + reach[short] * np.cos(self.angles[short] + yaw)
            ends_y = head_pos[1] + reach[short] * np.sin(self.angles[short] + yaw)
            hit_cols = np.clip(((ends_x - self.x0) // cell).astype(np.intp), -pad, self.cols + pad - 1)
            hit_rows = np.clip(((ends_y - self.y0) // cell).astype(np.intp), -pad, self.rows + pad - 1)
            self.hit[hit_rows + pad, hit_cols + pad] = True

    def read_sectors(self) -> np.ndarray:
        """The marks round the head (after :meth:`mark`) in its sectors and rings, shape (sectors, 3)."""
        _, _, yaw, row, col = self._where
        pad = self.pad
        window = (slice(row, row + 2 * pad + 1), slice(col, col + 2 * pad + 1))
        floor = self.floor[window][self.keep]
        unlooked = floor & ~self.seen[window][self.keep]
        width = 2 * math.pi / self.sectors
        sector = ((self.bearing - yaw + width / 2) % (2 * math.pi) // width).astype(np.intp)
        np.minimum(sector, self.sectors - 1, out=sector)
        bins = sector * len(SWEEP_RINGS) + self.ring
        share = _unlooked_share(bins, floor, unlooked, self.sectors * len(SWEEP_RINGS))
        return share.reshape(self.sectors, len(SWEEP_RINGS)).astype(np.float32)

    def read_map(self) -> np.ndarray:
        """The marks round the head as a map turned with it (after :meth:`mark`), shape (2, n, n):
        a square SWEEP_MAP_REACH ray lengths each way from the head, cut into n x n blocks, the first
        axis from behind to ahead, the second from right to left. Channel 0: the share of a block's
        floor, inside the arena, not yet looked over (0 where it holds none); channel 1: 1 where a ray
        has stopped on something there (a wall, a box, food: what the rays have met), else 0."""
        n, reach, m, pad, cell = self.map_cells, self.map_reach, self.map_pad, self.pad, self.cell
        x, y, yaw, row, col = self._where
        dx = self.x0 + (col + self.map_offsets + 0.5) * cell - x
        dy = self.y0 + (row + self.map_offsets + 0.5) * cell - y
        c, s = math.cos(yaw), math.sin(yaw)
        ahead = c * dx[None, :] + s * dy[:, None]
        left = -s * dx[None, :] + c * dy[:, None]
        width = 2 * reach / n
        i = np.floor((ahead + reach) / width).astype(np.intp)
        j = np.floor((left + reach) / width).astype(np.intp)
        inside = (i >= 0) & (i < n) & (j >= 0) & (j < n)
        bins = (i * n + j)[inside]
        window = (slice(pad + row - m, pad + row + m + 1), slice(pad + col - m, pad + col + m + 1))
        floor = self.floor[window][inside]
        unlooked = floor & ~self.seen[window][inside]
        share = _unlooked_share(bins, floor, unlooked, n * n)
        hit = np.bincount(bins[self.hit[window][inside]], minlength=n * n) > 0
        return np.stack([share, hit]).reshape(2, n, n).astype(np.float32)


def _unlooked_share(bins: np.ndarray, floor: np.ndarray, unlooked: np.ndarray, size: int) -> np.ndarray:
    """Per bin (of ``size``), the share of its floor cells not yet looked over (0 where it holds none)."""
    total = np.bincount(bins[floor], minlength=size)
    return np.divide(np.bincount(bins[unlooked], minlength=size), total, out=np.zeros(size), where=total > 0)


def sighting_velocity(before, position, now: float) -> tuple[float, float]:
    """A seen piece's velocity in the floor's plane from its sighting ``before`` ((x, y, z), (vx, vy),
    time; None for a first sighting) and this one: the motion between two sightings less than
    FOOD_MOTION_GAP apart, the earlier velocity for a second sighting at the same moment, else 0."""
    if not before:
        return 0.0, 0.0
    (x, y, _), velocity, seen = before
    if 0.0 < now - seen <= FOOD_MOTION_GAP:
        return (position[0] - x) / (now - seen), (position[1] - y) / (now - seen)
    return velocity if now == seen else (0.0, 0.0)


def would_hit(starts: np.ndarray, dirs: np.ndarray, reach: np.ndarray, position, radius: float) -> bool:
    """Would one of the rays, as cast (each stopped at ``reach``), have hit a piece of ``radius`` at ``position``?"""
    offset = np.asarray(position) - starts
    along = np.einsum("ij,ij->i", offset, dirs)
    inside = (along > radius) & (along < reach - radius)
    miss = np.linalg.norm(offset - along[:, None] * dirs, axis=1)
    return bool(np.any(inside & (miss < FOOD_MISS * radius)))


class Senses:
    """The body's senses as the config's ``sensors`` section sets them, and their Dict space."""

    def __init__(self, client: int, sensors: SensorsConfig, body: Quadruped | Sphere):
        self.body = body
        self.rays = (
            Rays(
                client,
                sensors.rays_per_side,
                sensors.ray_max_angle,
                sensors.ray_length,
                sensors.rays_flat,
                sensors.ray_kinds,
                sensors.ray_down_fan,
                sensors.ray_width,
            )
            if sensors.rays
            else None
        )
        self.camera = Camera(client, sensors.camera_resolution, sensors.camera_grayscale) if sensors.camera else None
        self.blackout = Blackout()
        self.foot_slot = body.foot_slot
        self.feet = np.zeros(len(body.foot_links), np.float32)
        n = body.n_axes
        space: dict[str, spaces.Space] = {"joints": spaces.Box(-1.0, 1.0, (n,), np.float32)}
        if self.rays:
            space["rays"] = self.rays.space
        depth = sensors.ray_memory
        self.memory = RayMemory(self.rays, depth) if self.rays and depth else None
        if self.memory:
            space["ray_memory"] = self.memory.space
        self.food_memory = FoodMemory(self.rays, sensors.food_memory) if self.rays and sensors.food_memory else None
        if self.food_memory:
            space["food_memory"] = self.food_memory.space
        sweeps = sensors.sweep_memory or sensors.sweep_map
        self.sweep_memory = (
            SweepMemory(self.rays, sensors.sweep_memory, sensors.sweep_map) if self.rays and sweeps else None
        )
        if self.sweep_memory and sensors.sweep_memory:
            space["sweep_memory"] = self.sweep_memory.space
        if self.sweep_memory and sensors.sweep_map:
            space["sweep_map"] = self.sweep_memory.map_space
        if self.camera:
            space["camera"] = self.camera.space
        if sensors.joint_velocities:
            space["joint_velocities"] = spaces.Box(-np.inf, np.inf, (n,), np.float32)
        if sensors.head_orientation:
            space["head_orientation"] = spaces.Box(-1.0, 1.0, (3,), np.float32)
        if sensors.foot_contacts:
            space["foot_contacts"] = spaces.Box(0.0, 1.0, (len(self.feet),), np.float32)
        self.space = spaces.Dict(space)
        self.joint_velocities = "joint_velocities" in space
        self.head_orientation = "head_orientation" in space
        self.foot_contacts = "foot_contacts" in space

    def start(self, spec: LevelSpec, control_dt: float) -> None:
        """Readies the senses for a new level (after the body is loaded): the rays learn its missing
        floor, the camera its blackout; both start just outside the body's head, as large as it is now."""
        eye = getattr(self.body, "radius", HEAD_RADIUS) + (EYE_OFFSET - HEAD_RADIUS)
        for sense in (self.rays, self.camera):
            if sense is not None:
                sense.eye = eye
        if self.rays:
            self.rays.set_holes(missing_floor(spec))
            self.rays.set_zones(
                [
                    (*obj.position[:2], obj.yaw, obj.size[0] / 2, obj.size[1] / 2, KIND_INDEX[obj.kind])
                    for obj in spec.objects
                    if getattr(kind_class(obj.kind), "zone", False)
                ]
            )
        self.blackout = Blackout(spec.blackout, control_dt)
        self.feet[:] = 0.0
        if self.memory:
            self.memory.clear()
        if self.food_memory:
            self.food_memory.clear()
        if self.sweep_memory:
            self.sweep_memory.start(spec.arena_size)

    def feel(self, contacts) -> None:
        """Which feet touch anything, from the step's contacts of the body (only worked out when the
        feet are observed)."""
        if not self.foot_contacts:
            return
        self.feet[:] = 0.0
        slot = self.foot_slot
        for contact in contacts:
            if contact[3] in slot:
                self.feet[slot[contact[3]]] = 1.0

    def observe(
        self,
        angles: np.ndarray,
        speeds: np.ndarray,
        position,
        orientation,
        kind_index: np.ndarray,
        dark: bool,
        now: float = 0.0,
    ) -> dict[str, np.ndarray]:
        """The observation; ``now`` (seconds into the episode) times the food memory's sightings."""
        observation = {"joints": angles.astype(np.float32)}
        if self.rays or self.camera or self.head_orientation:
            head_pos = np.array(position)
            head_rot = np.array(p.getMatrixFromQuaternion(orientation)).reshape(3, 3)
        if self.rays:
            observation["rays"] = self.rays.observe(head_pos, head_rot, kind_index)
            if self.memory:
                observation["ray_memory"] = self.memory.recall(observation["rays"])
            if self.food_memory:
                observation["food_memory"] = self.food_memory.recall(head_pos, head_rot, kind_index, now)
            if self.sweep_memory:
                self.sweep_memory.mark(head_pos, head_rot)
                if self.sweep_memory.sectors:
                    observation["sweep_memory"] = self.sweep_memory.read_sectors()
                if self.sweep_memory.map_cells:
                    observation["sweep_map"] = self.sweep_memory.read_map()
        if self.camera:
            observation["camera"] = self.camera.blank() if dark else self.camera.observe(head_pos, head_rot)
        if self.joint_velocities:
            observation["joint_velocities"] = speeds.astype(np.float32)
        if self.head_orientation:
            observation["head_orientation"] = (-head_rot[2, :]).astype(np.float32)  # gravity in the head frame
        if self.foot_contacts:
            observation["foot_contacts"] = self.feet.copy()
        return observation


def render_rgb(client: int, width: int, height: int, view, projection, grayscale: bool = False) -> np.ndarray:
    """An image from TinyRenderer as uint8 H x W x 3 (or H x W x 1 in grey)."""
    _, _, rgba, _, _ = p.getCameraImage(
        width,
        height,
        view,
        projection,
        renderer=p.ER_TINY_RENDERER,
        flags=p.ER_NO_SEGMENTATION_MASK,
        physicsClientId=client,
    )
    rgb = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]
    if grayscale:
        return cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)[:, :, None]
    return np.ascontiguousarray(rgb)
