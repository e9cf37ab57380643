"""Seed ranges: training draws from TRAIN_SEEDS only; RESERVED_SEEDS are kept for evaluation."""
from __future__ import annotations

TRAIN_SEEDS = range(0, 1288490240)
RESERVED_SEEDS = range(1288490240, 1717986944)
