"""The soak prober's latencies in fixed memory: its percentiles are the exact ones to within 1 %."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from paramdds.bench._common import Latencies, percentile

LATENCIES_MS = st.lists(st.floats(min_value=1e-3, max_value=1e5), min_size=1, max_size=500)


@given(LATENCIES_MS, st.sampled_from([1, 50, 90, 99, 100]))
def test_a_percentile_is_the_nearest_rank_within_one_percent(values: list[float], q: int) -> None:
    kept = Latencies()
    for x in values:
        kept.add(x)
    exact = percentile(values, q)
    assert kept.percentile(q) == pytest.approx(exact, rel=0.01)
    assert (kept.n, kept.max) == (len(values), max(values))


def test_memory_is_buckets_not_samples() -> None:
    kept = Latencies()
    for i in range(100_000):
        kept.add(0.5 + (i % 1000) / 100)  # 0.5 to 10.5 ms, 1,000 distinct values
    assert kept.n == 100_000
    assert len(kept.counts) <= 310  # a 21-fold range in 1 % buckets: ln 21 / ln 1.01 = 306


def test_no_samples_is_an_error_not_a_figure() -> None:
    with pytest.raises(ValueError, match="no samples"):
        Latencies().percentile(50)
