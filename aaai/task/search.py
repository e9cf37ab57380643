"""The searching reference: the reference controller acting only on the food its rays have shown it.

``SearchController(env)`` (``aaai eval --policy search``, ``train.teacher: search``) is the reference
controller of aaai.task.reference with one thing taken away: it is not told where the food is. A piece
becomes known to it only when one of the agent's own rays (the env's ``sensors``: fans, length,
angle) hits it, read from what the rays reported at the last observation (``Rays.last``: the body
each ray hit), never from a line of sight worked out from the spec. Then:

- **memory**: it remembers where it last saw each piece (its position at that moment; what is
  limited is which pieces it perceives, not how well), and how fast it was moving between two
  sightings less than a second apart: a piece out of view is looked for where that motion carries
  it, for at most PREDICT_SECONDS (a sliding piece behind an occluder). A remembered piece is
  forgotten when a ray that would have hit it where it should be (passing within half its radius
  of that place, unblocked before it) reports something else; it is then searched for from there.
- **search**: with no food known, it turns on the spot to look round (once at the start, and after
  losing a piece), then walks to unexplored space: the cell of the planner's grid, not yet swept by
  any of its rays, that is cheapest to reach with the most unswept space round it and the least turn
  from where the head faces (frontier exploration; so which way it goes follows from where it faces,
  which a student sees, more than from which of two like places scores a hair better). Rays sweep
  the cells they pass over, up to what they hit; a wall or an occluder leaves the space behind it
  unswept, so that is where it goes next. When everything reachable has
  been swept without food in sight, the sweep is forgotten and it starts again.
- **sectors** (L9): it looks round first, then goes into the sector where it has seen the most food.

What it knows of the static layout: the walls, holes and the plank of L10 are the planner's, as for the
reference (it plans paths and keeps clear of walls on the full occupancy grid, and so knows which
unswept places can be walked to). ``StrictSearchController`` (``--policy search_strict``) knows the
solids only once its rays have hit them or its head has come near them; it still knows the holes,
death zones and bad food from the layout. The food, and where to look for it, come from its rays alone.
The one privileged fact it reads is whether any food is left to eat at all (the world's list of
uneaten pieces): with none left it stops searching and stands, as the reference does; that ends
the search, it never chooses where to go. ``ThoroughSearchController`` (``--policy search_thorough``)
reads one more, whether food of positive value is left that its rays have never shown it: while some
is and the time allows, it searches on instead of eating a piece that ends the episode.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
import pybullet as p

from aaai.errors import ConfigError
from aaai.levels import validate
from aaai.sim.gait import SineGait
from aaai.sim.sensors import sighting_velocity, would_hit
from aaai.spec import ObjectSpec
from aaai.task.reference import GREEN_BERTH, INTERCEPT_SPEED, LAST, ReferenceController, _angle, _sector_of

PREDICT_SECONDS = 3.0  # a piece out of view is predicted along its seen motion for at most this long
LOOK_MARGIN = math.radians(20)  # a look round turns this much beyond what the fan already covers
LOOK_SECONDS = 12.0  # ... or for at most this long
SECTOR_TURNS = 2  # in a level of sectors (L9) it turns round this many times before it counts the food it saw
BODY_SEEN = 2.0  # cells this close to the head count as swept (it stands there)
GAIN_SPAN = 8.0  # unexplored space is weighed within a square this wide round a candidate cell
GAIN_WEIGHT = 20.0  # units of path cost one fully unswept neighbourhood is worth
TURN_WEIGHT = 8.0  # units of path cost a radian of turn from the head's heading to a goal's bearing costs
GOAL_SECONDS = 15.0  # gives up an exploration goal after this long, marking it swept
GOAL_REACHED = 2.0
HOLD_DETOUR = 1.5  # thorough: the way to a piece is counted as this many times the straight line ...
HOLD_MARGIN = 5.0  # ... walked at INTERCEPT_SPEED, plus this many seconds to spare
REVEAL = 0.75  # strict: a ray that hits a solid shows it within this far of the point it hit (units) ...
TOUCH = 3.0  # ... and a solid this near the head is felt (one under the rays: the legs meet it)
_SPAN = int(math.ceil(REVEAL / validate.GRID))
REVEAL_OFFSETS = [  # the cells (row, column offsets) within REVEAL of a ray's hit
    (dr, dc)
    for dr in range(-_SPAN, _SPAN + 1)
    for dc in range(-_SPAN, _SPAN + 1)
    if math.hypot(dr, dc) * validate.GRID <= REVEAL
]
SEARCH_CROUCH = 1.0  # it searches with its head low (about 1.7 above the floor, not 2.3): level rays see size-2 food


class _SearchGait(SineGait):
    """The gait, crouched at least ``low`` while it searches (as fast as upright, measured)."""

    low = 0.0

    def command(self, forward: float, turn: float, crouch: float = 0.0) -> None:
        super().command(forward, turn, max(crouch, self.low))


class SearchController(ReferenceController):
    """A policy: ``action = controller(observation)``; ``reset(seed)`` at each episode start."""

    strict = False  # plans on the solids its rays have shown, not on the level's layout (StrictSearchController)
    thorough = False  # searches on before eating a piece that ends the episode (ThoroughSearchController)
    gait: _SearchGait
    memory: dict[int, list]  # body -> [spec, (x, y, z), (vx, vy), time seen]
    seen: np.ndarray  # cells some ray has swept
    look_yaw: float | None
    goal: tuple[float, float] | None
    goals: int  # exploration goals chosen so far (each a plan key)
    hint: tuple[float, float] | None  # where a lost piece was last expected

    def __init__(self, env):
        super().__init__(env)
        self.gait = _SearchGait(self.env.body.joint_names, "forward", self.env.control_dt)
        if self.env.rays is None:
            raise ConfigError(
                "policy 'search': config key 'sensors.rays': got false; allowed: true (the searching "
                "reference sees food only through the agent's rays)"
            )
        local = self.env.rays.local_dirs
        self.fan = float(np.max(np.abs(np.arctan2(local[:, 1], local[:, 0]))))  # half the fan's angle

    # --- the episode's state -------------------------------------------------------------
    def _start_episode(self) -> None:
        super()._start_episode()
        self.sectors = self.sector is not None  # the level has sectors (layout), not which holds most food
        self.sector = None
        self.memory = {}
        self.sighted: set[int] = set()  # the pieces its rays have ever shown it
        self.seen = np.zeros(self.walk.shape, bool)
        self.looking, self.look_turned, self.look_yaw, self.look_started = True, 0.0, None, 0.0
        self.goal = None
        self.goal_started, self.goals = 0.0, 0
        self.hint = None
        if self.strict:  # the solids (walls, boxes, blocks, drops) are unknown, so free, until seen or felt
            self.hidden = (self.grid == 1) & (validate.hazard_grid(self.level) == 0)
            self.grid[self.hidden] = 0
            self._map()

    def student_drove(self, seconds: float) -> None:
        super().student_drove(seconds)
        self.goal_started += seconds
        self.look_started += seconds

    # --- what the rays show ----------------------------------------------------------------
    def _look(self, head: np.ndarray, now: float) -> None:
        """Reads the rays' last cast: the food they hit is known (or its memory refreshed), the
        cells they passed over are swept, and a remembered piece a ray should have hit is lost."""
        env = self.env
        starts, dirs, hits = env.rays.last
        if not len(hits):
            return
        reach = env.rays.reach()
        hit_now = set()
        for hit in hits:
            body = hit[0]
            if body in env.world.food and body not in hit_now:
                hit_now.add(body)
                self._saw(body, env.world.food[body], now)
        from_head = np.hypot(self.cell_x[None, :] - head[0], self.cell_y[:, None] - head[1])  # each cell's distance
        self._sweep(starts, dirs, reach, from_head)
        if self.strict:
            self._reveal(starts, dirs, reach, hits, head, from_head)
        for body in [body for body in self.memory if body not in hit_now]:
            if body not in env.world.food:  # eaten
                del self.memory[body]
                continue
            food, position = self.memory[body][0], self._where(body, now)
            if would_hit(starts, dirs, reach, position, food.size[0] / 2):
                del self.memory[body]
                self.hint = position[0], position[1]
                self._look_round(now)

    def _saw(self, body: int, food: ObjectSpec, now: float) -> None:
        position = p.getBasePositionAndOrientation(body, physicsClientId=self.env.client)[0]
        before = self.memory.get(body)
        velocity = sighting_velocity(before[1:4] if before else None, position, now)
        self.memory[body] = [food, tuple(position), velocity, now]
        self.sighted.add(body)
        self.hint = None

    def _where(self, body: int, now: float) -> tuple[float, float, float]:
        """Where a remembered piece should be now: where it was seen, moved on as it was moving
        then (for at most PREDICT_SECONDS), stopped short of a wall."""
        _, (x, y, z), (vx, vy), seen = self.memory[body]
        lapse = min(now - seen, PREDICT_SECONDS)
        if lapse <= 0.0 or vx == 0.0 and vy == 0.0:
            return x, y, z
        steps = max(1, int(math.hypot(vx, vy) * lapse / validate.GRID))
        last = x, y
        for k in range(1, steps + 1):
            t = lapse * k / steps
            if self.grid[validate.cell(self.level, x + vx * t, y + vy * t, self.grid.shape)]:
                break
            last = x + vx * t, y + vy * t
        return (*last, z)

    def _sweep(self, starts, dirs, reach, from_head: np.ndarray) -> None:
        """Marks the cells the rays passed over (their ground track up to what they hit)."""
        shape, level = self.seen.shape, self.level
        samples = np.arange(0.0, float(reach.max()) + validate.GRID, validate.GRID / 2)
        along = np.minimum(samples[None, :], reach[:, None])  # (rays, samples)
        x = starts[:, 0:1] + dirs[:, 0:1] * along
        y = starts[:, 1:2] + dirs[:, 1:2] * along
        cols = np.clip(np.floor((x + level.arena_size[0] / 2) / validate.GRID).astype(int), 0, shape[1] - 1)
        rows = np.clip(np.floor((y + level.arena_size[1] / 2) / validate.GRID).astype(int), 0, shape[0] - 1)
        self.seen[rows, cols] = True
        self.seen |= from_head <= BODY_SEEN

    def _reveal(self, starts, dirs, reach, hits, head: np.ndarray, from_head: np.ndarray) -> None:
        """Strict: the hidden solid cells near where a ray hit something other than food, and near the
        head, become known; the map is made again (from where the head is) when any did."""
        shape, level = self.grid.shape, self.level
        solid = np.array([hit[0] >= 0 and hit[0] not in self.env.world.food for hit in hits])
        found = np.zeros(shape, bool)
        if solid.any():
            points = starts[solid, :2] + dirs[solid, :2] * reach[solid, None]
            cols = np.floor((points[:, 0] + level.arena_size[0] / 2) / validate.GRID).astype(int)
            rows = np.floor((points[:, 1] + level.arena_size[1] / 2) / validate.GRID).astype(int)
            for dr, dc in REVEAL_OFFSETS:
                r, c = rows + dr, cols + dc
                inside = (r >= 0) & (r < shape[0]) & (c >= 0) & (c < shape[1])
                found[r[inside], c[inside]] = True
        found |= from_head <= TOUCH
        new = found & self.hidden
        if new.any():
            self.hidden &= ~new
            self.grid[new] = 1
            self._map((float(head[0]), float(head[1])))

    # --- what to do ----------------------------------------------------------------------
    def _look_round(self, now: float) -> None:
        self.looking, self.look_turned, self.look_yaw, self.look_started = True, 0.0, None, now
        self.goal = None

    def _foods(self):
        """The remembered pieces, where they should be now (in the chosen sector, in L9)."""
        now = self._now()
        if self.sectors and self.sector is None:
            if self.looking or not self.memory:
                return []  # looks round before it chooses a sector
            counts: dict[tuple[float, float], int] = {}
            for body in self.memory:
                sector = _sector_of(self._where(body, now))
                counts[sector] = counts.get(sector, 0) + 1
            self.sector = max(counts, key=lambda s: counts[s])
        foods = []
        for body, (food, *_) in self.memory.items():
            position = self._where(body, now)
            if self.sector is not None and _sector_of(position) != self.sector:
                continue
            foods.append((body, food, position))
        return foods

    @staticmethod
    def _food_goal(food: ObjectSpec, position) -> tuple[float, float]:
        return position[0], position[1]  # where it is expected now (_where), not where the spec moves it

    def _target(self, head: np.ndarray):
        target = super()._target(head)
        avoid: list = []
        if target is not None:
            if not self._holds_off(head, target):
                return target
            food, position = self.env.world.food[target[2]], self.memory[target[2]][1]
            avoid = [*target[3], (position[0], position[1], food.size[0] / 2 + self.radius + GREEN_BERTH)]
        elif not self.env.world.food:  # nothing left to eat: the search is over
            return target
        goal = self._explore_goal(head)
        if goal is None:
            return None
        return goal, 0.5, ("explore", self.goals), avoid, False

    def _holds_off(self, head: np.ndarray, target) -> bool:
        """Thorough: does it search on instead of eating the piece it goes for? When that piece ends the
        episode, the world still holds food of positive value its rays have never shown it, and the time
        left is more than walking there takes (HOLD_DETOUR x the straight line at INTERCEPT_SPEED, plus
        HOLD_MARGIN seconds)."""
        if not self.thorough or target[2] not in self.memory:  # not thorough, or a place to explore
            return False
        world = self.env.world.food
        food = world.get(target[2])
        if food is None or not (food.kind in LAST or self._ends_episode(food)):
            return False
        if not any(body not in self.sighted and piece.food_value > 0 for body, piece in world.items()):
            return False
        walk = math.dist(head[:2], target[0]) * HOLD_DETOUR / INTERCEPT_SPEED + HOLD_MARGIN
        return self.level.time_limit - self._now() > walk

    def _explore_goal(self, head: np.ndarray) -> tuple[float, float] | None:
        """The current exploration goal, or a new one: the unswept walkable cell cheapest to reach
        with the most unswept space round it; None when all is swept (the sweep starts again)."""
        now = self._now()
        if self.goal is not None:
            row, col = validate.cell(self.level, *self.goal, self.seen.shape)
            timed_out = now - self.goal_started > GOAL_SECONDS or self.strict and not self.walk[row, col]  # a wall seen
            if timed_out:
                self.seen[row, col] = True
            if not (self.seen[row, col] or math.dist(head[:2], self.goal) < GOAL_REACHED):
                return self.goal
        unswept = self.walk & ~self.seen
        if not unswept.any():
            self.seen[:] = False
            self._look_round(now)
            return None
        span = int(GAIN_SPAN / validate.GRID) | 1
        gain = cv2.blur(unswept.astype(np.float32), (span, span))
        here = np.zeros(self.walk.shape, bool)
        here[validate.cell(self.level, head[0], head[1], here.shape)] = True
        if not (here & self.walk).any():  # beside a wall: from the nearest walkable cell
            distance = np.where(
                self.walk, np.hypot(self.cell_x[None, :] - head[0], self.cell_y[:, None] - head[1]), 1e9
            )
            here = distance == distance.min()
        cost = validate.path_costs(self.walk, here, self.crowding)
        if self.hint is not None:
            cost = cost + np.hypot(self.cell_x[None, :] - self.hint[0], self.cell_y[:, None] - self.hint[1])
        rotation = self.env.body.head_pose()[1]
        yaw = math.atan2(rotation[1, 0], rotation[0, 0])
        turn = np.abs(_angle(np.arctan2(self.cell_y[:, None] - head[1], self.cell_x[None, :] - head[0]) - yaw))
        score = np.where(unswept & np.isfinite(cost), cost - GAIN_WEIGHT * gain + TURN_WEIGHT * turn, np.inf)
        if not np.isfinite(score).any():
            self.seen |= unswept  # nothing unswept can be reached from here
            return None
        r, c = np.unravel_index(np.argmin(score), score.shape)
        self.goal, self.goal_started, self.goals = (float(self.cell_x[c]), float(self.cell_y[r])), now, self.goals + 1
        return self.goal

    def _act(self) -> np.ndarray:
        env = self.env
        if self.spec is not env.level_spec or env.steps == 0 and self.plan_key is not None:
            self._start_episode()
        head, rotation = env.body.head_pose()
        yaw = math.atan2(rotation[1, 0], rotation[0, 0])
        now = self._now()
        self._look(head, now)
        self.gait.low = SEARCH_CROUCH if self.looking or not self._foods() else 0.0
        if self.looking:
            self.look_turned += abs(_angle(yaw - self.look_yaw)) if self.look_yaw is not None else 0.0
            self.look_yaw = yaw
            counting = self.sectors and self.sector is None  # L9: it counts the food in each sector first
            turn = 2 * math.pi * SECTOR_TURNS if counting else 2 * math.pi - 2 * self.fan + LOOK_MARGIN
            done = self.look_turned >= turn or now - self.look_started > LOOK_SECONDS * (
                SECTOR_TURNS if counting else 1
            )
            found = bool(self.memory) and not self.sectors
            if done or found or not env.world.food:
                self.looking = False
            else:
                self.gait.command(0.0, 1.0)
                return self.gait()
        return super()._act()


class StrictSearchController(SearchController):
    """The searching reference that knows the solids only as its senses show them (``--policy
    search_strict``, ``train.teacher: search_strict``): the walls, boxes, blocks and drops of the level
    are free space to its planner until a ray hits them (the cells within REVEAL of where it hit) or
    the head comes within TOUCH of them; then it plans round them. Holes, death zones and bad food it
    knows from the layout, as the searching reference does (the rays, in the head's plane, do not show
    a gap in the floor)."""

    strict = True


class ThoroughSearchController(SearchController):
    """The searching reference that, before it eats a piece that ends the episode (a green), searches on
    for food it has never seen while the time left allows (``--policy search_thorough``,
    ``train.teacher: search_thorough``). What it reads of the world for this is whether food of positive
    value is left that its rays have not shown it, never where or how much: so on L1 it looks for the
    yellows before it eats the green it saw first, and on L2b it searches until the yellow has sunk from
    its pillar into the rays' plane."""

    thorough = True


SEARCHERS = {
    "search": SearchController,
    "search_strict": StrictSearchController,
    "search_thorough": ThoroughSearchController,
}  # by policy and teacher name


def teacher(name: str, env) -> ReferenceController:
    """The controller a teacher's name (aaai.config.TEACHERS: reference, search, search_strict) names, on ``env``."""
    return SEARCHERS.get(name, ReferenceController)(env)
