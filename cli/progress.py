"""A job's progress on the terminal: a click progress bar, or its lines when the output is piped."""

from __future__ import annotations

import contextlib
import sys
import time
from typing import Iterator

import click

from aaai.jobs import Advance, Progress, print_lines

REDRAW = 0.25  # seconds between redraws of a terminal's progress bar


@contextlib.contextmanager
def progress_output(report: Progress) -> Iterator[Advance]:
    """Yields the function to advance ``report`` (an aaai.jobs.Progress; an aaai.jobs.Display) with: a progress bar
    showing its rate, episodes, pass rate and ETA in a terminal; elsewhere (piped, nohup) its line
    every ``report.every`` seconds, and once more at the end."""
    if sys.stdout.isatty():
        with click.progressbar(
            length=report.total, label=report.label, show_pos=True, show_eta=False, item_show_func=lambda item: item
        ) as bar:
            bar.update(report.done)
            pending, drawn = [0], [0.0]

            def update(n: int) -> None:  # the bar is redrawn at most every REDRAW seconds: a redraw
                report.update(n)  # costs about 1000 times a step's bookkeeping
                pending[0] += n
                now = time.monotonic()
                if now - drawn[0] >= REDRAW:
                    bar.update(pending[0], current_item=report.details())
                    pending[0], drawn[0] = 0, now

            yield update
            bar.update(pending[0], current_item=report.details())
    else:
        write = report.write = print_lines(sys.stdout)
        yield report.update
        write(report.line())
