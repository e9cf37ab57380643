"""Tools around the environment: pictures and videos, the benchmark, the gait's tuning, human play, imports."""
