"""Scoring: resolved policies, the episode loop, the scoreboard and its backends, run folders, replays."""
