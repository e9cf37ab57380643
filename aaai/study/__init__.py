"""Human studies: a battery of trials played by participants through their own links.

``studyfile`` reads a study file (the battery, practice, order, breaks, time limit, texts, what a
participant may see); ``order`` gives each participant's order of trials; ``store`` keeps the
participants, their trials, rows and replays in one SQLite file; ``participant`` plays one
participant's trials on the ``aaai play`` session machinery, each finished trial committed before
the next starts; ``server`` serves the participant pages; ``export`` writes the scoreboard CSV and
the replays from the store.
"""
