"""Solving each distinct contact problem once (issue 8, item 8) gives the results of the
straightforward per-position path (losses.partial_losses(..., dedup=False)) to 1e-12 relative."""
import dataclasses

import numpy as np
import pytest

from model_core import DriveDesign, losses


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_distinct_problems_match_reference(seed):
    rng = np.random.default_rng(seed)
    d = DriveDesign()
    d = dataclasses.replace(
        d, delta_z=float(rng.uniform(0, 2e-5)), contact_law=str(rng.choice(["hertz", "linear"])),
        torque_share=float(rng.choice([0.5, rng.uniform(0.3, 0.7)])),
        profile_modification=str(rng.choice(["equidistant", "offset"])))
    T = rng.uniform(0.0, 200.0, 40)
    W = rng.uniform(-300.0, 300.0, 40)
    a = losses.partial_losses(d, T, W, dedup=True)
    b = losses.partial_losses(d, T, W, dedup=False)
    for n in losses.LOSS_NAMES:
        x, y = getattr(a, n), getattr(b, n)
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=0.0, err_msg=n)


def test_default_design_has_few_distinct_problems():
    from model_core import contact
    d = DriveDesign()
    psi_r, ri, psi_d, di = losses._mesh_entries(d, None, (0, 1), True)
    assert psi_r.size < ri.size and psi_d.size < di.size
