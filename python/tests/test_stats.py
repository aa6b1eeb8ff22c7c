"""locsim.stats against the C++ sweep's numbers and known quantiles."""
import math

import pytest

import locsim
from locsim.stats import format_mean_ci, wilson_95


def test_t975_table_and_expansion():
    assert locsim.t975(0) == 0.0
    assert locsim.t975(1) == 12.706
    assert locsim.t975(19) == 2.093  # 20 seeds, the paper experiments' count
    # Beyond the table: the expansion, close to the exact quantiles (scipy: 2.0395, 1.9840, 1.9623).
    assert locsim.t975(31) == pytest.approx(2.0395, abs=2e-4)
    assert locsim.t975(100) == pytest.approx(1.9840, abs=1e-4)
    assert locsim.t975(1000) == pytest.approx(1.9623, abs=1e-4)
    # Continuous across the table's end and decreasing towards the normal quantile.
    values = [locsim.t975(d) for d in range(25, 200)]
    assert all(a >= b for a, b in zip(values, values[1:]))
    assert values[-1] > 1.95996


def test_aggregate_and_mean_ci():
    a = locsim.aggregate([1.0, 2.0, 4.0, float("nan")])  # NaN is a run without the number
    assert a.n == 3 and a.mean == pytest.approx(7 / 3) and a.median == 2.0
    sd = math.sqrt(((1 - 7 / 3) ** 2 + (2 - 7 / 3) ** 2 + (4 - 7 / 3) ** 2) / 2)
    assert a.ci95 == pytest.approx(4.303 * sd / math.sqrt(3))
    assert locsim.aggregate([5.0, 1.0, 3.0, 2.0]).median == 2.5
    assert locsim.mean_ci([3.0]) == (3.0, pytest.approx(math.nan, nan_ok=True))
    m, h = locsim.mean_ci([])
    assert math.isnan(m) and math.isnan(h)
    assert format_mean_ci([1.0, 2.0, 4.0], digits=2) == f"2.33 ± {4.303 * sd / math.sqrt(3):.2f}"
    assert format_mean_ci([]) == "—"


def test_wilson_interval():
    assert wilson_95(0, 0) == (0.0, 1.0)
    low, high = wilson_95(10, 10)
    assert high == pytest.approx(1.0) and 0.69 < low < 0.73  # not empty at n of n
    low, high = wilson_95(9, 20)
    assert low < 0.45 < high


def test_summary_csv_is_what_the_package_computes(small_sweep):
    """summary.csv (C++) and locsim.aggregate over results.csv (Python) agree: one CI formula."""
    results, summary = small_sweep.results, small_sweep.summary.set_index("config")
    assert list(summary.index) == ["odometry", "ekf"]
    for config, rows in results.groupby("config"):
        ok = rows[rows.status == "ok"]
        a = locsim.aggregate(ok.position_rms_m)
        assert a.n == 4
        assert summary.loc[config, "position_rms_m_mean"] == pytest.approx(a.mean, abs=2e-6)
        assert summary.loc[config, "position_rms_m_ci95"] == pytest.approx(a.ci95, abs=2e-6)
        assert summary.loc[config, "position_rms_m_median"] == pytest.approx(a.median, abs=2e-6)
