"""The diagnosis's faster routes give the numbers of the plain ones (issue 18, speed): to the
bit where the route only avoids a temporary, to rounding where the algebra changes. No timing
here (benchmarks/bench_diagnosis.py measures it)."""
import math

import numpy as np

from cyclo_fmu.diagnosis.problem import masked_means
from cyclo_fmu.diagnosis.residual import order_amplitudes


def test_block_counts_given_once_give_the_same_means():
    """Many columns share one mask: its counts per block, passed in, change no bit."""
    rng = np.random.default_rng(3)
    for m in (1, 10):
        for shape in [(m * 53 + 2,), (m * 53 + 2, 1), (m * 53, 3)]:
            x = rng.normal(size=shape)
            mask = rng.random(shape[0]) > 0.3
            mask[:2 * m] = False
            n = (shape[0] // m) * m
            counts = mask[:n].reshape(-1, m).sum(1)
            assert np.array_equal(masked_means(x, mask, m, counts), masked_means(x, mask, m))


def test_column_scales_are_numpys_to_the_bit():
    """The weighted sums of squares behind the Gram problem's and the robust fit's column
    scales (einsum, no n x k temporary) are numpy's, to the bit."""
    rng = np.random.default_rng(4)
    X = rng.normal(size=(6001, 9)) * 10.0 ** rng.integers(-6, 3, size=9)
    w = rng.random(6001)
    assert np.array_equal(np.einsum("i,ij,ij->j", w, X, X), (w[:, None] * X * X).sum(0))
    assert np.array_equal(np.einsum("ij,ij->j", X, X) / len(X), (X * X).mean(0))


def _orders_case(turns, amplitude, k=14.0, n=20000, noise=1e-3, seed=0):
    rng = np.random.default_rng(seed)
    dt = 1e-3
    theta = np.linspace(0.0, 2 * math.pi * turns, n)
    w = np.gradient(theta, dt)
    r = amplitude * np.sin(k * theta + 0.3) + 2e-4 + noise * rng.normal(size=n)
    return r, {"theta_in": theta, "w_in": w}, dt


def test_order_amplitude_is_the_least_squares_of_its_sine_and_cosine():
    """The normal equations of (1, sin, cos) give the SVD least squares of the sample-level
    columns (to rounding), many turns or a fraction of one; and a known amplitude is found
    within its standard error."""
    for turns, k in ((300.0, 14.0), (0.3, 1.0)):
        r, sig, dt = _orders_case(turns, 2e-3, k=k)
        got = order_amplitudes(r, sig, {"o": k}, dt)["o"]
        th = sig["theta_in"]
        B = np.stack([np.ones_like(th), np.sin(k * th), np.cos(k * th)], -1)
        coef = np.linalg.lstsq(B, r, rcond=None)[0]
        ref_a = math.hypot(coef[1], coef[2])
        ref_se = float(np.std(r - B @ coef)) * math.sqrt(2.0 / len(r))
        assert abs(got[0] - ref_a) <= 1e-9 * ref_a
        assert abs(got[1] - ref_se) <= 1e-9 * ref_se
        if turns > 10:
            assert abs(got[0] - 2e-3) < 4 * got[1]


def test_releasing_the_free_heap_leaves_the_allocator_alone_when_asked(monkeypatch):
    """The diagnosis hands free heap pages back between stages (glibc only); with
    CYCLO_FMU_KEEP_MALLOC set nothing is touched."""
    from cyclo_fmu.slaves import heap
    monkeypatch.setenv("CYCLO_FMU_KEEP_MALLOC", "1")
    assert heap.release_free_heap() is False
