"""The statistics of a comparison of samplers: before, how many training seeds and reserved episodes
it needs (``aaai experiment power``); after, intervals and tests of the differences (its table).

A run's reserved pass rate varies for two reasons: the training seed (the run learns more or less),
and the reserved episodes it is scored on (a finite sample of each cell's seeds). From an experiment's
runs.csv (and its runs' reserved scoreboards, when the folders are there) this module splits the
observed between-run variance into those two parts:

- observed: the pooled sample variance of the runs' reserved pass rates within each sampler;
- binomial: the variance of a pass rate measured on K episodes per cell, with each cell's pass
  probability estimated from the run's own scoreboard (a stratified mean over cells); without the
  scoreboards, p (1 - p) / n of the run's pass rate (larger: it ignores that cells differ);
- seed: observed minus binomial (at least 0), the part more reserved episodes cannot remove.

The number of seeds per sampler a difference needs is that of a two-sided two-sample t test
(Welch's, with equal sizes and variances, has the same degrees of freedom 2n - 2): the smallest n
with power >= the goal, from the noncentral t distribution (scipy.stats.nct). The standard
deviation per run at K episodes per cell is sqrt(seed + binomial x K0 / K), K0 the experiment's K.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aaai.config import ConfigError

ALPHA = 0.05
POWER = 0.8
DIFFERENCE = 10.0  # points of reserved pass rate
MAX_SEEDS = 10_000


@dataclass
class Variance:
    """The variance parts of a run's reserved pass rate, in points (percent) squared."""

    samplers: dict[str, list[float]]  # sampler -> reserved pass rates of its runs (%)
    seeds_per_cell: int  # K of the experiment's reserved scoreboards
    cells: int
    observed: float  # pooled within-sampler variance of the runs' pass rates
    binomial: float  # the part from scoring K episodes per cell
    stratified: bool  # binomial part from per-cell scoreboards (else from p (1 - p) / n)

    @property
    def df(self) -> int:
        """Degrees of freedom of the pooled variance: runs minus samplers."""
        return sum(len(v) - 1 for v in self.samplers.values() if len(v) > 1)

    @property
    def seed(self) -> float:
        return max(0.0, self.observed - self.binomial)

    def sd(self, seeds_per_cell: int, seed_variance: float | None = None) -> float:
        """Standard deviation of a run's pass rate scored on ``seeds_per_cell`` episodes per cell."""
        seed = self.seed if seed_variance is None else seed_variance
        return math.sqrt(seed + self.binomial * self.seeds_per_cell / seeds_per_cell)

    def seed_variance_upper(self, confidence: float = 0.8) -> float:
        """An upper ``confidence`` bound of the seed variance: the observed variance's chi-square bound
        (df degrees of freedom) minus the binomial part. Few runs make the estimate itself uncertain."""
        from scipy import stats

        if self.df < 1:
            return math.nan
        upper = self.observed * self.df / float(stats.chi2.ppf(1.0 - confidence, self.df))
        return max(0.0, upper - self.binomial)


def t_test_power(n: int, effect: float, alpha: float = ALPHA) -> float:
    """Power of a two-sided two-sample t test with ``n`` runs per group at standardized ``effect``
    (difference / standard deviation)."""
    from scipy import stats

    if n < 2:
        return 0.0
    df = 2 * n - 2
    critical = float(stats.t.ppf(1.0 - alpha / 2.0, df))
    shift = effect * math.sqrt(n / 2.0)
    return float(stats.nct.sf(critical, df, shift) + stats.nct.cdf(-critical, df, shift))


def seeds_needed(difference: float, sd: float, alpha: float = ALPHA, power: float = POWER) -> int:
    """The fewest runs per sampler for which the t test finds ``difference`` with ``power``."""
    if not sd > 0:
        return 2
    effect = difference / sd
    n = 2
    while t_test_power(n, effect, alpha) < power:
        n += 1
        if n > MAX_SEEDS:
            return MAX_SEEDS
    return n


def normal_seeds(difference: float, sd: float, alpha: float = ALPHA, power: float = POWER) -> float:
    """The closed-form (normal) approximation: 2 (z_{1-alpha/2} + z_power)^2 / effect^2 runs per group."""
    from scipy import stats

    z = float(stats.norm.ppf(1 - alpha / 2) + stats.norm.ppf(power))
    return 2 * z * z * (sd / difference) ** 2


def detectable(n: int, sd: float, alpha: float = ALPHA, power: float = POWER) -> float:
    """The smallest difference (points) that ``n`` runs per sampler find with ``power``."""
    if n < 2 or not sd > 0:
        return math.nan
    low, high = 0.0, sd
    while t_test_power(n, high / sd, alpha) < power:
        low, high = high, 2 * high
    for _ in range(60):
        middle = (low + high) / 2
        if t_test_power(n, middle / sd, alpha) >= power:
            high = middle
        else:
            low = middle
    return high


# --- after the runs: intervals and tests ---------------------------------------------------------
RESAMPLES = 10_000  # bootstrap and permutation draws
CONFIDENCE = 0.95


def mean_interval(values: list[float], confidence: float = CONFIDENCE) -> tuple[float, float, float]:
    """Mean and its two-sided t interval over ``values`` (NaN bounds with fewer than 2)."""
    from scipy import stats

    x = np.asarray(values, dtype=float)
    if len(x) == 0:
        return math.nan, math.nan, math.nan
    mean = float(x.mean())
    if len(x) < 2:
        return mean, math.nan, math.nan
    half = float(stats.t.ppf(0.5 + confidence / 2, len(x) - 1)) * float(x.std(ddof=1)) / math.sqrt(len(x))
    return mean, mean - half, mean + half


def _welch_terms(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """The squared standard errors of the two means and their Welch-Satterthwaite degrees of freedom
    (NaN when neither side has any spread)."""
    va, vb = float(x.var(ddof=1)) / len(x), float(y.var(ddof=1)) / len(y)
    if va + vb == 0:
        return va, vb, math.nan
    return va, vb, (va + vb) ** 2 / (va**2 / (len(x) - 1) + vb**2 / (len(y) - 1))


def welch(a: list[float], b: list[float]) -> tuple[float, float, float]:
    """Welch's t test of mean(a) - mean(b): (t, degrees of freedom, two-sided p); NaN with fewer than
    2 values on a side. Two groups without any spread give t = ±inf (p = 0) or NaN (equal means)."""
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if len(x) < 2 or len(y) < 2:
        return math.nan, math.nan, math.nan
    from scipy import stats

    va, vb, df = _welch_terms(x, y)
    if va + vb == 0:
        difference = x.mean() - y.mean()
        return (math.copysign(math.inf, difference), math.nan, 0.0) if difference else (math.nan, math.nan, math.nan)
    result = stats.ttest_ind(x, y, equal_var=False)
    return float(result.statistic), float(df), float(result.pvalue)


def welch_interval(a: list[float], b: list[float], confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Welch's two-sided ``confidence`` interval of mean(a) - mean(b), on the degrees of freedom of
    :func:`welch`: NaN bounds with fewer than 2 values on a side, or when neither side has any spread
    (there is nothing to build it from; :class:`aaai.tools.compare.RunsComparison` then counts the
    episodes' chance instead)."""
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if len(x) < 2 or len(y) < 2:
        return math.nan, math.nan
    difference = float(x.mean() - y.mean())
    va, vb, df = _welch_terms(x, y)
    if va + vb == 0:
        return math.nan, math.nan
    from scipy import stats

    half = float(stats.t.ppf(0.5 + confidence / 2, df)) * math.sqrt(va + vb)
    return difference - half, difference + half


def anova(groups: list[list[float]]) -> tuple[float, float]:
    """One-way ANOVA over the groups with 2 or more values: (F, p); NaN with fewer than 2 such groups."""
    kept = [np.asarray(g, dtype=float) for g in groups if len(g) > 1]
    if len(kept) < 2 or all(g.var() == 0 for g in kept):
        return math.nan, math.nan
    from scipy import stats

    result = stats.f_oneway(*kept)
    return float(result.statistic), float(result.pvalue)


def f_statistic(values: np.ndarray, labels: np.ndarray, groups: int) -> float:
    means = np.array([values[labels == g].mean() for g in range(groups)])
    sizes = np.array([(labels == g).sum() for g in range(groups)])
    between = float((sizes * (means - values.mean()) ** 2).sum()) / (groups - 1)
    within = float(sum(((values[labels == g] - means[g]) ** 2).sum() for g in range(groups))) / (len(values) - groups)
    return between / within if within > 0 else math.inf


def permutation_anova(groups: list[list[float]], resamples: int = RESAMPLES, seed: int = 0) -> float:
    """The permutation p of the ANOVA's F: the share of relabellings of the runs (``resamples``,
    from a generator seeded with ``seed``, the observed labelling counted once) with F at least
    the observed. It does not assume normal pass rates."""
    kept = [list(map(float, g)) for g in groups if len(g) > 1]
    if len(kept) < 2:
        return math.nan
    values = np.concatenate([np.asarray(g) for g in kept])
    labels = np.concatenate([np.full(len(g), i) for i, g in enumerate(kept)])
    observed = f_statistic(values, labels, len(kept))
    if math.isnan(observed):
        return math.nan
    rng = np.random.default_rng(seed)
    hits = sum(f_statistic(values, rng.permutation(labels), len(kept)) >= observed - 1e-12 for _ in range(resamples))
    return (hits + 1) / (resamples + 1)


def bootstrap_difference(
    a: list[float], b: list[float], resamples: int = RESAMPLES, seed: int = 0, confidence: float = CONFIDENCE
) -> tuple[float, float]:
    """The percentile bootstrap interval of mean(a) - mean(b), resampling the runs of each side."""
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if len(x) < 2 or len(y) < 2:
        return math.nan, math.nan
    rng = np.random.default_rng(seed)
    means_a = x[rng.integers(0, len(x), (resamples, len(x)))].mean(axis=1)
    means_b = y[rng.integers(0, len(y), (resamples, len(y)))].mean(axis=1)
    low, high = np.quantile(means_a - means_b, [0.5 - confidence / 2, 0.5 + confidence / 2])
    return float(low), float(high)


# --- reading an experiment ------------------------------------------------------------------
def read_rows(path: Path) -> list[dict]:
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def cell_variance(board: list[dict]) -> tuple[float, int, int]:
    """The binomial variance (points squared) of a scoreboard's pass rate as a mean over its cells,
    each cell's p (1 - p) estimated without bias (times k / (k - 1)); with its cells and K."""
    cells: dict[tuple[str, str], list[bool]] = {}
    for row in board:
        cells.setdefault((row["level"], row["difficulty"]), []).append(row["outcome"] != "failed")
    total, smallest = 0.0, min((len(v) for v in cells.values()), default=0)
    for passed in cells.values():
        k, p = len(passed), float(np.mean(passed))
        unbiased = p * (1 - p) * k / (k - 1) if k > 1 else p * (1 - p)
        total += unbiased / k
    return 1e4 * total / len(cells) ** 2, len(cells), smallest


def variance(folder: str | Path) -> Variance:
    """The variance parts of the experiment in ``folder`` (its runs.csv; its runs' scoreboard_reserved.csv
    when present)."""
    folder = Path(folder)
    path = folder / "runs.csv"
    if not path.is_file():
        raise ConfigError(f"--from: {str(folder)!r} has no runs.csv; allowed: a folder of `aaai experiment curricula`")
    rows = [r for r in read_rows(path) if r.get("reserved_pass_pct") not in ("", "nan", None)]
    if not rows:
        raise ConfigError(f"--from: {str(path)!r} holds no scored run")
    samplers: dict[str, list[float]] = {}
    for row in rows:
        samplers.setdefault(row["sampler"], []).append(float(row["reserved_pass_pct"]))
    groups = [v for v in samplers.values() if len(v) > 1]
    if not groups:
        raise ConfigError(f"--from: {str(path)!r} has no sampler with 2 or more runs: no variance between seeds")
    df = sum(len(v) - 1 for v in groups)
    observed = sum(float(np.var(v, ddof=1)) * (len(v) - 1) for v in groups) / df
    parts, cells, k = [], 0, 0
    for row in rows:
        board = folder / f"{row['sampler']}-seed{row['seed']}" / "scoreboard_reserved.csv"
        if board.is_file():
            part, cells, k = cell_variance(read_rows(board))
            parts.append(part)
    if parts and len(parts) == len(rows):
        return Variance(samplers, k, cells, observed, float(np.mean(parts)), stratified=True)
    record = folder / "experiment.yaml"
    k = 0
    if record.is_file():
        from aaai import safe_yaml

        k = int(safe_yaml.load_mapping(record, "experiment record").get("seeds_per_cell") or 0)
    episodes = [float(r["reserved_episodes"]) for r in rows]
    cells = round(np.mean(episodes) / k) if k else 0
    binomial = float(
        np.mean([p * (100 - p) / n for p, n in zip(map(float, (r["reserved_pass_pct"] for r in rows)), episodes)])
    )
    return Variance(samplers, k, cells, observed, binomial, stratified=False)


def report(
    source: str | Path,
    difference: float = DIFFERENCE,
    alpha: float = ALPHA,
    power: float = POWER,
    per_cell: tuple[int, ...] = (5, 10, 20, 40),
    seeds: tuple[int, ...] = (3, 5, 8, 10),
) -> str:
    """The power analysis of the experiment in ``source`` as markdown."""
    v = variance(source)
    from scipy import __version__ as scipy_version

    means = ", ".join(f"{s} {np.mean(x):.1f} ({len(x)} runs)" for s, x in v.samplers.items())
    upper = v.seed_variance_upper()
    binomial_how = (
        f"from each run's per-cell pass rates (stratified over its {v.cells} cells, p (1 - p) k / (k - 1) per cell)"
        if v.stratified
        else "from p (1 - p) / n of each run's pass rate (the scoreboards were not there; an upper bound)"
    )
    lines = [
        f"# Power of a comparison of samplers, from {source}",
        "",
        f"Reserved pass rates (mean per sampler): {means}; {v.cells} cells, K = {v.seeds_per_cell} reserved episodes "
        f"per cell, {v.cells * v.seeds_per_cell} per run.",
        "",
        "| part of a run's variance | variance (points²) | standard deviation (points) |",
        "|---|---:|---:|",
        f"| observed between runs of a sampler (pooled, {v.df} degrees of freedom) | {v.observed:.1f} "
        f"| {math.sqrt(v.observed):.1f} |",
        f"| binomial: scoring K = {v.seeds_per_cell} episodes per cell, {binomial_how} | {v.binomial:.1f} "
        f"| {math.sqrt(v.binomial):.1f} |",
        f"| seed: observed minus binomial | {v.seed:.1f} | {math.sqrt(v.seed):.1f} |",
        f"| seed, upper 80 % bound (chi-square on {v.df} degrees of freedom) | {upper:.1f} | {math.sqrt(upper):.1f} |",
        "",
        f"Seeds per sampler for a difference of {difference:g} points, two-sided t test (Welch's with equal sizes "
        f"and variances), alpha {alpha:g}, power {power:g}; scipy {scipy_version} (scipy.stats.nct). "
        "In brackets: the same with the seed variance at its upper 80 % bound.",
        "",
        "| reserved episodes per cell (per run) | sd of a run (points) | seeds per sampler | normal approximation "
        + "".join(f"| difference found with {n} seeds " for n in seeds)
        + "|",
        "|---|---:|---:|---:" + "|---:" * len(seeds) + "|",
    ]
    for k in per_cell:
        sd, sd_upper = v.sd(k), v.sd(k, upper)
        lines.append(
            f"| {k} ({k * v.cells}) | {sd:.1f} [{sd_upper:.1f}] | {seeds_needed(difference, sd, alpha, power)} "
            f"[{seeds_needed(difference, sd_upper, alpha, power)}] | {normal_seeds(difference, sd, alpha, power):.1f} "
            + "".join(
                f"| {detectable(n, sd, alpha, power):.1f} [{detectable(n, sd_upper, alpha, power):.1f}] " for n in seeds
            )
            + "|"
        )
    lines += [
        "",
        f"More reserved episodes remove only the binomial part: with every cell's reserved seeds (K → ∞) a run's "
        f"sd is {math.sqrt(v.seed):.1f} points [{math.sqrt(upper):.1f}], and "
        f"{seeds_needed(difference, math.sqrt(v.seed), alpha, power) if v.seed > 0 else 2} "
        f"[{seeds_needed(difference, math.sqrt(upper), alpha, power) if upper > 0 else 2}] seeds per sampler are "
        "still needed. The variance was measured at this experiment's budget; a longer run may vary more or less "
        "between seeds, so the larger experiment's own runs.csv is the check (re-run this command on it).",
    ]
    return "\n".join(lines) + "\n"
