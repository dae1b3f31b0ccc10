"""The radix stable order (lidar_sig.numerics.sorting) is numpy's stable argsort, element for
element, whatever the keys' width, ties and size."""
import numpy as np
import pytest

from lidar_sig.numerics.sorting import stable_order


def _cases():
    rng = np.random.default_rng(7)
    n = 20_000
    yield "empty", np.zeros(0, np.int64)
    yield "one", np.array([5])
    yield "few wide keys", rng.integers(0, 2**40, 100)
    yield "16-bit range", rng.integers(0, 3000, n)
    yield "just past 16 bits", rng.integers(0, 40_000, n)
    yield "many ties", rng.integers(0, 4, n) * 2**35 + 7
    yield "voxel keys", rng.integers(0, 2**27, n)
    yield "int32 cells", rng.integers(100_000, 100_300, n).astype(np.int32)
    hashes = rng.integers(0, 2**63, n, dtype=np.uint64) * np.uint64(2) + rng.integers(0, 2, n).astype(np.uint64)
    hashes[::3] = hashes[1::3][:len(hashes[::3])]  # repeats, and the top bit set in about half
    yield "unsigned 64-bit hashes", hashes


@pytest.mark.parametrize("name, keys", list(_cases()), ids=[c[0] for c in _cases()])
def test_the_radix_order_is_numpys_stable_argsort(name, keys):
    assert np.array_equal(stable_order(keys), np.argsort(keys, kind="stable"))


def test_a_field_of_records_sorts_as_its_copy():
    rec = np.zeros(10_000, [("cell", "i4"), ("key", "u8")])
    rec["key"] = np.random.default_rng(1).integers(0, 2**64 - 1, len(rec), dtype=np.uint64)
    assert np.array_equal(stable_order(rec["key"]), np.argsort(rec["key"].copy(), kind="stable"))
