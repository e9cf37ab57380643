"""``aaai play``: play the levels yourself in a web browser, scored as a policy named human:NAME."""

from __future__ import annotations

from pathlib import Path

import click

from aaai.config import ConfigError, load_config
from aaai.errors import needs_extra

from .options import DIFFICULTY, SEED, Finite, Output, SeedList, parse_levels, parse_range, rule


@click.command("play")
@click.argument("level", required=False)
@click.option("-d", "difficulty_text", type=DIFFICULTY, help="One episode: its difficulty [default: 0].")
@click.option("-s", "--seed", type=SEED, help="One episode: its seed [default: 0].")
@click.option(
    "--arena",
    type=click.Path(exists=True),
    help="Play an arena file (or a folder of them), on seed -s or the --seeds list.",
)
@click.option(
    "--seeds",
    "seeds_mode",
    type=SeedList(),
    help="A battery: reserved, train or a list like 1,2,3, over --levels x --difficulty.",
)
@click.option("--levels", help="Battery levels by id, label or name, e.g. '0-11,L2b' [default with --seeds: all].")
@click.option("--difficulty", "difficulties", help="Battery difficulties, e.g. '0,5,10' [default: 0].")
@click.option(
    "-k",
    "--seeds-per-cell",
    "count",
    type=rule("eval.seeds_per_cell"),
    default=1,
    show_default=True,
    help="With --seeds reserved or train: episodes per (level, difficulty).",
)
@click.option(
    "--seed-key-file",
    type=click.Path(dir_okay=False),
    help="With --seeds reserved: the hidden reserved list this key stands for (or AAAI_SEED_KEY).",
)
@click.option("--player", help="The player's name, recorded as human:NAME [default: the page asks].")
@click.option(
    "--out",
    "output",
    type=Output(what="file"),
    default="human_{player}.csv",
    show_default=True,
    help="Scoreboard CSV; {player} is replaced by the player's name. Re-run with the same --out to "
    "resume at the next unplayed episode.",
)
@click.option("--replays", type=Output(file_okay=False), help="Save each scored episode's replay (JSON) here.")
@click.option(
    "--host",
    default="127.0.0.1",
    show_default=True,
    help="Address to listen on: 127.0.0.1 is this machine only; 0.0.0.0 lets anyone who can reach it and "
    "has the printed link (it holds a random token) play.",
)
@click.option("--port", type=click.IntRange(0, 65535), default=8000, show_default=True, help="0: any free port.")
@click.option("--config", "config_path", type=click.Path(), help="A YAML overriding configs/default.yaml.")
@click.option(
    "--max-steps",
    type=rule("episode.max_steps"),
    help="Episode length in control steps (default: each level's time limit).",
)
@click.option(
    "--camera-resolution",
    type=click.IntRange(8, 512),
    default=84,
    show_default=True,
    help="Pixels across the agent's camera view.",
)
@click.option(
    "--fps",
    type=Finite(1, 50),
    default=30,
    show_default=True,
    help="Frames sent to a page per second, at most (the simulation runs at 50 steps/s regardless).",
)
@click.option(
    "--grace",
    type=Finite(0, 86400),
    default=20,
    show_default=True,
    help="Seconds a page that lost its connection may come back before its episode is abandoned.",
)
@click.option(
    "--idle",
    type=Finite(10, 86400),
    default=600,
    show_default=True,
    help="Seconds a session may wait for a key before its battery is abandoned (its environment freed).",
)
@click.option(
    "--max-sessions",
    type=click.IntRange(1, 10_000),
    help="Players at once (each holds a simulation); a join beyond is refused "
    "[default: 3, what one server process holds at 50 steps/s, within half the available memory at 50 MB each].",
)
def play(
    level,
    difficulty_text,
    seed,
    arena,
    seeds_mode,
    levels,
    difficulties,
    count,
    seed_key_file,
    player,
    output,
    replays,
    host,
    port,
    config_path,
    max_steps,
    camera_resolution,
    fps,
    grace,
    idle,
    max_sessions,
):
    """Play LEVEL (default L0) in a browser: arrows or WASD walk and turn, C or Shift crouches.

    Starts a web server and prints the address to open. Every finished episode is a scoreboard row
    of the policy human:NAME (as `aaai eval` writes them); a closed tab's episode is logged in
    <out>_abandoned.csv, not scored. --seeds runs a battery, one episode after another.
    """
    from aaai.scoring.evaluation import Cell, cells_for
    from aaai.tools.play.session import InputError, PlaySettings, check_player

    battery = seeds_mode is not None or levels is not None or difficulties is not None
    if battery and arena is None and (level is not None or difficulty_text is not None or seed is not None):
        raise click.UsageError(
            "LEVEL, -d and -s choose one episode; --seeds, --levels and --difficulty a battery: use one or the other"
        )
    if arena is not None and (
        level is not None or levels is not None or difficulties is not None or difficulty_text is not None
    ):
        raise click.UsageError(
            "--arena: LEVEL, --levels, -d and --difficulty cannot be used with it (an arena file is its own level)"
        )
    if "{player}" not in output and player is None:
        raise click.UsageError(
            f"--out: got {output!r} without {{player}}, so every player's rows would go to one "
            "file; name the one player with --player, or put {player} in the path"
        )
    try:
        if player is not None:
            check_player(player)
        overrides = {"camera": True, "camera_resolution": camera_resolution, "action_mode": "gait"}
        if max_steps is not None:
            overrides["max_steps"] = max_steps
        config = load_config(config_path, **overrides)
        physics = config.physics  # one control step per action: each env.step is 1/50 s of play
        config = load_config(config, decision_interval=physics.control_dt)
        settings = PlaySettings(
            config=config,
            output=output,
            player=player,
            max_fps=fps,
            grace_seconds=grace,
            idle_seconds=idle,
            max_sessions=max_sessions,
            replays=Path(replays) if replays else None,
        )
        if arena is not None:
            from aaai.task.arena import arena_files, load_arena

            settings.arenas = arena_files(arena)
            if seeds_mode is not None:
                try:
                    settings.arena_seeds = [int(part) for part in seeds_mode.split(",")]
                except ValueError:
                    raise ConfigError(f"--seeds: got {seeds_mode!r} with --arena; allowed: a list like 1,2,3") from None
            else:
                settings.arena_seeds = [seed or 0]
            for path in settings.arenas:  # every instance is checked before anyone plays
                for arena_seed in settings.arena_seeds:
                    load_arena(path, arena_seed, body=config.agent.body)  # for the body's footprint
            settings.seeds_label = ",".join(map(str, settings.arena_seeds))
        elif battery:
            from aaai.levels.seeds import read_seed_key

            key = read_seed_key(seed_key_file)
            level_list = parse_levels(levels)
            difficulty_list = parse_range(difficulties or "0", "--difficulty", 0, 10)
            settings.cells = cells_for(level_list, difficulty_list, seeds_mode or "reserved", count, key)
            settings.seeds_label, settings.seed_key = seeds_mode or "reserved", key
        else:
            from aaai.levels import check_difficulty, get_level

            lvl = get_level(level if level is not None else 0)
            settings.cells = [Cell(lvl.id, check_difficulty(difficulty_text or 0), [seed or 0])]
            settings.seeds_label = str(seed or 0)
    except (ConfigError, InputError, ValueError) as error:
        raise click.UsageError(str(error)) from None

    try:
        from aaai.tools.play.server import Server
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai play")) from None
    try:
        server = Server(settings, host, port)
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai play")) from None
    episodes = len(settings.episodes())
    click.echo(
        f"aaai play: open {server.url} in a browser ({episodes} episode{'s' * (episodes != 1)} per player, "
        f"at most {server.registry.max_sessions} players at once; scores to {output}). Ctrl+C stops."
    )
    if server.network:
        here = f" ({server.local_url} on this machine)" if server.local_url != server.url else ""
        click.echo(
            f"--host {host}: anyone who can reach this machine on port {server.port} and has this link{here} "
            "can play under any name (the token in it is the only key; there is no encryption); "
            "the scoreboards are written here."
        )
    server.run()
