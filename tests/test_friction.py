"""Friction laws: Benedict-Kelley value and clamps, SKF moment scaling, rolling/sliding losses."""
import numpy as np
import pytest

from model_core import Friction
from model_core.friction import benedict_kelley_mu, skf_frictional_moment


def test_benedict_kelley_reference_value():
    # 200 N on 12 mm, eta = 0.18 Pa*s, V_s = 0.1, V_r = 0.5 m/s, smooth surfaces (C_R = 1)
    mu = benedict_kelley_mu(200 / 0.012, 0.18, 0.1, 0.5, 0.0, 1.0, 0.0)
    assert mu == pytest.approx(0.0127 * np.log10(0.02966 * 200 / 0.012 / (0.18 * 0.1 * 0.25)), rel=1e-12)
    assert mu == pytest.approx(0.064, abs=1e-3)


def test_benedict_kelley_trends_and_clamps():
    base = dict(eta=0.18, v_slide=0.1, v_sum=0.5, roughness=0.5e-6, mu_boundary=0.5, mu_full_film=0.0)
    mu = lambda **kw: float(benedict_kelley_mu(**{"load_per_width": 1e4, **base, **kw}))
    assert mu(load_per_width=2e4) > mu()                       # rises with load
    assert mu(v_slide=0.2) < mu() and mu(v_sum=1.0) < mu()      # falls with speed
    assert mu(eta=0.36) < mu()                                  # falls with viscosity
    assert mu(roughness=1.0e-6) > mu()                          # rises with roughness
    assert mu(v_slide=0.0) == 0.5                               # diverges -> boundary value
    assert mu(roughness=2e-6) == 0.5                            # beyond the 50 uin pole
    assert mu(v_slide=1e3, v_sum=1e3, mu_full_film=0.01) == 0.01   # negative -> full film


def test_skf_moment_scaling():
    fr = Friction()
    M1 = skf_frictional_moment(100.0, 100.0, 0.025, 0.032, 200e-6, fr)
    M2 = skf_frictional_moment(200.0, 100.0, 0.025, 0.032, 200e-6, fr)
    assert 1.0 < M2 / M1 < 2.0          # M_rr ~ F^0.31, M_sl ~ F
    fr0 = Friction(skf_S2=0.0)
    r = skf_frictional_moment(200.0, 100.0, 0.025, 0.032, 200e-6, fr0) / \
        skf_frictional_moment(100.0, 100.0, 0.025, 0.032, 200e-6, fr0)
    assert r == pytest.approx(2 ** 0.31, rel=1e-12)
    assert skf_frictional_moment(0.0, 100.0, 0.025, 0.032, 200e-6, fr) == 0.0
    assert skf_frictional_moment(100.0, 0.0, 0.025, 0.032, 200e-6, fr) > 0  # M_sl at rest
