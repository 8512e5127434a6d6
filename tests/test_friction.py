"""Friction laws: Benedict-Kelley value and clamps, SKF moment scaling, rolling/sliding losses."""
import numpy as np
import pytest

from model_core import Friction
from model_core.friction import benedict_kelley_mu, skf_frictional_moment


def test_benedict_kelley_reference_value():
    # 200 N on 12 mm, eta = 0.18 Pa*s, V_s = 0.1, V_r = 0.5 m/s, smooth surfaces (C_R = 1)
    mu = benedict_kelley_mu(200 / 0.012, 0.18, 0.1, 0.5, 0.0, 1.0, 0.0)
    # the original's US units: W' in lb/in, eta in cP, speeds in in/s, constant 3.17e8
    w_lb_in = 200 / 4.4482216 / (12 / 25.4)
    arg_us = 3.17e8 * w_lb_in / (180.0 * (0.1 / 0.0254) * (0.5 / 0.0254) ** 2)
    assert mu == pytest.approx(0.0127 * np.log10(arg_us), rel=1e-4)
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
    # absolute value, by hand in the catalogue's units: F_r = 100 N, n = 1000 r/min,
    # d = 25, D = 32 mm, nu = 200 mm^2/s: M_rr = 0.9732 * 0.6617 * 0.014551 * 1516 N*mm,
    # M_sl = 0.0015 * 28.5 * 100 * 0.02 N*mm  ->  about 14.29 N*mm
    M = skf_frictional_moment(100.0, 1000 * np.pi / 30, 0.025, 0.032, 200e-6, fr)
    assert M * 1e3 == pytest.approx(14.29, rel=5e-3)
    assert skf_frictional_moment(100.0, 0.0, 0.025, 0.032, 200e-6, fr) > 0  # M_sl at rest
