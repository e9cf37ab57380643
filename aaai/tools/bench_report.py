"""The benchmark's report: the figures :func:`aaai.tools.bench.run` measured, as ``bench.json`` and as a
markdown page (``bench.md``: a table per level, workers, training, the peer, memory)."""

from __future__ import annotations

import json
from pathlib import Path

from aaai.files import write_atomic
from aaai.tools.bench import NO_HOLE_CASTING


def _rate(figure: dict) -> str:
    return f"{figure['median']:.0f}"


def _ratio(figure: dict, percent: bool = False) -> str:
    """A median with its spread: 0.52 (0.48..0.55), or +61% (+55..+70%)."""
    if percent:
        return f"{100 * figure['median']:+.0f}% ({100 * figure['min']:+.0f}..{100 * figure['max']:+.0f}%)"
    return f"{figure['median']:.2f} ({figure['min']:.2f}..{figure['max']:.2f})"


def markdown(results: dict) -> str:
    m, settings = results["machine"], results["settings"]
    lines = [
        f"Machine: {m['platform']}, {m['cpus']} CPUs; Python {m['versions']['python']}, "
        f"pybullet {m['versions']['pybullet']}. Settings: {settings}. Load average (1, 5, 15 min): "
        f"{results['load']['before']} before, {results['load']['after']} after.",
        "",
        f"Steps per second (medians over {settings['rounds']} alternated rounds); ratios as median "
        "(min..max) of the per-round ratios.",
        "",
        "| level | limit | joints | joints / limit | +rays | rays overhead | rays overhead, rayTestBatch on 2 "
        "threads | +cam 64 RGB | +cam 84 gray | reset median ms | reset p95 ms |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    holes = []
    for label, level in results["levels"].items():
        rates, level_ratios = level["rates"], level["ratios"]
        lines.append(
            f"| {label} | {_rate(rates['limit'])} | {_rate(rates['joints'])} | "
            f"{_ratio(level_ratios['joints / limit'])} | {_rate(rates['joints+rays'])} | "
            f"{_ratio(level_ratios['rays overhead'], True)} | "
            f"{_ratio(level_ratios['rays overhead, 2 threads'], True)} | {_rate(rates['joints+cam64rgb'])} | "
            f"{_rate(rates['joints+cam84gray'])} | {level['reset_ms']['median']:.1f} | "
            f"{level['reset_ms']['p95']:.1f} |"
        )
        if "cost of seeing holes" in level_ratios:
            holes.append(
                f"- {label} rays seeing holes: {_rate(rates['joints+rays'])} steps/s; the same rays without "
                f"the hole casting: {_rate(rates[NO_HOLE_CASTING])} steps/s "
                f"({_ratio(level_ratios['cost of seeing holes'], True)} for seeing holes)"
            )
    lines += [""] + holes + ([""] if holes else [])
    overheads = {
        "wide rays overhead": "Rays 1.0 wide (sensors.ray_width 1.0, three casts a ray), overhead over joints-only",
        "sweep memory overhead": "The sweep memory (sensors.sweep_memory 8), overhead over the same rays without it",
        "sweep map overhead": "The sweep map (sensors.sweep_map 15), overhead over the sweep memory without it",
    }
    for key, title in overheads.items():
        per_level = [
            f"{label} {_ratio(level['ratios'][key], True)}"
            for label, level in results["levels"].items()
            if key in level["ratios"]
        ]
        if per_level:
            lines += [f"- {title}: " + ", ".join(per_level), ""]
    workers = results["workers"]
    w_rates, w_ratios = workers["rates"], workers["ratios"]
    lines += [
        f"- Workers (L0 joints, AsyncVectorEnv): 1: {_rate(w_rates['1'])}, 2: {_rate(w_rates['2'])}, "
        f"4: {_rate(w_rates['4'])} steps/s; 2 in-process (SyncVectorEnv): {_rate(w_rates['2 in-process'])}; "
        f"2 / 1 = {_ratio(w_ratios['2 workers / 1'])}, 4 / 1 = {_ratio(w_ratios['4 workers / 1'])}, "
        f"2 in-process / 2 workers = {_ratio(w_ratios['2 in-process / 2 workers'])}"
    ]
    if results.get("worker_groups"):
        from aaai.tools.workers_bench import markdown as groups_markdown

        lines += ["", groups_markdown(results["worker_groups"]).rstrip()]
    training = results.get("training")
    if training:
        c, t_rates, t_ratios = training["config"], training["rates"], training["ratios"]
        lines += [
            "",
            f"Training ({c['num_envs']} workers x n_steps {c['n_steps']}, train.vector {c['vector']}: "
            f"{c['runs']}; PPO {c.get('n_epochs', '?')} epochs of batch {c.get('batch_size', '?')}, "
            f"net_width {c.get('net_width', '?')}; levels {c['levels']}, difficulties {c['difficulties']}; sensors "
            f"{', '.join(c['sensors'])}; load {training['load']['before']} -> {training['load']['after']}):",
            "",
            "| | steps/s (median, min..max) | / env alone, same vector env | / env alone, the faster |",
            "|---|---:|---:|---:|",
        ]
        for name, figure in t_rates.items():
            same = t_ratios.get(f"{name} / env alone")
            best = t_ratios.get(f"{name} / env alone (best)")
            lines.append(
                f"| {name} | {figure['median']:.0f} ({figure['min']:.0f}..{figure['max']:.0f}) | "
                f"{_ratio(same) if same else ''} | {_ratio(best) if best else ''} |"
            )
    ant = results["ant_v5"]
    memory = results["memory"]
    lines += [
        "",
        "- Ant-v5 (MuJoCo, random actions): "
        + (
            f"{_rate(ant['rates']['Ant-v5'])} steps/s; "
            f"L0 joints / Ant-v5 = {_ratio(ant['ratios']['L0 joints / Ant-v5'])}"
            if ant
            else "not measured (install the bench extra)"
        ),
        f"- Memory: peak {memory['peak_mb']:.0f} MB; RSS {memory['rss_before_mb']:.1f} -> "
        f"{memory['rss_after_mb']:.1f} MB over {settings['memory_steps']} steps with a reset "
        f"every 200 ({100 * memory['growth']:+.1f}%)",
    ]
    return "\n".join(lines) + "\n"


def write(results: dict, folder: Path) -> tuple[Path, Path]:
    folder.mkdir(parents=True, exist_ok=True)
    json_path, md_path = folder / "bench.json", folder / "bench.md"
    write_atomic(json_path, json.dumps(results, indent=2) + "\n")
    write_atomic(md_path, markdown(results))
    return json_path, md_path
