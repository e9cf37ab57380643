"""``aaai show``: a picture of a level (top-down map beside the agent's camera), or a video."""

from __future__ import annotations

from pathlib import Path

import click

from aaai.config import ACTION_MODES, ConfigError
from aaai.levels import check_difficulty, check_seed, get_level
from aaai.scoring.episodes import play
from aaai.scoring.policies import BUILT_IN
from aaai.tools.media import VIDEO_CODECS, VideoWriter, save_png, video_extension_error
from aaai.tools.viewer import compose, draw_top_down, draw_world

from .options import DIFFICULTY, SEED, Output

CAMERA_RESOLUTION = 128
STEP_CAP = 10000  # the longest episode a config allows (episode.max_steps): --video's default cap
MAP_SIZE = 640  # pixels across the longer side of the top-down map


def frame_every(fps: float, control_dt: float) -> int:
    """Control steps between video frames so the video plays in simulated real time (at least 1)."""
    return max(1, int(round(1.0 / (fps * control_dt))))


@click.command("show")
@click.argument("level", required=False)
@click.option(
    "--arena",
    type=click.Path(dir_okay=False),
    help="Draw this arena file (docs, Write your own test) instead of LEVEL, at --seed.",
)
@click.option("-d", "--difficulty", type=DIFFICULTY, default=0, show_default=True)
@click.option("-s", "--seed", type=SEED, default=0, show_default=True)
@click.option(
    "-o",
    "--output",
    type=Output(dir_okay=False),
    help="PNG to write [default: <label>_d<D>_s<S>.png, e.g. L1_d0_s0.png; with --video, only if given].",
)
@click.option("--video", type=Output(dir_okay=False), help="Record an episode to this .mp4 or .avi.")
@click.option(
    "--policy",
    default="random",
    show_default=True,
    help=f"Who moves the agent in the video: {', '.join(BUILT_IN)}, a model .zip, a run folder or module:callable.",
)
@click.option(
    "--steps",
    type=click.IntRange(1, STEP_CAP),
    default=None,
    help=f"Steps to record at most [default: to the episode's end, capped at {STEP_CAP}]; when the cap "
    "cuts the episode, the message says so.",
)
@click.option(
    "--fps",
    type=click.IntRange(1, 500),
    default=25,
    show_default=True,
    help="Video frame rate; a frame every round(1 / (fps x 0.02 s)) control steps, at least 1.",
)
@click.option(
    "--size",
    type=click.IntRange(200, 4000),
    default=MAP_SIZE,
    show_default=True,
    help="Pixels across the longer side of the top-down map.",
)
@click.option("--config", "config_path", type=click.Path(), help="A YAML overriding configs/default.yaml.")
@click.option(
    "--action-mode",
    type=click.Choice(ACTION_MODES),
    help="The policy's action mode (default: the config's); gait: forward, turn, crouch commands.",
)
@click.option(
    "--trust-model",
    is_flag=True,
    help="Load a model file with stable-baselines3's own loader, which unpickles it and so runs any code "
    "in it (default: rebuilt without unpickling). Only for files you trust.",
)
@click.option(
    "--replay",
    type=click.Path(dir_okay=False),
    help="With --video: film a replay file (aaai play --replays, aaai eval --save-replays): its level, "
    "config and actions (--arena: where its arena file is now).",
)
def show(
    level,
    difficulty,
    seed,
    output,
    video,
    policy,
    steps,
    fps,
    size,
    config_path,
    arena,
    action_mode,
    trust_model,
    replay,
):
    """Draw LEVEL (id, label like L1, or name) from above beside the agent's camera view.

    Writes a PNG, and with --video records an episode (random policy by default) so that the
    moving parts can be watched. Outputs are written atomically.
    """
    if replay is not None:
        return show_replay(replay, video, output, steps, fps, size, arena, level)
    if (level is None) == (arena is None):
        raise click.UsageError("name a LEVEL or an --arena file (one of the two)")
    try:
        if arena is not None:
            from aaai.config import load_config
            from aaai.task.arena import load_arena

            body = load_config(config_path).agent.body  # checked for its footprint
            load_arena(arena, check_seed(seed), body=body)  # an invalid file fails here, before anything runs
            lvl = None
        else:
            lvl = get_level(level)
        difficulty, seed = check_difficulty(difficulty), check_seed(seed)
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    if output is None and video is None:
        output = f"{Path(arena).stem}_s{seed}.png" if lvl is None else f"{lvl.label}_d{difficulty}_s{seed}.png"
    if output is not None and Path(output).suffix.lower() != ".png":
        raise click.UsageError(f"--output: got {output!r}; allowed: a path ending in .png")
    if video is not None and Path(video).suffix.lower() not in VIDEO_CODECS:
        raise click.UsageError(video_extension_error(video))
    for path in (output, video):
        if path is not None and not Path(path).absolute().parent.is_dir():
            raise click.UsageError(f"output {path!r}: the folder {str(Path(path).absolute().parent)!r} does not exist")

    from aaai.config import load_config
    from aaai.env import AnimalAIEnv  # after the checks: bad input fails fast
    from aaai.scoring.policies import resolve

    try:
        chosen = resolve(policy, trust_model) if video is not None else None
        base = chosen.play_config(config_path) if chosen is not None else load_config(config_path)
        env = AnimalAIEnv(
            level=lvl.id if lvl else None,
            difficulty=difficulty,
            config=base,
            camera=True,
            # a policy that sees the camera films with its own camera; otherwise it is turned on here to draw it
            camera_resolution=base.sensors.camera_resolution
            if chosen is not None and base.sensors.camera
            else CAMERA_RESOLUTION,
            arena=arena,
            **({"action_mode": action_mode} if action_mode else {}),
        )
        # the camera is turned on here to draw it: a model that was not trained with it does not see it
        extra = () if base.sensors.camera else ("camera",)
        actor = chosen.build(env, extra_keys=extra) if chosen is not None else None
    except ConfigError as error:
        raise click.UsageError(str(error)) from None

    picture = picture_writer(env, output, size)

    try:
        if video is None:
            picture(env.reset(seed=seed)[0])
        else:  # the PNG, if asked for, shows the episode's start
            record(env, actor, seed, video, steps, fps, size, on_reset=picture if output is not None else None)
    finally:
        env.close()


def picture_writer(env, output: str | None, size: int):
    """``picture(observation, info=None)``: writes the level's top-down map beside the head camera's
    view to the PNG ``output``."""

    def picture(observation, info=None) -> None:
        assert output is not None, "a picture is drawn only when there is a PNG to write"
        image = compose(draw_top_down(env.level_spec, size), observation["camera"])
        click.echo(f"wrote {save_png(image, output)} ({image.shape[1]} x {image.shape[0]})")

    return picture


ENDS = {"ate green": "ate green food", "time": "reached max_steps"}  # how the messages name them


def record(
    env,
    policy,
    seed: int,
    path: str,
    steps: int | None,
    fps: int,
    size: int,
    on_reset=None,
    options: dict | None = None,
) -> int:
    """Resets ``env`` to ``seed``, runs ``policy`` to the episode's end (or ``steps`` steps at most;
    None: :data:`STEP_CAP`) and writes a frame every few steps; returns the frames. When the cap cuts
    the episode, the message says so. ``on_reset(observation, info)`` sees the start."""
    cap = STEP_CAP if steps is None else steps
    every = frame_every(fps, env.control_dt * env.hold)  # an env step is `hold` control steps in gait mode
    with VideoWriter(path, fps) as writer:

        def frame(step: int, observation, reward: float, info: dict) -> None:
            if step % every == 0:
                writer.write(compose(draw_world(env, size), observation["camera"]))

        result = play(env, policy, seed, options=options, on_reset=on_reset, on_step=frame, max_steps=cap)
        if writer.frames == 0:  # the episode ended before the first frame
            writer.write(compose(draw_world(env, size), result.observation["camera"]))
    end = ENDS.get(result.end, result.end) if result.end is not None else None
    ended = (
        f"; the episode ended at step {result.steps} ({end})"
        if end
        else f"; stopped at step {result.steps} by {'--steps' if steps is not None else 'the cap'} before the episode "
        f"ended (it runs to step {result.info.get('max_steps', '?')} at most; raise --steps to see more)"
    )
    click.echo(f"wrote {path} ({writer.frames} frames at {fps} fps, a frame every {every} steps{ended})")
    return writer.frames


def show_replay(
    path: str,
    video: str | None,
    output: str | None,
    steps: int | None,
    fps: int,
    size: int,
    arena: str | None,
    level: str | None,
) -> None:
    """``aaai show --video FILE --replay REPLAY``: the recorded episode filmed (its own level,
    config and actions; the camera turned on to draw it, which changes nothing the body does)."""
    from aaai.scoring.replays import ReplayPolicy, load_replay, make_env, replay_options

    if video is None:
        raise click.UsageError("--replay: give --video FILE to film it (and -o for a picture of its start)")
    if level is not None:
        raise click.UsageError(f"--replay: got LEVEL {level!r} too; a replay plays its own level")
    if Path(video).suffix.lower() not in VIDEO_CODECS:
        raise click.UsageError(video_extension_error(video))
    if output is not None and Path(output).suffix.lower() != ".png":
        raise click.UsageError(f"--output: got {output!r}; allowed: a path ending in .png")
    try:
        data = load_replay(path)
        options = replay_options(data, arena)
        env = make_env(data, camera=True, camera_resolution=CAMERA_RESOLUTION)
    except ConfigError as error:
        raise click.UsageError(str(error)) from None

    picture = picture_writer(env, output, size)

    try:
        record(
            env,
            ReplayPolicy(data),
            data["seed"],
            video,
            min(steps or data["steps"], data["steps"]),
            fps,
            size,
            on_reset=picture if output is not None else None,
            options=options,
        )
    finally:
        env.close()
