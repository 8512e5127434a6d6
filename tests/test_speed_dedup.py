"""Solving each distinct contact problem once (the fast path) gives the straightforward
per-position path's losses: random designs, torques, speeds and both torque shares."""
from dataclasses import replace

import numpy as np
import pytest

from model_core import DriveDesign
from model_core.losses import partial_losses, partial_losses_by_position

FIELDS = ("PL1", "PL2", "PL3", "PL5", "PL6")


def _designs():
    rng = np.random.default_rng(5)
    base = DriveDesign()
    yield base
    yield replace(base, torque_share=0.6)
    for _ in range(3):
        z1 = int(rng.integers(9, 25))
        k = int(rng.integers(4, 10))
        yield replace(base, z1=z1, n_disc_rollers=k, n_positions=int(rng.integers(4, 10)))


@pytest.mark.parametrize("design", list(_designs()))
def test_fast_path_equals_the_straightforward_one(design):
    rng = np.random.default_rng(1)
    T1 = rng.uniform(1.0, 12.0, 7)
    w2 = rng.uniform(-300.0, 300.0, 7)
    fast = partial_losses(design, T1, w2)
    slow = partial_losses(design, T1, w2, dedup=False)
    for f in FIELDS:
        a, b = np.asarray(getattr(fast, f)), np.asarray(getattr(slow, f))
        np.testing.assert_allclose(a, b, rtol=1e-11, atol=1e-12 * np.max(np.abs(b)) + 1e-300)
    _, by_fast = partial_losses_by_position(design, T1[:2], w2[:2])
    _, by_slow = partial_losses_by_position(design, T1[:2], w2[:2], dedup=False)
    for f in FIELDS:
        np.testing.assert_allclose(getattr(by_fast, f), getattr(by_slow, f), rtol=1e-11,
                                   atol=1e-300)
