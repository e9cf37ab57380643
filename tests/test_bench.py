"""The benchmark runs and reports every figure (its numbers are read by people, not asserted)."""
import json
import subprocess
import sys


def test_bench_writes_every_figure(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "aaai_cli.main", "bench", "--levels", "0,10", "--steps", "200", "--resets", "5",
         "--worker-steps", "100", "--memory-steps", "1000", "--out", str(tmp_path)],
        capture_output=True, text=True, check=True)
    results = json.loads((tmp_path / "bench.json").read_text())
    level = results["env"]["L0"]
    assert set(level) == {"joints", "joints+rays", "joints+cam64rgb", "joints+cam84gray", "reset_median_ms",
                          "reset_p95_ms"}
    assert all(value > 0 for value in level.values())
    assert results["limit"]["L0"] > 0 and set(results["workers"]) == {"1", "2", "4"}
    assert "L0 joints / limit" in results["ratios"] and "2 workers / 1" in results["ratios"]
    assert results["memory"]["rss_after_mb"] > 0
    assert "| L0 |" in (tmp_path / "bench.md").read_text() and "| L0 |" in result.stdout
    assert set(results["hole_casting"]) == {"L10"}  # only a level with missing floor casts for holes
    assert all(rate > 0 for rate in results["hole_casting"]["L10"].values())
    assert "L10 rays seeing holes" in (tmp_path / "bench.md").read_text()
