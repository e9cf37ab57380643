"""The config group: ``--config`` files of odd keys, types, YAML 1.1 forms and encodings."""

from __future__ import annotations

from .base import AAAI, attack, train_argv
from .inputs import text

GROUP = "config"
RUN = [AAAI, "run", "--levels", "0", "--max-steps", "10", "--no-camera", "--config", "c.yaml"]
TRAIN = train_argv("50", "--config", "c.yaml", "--run", "r")


def attacks():
    cases = [
        ("section-scalar", "agent: walker\n", "error"),
        ("section-list", "agent: [1, 2]\n", "error"),
        ("section-null", "agent: null\n", "any"),
        ("rays-string-yes", "sensors: {rays: 'yes'}\n", "error"),
        ("rays-yaml11-on", "sensors: {rays: on}\n", "any"),
        ("rays-per-side-float", "sensors: {rays_per_side: 8.5}\n", "error"),
        ("rays-per-side-string", "sensors: {rays_per_side: '8'}\n", "any"),
        ("rays-per-side-bool", "sensors: {rays_per_side: true}\n", "error"),
        ("max-steps-auto-space", "episode: {max_steps: 'auto '}\n", "any"),
        ("max-steps-AUTO", "episode: {max_steps: AUTO}\n", "any"),
        ("max-steps-float", "episode: {max_steps: 100.0}\n", "any"),
        ("max-steps-float-frac", "episode: {max_steps: 100.5}\n", "error"),
        ("level-label", "level: L0\n", "any"),
        ("level-hex", "level: 0x0\n", "any"),
        ("level-octal", "level: 0o17\n", "error"),
        ("difficulty-underscore", "difficulty: 1_0\n", "any"),
        ("sexagesimal", "difficulty: 1:20\n", "any"),
        ("unicode-key", "agent: {bödy: quadruped}\n", "error"),
        ("int-key", "1: 2\n", "error"),
        ("dunder-key", "__class__: {x: 1}\n", "error"),
        ("dotted-top-key", "agent.body: quadruped16\n", "any"),
        ("empty-key", "'': 1\n", "error"),
        ("date-number", "physics: {gravity: 2020-01-01}\n", "error"),
        ("shaping-inf", "episode: {shaping: .inf}\n", "error"),
        ("shaping-nan", "episode: {shaping: -.nan}\n", "error"),
        ("body-900kb", "agent: {body: " + "q" * 900_000 + "}\n", "error"),
        ("bom", "\ufeffepisode: {max_steps: 20}\n", "any"),
        ("crlf", "episode:\r\n  max_steps: 20\r\n", "any"),
        ("tabs", "episode:\n\tmax_steps: 20\n", "error"),
        ("empty", "", "any"),
        ("comments-only", "# nothing\n", "any"),
        ("document-marker-only", "---\n", "any"),
        ("top-null", "null\n", "any"),
        ("top-list", "- 1\n- 2\n", "error"),
        ("top-scalar", "hello\n", "error"),
        ("gravity-negative-zero", "physics: {gravity: -0.0}\n", "any"),
        ("solver-iterations-huge", "physics: {solver_iterations: 1000000}\n", "error"),
        ("action-repeat-zero", "physics: {action_repeat: 0}\n", "error"),
        ("ray-length-tiny", "sensors: {ray_length: 1.0e-300}\n", "any"),
        ("action-mode-unicode", "agent: {action_mode: rotatіon}\n", "error"),
        ("nested-extra-section", "sensors: {rays: {deep: {deeper: 1}}}\n", "error"),
        ("train-section-junk", "train: {learning_rate: [1, 2]}\n", "error"),
        ("curriculum-levels-int", "curriculum: {levels: 5}\n", "any"),
        ("curriculum-levels-huge-range", "curriculum: {levels: '0-99999999999'}\n", "error"),
    ]
    for name, content, expect in cases:
        attack(f"config-{name}", GROUP, RUN, text("c.yaml", content), expect)
    for name, content, encoding in [
        ("utf16", "episode: {max_steps: 20}\n", "utf-16"),
        ("latin1", "# café\nepisode: {max_steps: 20}\n", "latin-1"),
    ]:
        attack(f"config-{name}", GROUP, RUN, text("c.yaml", content, encoding), "error")
    for name, content, expect in [
        ("curriculum-huge", "curriculum: {levels: '0-99999999999'}\n", "error"),
        ("window-zero", "curriculum: {window: 0}\n", "any"),
    ]:
        attack(f"config-train-{name}", GROUP, TRAIN, text("c.yaml", content), expect)
