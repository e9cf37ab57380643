"""`aaai experiment limbs`: the cost of limbs, measured. The same tasks scored with both bodies,
the quadruped (``agent.body: quadruped``) and Animal-AI's sphere (``agent.body: sphere``,
aaai.agent.sphere), by the same policies: the reference controller (the same planner, steering the
gait or the sphere) and, given a budget, PPO trained on each body for that budget. The gap between
the two bodies' columns is what the limbs cost.

Both bodies act in gait mode (forward, turn and crouch commands; the sphere ignores crouch), on the
same cells: every level and difficulty asked for, on the reserved seeds (``seeds_per_cell`` each),
and, given an arena folder (an imported Animal-AI battery, ``aaai import-animalai``), every arena
file on seeds 0..``arena_seeds``-1, summarised per category (the file's own, or for an imported
competition file without one the Animal-AI Olympics category its name begins with).

An arena file is checked for each body's own footprint (aaai.task.arena.footprint_for: the
quadruped's radius 5, the sphere's radius in that arena plus 0.5): a file valid on every seed for one
body only is scored for that body only. The battery's table says how many tasks each body had; the
gap between the bodies is taken on the tasks valid for both, and each body's tasks valid for it alone
are counted apart.

The folder (default experiments/limbs/) gets:

  tasks_<body>.csv                  every arena file: its hash, category, the seeds checked, valid for the
                                    body or the first problem found (kept: a file not changed is not
                                    checked again)
  reference_<body>.csv, reference_<body>_arenas.csv, ppo_<body>.csv, ppo_<body>_arenas.csv
                                    scoreboards (one row an episode)
  runs/<body>/                      the PPO runs
  limbs.csv                         per body, policy, level or category and task set: episodes, passed,
                                    pass rate, mean time to food
  table.md                          the tables docs/levels.md shows

Re-running continues: scoreboards resume (episodes already scored are skipped), a finished PPO run
is kept and an unfinished one resumes. It runs in parts: ``bodies`` and ``policies`` choose what is
scored this time (one body in each of two processes, the reference now and PPO later), and the
tables are always made from every scoreboard in the folder (``tables_only``: made, nothing scored).
The time to food is the mean simulated time of the passed episodes (the time at which the episode
ended, the food that passed it eaten).
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from aaai.config import Config, ConfigError, load_config
from aaai.files import file_sha256, hold, write_atomic
from aaai.levels import get_level, level_ids
from aaai.scoring.evaluation import cells_for, evaluate, evaluate_arenas
from aaai.scoring.provenance import arena_hashes, policy_record
from aaai.scoring.runs import RunFolder

BODIES = ("quadruped", "sphere")
POLICIES = ("reference", "ppo")
# The Animal-AI Olympics' ten categories, by the first number of a competition file's name (01-05-02.yaml):
# the category of an imported file that does not name its own.
OLYMPICS = {
    "01": "food retrieval",
    "02": "preferences",
    "03": "obstacles",
    "04": "avoidance",
    "05": "spatial reasoning",
    "06": "generalisation",
    "07": "internal models",
    "08": "object permanence",
    "09": "advanced preferences",
    "10": "causal reasoning",
}
ALL_LEVELS = "all levels"  # the level rows together
BATTERY = "all categories"  # the category rows together
TASK_COLUMNS = ["arena", "sha256", "category", "seeds", "checker", "valid", "problem"]
# The code that judges an arena file (aaai.task.arena.load_arena): a verdict is reused only while it
# is the same, so that a change to the check (a new rule) re-checks every file instead of trusting an
# old verdict. Any change to these files re-checks (about 0.05 s a file and seed).
CHECKER_FILES = (
    "task/arena.py",
    "task/arena_reader.py",
    "levels/validate.py",
    "spec/__init__.py",
    "spec/kinds.py",
    "spec/behaviours.py",
    "spec/dispensers.py",
    "agent/sphere.py",
)


def checker_fingerprint() -> str:
    """The SHA-256 of the code that checks arena files (:data:`CHECKER_FILES`), 16 hex digits."""
    import hashlib

    import aaai

    digest = hashlib.sha256()
    root = Path(aaai.__file__).parent
    for name in CHECKER_FILES:
        digest.update(name.encode() + b"\0" + (root / name).read_bytes())
    return digest.hexdigest()[:16]


SUMMARY_COLUMNS = [
    "body",
    "policy",
    "group",
    "tasks",
    "episodes",
    "passed",
    "pass_rate",
    "seconds_to_food",
    "seconds_both_passed",
]
# The task sets of a battery's summary: the tasks valid for both bodies (the gap is taken on them), and
# those valid for this body only. The levels' rows are all "both" (every generated level is valid for both).
BOTH, ONLY = "both", "this body only"


@dataclass(frozen=True)
class LimbsSettings:
    """What is measured: the cells, the battery, the PPO budget (0: no PPO), and what is scored this time
    (``bodies``, ``policies``; the tables are made from the whole folder)."""

    levels: list[int] = field(default_factory=level_ids)
    difficulties: list[int] = field(default_factory=lambda: list(range(11)))
    seeds_per_cell: int = 10
    arenas: tuple[Path, ...] = ()  # arena files or folders
    arena_seeds: int = 3
    ppo_steps: int = 0
    seed: int = 0
    bodies: tuple[str, ...] = BODIES
    policies: tuple[str, ...] = POLICIES
    tables_only: bool = False


def body_config(body: str, settings: LimbsSettings) -> Config:
    """The config both policies run with on ``body``: gait mode, the default config otherwise."""
    return load_config(
        None,
        body=body,
        action_mode="gait",
        levels=settings.levels,
        difficulties=settings.difficulties,
        total_steps=max(settings.ppo_steps, 1),
        seed=settings.seed,
    )


def train_body(folder: Path, body: str, settings: LimbsSettings, echo: Callable[[str], None]) -> RunFolder:
    """PPO on ``body`` for the budget; a finished run is kept, an unfinished one resumes; a run made for
    another budget is refused (its scoreboards would mix two models)."""
    from aaai.train.training import train

    run = RunFolder(folder / "runs" / body)
    resume = run.config_path.is_file()
    if resume:
        budget = load_config(run.read_config()).train.total_steps
        if budget != settings.ppo_steps:
            raise ConfigError(
                f"--ppo-steps: got {settings.ppo_steps}; the PPO run {str(run.path)!r} is for {budget} agent decisions "
                f"(allowed: --ppo-steps {budget}, or another --out)"
            )
    if (run.final / "model.zip").is_file():
        return run
    echo(f"{'resuming' if resume else 'training'} PPO on the {body}: {settings.ppo_steps} agent decisions")
    train(run.path, None if resume else body_config(body, settings), resume=resume, say=echo)
    return run


def category_of(path: Path) -> str:
    """An arena file's category: its own, else an imported competition file's Olympics category."""
    from aaai.task.arena import arena_meta

    return arena_meta(path)["category"] or _olympics(path.name)


_FAILED_ON = re.compile(r"seed (\d+): ")  # how a verdict of "not valid" names its seed (:func:`_problem`)


def _problem(seed: int, error: ConfigError) -> str:
    """A verdict's problem: the seed the file failed on and the first problem found there."""
    return f"seed {seed}: " + (list(getattr(error, "problems", None) or [str(error)])[0])


def _failing_seed(row: dict) -> int | None:
    """The seed a stored verdict of "not valid" failed on, None if it does not say."""
    found = _FAILED_ON.match(row.get("problem", ""))
    return int(found.group(1)) if found else None


def _reused(row: dict | None, sha: str, checker: str, seeds: int) -> tuple[bool | None, int]:
    """What a stored verdict says of seeds 0..``seeds``-1 of an unchanged file checked by the same code:
    (valid or not, or None when it cannot say; the seeds already known to be valid). A file valid on
    N seeds is valid on fewer; one that failed on seed K is valid on the seeds before K."""
    if row is None or row["sha256"] != sha or row.get("checker") != checker or not row["seeds"].isdigit():
        return None, 0
    checked = int(row["seeds"])
    if row["valid"] == "yes":
        return (True, checked) if checked >= seeds else (None, checked)
    failed = _failing_seed(row)
    if failed is None:
        return (False, 0) if checked == seeds else (None, 0)
    return (False, failed) if failed < seeds else (True, failed)


def check_tasks(folder: Path, body: str, settings: LimbsSettings, echo: Callable[[str], None]) -> list[Path]:
    """The arena files valid for ``body`` on every seed scored (aaai.task.arena.load_arena for its
    footprint), each file's verdict kept in tasks_<body>.csv and reused while the file and the checking
    code (:func:`checker_fingerprint`) are the same. A verdict answers for fewer seeds than it was made on
    (valid on 3 seeds is valid on 1; failed on seed 2 is valid on seeds 0 and 1) and is then kept as it
    is, so that scoring with fewer seeds leaves the file unchanged; with more seeds only the new ones are
    checked."""
    from aaai.task.arena import arena_files, load_arena

    files = [file for path in settings.arenas for file in arena_files(path)]
    names = [file.name for file in files]
    if len(set(names)) != len(names):
        twice = sorted(name for name in names if names.count(name) > 1)[0]
        raise ConfigError(
            f"--arenas: two arena files are named {twice}; allowed: distinct names (the tables name them)"
        )
    seeds = settings.arena_seeds
    path = folder / f"tasks_{body}.csv"
    known = {row["arena"]: row for row in read_rows(path)}
    checker = checker_fingerprint()
    rows: list[dict] = []
    valid: list[Path] = []
    fresh = 0
    for file in files:
        sha = file_sha256(file)
        row = known.get(file.name)
        verdict, done = _reused(row, sha, checker, seeds)
        if verdict is None:
            problem = ""
            try:
                for seed in range(done, seeds):
                    load_arena(file, seed, body=body)
            except ConfigError as error:
                problem = _problem(seed, error)
            row = {
                "arena": file.name,
                "sha256": sha,
                "category": category_of(file),
                "seeds": str(seeds),
                "checker": checker,
                "valid": "no" if problem else "yes",
                "problem": problem,
            }
            verdict = not problem
            fresh += 1
            if fresh % 50 == 0:  # what was checked is kept if the run stops
                seen = {r["arena"] for r in rows} | {file.name}
                _write_rows(path, TASK_COLUMNS, rows + [row] + [r for n, r in known.items() if n not in seen])
        assert row is not None
        rows.append(row)
        if verdict:
            valid.append(file)
    if fresh or [row["arena"] for row in rows] != list(known):
        _write_rows(path, TASK_COLUMNS, rows)
    echo(
        f"{len(valid)} of {len(files)} arena files valid for the {body} on seeds 0-{seeds - 1} "
        f"({fresh} checked now, the others as {path.name} holds them)"
    )
    return valid


def arena_record(policy: str, files: list[Path]) -> dict:
    """What an arena scoreboard of the experiment records (as aaai baselines --battery's): the policy on
    listed seeds, the folder of the files (when they share one) and each file's SHA-256, so that adding to
    it after a file has changed is refused and aaai diagnose finds the files."""
    folders = {file.resolve().parent for file in files}
    where = {"arenas": str(folders.pop())} if len(folders) == 1 else {}
    return {**policy_record(policy, "list"), **where, "arena_sha256": arena_hashes(files)}


def score_body(folder: Path, body: str, settings: LimbsSettings, echo: Callable[[str], None]) -> None:
    """Scores what ``settings`` asks for on ``body`` into the folder's scoreboards (resuming them)."""
    config = body_config(body, settings)
    cells = cells_for(settings.levels, settings.difficulties, "reserved", settings.seeds_per_cell)
    episodes = sum(len(cell.seeds) for cell in cells)
    valid: list[Path] = []
    if settings.arenas:
        lock = hold(folder / f".tasks_{body}.lock", lambda pid: f"tasks_{body}.csv is being written by process {pid}")
        with lock:
            valid = check_tasks(folder, body, settings, echo)
    arena_seeds = list(range(settings.arena_seeds))
    if "reference" in settings.policies:
        echo(f"reference on the {body}: {episodes} episodes")
        evaluate("reference", cells, folder / f"reference_{body}.csv", config)
        if valid:
            echo(f"reference on the {body}: {len(valid)} arena files x {settings.arena_seeds} seeds")
            board = folder / f"reference_{body}_arenas.csv"
            evaluate_arenas("reference", valid, arena_seeds, board, config, record=arena_record("reference", valid))
    if "ppo" in settings.policies and settings.ppo_steps:
        run = train_body(folder, body, settings, echo)
        model, run_config = str(run.final / "model.zip"), load_config(run.read_config())
        echo(f"PPO on the {body}: {episodes} episodes")
        evaluate(model, cells, folder / f"ppo_{body}.csv", run_config)
        if valid:
            echo(f"PPO on the {body}: {len(valid)} arena files x {settings.arena_seeds} seeds")
            board = folder / f"ppo_{body}_arenas.csv"
            evaluate_arenas(model, valid, arena_seeds, board, run_config, record=arena_record(model, valid))


def read_rows(path: Path) -> list[dict]:
    """A CSV's rows, read without writing to it (another process may be appending: a torn last line is
    left out)."""
    if not path.is_file():
        return []
    text = path.read_text()
    if text and not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]
    return list(csv.DictReader(io.StringIO(text)))


def _write_rows(path: Path, columns: list[str], rows: list[dict]) -> None:
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    write_atomic(path, text.getvalue())


def folder_rows(folder: Path) -> tuple[list[dict], dict[str, dict[str, dict]]]:
    """Every episode scored in the folder, tagged with body, policy, group (level or category) and arena
    (None for a level), and each body's task verdicts by arena name."""
    tasks = {body: {row["arena"]: row for row in read_rows(folder / f"tasks_{body}.csv")} for body in BODIES}
    rows = []
    for body in BODIES:
        for policy in POLICIES:
            for row in read_rows(folder / f"{policy}_{body}.csv"):
                rows.append(_tag(row, body, policy, get_level(int(row["level"])).label))
            for row in read_rows(folder / f"{policy}_{body}_arenas.csv"):
                task = tasks[body].get(row["arena"])
                if task is None or task["valid"] != "yes":
                    continue  # a file changed or found invalid since: not counted
                rows.append(_tag(row, body, policy, f"category {task['category']}", row["arena"]))
    return rows, tasks


def _olympics(name: str) -> str:
    """An Animal-AI competition file's category from its name (``01-05-02.yaml``), else uncategorised."""
    number = name[:2]
    return f"Animal-AI {number} {OLYMPICS[number]}" if number in OLYMPICS and name[2:3] == "-" else "uncategorised"


def _tag(row: dict, body: str, policy: str, group: str, arena: str | None = None) -> dict:
    control_dt = 0.02  # the default clock (physics.timestep x action_repeat), which both bodies run on
    return {
        "body": body,
        "policy": policy,
        "group": group,
        "arena": arena,
        "episode": (arena or row["level"], row["difficulty"], row["seed"]),  # the same episode on either body
        "passed": row["outcome"] != "failed",
        "seconds": int(float(row["steps"])) * control_dt,
    }


def summarise(rows: list[dict], tasks: dict[str, dict[str, dict]] | None = None) -> list[dict]:
    """Per body, policy, group and task set: episodes, passed, pass rate, mean time to food of the
    passed, and mean time to food of the episodes both bodies passed (the time ratio's, so that it compares
    like with like). A battery's episodes are split by ``tasks`` (each body's verdicts by arena name) into
    those on tasks valid for both bodies (BOTH) and those on tasks valid for this body only (ONLY);
    ``tasks`` None counts every arena valid for both."""
    won: dict[tuple[str, str], set] = {}  # (body, policy): the episodes passed
    for row in rows:
        if row["passed"]:
            won.setdefault((row["body"], row["policy"]), set()).add(row.get("episode"))
    valid = {
        body: {name for name, row in (tasks or {}).get(body, {}).items() if row["valid"] == "yes"} for body in BODIES
    }
    groups: dict[tuple[str, str, str, str], list[dict]] = {}
    for row in rows:
        arena = row.get("arena")
        both = arena is None or tasks is None or all(arena in valid[body] for body in BODIES)
        subset = BOTH if both else ONLY
        groups.setdefault((row["body"], row["policy"], row["group"], subset), []).append(row)
        total = BATTERY if row["group"].startswith("category ") else ALL_LEVELS
        groups.setdefault((row["body"], row["policy"], total, subset), []).append(row)
    summary = []
    for (body, policy, group, subset), members in groups.items():
        passed = [m for m in members if m["passed"]]
        paired = [m for m in passed if all(m.get("episode") in won.get((other, policy), ()) for other in BODIES)]
        summary.append(
            {
                "body": body,
                "policy": policy,
                "group": group,
                "tasks": subset,
                "episodes": len(members),
                "passed": len(passed),
                "pass_rate": round(len(passed) / len(members), 4),
                "seconds_to_food": round(sum(m["seconds"] for m in passed) / len(passed), 2) if passed else "",
                "seconds_both_passed": round(sum(m["seconds"] for m in paired) / len(paired), 2) if paired else "",
            }
        )
    return summary


def task_counts(tasks: dict[str, dict[str, dict]]) -> dict[str, dict[str, int]]:
    """Per category (and BATTERY): the tasks checked, valid for each body, and valid for both."""
    counts: dict[str, dict[str, int]] = {}
    names = sorted(set(tasks.get("quadruped", {})) | set(tasks.get("sphere", {})))
    for name in names:
        verdicts = {body: tasks.get(body, {}).get(name) for body in BODIES}
        category = next(row["category"] for row in verdicts.values() if row is not None)
        ok = {body: row is not None and row["valid"] == "yes" for body, row in verdicts.items()}
        for group in (f"category {category}", BATTERY):
            count = counts.setdefault(group, {"files": 0, "quadruped": 0, "sphere": 0, "both": 0})
            count["files"] += 1
            count["quadruped"] += ok["quadruped"]
            count["sphere"] += ok["sphere"]
            count["both"] += ok["quadruped"] and ok["sphere"]
    return counts


def _passed(found: dict | None) -> str:
    return f"{found['passed']}/{found['episodes']} ({100 * found['pass_rate']:.0f} %)" if found else "-"


def _table(summary: list[dict], groups: list[str], counts: dict[str, dict[str, int]] | None) -> list[str]:
    """One row per group, a column pair per body and policy on the tasks valid for both, the gap; with
    ``counts`` (a battery) the tasks each body had and each body's results on its own tasks."""
    index = {(s["body"], s["policy"], s["group"], s["tasks"]): s for s in summary}
    policies = [policy for policy in POLICIES if any(s["policy"] == policy for s in summary)]
    header = ["level or category" if counts is None else "category"]
    if counts is not None:
        header.append("tasks: files, quadruped, sphere, both")
    for policy in policies:
        for body in BODIES:
            header.append(f"{policy}, {body}: passed")
            if policy == "reference":
                header.append(f"{policy}, {body}: time to food")
        header.append(f"{policy}: sphere minus quadruped")
        if policy == "reference":
            header.append("time to food, episodes both passed: sphere / quadruped")
        if counts is not None:
            header += [f"{policy}, {body}: passed on its own tasks" for body in BODIES]
    lines = ["| " + " | ".join(header) + " |", "|---|" + "---:|" * (len(header) - 1)]
    for group in groups:
        cells = [group]
        if counts is not None:
            count = counts.get(group, {})
            cells.append(", ".join(str(count.get(k, "-")) for k in ("files", "quadruped", "sphere", "both")))
        for policy in policies:
            rates: list[float | None] = []
            for body in BODIES:
                found = index.get((body, policy, group, BOTH))
                cells.append(_passed(found))
                if policy == "reference":
                    seconds = found["seconds_to_food"] if found else ""
                    cells.append(f"{seconds:.1f} s" if seconds != "" else "-")
                rates.append(found["pass_rate"] if found else None)
            quadruped, sphere = rates
            gap = sphere - quadruped if sphere is not None and quadruped is not None else None
            cells.append(f"{100 * gap:+.0f} points" if gap is not None else "-")
            if policy == "reference":
                times = [index.get((body, policy, group, BOTH), {}).get("seconds_both_passed", "") for body in BODIES]
                cells.append(f"{times[1] / times[0]:.2f}" if "" not in times and times[0] else "-")
            if counts is not None:
                cells += [_passed(index.get((body, policy, group, ONLY))) for body in BODIES]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def table_markdown(summary: list[dict], tasks: dict[str, dict[str, dict]] | None = None) -> str:
    """The levels' table (one row per level, then all levels) and, if a battery was scored, the battery's
    (one row per category, then all categories, with the tasks each body had)."""
    groups = list(dict.fromkeys(s["group"] for s in summary))
    levels = sorted(
        (g for g in groups if not g.startswith("category ") and g not in (ALL_LEVELS, BATTERY)), key=_level_order
    )
    levels += [ALL_LEVELS] if ALL_LEVELS in groups else []
    counts = task_counts(tasks) if tasks else None
    categories = sorted(
        set(g for g in groups if g.startswith("category ")) | set(c for c in counts or {} if c != BATTERY)
    )
    categories += [BATTERY] if categories else []
    parts = []
    if levels:
        parts.append("\n".join(_table(summary, levels, None)) + "\n")
    if categories:
        parts.append("\n".join(_table(summary, categories, counts or {})) + "\n")
    return "\n".join(parts)


def _level_order(label: str) -> tuple[int, str]:
    digits = "".join(ch for ch in label if ch.isdigit())
    return (int(digits) if digits else 10**6, label)


def write_tables(folder: Path) -> Path:
    """limbs.csv and table.md from every scoreboard and task list in the folder."""
    rows, tasks = folder_rows(folder)
    summary = summarise(rows, tasks if any(tasks.values()) else None)
    _write_rows(folder / "limbs.csv", SUMMARY_COLUMNS, summary)
    write_atomic(folder / "table.md", table_markdown(summary, tasks if any(tasks.values()) else None))
    return folder / "table.md"


def run_experiment(
    folder: str | Path, settings: LimbsSettings | None = None, echo: Callable[[str], None] = print
) -> Path:
    """Scores what ``settings`` asks for (resuming what was scored), then writes limbs.csv and table.md from
    the whole folder."""
    settings = settings or LimbsSettings()
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    if not settings.tables_only:
        for body in settings.bodies:
            score_body(folder, body, settings, echo)
    return write_tables(folder)
