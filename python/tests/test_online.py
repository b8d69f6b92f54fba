"""imunoise.Online: snapshots of samples fed in chunks equal imunoise.avar of all of them."""

import numpy as np
import pytest

import imunoise

# the online and batch estimates sum the same squared differences in a different order (both
# compensated): ~1e-15 relative each; the Rust tests check 10^7 samples at 1e-12
TOL = 1e-12
# the chi-square interval's noise identification comes from running moments of the cluster
# means instead of the means themselves (avar's tests/online.rs: the same bound)
TOL_CI = 1e-7


def _data(n, seed):
    rng = np.random.default_rng(seed)
    return rng.normal(size=n) + np.cumsum(1e-2 * rng.normal(size=n)) + 3.0


def test_chunks_equal_the_batch_estimate_at_checkpoints():
    x = _data(60_000, 1)
    on = imunoise.Online(rate=50.0, tau_max=1e6)
    rng = np.random.default_rng(7)
    at = 0
    for cp in (10_000, 35_000, 60_000):
        while at < cp:
            k = min(int(rng.integers(1, 5_000)), cp - at)
            on.update(x[at : at + k])
            at += k
        live, batch = on.snapshot(), imunoise.avar(x[:cp], rate=50.0)
        assert on.n == cp == live.n
        assert live.m.tolist() == batch.m.tolist()
        np.testing.assert_allclose(live.avar, batch.avar, rtol=TOL, atol=0)
        np.testing.assert_allclose(live.lo, batch.lo, rtol=TOL_CI, atol=0)
        np.testing.assert_allclose(live.hi, batch.hi, rtol=TOL_CI, atol=0)


def test_two_channels_and_memory_flat_in_the_length():
    x = np.column_stack([_data(40_000, 2), _data(40_000, 3)])
    on = imunoise.Online(rate=100.0, channels=2, tau_max=10.0, names=["gx", "gy"])
    on.update(x[:10_000])
    before = on.heap_bytes()
    on.update(x[10_000:])
    assert on.heap_bytes() == before
    live = on.snapshot()
    assert [r.name for r in live] == ["gx", "gy"]
    for j in range(2):
        batch = imunoise.avar(x[:, j], rate=100.0)
        k = len(live[j])  # the scales up to tau_max = 10 s: m <= 1000
        assert live[j].m.max() <= 1000 and k < len(batch)
        np.testing.assert_allclose(live[j].avar, batch.avar[:k], rtol=TOL, atol=0)


def test_bad_input_changes_nothing():
    on = imunoise.Online(rate=10.0)
    on.update(np.arange(10.0))
    with pytest.raises(imunoise.EstimationError):
        on.update(np.array([1.0, np.nan]))
    assert on.n == 10
    with pytest.raises(imunoise.UsageError):
        on.update(np.zeros((5, 2)))
    with pytest.raises(imunoise.UsageError):
        imunoise.Online(rate=10.0, ci="gaussian")
