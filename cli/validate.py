"""``aaai validate``: generate levels over many seeds and check that each is solvable."""

from __future__ import annotations

from typing import Any

import click

from aaai.config import RULES
from aaai.levels import InvalidLevelError, all_levels, generate
from aaai.levels.validate import check

from .options import COUNT, SEED, parse_levels, parse_range

ARENA_SEEDS = 10  # seeds an arena file is checked with unless --seeds says otherwise


@click.command("validate")
@click.option(
    "--levels", "levels_text", default=None, help="Levels by id, label or name, e.g. '0-3,5' or 'L2b' (default: all)."
)
@click.option("--difficulty", "difficulty_text", default="0-10", show_default=True, help="Difficulties, e.g. '0,5'.")
@click.option("--seeds", type=COUNT, default=100, show_default=True, help="Seeds per (level, difficulty).")
@click.option("--first-seed", type=SEED, default=0, show_default=True, help="The first seed checked.")
@click.option(
    "--arena",
    "arena",
    type=click.Path(exists=True),
    help="Check an arena file, or every *.yaml in a folder, instead of levels: each loaded with seeds "
    f"--first-seed onwards ({ARENA_SEEDS} unless --seeds is given); every problem is printed with "
    "its file, line and object.",
)
@click.option(
    "--body",
    type=click.Choice(list(RULES["agent.body"].choices or ())),
    default="quadruped",
    show_default=True,
    help="The body (agent.body) whose footprint an --arena file is checked for: the quadruped's radius 5, or "
    "the sphere's own radius in that arena plus 0.5 (3 in an imported arena 200 across).",
)
@click.pass_context
def validate(ctx, levels_text, difficulty_text, seeds, first_seed, arena, body):
    """Check generated levels without running a policy: no overlapping solids; the start and every
    food piece inside the arena, on solid ground and clear of walls; every piece reachable by a body
    of the agent's footprint. Prints seeds checked, regenerated and failed per (level, difficulty);
    exits with status 1 if any failed."""
    from aaai.levels import SEED_LIMIT

    if first_seed + seeds > SEED_LIMIT:  # every seed checked must be one a level takes
        raise click.BadParameter(
            f"got {first_seed} with --seeds {seeds}; allowed: seeds up to {SEED_LIMIT - 1} "
            f"(a first seed of at most {SEED_LIMIT - seeds})",
            param_hint="--first-seed",
        )

    if arena is not None:
        explicit = ctx.get_parameter_source("seeds") == click.core.ParameterSource.COMMANDLINE
        validate_arenas(arena, range(first_seed, first_seed + (seeds if explicit else ARENA_SEEDS)), body)
        return
    if ctx.get_parameter_source("body") == click.core.ParameterSource.COMMANDLINE:
        raise click.UsageError("--body applies to --arena files only (the levels are generated for the quadruped)")

    known = all_levels()
    levels = parse_levels(levels_text)
    difficulties = parse_range(difficulty_text, "--difficulty", 0, 10)
    click.echo(f"{'level':<28} {'diff':>4} {'checked':>8} {'regenerated':>12} {'failed':>7}")
    totals, errors = [0, 0, 0], []
    for level in levels:
        name = f"{known[level].label} {known[level].name}"
        for difficulty in difficulties:
            row = survey(level, difficulty, range(first_seed, first_seed + seeds))
            click.echo(f"{name:<28} {difficulty:>4} {row['checked']:>8} {row['regenerated']:>12} {row['failed']:>7}")
            totals = [t + row[k] for t, k in zip(totals, ("checked", "regenerated", "failed"))]
            errors += row["errors"]
    click.echo(f"{'total':<28} {'':>4} {totals[0]:>8} {totals[1]:>12} {totals[2]:>7}")
    for error in errors[:20]:
        click.echo(f"FAILED {error}", err=True)
    if totals[2]:
        raise SystemExit(1)


def validate_arenas(path: str, seeds, body: str = "quadruped") -> None:
    """``aaai validate --arena``: one line per file (seeds checked, failed) for ``body``'s footprint; exits 1 on
    any failure."""
    from aaai.config import ConfigError
    from aaai.task.arena import arena_files, check_arena, parse_arena

    try:
        files = arena_files(path)
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    click.echo(f"{'arena':<40} {'checked':>8} {'failed':>7}  description")
    failed_files, messages, seen = 0, [], set()
    for file in files:
        failed, description = 0, ""
        for seed in seeds:
            try:
                spec, meta, source = parse_arena(file, seed)
                description = meta["description"]
                problems = check_arena(spec, source, body=body)
            except ConfigError as error:  # every problem of the file, one line each
                problems = list(getattr(error, "problems", None) or [str(error)])
            if problems:
                failed += 1
                new = [problem for problem in problems if problem not in seen]  # a fixed file fails alike on every seed
                seen.update(new)
                messages += [f"seed {seed}: {problem}" for problem in new]
        failed_files += bool(failed)
        click.echo(f"{file.name:<40} {len(seeds):>8} {failed:>7}  {description}")
    click.echo(f"{len(files)} arena files, {failed_files} with problems")
    for message in messages[:40]:
        click.echo(f"FAILED {message}", err=True)
    if failed_files:
        raise SystemExit(1)


def survey(level: int, difficulty: int, seeds) -> dict:
    """Generates (level, difficulty, seed) for every seed and checks each spec once more.

    Returns the counts for one row of ``aaai validate``: seeds checked, regenerated (valid only
    after a regeneration), failed (no valid level, or a returned spec with problems), and the
    first failures' messages.
    """
    row: dict[str, Any] = {"checked": 0, "regenerated": 0, "failed": 0, "errors": []}
    for seed in seeds:
        row["checked"] += 1
        try:
            spec = generate(level, difficulty, seed)
            problems = check(spec)
        except InvalidLevelError as error:
            problems = [str(error)]
        else:
            problems = [f"level {level} difficulty {difficulty} seed {seed}: {problem}" for problem in problems]
            row["regenerated"] += bool(spec.regenerated)
        if problems:
            row["failed"] += 1
            row["errors"] += problems[:1]
    return row
