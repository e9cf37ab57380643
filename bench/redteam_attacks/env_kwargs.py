"""The env-kwargs group: ``gym.make`` keywords of every wrong type, and bad steps and resets."""

from __future__ import annotations

from .base import PY, attack
from .inputs import fifo

GROUP = "env-kwargs"


def env_code(kwargs: str, steps: int = 3, make: str = "gym.make('aaai/L0-FoodContact-v0', {kw})") -> str:
    return (
        "import sys\nimport gymnasium as gym\nimport aaai\n"
        "try:\n"
        f"    env = {make.format(kw=kwargs)}\n"
        "    env.reset(seed=0)\n"
        f"    for _ in range({steps}):\n"
        "        env.step(env.action_space.sample())\n"
        "    env.close()\n"
        "except (ValueError, TypeError, gym.error.Error) as error:\n"
        "    print(f'Error: {type(error).__name__}: {error}'[:300], file=sys.stderr)\n"
        "    sys.exit(1)\n"
    )


def attacks():
    cases = [
        ("config-etc-passwd", "config='/etc/passwd'", "error"),
        ("config-dev-zero", "config='/dev/zero'", "error"),
        ("config-fifo", "config='{W}/f.yaml'", "error"),
        ("config-int", "config=123", "error"),
        ("config-bytes", "config=b'episode: {max_steps: 20}'", "error"),
        ("config-nested-list", "config={'agent': [1]}", "error"),
        ("config-object", "config=object()", "error"),
        ("render-mode-evil", "render_mode='evil'", "error"),
        ("render-mode-list", "render_mode=['rgb_array']", "error"),
        ("level-99", "level=99", "error"),
        ("level-path", "level='../../etc/passwd'", "error"),
        ("level-float", "level=0.5", "error"),
        ("level-bool", "level=True", "error"),
        ("difficulty-negative", "difficulty=-1", "error"),
        ("difficulty-1e308", "difficulty=1e308", "error"),
        ("difficulty-nan", "difficulty=float('nan')", "error"),
        ("max-episode-steps-negative", "max_episode_steps=-1", "any"),
        ("camera-resolution-huge", "camera_resolution=10**9", "error"),
        ("camera-resolution-float", "camera_resolution=64.5", "error"),
        ("rays-per-side-numpy", "rays_per_side=__import__('numpy').int64(4)", "any"),
        ("max-force-numpy-nan", "max_force=__import__('numpy').float64('nan')", "error"),
        ("sensors-not-mapping", "sensors='camera'", "error"),
        ("sensors-unknown", "sensors={'evil': 1}", "error"),
        ("arena-int", "arena=5", "error"),
        ("arena-dev-zero", "arena='/dev/zero'", "error"),
        ("arena-folder", "arena='/'", "error"),
        ("arena-fifo", "arena='{W}/f.yaml'", "error"),
        ("unknown-kwarg", "evil=1", "error"),
        ("kwarg-dunder", "**{'__class__': 1}", "error"),
        ("gravity-string", "gravity='9.81'", "any"),
        ("timestep-tiny", "timestep=1e-9", "error"),
        ("body-path", "body='../../../etc/passwd'", "error"),
        ("action-mode-none", "action_mode=None", "error"),
    ]
    for name, kw, expect in cases:
        setup = fifo("f.yaml") if "f.yaml" in kw else None
        attack(f"env-{name}", GROUP, [PY, "-c", env_code(kw)], setup, expect, timeout=40)
    plain = env_code("", make="gym.make('aaai/L0-FoodContact-v0')")
    for name, old, new, expect in [
        ("step-nan-action", "env.action_space.sample()", "[float('nan')] * 8", "any"),
        ("step-wrong-shape", "env.action_space.sample()", "[0.0] * 3", "error"),
        ("reset-huge-seed", "env.reset(seed=0)", "env.reset(seed=2**80)", "error"),
        (
            "reset-bad-options",
            "env.reset(seed=0)",
            "env.reset(seed=0, options={'level': 'evil', 'difficulty': [1]})",
            "error",
        ),
    ]:
        attack(f"env-{name}", GROUP, [PY, "-c", plain.replace(old, new)], None, expect)
