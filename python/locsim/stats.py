"""The statistics locsim's sweeps report, the same numbers in Python as in C++.

`t975`, `aggregate` and `wilson_95` are ports of sim/experiments/statistics.cpp and sweep.cpp's
`wilson_95`: summary.csv, summary.md, report.md and the paper tables all quote one confidence
interval (Student's t over the seeds), and tests/python check the ports against summary.csv.
"""

import math
from dataclasses import dataclass

# Student's t, two-sided 97.5 % quantile, exact to 3 decimals for 1..30 degrees of freedom.
_T975 = (12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
         2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
         2.052, 2.048, 2.045, 2.042)
_Z975 = 1.959963984540054  # the normal's 97.5 % quantile


def t975(dof):
    """The 97.5 % quantile of Student's t with `dof` degrees of freedom (0 for none): the table to
    30, beyond it the Cornish-Fisher expansion around the normal quantile (error below 1e-4)."""
    dof = int(dof)
    if dof <= 0:
        return 0.0
    if dof <= 30:
        return _T975[dof - 1]
    z, n = _Z975, float(dof)
    return z + (z**3 + z) / (4 * n) + (5 * z**5 + 16 * z**3 + 3 * z) / (96 * n * n)


@dataclass(frozen=True)
class Aggregate:
    """Mean, half-width of its 95 % confidence interval (mean ± ci95; 0 for n < 2) and median of
    n values, as summary.csv reports them."""

    n: int = 0
    mean: float = 0.0
    ci95: float = 0.0
    median: float = 0.0


def _finite(values):
    out = []
    for v in values:
        v = float(v)
        if math.isfinite(v):
            out.append(v)
    return out


def aggregate(values):
    """`Aggregate` of the finite values among `values` (NaN, None-turned-NaN and inf are left
    out, as the sweep leaves out runs without the number)."""
    v = sorted(_finite(values))
    n = len(v)
    if n == 0:
        return Aggregate()
    mean = math.fsum(v) / n
    ci95 = 0.0
    if n > 1:
        sd = math.sqrt(math.fsum((x - mean) ** 2 for x in v) / (n - 1))
        ci95 = t975(n - 1) * sd / math.sqrt(n)
    median = v[n // 2] if n % 2 == 1 else 0.5 * (v[n // 2 - 1] + v[n // 2])
    return Aggregate(n, mean, ci95, median)


def mean_ci(values):
    """(mean, half-width of its 95 % CI by Student's t) of the finite `values`: (nan, nan) for
    none, (mean, nan) for one (no spread to judge)."""
    a = aggregate(values)
    if a.n == 0:
        return math.nan, math.nan
    return a.mean, (a.ci95 if a.n > 1 else math.nan)


def format_mean_ci(values, digits=3, scale=1.0):
    """'mean ± half' of `values` × `scale` to `digits` decimals; only the mean for one value and
    '—' for none, the way the reports' tables write it."""
    mean, half = mean_ci([float(v) * scale for v in values])
    if math.isnan(mean):
        return "—"
    if math.isnan(half):
        return f"{mean:.{digits}f}"
    return f"{mean:.{digits}f} ± {half:.{digits}f}"


def wilson_95(k, n):
    """Wilson's 95 % interval (low, high) of the proportion k/n: it stays within [0, 1] and is not
    empty at 0 or n; (0, 1) for n = 0."""
    if n == 0:
        return 0.0, 1.0
    z, nn = _Z975, float(n)
    p = k / nn
    centre = (p + z * z / (2 * nn)) / (1 + z * z / nn)
    half = z / (1 + z * z / nn) * math.sqrt(p * (1 - p) / nn + z * z / (4 * nn * nn))
    return max(0.0, centre - half), min(1.0, centre + half)
