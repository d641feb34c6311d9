"""The one counting sort (granalytics.base.sorting): the simulator's cell sort and the ranking of
granules by size."""

import numpy as np
import pytest

from granalytics.base.sorting import counting_sort


@pytest.mark.parametrize("n, n_keys", [(0, 1), (1, 1), (1000, 1), (1000, 7), (5000, 4096), (300, 10_000)])
def test_the_order_is_numpys_stable_argsort_and_start_bounds_each_keys_run(n, n_keys):
    keys = np.random.default_rng(n + n_keys).integers(0, n_keys, n)
    order, start = counting_sort(keys, n_keys)
    assert order.dtype == start.dtype == np.int64
    assert np.array_equal(order, np.argsort(keys, kind="stable"))
    assert start.shape == (n_keys + 1,) and start[0] == 0 and start[-1] == n
    assert np.array_equal(np.diff(start), np.bincount(keys, minlength=n_keys))
    for k in np.unique(keys)[:50]:
        run = order[start[k]:start[k + 1]]
        assert (keys[run] == k).all() and (np.diff(run) > 0).all()  # equal keys in index order


def test_equal_keys_keep_their_order_whatever_the_key_type():
    keys = np.array([3, 1, 3, 0, 1, 3], dtype=np.int32)
    order, start = counting_sort(keys, 4)
    assert order.tolist() == [3, 1, 4, 0, 2, 5] and start.tolist() == [0, 1, 3, 3, 6]
