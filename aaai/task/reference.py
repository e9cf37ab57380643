"""The reference controller: a privileged policy that shows what this body can do in each level.

It reads what no learning agent is given (the level spec, the live positions of food and
planks) and plans on the solvability grid of ``aaai.levels.validate``; it acts only through the
ordinary action vector, by steering the gait of ``aaai.sim.gait`` (no teleporting, no forces of its
own). Its tactic is the same in every level, driven by what the level holds:

- food: every yellow worth eating first (nearest first), then the best green; a green that is
  not the target is given a wide berth, so it is not eaten by accident before the yellows;
- a yellow on a sinking pillar (L2b): wait beside the pillar until the piece is down, eat it,
  then the green;
- a sliding piece (L8): go to where it will stop;
- a bouncing piece (Animal-AI's bouncing goals), with the quadruped: while it is far, stand on its
  path where the body gets first with INTERCEPT_MARGIN seconds to spare, before the episode's time is
  up (the path worked out once, as the world moves it, aaai.spec.behaviours.Bounce), facing it; once
  it is near, go at it (the sphere, many times as fast, goes straight at it);
- a big piece (Animal-AI's size 10, its centre HIGH_FOOD or more above the floor), which the front legs
  meet before the head: crouched up to it, then the head up, onto it;
- sectors with doors (L9): only the sector with the most food, and every piece in it;
- an arena that allows food out of reach (``reach: pass_mark``, Animal-AI's lures): the pieces the
  body cannot reach (aaai.levels.validate.food_reachable) are left alone;
- a plank to tip over as a bridge (L10): walk round behind it, push it over, cross on it;
- everything else (walls, holes, pits, mazes, terrain) is the planner's: the cheapest path on
  the occupancy grid, kept away from walls and edges where there is room; its progress is counted
  along that path (no progress for STUCK_SECONDS: it backs off, and comes at food from another side);
- the newer kinds (aaai.spec.kinds): multi food, and food that ripens or decays, is eaten as yellows
  are (nearest first, whatever its value now), but the last multi food piece, which ends the episode
  as a green does, is eaten last, and not at all when a green is worth as much or more; food that
  grows or shrinks is a green, chosen by its best value; bad food and death zones are
  blocked on the grid (aaai.levels.validate), so the body keeps clear of them; a path near a hot zone
  costs HOT_COST more per unit, so it goes round one where it can; tunnels are walked through.

Use it as any policy: ``aaai eval --policy reference``, ``aaai run --policy reference``,
``aaai show --video out.mp4 --policy reference``, or ``ReferenceController(env)`` in Python.
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as p

from aaai.agent.sphere import Sphere
from aaai.agent.urdf_writer import HEAD_RADIUS
from aaai.levels import validate
from aaai.levels.validate import FOOTPRINT_RADIUS
from aaai.sim.gait import BACK_UP, SineGait, approach, choice_of_command, steer
from aaai.sim.geometry import corners
from aaai.spec import LevelSpec, ObjectSpec
from aaai.spec.behaviours import PATH_STEP, Bounce, Sink, behaviour_class
from aaai.spec.kinds import ENDING_KINDS, FOOD_KINDS, kind_class
from aaai.task.arena import sides
from aaai.task.sphere_steer import SphereSteer

# pieces that do not end the episode (yellow, multi, ripening, decaying food): eaten before the green
EAT_FIRST = tuple(kind for kind in FOOD_KINDS if kind not in ENDING_KINDS)
LAST = tuple(kind for kind in FOOD_KINDS if kind in ENDING_KINDS)  # green, growing and shrinking food
COMFORT = 8.0  # paths keep this far (units) from walls and edges where there is room ...
CROWDING_COST = 4.0  # ... paying up to this many times a step's length where there is not,
CLOSE = 6.5  # and far more (CLOSE_COST) nearer than this, where a sweeping foot may touch a wall
CLOSE_COST = 30.0
SLOW = 0.4  # the fraction of full speed it walks at where a wall is within FOOTPRINT_RADIUS
ARC = 0.5  # the least forward command while getting out from beside a wall
GREEN_BERTH = 6.0  # extra clearance round a green that is not the target (while yellows remain)
LOOKAHEAD = 4.0  # the body steers at the cheapest cell this close along the plan
DIRECT = 7.0  # nearer than this (plus the food's radius) it steers straight at the food
REPLAN_MOVE = 1.0  # a goal that moved this far gets a new plan (wandering, sliding food)
PILLAR_WAIT = 8.0  # waits this far from a sinking pillar's axis until its food is down
SETTLED = 0.3  # a sinking piece within this of its resting height counts as down
PUSH_STAND_OFF = 6.0  # where the body starts its push, behind the plank
PUSH_ALIGN_X = 1.5  # starts its push this close to the plank's middle line
PUSH_ALIGN = math.radians(15)  # faces the plank this squarely before walking into it
PUSH_LEAD = 6.0  # while pushing it steers at the plank's middle line this far ahead
PUSHED_TILT = math.radians(60)  # a plank tilted this far is falling: the push is over
PUSH_SECONDS = 15.0  # gives up pushing after this long and walks on
CROSS_SECONDS = 25.0  # ... and crossing after this long
CROSS_ALIGN_X = 4.5  # starts across this close to the fallen plank's middle line (it is 11 wide)
CROSSED = 2.0  # across once the head is this close to the fallen plank's far end
REST_SEARCH = 12.0  # with nothing left to eat, it stands at the roomiest place this close
STUCK_SECONDS = 3.0  # no progress for this long: back off for a moment
BACK_OFF_SECONDS = 1.0
APPROACH_GAP = 4.0  # the approach point lies this far beyond head-to-food contact distance
DETOUR_REACHED = 2.5
RETRY_TURN = math.radians(50)  # a stuck approach is tried again from a side turned this far
HOT_COST = 20.0  # extra path cost per unit where a foot may touch a hot zone
HIGH_FOOD = 4.0  # a piece whose centre is this high (size 8 and more) is touched by the head rising from
HEAD_UP = 2.2  # its crouch (to about this height) once near enough for the head up to touch it
PLAN_NEAR = 1.5  # progress is the least plan cost this near a head just off the plan
INTERCEPT_SPEED = 2.0  # units/s: the walking speed an interception counts on (about 2.7 on open floor)
INTERCEPT_MARGIN = 3.0  # s: it stands on a bouncing piece's path this long before the piece comes by
INTERCEPT_ROOM = 3.0  # it waits only where a wall, an edge or a zone is this much farther than its footprint
INTERCEPT_PICK = 0.5  # s: the places of the path it picks from are this far apart
INTERCEPT_EVERY = 1.0  # s: the place on the path is picked again this often


class ReferenceController:
    """A policy: ``action = controller(observation)``; ``reset(seed)`` at each episode start."""

    # The episode's plan, made at its first step (_start_episode).
    level: LevelSpec  # the episode's spec
    clearance: np.ndarray  # distance to the nearest blocked cell, per cell of the validate grid
    walk: np.ndarray  # the cells the body may walk
    crowding: np.ndarray  # the cost of a step through each cell
    plan: np.ndarray | None  # path costs to the current goal
    plan_goal: tuple[float, float] | None
    rest: tuple[float, float] | None  # where it stands with nothing left to eat
    detour: tuple[float, float] | None  # a point to walk round to before the food
    approached: set  # goals it has come near (and picked a side for)
    side: np.ndarray | None  # from a start on a ledge: the region it steps down into, if worth more than any other

    def __init__(self, env):
        self.env = env.unwrapped
        # the sphere (agent.body: sphere) is steered by the same commands without a gait
        self.sphere = isinstance(self.env.body, Sphere)
        self.gait: SineGait | SphereSteer = SphereSteer(self.env) if self.sphere else SineGait.for_env(self.env)
        self.radius = HEAD_RADIUS  # the head's radius: how near food's surface its centre comes to eat
        self.spec: LevelSpec | None = None

    def reset(self, seed: int | None = None) -> None:
        self.spec = None  # plans are made at the first step, from the episode's spec

    # --- planning -------------------------------------------------------------------
    def _start_episode(self) -> None:
        env = self.env
        spec = self.spec = self.level = env.level_spec
        self.gait.reset()
        self.radius = env.body.radius  # the sphere's size follows the arena's
        # the region it plans in is the validator's for this body (aaai.task.arena.footprint_for)
        self.footprint = env.body.footprint if isinstance(env.body, Sphere) else FOOTPRINT_RADIUS
        self.grid = validate.blocked_grid(spec)
        # start on a ledge: its top is ground to plan from until the body is off it (never climbed back)
        self.ledge = validate.start_ledge(spec)
        if self.ledge is not None:
            validate.fill(self.grid, spec, corners(self.ledge), value=0)
        self.doors_closed = 0
        self._map()
        rows, cols = self.walk.shape
        self.cell_x = (np.arange(cols) + 0.5) * validate.GRID - spec.arena_size[0] / 2
        self.cell_y = (np.arange(rows) + 0.5) * validate.GRID - spec.arena_size[1] / 2
        self.plan_key, self.plan_goal, self.plan = None, None, None
        self.sector = _best_sector(spec)
        self.plank = _bridge_plank(env, spec)
        self.bridge_phase, self.phase_started, self.lined_up = "push", 0.0, False
        self.standing, self.rest = False, None
        self.detour, self.approached, self.tries = None, set(), 0
        self.best_progress, self.progress_time, self.back_off_until = math.inf, 0.0, -1.0
        self.progress_key = None
        self.intercepts: dict[int, tuple[float, tuple[float, float] | None]] = {}  # body -> (picked at, place)
        self.bounce_paths: dict[int, tuple] = {}  # body -> a bouncing piece's path (_bounce_path)
        self.lures = self._lures(spec)
        ranked = sides(spec) if self.ledge is not None else []  # start on a ledge: it takes one side
        side = ranked[0][1] if ranked else None
        # where a side is worth more than every other, going down on another loses food: _held_back
        self.side = side if len(ranked) > 1 and ranked[0][0] > ranked[1][0] else None
        if side is not None:  # the one whose food is worth most; the other sides' pieces are never gone for
            self.lures += [food for food in spec.foods if not validate.food_reachable(spec, side, food)]

    def _lures(self, spec: LevelSpec) -> list[ObjectSpec]:
        """The pieces of an arena whose food out of reach is allowed (``reach: pass_mark``, Animal-AI's
        lures) that this body cannot reach (aaai.levels.validate.food_reachable, with the footprint the
        arena was checked with): never gone for, as going for one ends at a wall or in the time limit."""
        if spec.extras.get("reach") != "pass_mark":
            return []
        region, clear = validate.reachable_region(spec, footprint=self.footprint, clearance=self.clearance)
        speed = validate.walk_speed(self.footprint)
        return [food for food in spec.foods if not (clear and validate.food_reachable(spec, region, food, speed))]

    def _map(self, start: tuple[float, float] | None = None) -> None:
        """Clearance, the region walkable from ``start`` (default: the agent's start) and crowding
        cost from the occupancy grid."""
        self.clearance = validate.clearance_map(self.level, self.grid)
        walk = validate.walk_region(self.level, self.clearance, start, self.footprint)
        self.walk = walk if walk is not None else self.clearance > self.radius
        self.crowding = (
            1.0
            + CROWDING_COST * np.clip(1.0 - self.clearance / COMFORT, 0.0, 1.0)
            + CLOSE_COST * np.clip((CLOSE - self.clearance) / (CLOSE - FOOTPRINT_RADIUS), 0.0, 1.0)
        )
        hot = [obj for obj in self.level.objects if getattr(kind_class(obj.kind), "hot", False)]
        if hot:  # where a foot may touch a hot zone
            zones = np.zeros(self.clearance.shape, np.uint8)
            for obj in hot:
                validate.fill(zones, self.level, corners(obj))
            away = validate.distances(zones == 0) * validate.GRID
            self.crowding = self.crowding + HOT_COST * (away < FOOTPRINT_RADIUS)
        self.plan_key = None

    def _doors(self, head: np.ndarray) -> None:
        """A sector door that has closed (L9) is a wall from now on: the map is made again, with
        the walking region the one the head is in."""
        closed = self.env.world.closed
        if len(closed) == self.doors_closed:
            return
        for door in closed[self.doors_closed :]:
            validate.fill(self.grid, self.level, corners(door.obj))
        self.doors_closed = len(closed)
        self._map((float(head[0]), float(head[1])))

    def _costs(self, goal: tuple[float, float], reach: float, avoid: list[tuple[float, float, float]]) -> np.ndarray:
        """Path costs to the cells from which the head reaches ``goal`` (within ``reach``)."""
        near = np.hypot(self.cell_x[None, :] - goal[0], self.cell_y[:, None] - goal[1])
        goals = self.walk & (near <= reach)
        grow = reach
        while not goals.any() and grow < 4 * reach + 10:  # a goal off the walkable region: the nearest part
            grow += validate.GRID
            goals = self.walk & (near <= grow)
        cost = self.crowding
        if avoid:
            cost = cost.copy()
            for x, y, radius in avoid:
                cost[np.hypot(self.cell_x[None, :] - x, self.cell_y[:, None] - y) < radius] += 50.0
        return validate.path_costs(self.walk, goals, cost)

    def _waypoint(
        self, head: np.ndarray, goal: tuple[float, float], reach: float, key, avoid: list[tuple[float, float, float]]
    ) -> tuple[float, float]:
        """Where to steer now: straight at a near goal, else the cheapest cell within LOOKAHEAD."""
        if math.dist(head[:2], goal) < DIRECT + reach - self.radius and self._clear_line(head, goal):
            return goal
        if key != self.plan_key or self.plan_goal is None or math.dist(goal, self.plan_goal) > REPLAN_MOVE:
            self.plan = self._costs(goal, reach, avoid)
            self.plan_key, self.plan_goal = key, goal
        plan = self.plan
        assert plan is not None  # made with plan_key, just now or for this key before
        row, col = validate.cell(self.level, head[0], head[1], plan.shape)
        span = int(LOOKAHEAD / validate.GRID) + 1
        r0, c0 = max(row - span, 0), max(col - span, 0)
        rows, cols = slice(r0, row + span + 1), slice(c0, col + span + 1)
        near = np.hypot(self.cell_x[None, cols] - head[0], self.cell_y[rows, None] - head[1]) <= LOOKAHEAD
        here = np.where(near, plan[rows, cols], np.inf)
        if np.isfinite(here).any():
            r, c = np.unravel_index(np.argmin(here), here.shape)
            return float(self.cell_x[c0 + c]), float(self.cell_y[r0 + r])
        # off the plan: head for the nearest planned cell
        distance = np.where(
            np.isfinite(plan), np.hypot(self.cell_x[None, :] - head[0], self.cell_y[:, None] - head[1]), np.inf
        )
        r, c = np.unravel_index(np.argmin(distance), distance.shape)
        return float(self.cell_x[c]), float(self.cell_y[r])

    def _clear_line(self, head: np.ndarray, goal: tuple[float, float]) -> bool:
        """No blocked cell on the straight line from the head to the goal."""
        steps = max(2, int(math.dist(head[:2], goal) / validate.GRID))
        for t in np.linspace(0.0, 1.0, steps):
            x, y = head[0] + t * (goal[0] - head[0]), head[1] + t * (goal[1] - head[1])
            row, col = validate.cell(self.level, x, y, self.clearance.shape)
            if self.clearance[row, col] < 1.0:
                return False
        return True

    # --- what to do now -----------------------------------------------------------------
    def _foods(self) -> list[tuple[int, ObjectSpec, tuple[float, float, float]]]:
        env = self.env
        foods = []
        for body, food in env.world.food.items():
            position = p.getBasePositionAndOrientation(body, physicsClientId=env.client)[0]
            if self.sector is not None and _sector_of(position) != self.sector or food in self.lures:
                continue
            foods.append((body, food, position))
        return foods

    def _target(self, head: np.ndarray):
        """(goal x y, reach, plan key, things to avoid, wait): what the body goes for now."""
        foods = self._foods()
        yellows = [f for f in foods if f[1].kind in EAT_FIRST]
        greens = [f for f in foods if f[1].kind in LAST]
        down = [f for f in yellows if not _still_sinking(f)]
        sinking = [f for f in yellows if _still_sinking(f)]
        avoid = [(pos[0], pos[1], food.size[0] / 2 + self.radius + GREEN_BERTH) for _, food, pos in greens]
        # the last piece of a kind whose every piece eaten ends the episode (multi_food) ends it as a green
        # does: it waits until nothing else is left but greens, and then for a green worth as much or more
        last = [f for f in down if self._ends_episode(f[1])]
        best_green = max((f[1].food_value for f in greens), default=-math.inf)
        if last and (len(last) < len(down) or sinking or best_green >= max(f[1].food_value for f in last)):
            down = [f for f in down if f not in last]
        if down:
            body, food, position = min(down, key=lambda f: math.dist(head[:2], f[2][:2]))
            return self._go_for(head, body, food, position, avoid)
        if sinking:
            body, food, position = min(sinking, key=lambda f: math.dist(head[:2], f[2][:2]))
            return position[:2], PILLAR_WAIT, ("wait", body), avoid, True
        if greens:
            body, food, position = max(greens, key=lambda f: (f[1].food_value, -math.dist(head[:2], f[2][:2])))
            others = [berth for berth, green in zip(avoid, greens) if green[0] != body]
            return self._go_for(head, body, food, position, others)
        return None

    def _go_for(self, head: np.ndarray, body: int, food: ObjectSpec, position, avoid):
        """The target for eating ``food`` (body id ``body``, now at ``position``): where it is, where it
        will stop (:meth:`_food_goal`), or, for a bouncing piece still far off, where to wait (:meth:`_meet`)."""
        eat = (self._food_goal(food, position), self.radius + food.size[0] / 2, body, avoid, False)
        met = self._meet(head, body, food, position, avoid)
        if met is None and self._held_back(body, position):  # waits on the ledge, facing the piece
            return (float(head[0]), float(head[1])), self.radius, ("intercept", body), avoid, True
        return met or eat

    def _held_back(self, body: int, position) -> bool:
        """Is a bouncing piece that cannot be met yet waited for on the start ledge? So while the body is
        still on its ledge, a side is worth more than any other (``side``), and the piece is not over that
        side: going for where it is now could take the body down on another, from which it does not climb
        back to the side's food, while the piece rolls on to that side. (Where sides are worth the same,
        it goes for the piece as anywhere: down on whichever side the way to it leads.)"""
        side = self._side_kept()
        if self.sphere or side is None or not isinstance(self.env.world.running.get(body), Bounce):
            return False
        return not side[validate.cell(self.level, position[0], position[1], side.shape)]

    def _side_kept(self) -> np.ndarray | None:
        """The side worth more than any other (``side``) while the body is still on its start ledge, else None."""
        return self.side if self.ledge is not None else None

    def _meet(self, head: np.ndarray, body: int, food: ObjectSpec, position, avoid):
        """For a bouncing piece still far off: (its place to wait at, reach, key, avoid, wait), else None.
        Not for the sphere: many times as fast as a bouncing piece, it goes straight at it."""
        if self.sphere:
            return None
        reach = self.radius + food.size[0] / 2
        if math.dist(head[:2], position[:2]) < DIRECT + reach:
            return None
        place = self._intercept(head, body, food)
        return (place, self.radius, ("intercept", body), avoid, True) if place is not None else None

    def _intercept(self, head: np.ndarray, body: int, food: ObjectSpec) -> tuple[float, float] | None:
        """The first place on a bouncing piece's path, before the episode's time is up, where the body
        can stand and gets to INTERCEPT_MARGIN seconds before the piece (None: not a bouncing piece, or
        no such place). Picked again every INTERCEPT_EVERY seconds, from the path worked out once
        (:meth:`_bounce_path`)."""
        part = self.env.world.running.get(body)
        if not isinstance(part, Bounce):
            return None
        now = self._now()
        picked = self.intercepts.get(body)
        if picked is not None and now - picked[0] < INTERCEPT_EVERY:
            return picked[1]
        xs, ys, walkable, offset = self._bounce_path(body, part, food, now)
        every = max(1, round(INTERCEPT_PICK / PATH_STEP))
        ahead = np.arange(offset + every, len(xs), every)
        walk_time = np.hypot(xs[ahead] - head[0], ys[ahead] - head[1]) / INTERCEPT_SPEED + INTERCEPT_MARGIN
        fits = walkable[ahead] & (walk_time <= (ahead - offset) * PATH_STEP)
        place = (float(xs[ahead[fits.argmax()]]), float(ys[ahead[fits.argmax()]])) if fits.any() else None
        self.intercepts[body] = (now, place)
        return place

    def _bounce_path(self, body: int, part: Bounce, food: ObjectSpec, now: float):
        """(xs, ys, walkable, offset): the piece's places every PATH_STEP to the end of the episode,
        whether the body may wait at each (its walking region, INTERCEPT_ROOM more than its footprint clear), and the
        index of now. Worked out
        from the piece's state when first asked, and again if the piece is more than REPLAN_MOVE
        from where the path puts it now (with other physics steps than PATH_STEP, or a new map)."""
        kept = self.bounce_paths.get(body)
        if kept is not None:
            start, xs, ys, walkable, walk = kept
            offset = round((now - start) / PATH_STEP)
            if walk is self.walk and offset < len(xs):
                if math.dist(part.state[:2], (xs[offset], ys[offset])) <= REPLAN_MOVE:
                    return xs, ys, walkable, offset
        state, places = list(part.state), [tuple(part.state[:2])]
        speed, radius = part.obj.behaviour["speed"], food.size[0] / 2
        for _ in range(max(0, int((self.level.time_limit - now) / PATH_STEP))):
            Bounce.step(state, speed, PATH_STEP, radius, self.env.world.bounds)
            places.append((state[0], state[1]))
        xs, ys = (np.array(values) for values in zip(*places))
        shape, size = self.walk.shape, self.level.arena_size
        cols = np.clip(np.floor((xs + size[0] / 2) / validate.GRID), 0, shape[1] - 1).astype(int)
        rows = np.clip(np.floor((ys + size[1] / 2) / validate.GRID), 0, shape[0] - 1).astype(int)
        walkable = self.walk[rows, cols] & (self.clearance[rows, cols] > self.footprint + INTERCEPT_ROOM)
        side = self._side_kept()
        if side is not None:  # still on its start ledge: only places over the side worth most
            walkable &= side[rows, cols]
        self.bounce_paths[body] = (now, xs, ys, walkable, self.walk)
        return xs, ys, walkable, 0

    def _now(self) -> float:
        """Simulated seconds since the episode began."""
        return self.env.steps * self.env.control_dt

    def _ends_episode(self, food: ObjectSpec) -> bool:
        """Is ``food`` the last piece left of a kind whose every piece eaten ends the episode (multi_food)?"""
        kind = food.kind
        return kind in self.env.world.all_end and sum(obj.kind == kind for obj in self.env.world.food.values()) == 1

    @staticmethod
    def _food_goal(food: ObjectSpec, position) -> tuple[float, float]:
        """Where the piece is, or where it will stop if it slides."""
        moving = behaviour_class(food)
        ahead = moving.places(food) if moving else []
        return (ahead[-1][0], ahead[-1][1]) if ahead else (position[0], position[1])

    # --- acting ---------------------------------------------------------------------
    def __call__(self, observation=None) -> np.ndarray:
        """The next action: joint targets in the joint modes; in gait mode the gait commands
        (forward, turn, crouch) that its own gait would be following now; in discrete mode the
        choice nearest them (aaai.sim.gait.choice_of_command)."""
        joints = self._act()
        if self.env.gait is None:
            return joints
        if self.env.action_mode == "discrete":
            return choice_of_command(self.gait.target)
        return np.asarray(self.gait.target, np.float32)

    def command(self) -> np.ndarray:
        """The gait commands (forward, turn, crouch) of the last action: the label a student of
        this controller learns, in any action mode."""
        return np.asarray(self.gait.target, np.float32)

    def student_drove(self, seconds: float) -> None:
        """As a teacher (aaai.train.student): another policy chose the last ``seconds`` of actions. Its
        progress, or lack of it, is not this controller's: the clocks that detect being stuck and
        time its pushes are held, and a back-off in progress is called off, so that the next label
        is what it would do here, not a reaction to the student's walk."""
        self.progress_time += seconds
        self.back_off_until = -1.0
        if getattr(self, "phase_started", None) is not None:
            self.phase_started += seconds

    def _act(self) -> np.ndarray:
        env = self.env
        if self.spec is not env.level_spec or env.steps == 0 and self.plan_key is not None:
            self._start_episode()
        head, rotation = env.body.head_pose()
        yaw = math.atan2(rotation[1, 0], rotation[0, 0])
        now = self._now()
        self._doors(head)
        if self.ledge is not None and _off_ledge(self.ledge, head):  # start on a ledge: down, it is a solid again
            validate.fill(self.grid, self.level, corners(self.ledge))
            self.ledge = None
            self._map((float(head[0]), float(head[1])))
        if self.plank is not None and self._bridging(head, yaw, now):
            return self.gait()
        target = self._target(head)
        if target is None:  # nothing left to eat: stand still in the open, clear of walls
            rest = self._rest_spot(head)
            if math.dist(head[:2], rest) < 1.0 or self.standing:
                self.standing = True
                self.gait.command(0.0, 0.0, 0.0)
                return self.gait.stand()
            target = rest, 0.5, "rest", [], False
        goal, reach, key, avoid, wait = target
        if wait and math.dist(head[:2], goal) <= reach + 1.0:
            if isinstance(key, tuple) and key[0] == "intercept":  # on a bouncing piece's path: face the piece
                goal = p.getBasePositionAndOrientation(key[1], physicsClientId=env.client)[0][:2]
            error = _angle(math.atan2(goal[1] - head[1], goal[0] - head[0]) - yaw)
            self.gait.command(0.0, steer(error, 0.0, reverse=False)[1] * 0.5)  # head, not tail, to it
            self._progress(0.0, now, key)
            return self.gait()
        if now < self.back_off_until:
            self.gait.command(-1.0, 0.0)
            return self.gait()
        if self._cramped(head, yaw, goal):
            return self.gait()
        eating = reach > self.radius and key != "rest"
        close = eating and math.dist(head[:2], goal) < DIRECT + reach - self.radius
        if close and key not in self.approached:  # first time near this piece: pick the open side
            self.approached.add(key)
            self.detour = self._approach_point(head, goal, reach, 0.0)
        if self.detour is not None:
            if math.dist(head[:2], self.detour) < DETOUR_REACHED:
                self.detour = None
            else:
                goal, reach, key, close = self.detour, 0.5, ("detour", self.detour), False
        point = self._waypoint(head, goal, reach, key, avoid)
        remaining = to_go = math.dist(head[:2], goal)
        if self.plan is not None and self.plan_key == key:
            row, col = validate.cell(self.level, head[0], head[1], self.plan.shape)
            planned = self.plan[row, col]
            remaining = min(remaining, planned)
            # progress is counted along the plan, not as the crow flies (a way round walks away from the
            # goal for a while); from the planned cells near the head where it is just off the plan (in a
            # passage as wide as the body), else as the crow flies; none is made where the plan ends
            if not math.isfinite(planned):
                span = int(PLAN_NEAR / validate.GRID)
                near = self.plan[max(row - span, 0) : row + span + 1, max(col - span, 0) : col + span + 1].min()
                planned = near if 0.0 < near < math.inf else planned
            to_go = float(planned) if math.isfinite(planned) else to_go
        if not self._progress(to_go, now, key):  # stuck: back off, and come at food from another side
            if self._room_behind(head, yaw):
                self.back_off_until = now + BACK_OFF_SECONDS
            self.detour = None
            if close:
                self.tries += 1
                self.detour = self._approach_point(head, goal, reach, (-1) ** self.tries * RETRY_TURN)
        error = _angle(math.atan2(point[1] - head[1], point[0] - head[0]) - yaw)
        if isinstance(self.gait, SphereSteer):  # the sphere: straight at the point, as fast as the room allows
            row, col = validate.cell(self.level, head[0], head[1], self.clearance.shape)
            ahead = math.dist(head[:2], goal) if close and point == goal else remaining
            self.gait.drive(error, ahead, float(self.clearance[row, col]) - self.radius)
        elif close and point == goal:  # the final approach to a piece: crouch to reach it
            distance = math.dist(head[:2], goal)
            forward, turn, crouch = approach(self.gait.parameters, error, distance, reach - self.radius)
            height = self._height(key)
            if crouch and height >= HIGH_FOOD and distance**2 < reach**2 - (height - HEAD_UP) ** 2:
                crouch = 0.0  # a big piece: the crouched head gets nearest, and rising there lifts it onto the piece
            self.gait.command(forward, turn, crouch)
        else:
            forward, turn = steer(
                error, math.dist(head[:2], point), arrive=2.0 if self.detour else 0.0, reverse=remaining < BACK_UP
            )
            row, col = validate.cell(self.level, head[0], head[1], self.clearance.shape)
            room = (self.clearance[row, col] - FOOTPRINT_RADIUS) / (CLOSE - FOOTPRINT_RADIUS)
            self.gait.command(forward * min(1.0, max(SLOW, room)) if forward > 0 else forward, turn)
        return self.gait()

    def _height(self, key) -> float:
        """How high the centre of the piece of food ``key`` is (0 for a goal that is no piece)."""
        if key not in self.env.world.food:
            return 0.0
        return p.getBasePositionAndOrientation(key, physicsClientId=self.env.client)[0][2]

    def _approach_point(
        self, head: np.ndarray, food: tuple[float, float], reach: float, turn: float
    ) -> tuple[float, float] | None:
        """Where to stand before the last few steps to a piece: the side with the most room for
        the head as it eats (so that it can back out straight) and on the way in, preferring the
        side the head comes from (turned by ``turn`` rad); None when the head can go straight on."""
        towards = math.atan2(head[1] - food[1], head[0] - food[0]) + turn
        gap = reach + APPROACH_GAP
        best, best_score = None, -math.inf
        for k in range(-8, 8):
            angle = towards + k * math.pi / 8
            cos, sin = math.cos(angle), math.sin(angle)
            stand = validate.cell(self.level, food[0] + gap * cos, food[1] + gap * sin, self.clearance.shape)
            if not self.walk[stand]:
                continue
            eat = validate.cell(self.level, food[0] + reach * cos, food[1] + reach * sin, self.clearance.shape)
            # room where the head will be as it eats (to back out straight), then on the way in
            score = min(self.clearance[eat], COMFORT) + 0.5 * min(self.clearance[stand], CLOSE) - 0.3 * abs(k)
            if score > best_score:
                best, best_score = (food[0] + gap * cos, food[1] + gap * sin, k), score
        if best is None or (best[2] == 0 and turn == 0.0):
            return None
        return best[0], best[1]

    def _cramped(self, head: np.ndarray, yaw: float, goal: tuple[float, float]) -> bool:
        """Too near a wall to turn on the spot without a foot touching it (after eating food by a
        wall): walk out toward more room, backward if that is behind, arcing away from a wall
        beside. False when there is room."""
        row, col = validate.cell(self.level, head[0], head[1], self.clearance.shape)
        if self.sphere or self.clearance[row, col] >= FOOTPRINT_RADIUS or math.dist(head[:2], goal) < DIRECT:
            return False  # (a sphere turns on the spot without touching anything)
        here = self.clearance[row, col]
        straight = []  # straight out, ahead or behind, turns no leg toward the wall
        for sign in (1.0, -1.0):
            cell = validate.cell(
                self.level,
                head[0] + sign * 2.0 * math.cos(yaw),
                head[1] + sign * 2.0 * math.sin(yaw),
                self.clearance.shape,
            )
            straight.append((self.clearance[cell], sign))
        room, sign = max(straight)
        if room > here + 0.3:
            self.gait.command(sign * SLOW, 0.0)
            return True
        best, roomiest = yaw, -1.0
        for k in range(16):  # the way out: the direction in which there is most room 2 units on
            angle = yaw + k * math.pi / 8
            room = self.clearance[
                validate.cell(
                    self.level, head[0] + 2.0 * math.cos(angle), head[1] + 2.0 * math.sin(angle), self.clearance.shape
                )
            ]
            if room > roomiest:
                best, roomiest = angle, room
        forward, turn = steer(_angle(best - yaw), 2.0, reverse=True)
        if 0.0 <= forward < ARC:  # a wall beside: arc away from it rather than turn on the spot
            forward = ARC
        self.gait.command(forward * SLOW, turn)
        return True

    def _room_behind(self, head: np.ndarray, yaw: float) -> bool:
        """Is there room to back off (no wall within the footprint of a place 2.5 behind)?"""
        x, y = head[0] - 2.5 * math.cos(yaw), head[1] - 2.5 * math.sin(yaw)
        row, col = validate.cell(self.level, x, y, self.clearance.shape)
        return bool(self.clearance[row, col] > (self.radius + 1.0 if self.sphere else FOOTPRINT_RADIUS))

    def _rest_spot(self, head: np.ndarray) -> tuple[float, float]:
        """The roomiest walkable place within REST_SEARCH of the head (chosen once)."""
        if self.rest is None:
            near = np.hypot(self.cell_x[None, :] - head[0], self.cell_y[:, None] - head[1]) <= REST_SEARCH
            room = np.where(self.walk & near, self.clearance, -1.0)
            row, col = np.unravel_index(np.argmax(room), room.shape)
            self.rest = (float(self.cell_x[col]), float(self.cell_y[row])) if room[row, col] > 0 else tuple(head[:2])
        return self.rest

    def _progress(self, remaining: float, now: float, key=None) -> bool:
        """Records progress toward the goal ``key``; False when none was made for STUCK_SECONDS."""
        if key != self.progress_key:  # a new goal: progress is counted afresh
            self.progress_key, self.best_progress = key, math.inf
        if remaining < self.best_progress - 0.5 or not math.isfinite(self.best_progress):
            self.best_progress, self.progress_time = remaining, now
            return True
        if now - self.progress_time > STUCK_SECONDS:
            self.best_progress, self.progress_time = remaining, now
            return False
        return True

    def _bridging(self, head: np.ndarray, yaw: float, now: float) -> bool:
        """L10: lines up behind the standing plank and walks it over, then lines up again and
        walks straight across on it; False once across (or when either part takes too long)."""
        env, (body, base_x, face, far_end) = self.env, self.plank
        if self.bridge_phase == "push":
            orientation = p.getBasePositionAndOrientation(body, physicsClientId=env.client)[1]
            pushed_long = self.lined_up and now - self.phase_started > PUSH_SECONDS
            if p.getMatrixFromQuaternion(orientation)[8] < math.cos(PUSHED_TILT) or pushed_long:
                self.bridge_phase, self.phase_started, self.lined_up = "cross", now, False
        elif head[1] > far_end - CROSSED or (self.lined_up and now - self.phase_started > CROSS_SECONDS):
            self.plank, self.plan_key = None, None
            return False
        if not self.lined_up:
            stand = (base_x, face - PUSH_STAND_OFF - self.radius)
            slack = PUSH_ALIGN_X if self.bridge_phase == "push" else CROSS_ALIGN_X
            on_line = abs(head[0] - base_x) < slack and stand[1] - 3.0 < head[1] < face
            if not on_line:  # round to the back of the plank
                point = self._waypoint(head, stand, 1.0, "push", [])
                error = _angle(math.atan2(point[1] - head[1], point[0] - head[0]) - yaw)
                self.gait.command(*steer(error, math.dist(head[:2], point), arrive=2.0))
                return True
            error = _angle(math.pi / 2 - yaw)
            if abs(error) > PUSH_ALIGN:  # face the trench
                self.gait.command(0.0, steer(error, 0.0, reverse=False)[1])  # turn, even from behind
                return True
            self.lined_up, self.phase_started = True, now
        # straight on along the plank's middle line, facing the trench
        error = _angle(math.atan2(PUSH_LEAD, base_x - head[0]) - yaw)
        self.gait.command(*steer(error, PUSH_LEAD))
        return True


def _off_ledge(ledge, head) -> bool:
    """Start on a ledge: is the head a footprint (FOOTPRINT_RADIUS) beyond the ledge's edge, the body down?"""
    c, s = math.cos(ledge.yaw), math.sin(ledge.yaw)
    dx, dy = head[0] - ledge.position[0], head[1] - ledge.position[1]
    u, v = abs(c * dx + s * dy) - ledge.size[0] / 2, abs(-s * dx + c * dy) - ledge.size[1] / 2
    return math.hypot(max(u, 0.0), max(v, 0.0)) >= FOOTPRINT_RADIUS


def _angle(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def _still_sinking(food) -> bool:
    _, obj, position = food
    return behaviour_class(obj) is Sink and position[2] > obj.size[0] / 2 + SETTLED


def _best_sector(spec) -> tuple[float, float] | None:
    """L9: the direction of the sector with the most food, or None in a level without sectors."""
    name = spec.extras.get("best_sector")
    return {"north": (0.0, 1.0), "east": (1.0, 0.0), "south": (0.0, -1.0), "west": (-1.0, 0.0)}[name] if name else None


def _sector_of(position) -> tuple[float, float]:
    x, y = position[0], position[1]
    if abs(x) > abs(y):
        return (1.0, 0.0) if x > 0 else (-1.0, 0.0)
    return (0.0, 1.0) if y > 0 else (0.0, -1.0)


def _bridge_plank(env, spec):
    """L10: (body, x, y where it stands, y where its far end lands) of the standing plank that
    bridges the trench, or None."""
    bridge = spec.bridge
    if not bridge:
        return None
    x0, y0, x1, y1 = bridge
    for body, obj in env.world.objects.items():
        if obj.kind == "plank" and obj.mass > 0 and abs(obj.position[0] - (x0 + x1) / 2) < 1e-6:
            return body, (x0 + x1) / 2, y0, y1
    return None
