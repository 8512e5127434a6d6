"""The diagnosis's faster routes give the numbers of the plain ones (issue 18, speed): to the
bit where the route only avoids a temporary, to rounding where the algebra changes. No timing
here (benchmarks/bench_diagnosis.py measures it)."""
import math

import numpy as np
import pytest

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


def test_first_order_low_pass_is_lfilters_to_the_bit():
    """The transducer's low pass runs scipy.signal.lfilter's own kernel (loaded without the
    package): the same numbers, one column or several, at several sampling rates."""
    from scipy.signal import lfilter
    from cyclo_fmu.diagnosis.replay import first_order
    rng = np.random.default_rng(6)
    for dt in (1e-2, 1e-3, 2e-4, 1e-4):
        a = math.exp(-2 * math.pi * 1000.0 * dt)
        for shape in [(5000,), (5000, 1), (5000, 3)]:
            x = rng.normal(size=shape)
            ref = lfilter([1 - a], [1, -a], x, axis=0, zi=a * x[:1])[0]
            assert np.array_equal(first_order(x, dt, 1000.0), ref)


def test_spectrogram_is_scipys_to_the_bit():
    from scipy.signal import spectrogram
    from cyclo_fmu.diagnosis.residual import hann_spectrogram
    rng = np.random.default_rng(7)
    for n, fs in ((20000, 1000.0), (9001, 333.3), (12000, 200.0)):
        x = rng.normal(size=n) * 1e-3
        nper = int(round(2.0 * fs))
        f0, _, S0 = spectrogram(x, fs=fs, window="hann", nperseg=nper, noverlap=nper // 2,
                                detrend="constant", scaling="density")
        f1, S1 = hann_spectrogram(x, fs, nper)
        assert np.array_equal(f0, f1) and np.array_equal(S0, S1)


def test_tails_and_ranks_are_scipy_stats_to_the_bit():
    """The twins' fitted tails and the burst statistic's ranks (scipy.special and numpy, not
    scipy.stats: its import costs a third of a second) give scipy.stats's numbers."""
    from scipy.stats import chi2, norm, rankdata
    from cyclo_fmu.diagnosis.twins import average_ranks, chi2_tail, normal_tail
    rng = np.random.default_rng(8)
    for _ in range(20):
        s = rng.chisquare(3.0, 200) * rng.uniform(0.1, 10)
        stat, alpha = float(rng.uniform(0, 40)), float(10 ** rng.uniform(-4, -1))
        mu, var = float(np.mean(s)), float(np.var(s, ddof=1))
        nu, c = 2 * mu * mu / var, var / (2 * mu)
        assert chi2_tail(s, stat, alpha) == (float(c * chi2.isf(alpha, nu)),
                                             float(chi2.sf(stat / c, nu)))
        g = rng.normal(3.0, 0.5, 200)
        mu, sd = float(np.mean(g)), float(np.std(g, ddof=1))
        assert normal_tail(g, stat / 10, alpha) == (float(mu + sd * norm.isf(alpha)),
                                                    float(norm.sf((stat / 10 - mu) / sd)))
    for x in (rng.normal(size=999), np.round(rng.normal(size=999), 1), np.zeros(5)):
        assert np.array_equal(average_ranks(x), rankdata(x))


def test_a_diagnosis_imports_neither_scipy_signal_nor_scipy_stats(tmp_path):
    """Their imports cost 0.35-0.45 s of CPU, a tenth of the command on 600 000 samples."""
    import subprocess
    import sys
    from cyclo_fmu.synth import synthesize, write_synth
    path = tmp_path / "rec.csv"
    write_synth(path, synthesize("load_independent_loss", 1, "S1"))
    code = ("import sys\nfrom cyclo_fmu.io import load_recording\n"
            "from cyclo_fmu.diagnosis import Diagnoser\n"
            f"rec, mode, _ = load_recording({str(path)!r}, 'auto')\n"
            "Diagnoser(mode=mode).fit(rec)\n"
            "print(sorted(m for m in ('scipy.signal', 'scipy.stats') if m in sys.modules))\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert r.stdout.strip().splitlines()[-1] == "[]"


def test_replays_sharing_their_speed_look_ups_give_the_same_torques():
    """A replay and its sensitivities look the recording's speeds up once per speed grid
    (``replay_input_torque(..., located=)``): the same numbers as each on its own, speeds
    below the grid and reversals included, both profiles."""
    from model_core import DriveDesign
    from model_core.lossmap import replay_input_torque
    rng = np.random.default_rng(9)
    n = 40000
    w = np.concatenate([np.linspace(-300.0, 300.0, n // 2), rng.uniform(-0.01, 0.01, n // 4),
                        rng.uniform(0.0, 300.0, n - n // 2 - n // 4)])
    tau = rng.uniform(-2.0, 2.0, n)
    for profile, mode in (("physical", "S1"), ("physical", "1S"), ("paper", "S2")):
        d = DriveDesign(profile=profile)
        located = {}
        for grid in ((18, 14), None, (18, 14)):       # the third from the shared look-ups
            got = replay_input_torque(d, mode, w, tau, grid, located)
            ref = replay_input_torque(d, mode, w, tau, grid)
            assert all(np.array_equal(a, b) for a, b in zip(got, ref))
        assert len(located) == 2


def test_a_ripple_law_from_the_constant_laws_columns_is_the_whole_one():
    """The mesh ripple's load law (a + b |tau_out|) begins with the constant law's columns
    (a): its basis built from them (``Effect.basis(lead=)``), and the diagnosis's block-mean
    columns that filter and average only the load columns, are the whole ones to the bit."""
    from cyclo_fmu.diagnosis.problem import _candidates, _edge_samples
    from cyclo_fmu.diagnosis.replay import first_order
    from model_core.effects import EFFECTS
    rng = np.random.default_rng(5)
    n, dt, m = 4000, 1e-3, 10
    w = 150.0 * np.sin(np.linspace(0.0, 9.0, n)) + rng.normal(0.0, 0.5, n)
    sig = {"t": np.arange(n) * dt, "w_in": w, "theta_in": np.cumsum(w) * dt,
           "tau_out": -4.0 - 3.0 * np.sin(np.linspace(0.0, 5.0, n)), "ratio_out": -1 / 14,
           "order_roller": 15.0}
    e = EFFECTS["mesh_ripple"]
    assert e.nested and e.leads(1.0, 0.0) and not e.leads(0.0, 1.0)
    assert not EFFECTS["low_speed_friction"].nested
    a = e.basis(sig, 0.0)
    whole = e.basis(sig, 1.0)
    assert np.array_equal(e.basis(sig, 1.0, (0.0, a)), whole)
    assert np.array_equal(whole[:, :a.shape[1]], a)
    # the load columns alone (what the diagnosis filters and averages), the same numbers
    assert np.array_equal(e.basis_beyond(sig, 1.0, (0.0, a)), whole[:, a.shape[1]:])
    mask = rng.random(n) > 0.05
    counts = mask.reshape(-1, m).sum(1)
    edges = np.array([2, 7, 100, 399])
    _, options, columns = _candidates(sig, ("mesh_ripple",), True, dt, 1000.0, mask, m,
                                      counts=counts, edges=edges)
    assert [t.shape for t in options["mesh_ripple"]] == [0.0, 1.0]
    y = first_order(whole, dt, 1000.0)
    assert np.array_equal(columns[("mesh_ripple", 1.0)][1], masked_means(y, mask, m, counts))
    assert np.array_equal(columns[("mesh_ripple", 1.0)][2], _edge_samples(y, edges, m))


def test_grid_cells_are_searchsorteds():
    """The replay's look-up of each sample's cell on a map's grid (``lossmap.grid_cell``:
    from the step of a grid of equal steps, checked) gives searchsorted's cells, clipped to
    the grid's cells, for values on the nodes, next to them, outside the grid, infinite or
    NaN, and on grids of unequal steps."""
    from model_core.lossmap import grid_cell
    rng = np.random.default_rng(7)
    for trial in range(200):
        n = int(rng.integers(2, 50))
        g = (np.log(np.geomspace(rng.uniform(1e-3, 1.0), rng.uniform(2.0, 1e3), n))
             if trial % 3 else np.unique(rng.normal(size=n)))
        x = np.concatenate([rng.uniform(g[0] - 1, g[-1] + 1, 2000), g, np.nextafter(g, 9.0),
                            np.nextafter(g, -9.0), [np.nan, np.inf, -np.inf]])
        for xx in (x, x[np.isfinite(x)], np.clip(x[np.isfinite(x)], g[0], g[-1])):
            ref = np.clip(np.searchsorted(g, xx, side="right") - 1, 0, len(g) - 2)
            assert np.array_equal(grid_cell(g, xx), ref)
            i, lo, hi = grid_cell(g, xx, nodes=True)
            assert np.array_equal(i, ref) and np.array_equal(lo, g[ref])
            assert np.array_equal(hi, g[ref + 1])


def test_the_subset_fits_least_squares_is_numpys_to_the_bit():
    """``selection.lstsq`` (LAPACK's loop without numpy's wrapper) gives numpy.linalg.lstsq's
    numbers for well-posed, nearly collinear and rank-deficient normal equations, and its
    error where the SVD cannot run (a NaN)."""
    from cyclo_fmu.diagnosis.selection import lstsq
    rng = np.random.default_rng(11)
    for k in (1, 2, 5, 12):
        A = rng.normal(size=(200, k))
        if k > 2:
            A[:, -1] = A[:, 0] + 1e-9 * rng.normal(size=200)     # nearly collinear
            A[:, -2] = A[:, 1]                                  # exactly: rank-deficient
        G, c = A.T @ A, A.T @ rng.normal(size=200)
        assert np.array_equal(lstsq(G, c), np.linalg.lstsq(G, c, rcond=1e-12)[0])
    G[0, 0] = np.nan
    with pytest.raises(np.linalg.LinAlgError):
        np.linalg.lstsq(G, c, rcond=1e-12)
    with pytest.raises(np.linalg.LinAlgError):
        lstsq(G, c)
