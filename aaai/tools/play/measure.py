"""How fast ``aaai play`` serves a page: frames per second delivered to a real browser and the
server's CPU share while the simulation runs at 50 control steps a second.

    python -m aaai.tools.play.measure [--seconds 20] [--resolutions 84,128] [--fps 30,50]

For each camera resolution and frame cap it starts ``aaai play L1`` (a 60 s level) as its own
process, opens the page in headless Chromium (Debian's chromium and chromium-driver, as the browser
test does), starts the episode with the forward key held, and counts for ``--seconds``: the
frames that reached the page, the control steps simulated and the server
process's CPU time (user + system, from /proc) over the wall time. Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-dev-shm-usage",
    "--window-size=1000,800",
)


def cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of a process and its waited-for children (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return sum(int(v) for v in fields[11:15]) / os.sysconf("SC_CLK_TCK")


def measure(resolution: int, fps: int, seconds: float, folder: Path) -> dict:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    server = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "aaai_cli.main",
            "play",
            "L1",
            "--port",
            "0",
            "--player",
            "bench",
            "--out",
            str(folder / f"bench_{resolution}_{fps}.csv"),
            "--camera-resolution",
            str(resolution),
            "--fps",
            str(fps),
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    profile = tempfile.mkdtemp(prefix="aaai-measure-")
    driver = None
    try:
        assert server.stdout is not None  # stdout=PIPE
        line = server.stdout.readline()
        found = re.search(r"open (\S+) in a browser", line)
        if found is None:
            raise RuntimeError(f"aaai play printed {line!r}, not the link to open")
        url = found.group(1)
        options = webdriver.ChromeOptions()
        options.binary_location = CHROMIUM
        for flag in FLAGS + (f"--user-data-dir={profile}",):
            options.add_argument(flag)
        driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
        driver.get(url)
        phase = lambda: driver.find_element(By.ID, "phase").get_attribute("data-phase")  # noqa: E731
        end = time.monotonic() + 30
        while phase() != "ready":
            if time.monotonic() > end:
                raise RuntimeError(f"the page did not become ready (phase {phase()})")
            time.sleep(0.05)
        time.sleep(0.5)
        ActionChains(driver).key_down(Keys.ARROW_UP).perform()
        time.sleep(2.0)  # settle
        frame_start = int(driver.execute_script("return frameNo"))
        steps_start = int(driver.execute_script("return lastStatus.steps"))
        cpu_start, wall_start = cpu_seconds(server.pid), time.monotonic()
        time.sleep(seconds)
        cpu, wall = cpu_seconds(server.pid) - cpu_start, time.monotonic() - wall_start
        frames = int(driver.execute_script("return frameNo")) - frame_start
        steps = int(driver.execute_script("return lastStatus.steps")) - steps_start
        return {
            "resolution": resolution,
            "fps_cap": fps,
            "frames_per_s": frames / wall,
            "cpu_share": cpu / wall,
            "steps_per_s": steps / wall,
            "phase": phase(),
            "load": os.getloadavg()[0],
        }
    finally:
        if driver is not None:
            driver.quit()
        server.terminate()
        server.wait(10)
        shutil.rmtree(profile, ignore_errors=True)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--resolutions", default="84,128")
    parser.add_argument("--fps", default="30,50", help="frame caps (aaai play --fps) to measure")
    args = parser.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for resolution in (int(v) for v in args.resolutions.split(",")):
            for fps in (int(v) for v in args.fps.split(",")):
                rows.append(measure(resolution, fps, args.seconds, Path(folder)))
                print(rows[-1], file=sys.stderr)
    print("| camera | --fps | frames/s delivered | control steps/s | server CPU (one core = 100%) |")
    print("|---|---:|---:|---:|---:|")
    for row in rows:
        print(
            f"| {row['resolution']} x {row['resolution']} | {row['fps_cap']} | {row['frames_per_s']:.1f} | "
            f"{row['steps_per_s']:.1f} | {100 * row['cpu_share']:.0f}% |"
        )


if __name__ == "__main__":
    main()
