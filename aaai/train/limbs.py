"""`aaai experiment limbs`: the cost of limbs, measured. The same tasks scored with both bodies,
the quadruped (``agent.body: quadruped``) and Animal-AI's sphere (``agent.body: sphere``,
aaai.agent.sphere), by the same policies: the reference controller (the same planner, steering the
gait or the sphere) and, given a budget, PPO trained on each body for that budget. The gap between
the two bodies' columns is what the limbs cost.

Both bodies act in gait mode (forward, turn and crouch commands; the sphere ignores crouch), on the
same cells: every level and difficulty asked for, on the reserved seeds (``seeds_per_cell`` each),
and, given an arena folder (an imported Animal-AI battery, ``aaai import-animalai``), every arena
file on seeds 0..``arena_seeds``-1, summarised per category (the file's own, or for an imported
competition file without one the Animal-AI Olympics category its name begins with). The folder (default
experiments/limbs/) gets:

  reference_<body>.csv, reference_<body>_arenas.csv, ppo_<body>.csv   scoreboards (one row an episode)
  runs/<body>/                                                        the PPO runs
  limbs.csv                                                           per body, policy and level or category:
                                                                      episodes, passed, pass rate, mean time to food
  table.md                                                            the table docs/levels.md shows

Re-running continues: scoreboards resume (episodes already scored are skipped), a finished PPO run
is kept and an unfinished one resumes. The time to food is the mean simulated time of the passed
episodes (the time at which the episode ended, the food that passed it eaten).
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from aaai.config import Config, load_config
from aaai.files import write_atomic
from aaai.levels import get_level, level_ids
from aaai.scoring.evaluation import cells_for, evaluate, evaluate_arenas
from aaai.scoring.runs import RunFolder

BODIES = ("quadruped", "sphere")
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


@dataclass(frozen=True)
class LimbsSettings:
    """What is measured: the cells, the battery and the PPO budget (0: no PPO columns)."""

    levels: list[int] = field(default_factory=level_ids)
    difficulties: list[int] = field(default_factory=lambda: list(range(11)))
    seeds_per_cell: int = 10
    arenas: Path | None = None
    arena_seeds: int = 3
    ppo_steps: int = 0
    seed: int = 0


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
    """PPO on ``body`` for the budget; a finished run is kept, an unfinished one resumes."""
    from aaai.train.training import train

    run = RunFolder(folder / "runs" / body)
    if (run.final / "model.zip").is_file():
        return run
    resume = run.config_path.is_file()
    echo(f"{'resuming' if resume else 'training'} PPO on the {body}: {settings.ppo_steps} agent decisions")
    train(run.path, None if resume else body_config(body, settings), resume=resume, say=echo)
    return run


def score_body(folder: Path, body: str, settings: LimbsSettings, echo: Callable[[str], None]) -> list[dict]:
    """Every scoreboard of ``body``, as rows tagged with body, policy and group (level or category)."""
    config = body_config(body, settings)
    cells = cells_for(settings.levels, settings.difficulties, "reserved", settings.seeds_per_cell)
    rows = []
    echo(f"reference on the {body}: {sum(len(cell.seeds) for cell in cells)} episodes")
    board = evaluate("reference", cells, folder / f"reference_{body}.csv", config)
    rows += [_tag(row, body, "reference", get_level(int(row["level"])).label) for row in board]
    if settings.arenas is not None:
        from aaai.task.arena import arena_files, arena_meta

        files = arena_files(settings.arenas)
        categories = {path.name: arena_meta(path)["category"] or _olympics(path.name) for path in files}
        echo(f"reference on the {body}: {len(files)} arena files x {settings.arena_seeds} seeds")
        board = evaluate_arenas(
            "reference", files, list(range(settings.arena_seeds)), folder / f"reference_{body}_arenas.csv", config
        )
        rows += [_tag(row, body, "reference", f"category {categories[row['arena']]}") for row in board]
    if settings.ppo_steps:
        run = train_body(folder, body, settings, echo)
        board = evaluate(
            str(run.final / "model.zip"), cells, folder / f"ppo_{body}.csv", load_config(run.read_config())
        )
        rows += [_tag(row, body, "ppo", get_level(int(row["level"])).label) for row in board]
    return rows


def _olympics(name: str) -> str:
    """An Animal-AI competition file's category from its name (``01-05-02.yaml``), else uncategorised."""
    number = name[:2]
    return f"Animal-AI {number} {OLYMPICS[number]}" if number in OLYMPICS and name[2:3] == "-" else "uncategorised"


def _tag(row: dict, body: str, policy: str, group: str) -> dict:
    control_dt = 0.02  # the default clock (physics.timestep x action_repeat), which both bodies run on
    return {
        "body": body,
        "policy": policy,
        "group": group,
        "passed": row["outcome"] != "failed",
        "seconds": int(float(row["steps"])) * control_dt,
    }


def summarise(rows: list[dict]) -> list[dict]:
    """Per body, policy and group: episodes, passed, pass rate, mean time to food of the passed."""
    groups: dict[tuple[str, str, str], list[dict]] = {}
    for row in rows:
        groups.setdefault((row["body"], row["policy"], row["group"]), []).append(row)
        if not row["group"].startswith("category "):
            groups.setdefault((row["body"], row["policy"], ALL_LEVELS), []).append(row)
    summary = []
    for (body, policy, group), members in groups.items():
        passed = [m for m in members if m["passed"]]
        summary.append(
            {
                "body": body,
                "policy": policy,
                "group": group,
                "episodes": len(members),
                "passed": len(passed),
                "pass_rate": round(len(passed) / len(members), 4),
                "seconds_to_food": round(sum(m["seconds"] for m in passed) / len(passed), 2) if passed else "",
            }
        )
    return summary


def table_markdown(summary: list[dict]) -> str:
    """One row per level (then per category), a column pair per body and policy, and the gap."""
    index = {(s["body"], s["policy"], s["group"]): s for s in summary}
    policies = [policy for policy in ("reference", "ppo") if any(s["policy"] == policy for s in summary)]
    header = ["level or category"]
    for policy in policies:
        for body in BODIES:
            header.append(f"{policy}, {body}: passed")
            if policy == "reference":
                header.append(f"{policy}, {body}: time to food")
        header.append(f"{policy}: sphere minus quadruped")
        if policy == "reference":
            header.append("time to food: sphere / quadruped")
    groups = list(dict.fromkeys(s["group"] for s in summary))
    levels = sorted((g for g in groups if not g.startswith("category ") and g != ALL_LEVELS), key=_level_order)
    levels += [ALL_LEVELS] if ALL_LEVELS in groups else []
    categories = sorted(g for g in groups if g.startswith("category "))
    lines = ["| " + " | ".join(header) + " |", "|---|" + "---:|" * (len(header) - 1)]
    for group in levels + categories:
        cells = [group]
        for policy in policies:
            rates: list[float | None] = []
            for body in BODIES:
                found = index.get((body, policy, group))
                cells.append(
                    f"{found['passed']}/{found['episodes']} ({100 * found['pass_rate']:.0f} %)" if found else "-"
                )
                if policy == "reference":
                    seconds = found["seconds_to_food"] if found else ""
                    cells.append(f"{seconds:.1f} s" if seconds != "" else "-")
                rates.append(found["pass_rate"] if found else None)
            quadruped, sphere = rates
            gap = sphere - quadruped if sphere is not None and quadruped is not None else None
            cells.append(f"{100 * gap:+.0f} points" if gap is not None else "-")
            if policy == "reference":
                times = [index.get((body, policy, group), {}).get("seconds_to_food", "") for body in BODIES]
                cells.append(f"{times[1] / times[0]:.2f}" if "" not in times and times[0] else "-")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _level_order(label: str) -> tuple[int, str]:
    digits = "".join(ch for ch in label if ch.isdigit())
    return (int(digits) if digits else 10**6, label)


def run_experiment(
    folder: str | Path, settings: LimbsSettings | None = None, echo: Callable[[str], None] = print
) -> Path:
    """Scores both bodies (resuming what was scored), then writes limbs.csv and table.md."""
    settings = settings or LimbsSettings()
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rows = [row for body in BODIES for row in score_body(folder, body, settings, echo)]
    summary = summarise(rows)
    text = io.StringIO()
    writer = csv.DictWriter(
        text, fieldnames=["body", "policy", "group", "episodes", "passed", "pass_rate", "seconds_to_food"]
    )
    writer.writeheader()
    writer.writerows(summary)
    write_atomic(folder / "limbs.csv", text.getvalue())
    write_atomic(folder / "table.md", table_markdown(summary))
    return folder / "table.md"
