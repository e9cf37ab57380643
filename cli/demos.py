"""``aaai demos``: a policy's episodes recorded as a Minari dataset."""

from __future__ import annotations

from pathlib import Path

import click

from aaai.config import ACTION_MODES, ConfigError
from aaai.errors import needs_extra
from aaai.scoring.eval_job import with_action_mode
from aaai.scoring.policies import resolve

from .options import POLICY_HELP, Output, SeedList, parse_levels, parse_range, rule


@click.command("demos")
@click.option("--policy", default="reference", show_default=True, help=POLICY_HELP)
@click.option(
    "--levels", default="all", show_default=True, help="Levels by id, label or name, e.g. '0-3,5' or 'L2b,L3', or all."
)
@click.option("--difficulty", default="0-10", show_default=True)
@click.option("-k", "--episodes-per-cell", "count", type=rule("eval.seeds_per_cell"), default=1, show_default=True)
@click.option(
    "--seeds",
    "seeds_mode",
    type=SeedList(),
    default="train",
    show_default=True,
    help="train (fixed draws from the training range), reserved, or a list like 1,2,3.",
)
@click.option(
    "--action-mode",
    type=click.Choice(ACTION_MODES),
    help="The actions recorded (default: the config's, or the run's for a run folder).",
)
@click.option("--config", "config_path", type=click.Path(), help="A YAML for the env.")
@click.option(
    "--out",
    "out",
    type=Output(file_okay=False),
    required=True,
    help="The folder holding the Minari datasets (MINARI_DATASETS_PATH to load them).",
)
@click.option("--dataset-id", help="The dataset's id (default aaai/<policy>-v0).")
def demos_command(policy, levels, difficulty, count, seeds_mode, action_mode, config_path, out, dataset_id):
    """Record a policy's episodes as a Minari dataset (the demos extra): the agent's own observations,
    the actions, rewards and ends, and each episode's seed, level and difficulty."""
    from aaai.scoring.evaluation import seeds_for

    try:
        import minari  # noqa: F401 (the demos extra: checked before anything is recorded)

        from aaai.scoring.demos import dataset_id_for, record
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai demos")) from None
    try:
        chosen = resolve(policy)
        config = with_action_mode(chosen.config(config_path), action_mode)
        plan = [
            (level, d, seed)
            for level in parse_levels(levels)
            for d in parse_range(difficulty, "--difficulty", 0, 10)
            for seed in seeds_for(seeds_mode, level, d, count)
        ]
        dataset_id = dataset_id or dataset_id_for(policy)
        with click.progressbar(length=len(plan), label=f"recording {len(plan)} episodes", show_pos=True) as bar:
            record(chosen, plan, Path(out), config, dataset_id, on_episode=lambda index: bar.update(1))
    except (ConfigError, FileNotFoundError) as error:
        raise click.UsageError(str(error)) from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai demos")) from None
    click.echo(
        f"dataset {dataset_id} in {out}: {len(plan)} episodes; load it with "
        f"MINARI_DATASETS_PATH={out} python -c \"import minari; minari.load_dataset('{dataset_id}')\""
    )
