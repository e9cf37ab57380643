"""``aaai study``: a human study from a study file: participant links, the participant server, the export."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import click

from aaai.config import ConfigError
from aaai.errors import needs_extra

from .options import Finite, Output

STUDY_FILE = click.Path(dir_okay=False)


def _study(path: str):
    from aaai.study.studyfile import load_study

    try:
        return load_study(path)
    except ConfigError as error:
        raise click.UsageError(str(error)) from None


def _store(study, writer: bool = True, serving: bool = False):
    from aaai.study.store import Store

    try:
        store = Store(study.store, study.name, writer=writer, serving=serving)
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    try:
        store.check_plan(study)
    except ConfigError as error:
        store.close()
        raise click.UsageError(str(error)) from None
    return store


@click.group("study")
def study():
    """Run a battery with participants: links, a participant server, the results (docs: play.md, Studies)."""


@study.command("participants")
@click.argument("study_file", type=STUDY_FILE)
@click.option("-n", "count", type=click.IntRange(1, 10_000), required=True, help="New participants to add.")
@click.option(
    "--url",
    "base_url",
    default="http://127.0.0.1:8000/",
    show_default=True,
    help="The address participants will open (where `aaai study serve` is reached).",
)
@click.option(
    "--out",
    "output",
    type=Output(dir_okay=False),
    help="The CSV of id,link to write [default: <study>_links.csv beside the study file].",
)
def participants(study_file, count, base_url, output):
    """Add COUNT participants to STUDY_FILE's store, each with an unguessable link, and write id,link.

    It may run while `aaai study serve` serves the study: the new links work at once."""
    from aaai.files import write_atomic
    from aaai.study.server import link

    if not base_url.startswith(("http://", "https://")):
        raise click.UsageError(f"--url: got {base_url!r}; allowed: an address starting with http:// or https://")
    chosen = _study(study_file)
    store = _store(chosen)
    try:
        store.add_participants(chosen, count)
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(["id", "link"])
        for row in store.participants():
            writer.writerow([row["id"], link(base_url, row["token"])])
    finally:
        store.close()
    path = Path(output) if output else chosen.path.with_name(f"{chosen.path.stem}_links.csv")
    write_atomic(path, buffer.getvalue())
    click.echo(f"aaai study: {count} participant{'s' * (count != 1)} added; every link is in {path} (keep it private)")


@study.command("serve")
@click.argument("study_file", type=STUDY_FILE)
@click.option("--host", default="127.0.0.1", show_default=True, help="Address to listen on.")
@click.option("--port", type=click.IntRange(0, 65535), default=8000, show_default=True, help="0: any free port.")
@click.option(
    "--grace",
    type=Finite(0, 86400),
    default=60,
    show_default=True,
    help="Seconds a closed tab's trial waits (paused) before it is abandoned; the link resumes it either way.",
)
@click.option(
    "--max-sessions",
    type=click.IntRange(1, 10_000),
    help="Participants playing at once; one more is told the study is full "
    "[default: 3, what one server process holds at 50 steps/s, within half the available memory].",
)
@click.option(
    "--public-url",
    help="The https:// address participants open through a TLS proxy (its Host and Origin are accepted).",
)
def serve(study_file, host, port, grace, max_sessions, public_url):
    """Serve STUDY_FILE to its participants: each link opens consent, instructions, practice, the battery."""
    chosen = _study(study_file)
    try:
        from aaai.study.participant import play_settings
        from aaai.study.server import StudyServer
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai study serve")) from None
    store = _store(chosen, serving=True)
    try:
        settings = play_settings(chosen, grace_seconds=grace)
        server = StudyServer(chosen, store, settings, host, port, max_sessions, public_url)
        waiting = sum(row["status"] != "finished" for row in store.participants())
        click.echo(
            f"aaai study: serving {chosen.name!r} at {server.base_url} ({waiting} participant link"
            f"{'s' * (waiting != 1)} not finished, at most {server.registry.max_sessions} playing at once; "
            f"the store is {chosen.store}). Ctrl+C stops."
        )
        if server.network and not public_url:
            click.echo(
                f"--host {host}: anyone who can reach port {server.port} can open the pages; only a participant's "
                "token lets them play, and there is no encryption: serve it behind a TLS proxy"
            )
        server.run()
    except (ConfigError, ValueError) as error:
        raise click.UsageError(str(error)) from None
    finally:
        store.close()


@study.command("export")
@click.argument("study_file", type=STUDY_FILE)
@click.option("--out", "out", type=Output(file_okay=False), required=True, help="Folder for scores.csv and replays/.")
def export_command(study_file, out):
    """Write STUDY_FILE's finished trials as a scoreboard CSV (policy human:ID) and replays."""
    from aaai.study.export import export

    chosen = _study(study_file)
    store = _store(chosen, writer=False)
    try:
        scores, replays = export(store, out)
    finally:
        store.close()
    click.echo(f"aaai study: {scores} and {len(replays)} replay{'s' * (len(replays) != 1)} in {Path(out) / 'replays'}")


@study.command("report")
@click.argument("study_file", type=STUDY_FILE)
@click.option(
    "--policy-scores",
    "scores",
    type=click.Path(dir_okay=False),
    multiple=True,
    help="A scoreboard from `aaai eval --study STUDY_FILE --policy ...` (repeat for more policies).",
)
@click.option(
    "--baselines",
    type=click.Path(file_okay=False),
    help="The baseline table's folder (baselines/): its rows on the study's trials join the report.",
)
@click.option(
    "--policy-replays",
    "replays",
    type=click.Path(),
    multiple=True,
    help="The replays of `aaai eval --study STUDY_FILE --save-replays DIR`: the policy's paths, measured from them.",
)
@click.option("--out", "out", type=Output(file_okay=False), required=True, help="Folder for report.md, .csv, .png.")
def report_command(study_file, scores, baselines, replays, out):
    """Humans against agents: pass rates (95 % Wilson intervals) per trial and level, attempts left
    unfinished, reaction times, paths in metres, steps."""
    from aaai.study.report import write_report

    chosen = _study(study_file)
    store = _store(chosen, writer=False)
    try:
        paths = write_report(
            chosen,
            store,
            out,
            [Path(s) for s in scores],
            Path(baselines) if baselines else None,
            [Path(r) for r in replays],
        )
    except ConfigError as error:
        raise click.UsageError(str(error)) from None
    except ImportError as error:
        raise click.ClickException(needs_extra(error, "aaai study report")) from None
    finally:
        store.close()
    click.echo(f"aaai study: the report is {paths[0]}, its rows {paths[1]}, its figure {paths[2]}")
