"""The order in which one participant plays a study's battery.

``fixed``: the file's order for everyone. ``random``: a permutation drawn from the participant's
own order seed (recorded in the store, so the order is reproducible from it). ``counterbalanced``:
row ``index mod n`` of a balanced Latin square over the n battery trials (Williams design: each
trial is in each position once per n participants, and for even n follows every other trial once).
Practice trials always come first, in the file's order.
"""

from __future__ import annotations

import numpy as np

from aaai.errors import ConfigError

ORDERS = ("fixed", "random", "counterbalanced")


def latin_square_row(n: int, row: int) -> list[int]:
    """Row ``row`` (mod n, or mod 2n for odd n: the mirrored square follows) of a balanced Latin square
    of order n: 0, 1, n-1, 2, n-2, ... shifted by the row."""
    base, low, high = [0], 1, n - 1
    while len(base) < n:
        base.append(low)
        low += 1
        if len(base) < n:
            base.append(high)
            high -= 1
    row %= 2 * n if n % 2 else n
    shifted = [(value + row) % n for value in base]
    return shifted[::-1] if row >= n else shifted


def battery_order(mode: str, n: int, index: int, seed: int) -> list[int]:
    """The battery positions' trial numbers (0 to n-1) for participant number ``index`` (0, 1, ...)
    with order seed ``seed``."""
    if mode == "fixed":
        return list(range(n))
    if mode == "random":
        return [int(i) for i in np.random.default_rng(seed).permutation(n)]
    if mode == "counterbalanced":
        return latin_square_row(n, index)
    raise ConfigError(f"order: got {mode!r}; allowed: {', '.join(ORDERS)}")


__all__ = ["ORDERS", "battery_order", "latin_square_row"]
