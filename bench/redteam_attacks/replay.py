"""The replay group: ``aaai run --replay`` and ``aaai show --replay --video`` given hostile JSON,
or a replay that is no regular file."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

from .base import AAAI, attack, base, digest, replay_data
from .inputs import both, fifo, folder, link, replay_file, text

GROUP = "replay"
RUN = [AAAI, "run", "--replay", "r.json"]
SHOW = [AAAI, "show", "--replay", "r.json", "--video", "v.mp4"]


def set_(key, value, rehash=False):
    def change(d, w):
        d[key] = value
        if rehash:
            d["config_digest"] = digest(d["config"])

    return change


def conf(path, value):
    def change(d, w):
        section, key = path.split(".") if "." in path else (None, path)
        if section:
            d["config"][section][key] = value
        else:
            d["config"][key] = value
        d["config_digest"] = digest(d["config"])

    return change


def actions(runs, steps=None):
    def change(d, w):
        d["actions"] = runs
        d["steps"] = steps if steps is not None else sum(r[0] for r in runs)

    return change


def arena_at(name, path):
    """The replay's arena: ``path`` (of the work folder ``w``) under ``name``, with the file's true hash."""

    def change(d, w):
        where = path(w)
        arena = {"name": name, "path": str(where), "sha256": hashlib.sha256(Path(where).read_bytes()).hexdigest()}
        return json.dumps({**d, "arena": arena})

    return change


def arena_copy(w):
    shutil.copy(base() / "arena.yaml", w / "a.yaml")
    return w / "a.yaml"


def attacks():
    cases = [
        ("deep-nesting", lambda d, w: "[" * 200000 + "]" * 200000, "error"),
        ("deep-object", lambda d, w: '{"a":' * 100000 + "1" + "}" * 100000, "error"),
        ("billion-steps", actions([[10**9, [0.0] * 8]]), "error"),
        ("huge-count-mismatch", actions([[10**18, [0.0] * 8]], 3), "error"),
        ("short-action", actions([[20, [0.0] * 3]]), "error"),
        ("long-action", actions([[20, [0.0] * 40]]), "error"),
        ("empty-action", actions([[20, []]]), "error"),
        ("extreme-action-values", actions([[20, [1e308, -1e308] * 4]]), "any"),
        ("no-actions", actions([], 0), "any"),
        ("level-99", set_("level", 99), "error"),
        ("level-huge", set_("level", 2**70), "error"),
        ("difficulty-11", set_("difficulty", 11), "error"),
        ("difficulty-huge", set_("difficulty", 10**30), "error"),
        ("seed-2-64", set_("seed", 2**64), "any"),
        ("seed-2-200", set_("seed", 2**200), "any"),
        ("return-nan", lambda d, w: json.dumps({**d, "return": float("nan")}), "error"),
        (
            "pose-infinity",
            lambda d, w: json.dumps({**d, "final_pose": {**d["final_pose"], "x": float("inf")}}),
            "error",
        ),
        ("config-list", set_("config", [1, 2], rehash=True), "error"),
        ("config-unknown-key", conf("evil", 1), "error"),
        ("config-body-16", conf("agent.body", "quadruped16"), "any"),
        ("config-max-steps-string", conf("episode.max_steps", "1e400"), "error"),
        ("config-timestep-tiny", conf("physics.timestep", 1e-300), "error"),
        ("config-section-null", conf("sensors", None), "error"),
        ("arena-etc-passwd", arena_at("x.yaml", lambda w: "/etc/passwd"), "error"),
        ("arena-dev-zero", set_("arena", {"name": "z", "path": "/dev/zero", "sha256": "0" * 64}), "error"),
        ("arena-folder", set_("arena", {"name": "z", "path": "/", "sha256": "0" * 64}), "error"),
        ("arena-name-traversal", arena_at("../../../../tmp/x", arena_copy), "any"),
        ("arena-number-fields", set_("arena", {"name": 1, "path": 2, "sha256": 3}), "error"),
        ("level-bool", set_("level", True), "error"),
        ("count-float", actions([[20.0, [0.0] * 8]], 20), "error"),
        ("count-zero", actions([[0, [0.0] * 8], [20, [0.0] * 8]], 20), "error"),
        ("duplicate-keys", lambda d, w: json.dumps(d)[:-1] + ',"level":5}', "any"),
        ("policy-10mb", set_("policy", "p" * 10_000_000), "any"),
        ("policy-dict", set_("policy", {"evil": [1, 2]}), "any"),
        ("end-object", set_("end", {"x": 1}), "any"),
        ("spec-digest-number", set_("spec_digest", 12), "any"),
        ("version-string", set_("version", "1"), "error"),
        ("top-array", lambda d, w: "[1,2,3]", "error"),
        ("bom", lambda d, w: "\ufeff" + json.dumps(d), "any"),
        ("nul-bytes", lambda d, w: json.dumps(d)[:50] + "\x00" + json.dumps(d)[50:], "error"),
        (
            "huge-int-digits",
            lambda d, w: json.dumps(d).replace('"seed":', '"seed":' + "9" * 5000 + ',"x":', 1),
            "error",
        ),
        ("lone-surrogate", set_("policy", "\ud800"), "any"),
    ]
    for name, change, expect in cases:
        attack(f"replay-{name}", GROUP, RUN, replay_file("r.json", change), expect)
    utf16 = lambda w: (w / "r.json").write_bytes(json.dumps(replay_data()).encode("utf-16"))  # noqa: E731
    attack("replay-utf16", GROUP, RUN, utf16, "error")
    for kind, setup in [
        ("dir", folder("r.json")),
        ("fifo", fifo("r.json")),
        ("empty", text("r.json", "")),
        ("loop", link("r.json", "{W}/r.json")),
        ("devzero", link("r.json", "/dev/zero")),
    ]:
        attack(f"replay-file-{kind}", GROUP, RUN, setup, "error", timeout=30)
    # the video path of show --replay
    for name, change in [
        ("billion", actions([[10**9, [0.0] * 8]])),
        ("deep", lambda d, w: "[" * 200000),
        ("short-action", actions([[20, [0.0] * 3]])),
    ]:
        attack(f"replay-show-{name}", GROUP, SHOW, replay_file("r.json", change), "error")
    video_fifo = both(replay_file("r.json", lambda d, w: None), fifo("v.mp4"))
    attack("replay-show-video-fifo", GROUP, SHOW, video_fifo, "any", timeout=30)
