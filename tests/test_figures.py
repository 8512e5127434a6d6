"""Figures a reader can read: ``cyclo-fmu paper`` writes each figure once and its top-level
efficiency figure in the design's own profile; the diagnosis' evidence chart keeps candidates a
few BIC units apart visible next to the plain model's bar; dimensionless values print without
a unit; the friction level is named by the coefficients it scales in each profile."""
from __future__ import annotations

import hashlib
from dataclasses import replace

import numpy as np
import pytest

from model_core import DriveDesign, operating_point, rpm_to_rad_s
from model_core.design import scale_friction_level
from model_core.paper import BenchEnvelope


def test_paper_figures_written_once_in_the_design_profile(tmp_path, monkeypatch):
    from cyclo_fmu import paper
    drawn = []
    real = paper._efficiency_figure

    def spy(design, envelope, path, reference=None):
        drawn.append((path.name, design.profile, reference.profile))
        return real(design, envelope, path, reference)
    monkeypatch.setattr(paper, "_efficiency_figure", spy)
    files = paper._figures(DriveDesign(), BenchEnvelope(n_speed=3, n_torque=3), tmp_path)
    assert [f.name for f in files] == ["efficiency_S1_S2.png", "efficiency_S1_S2_paper.png",
                                      "partial_losses.png"]
    # the top-level figure shows the default (physical) profile, the paper profile as reference
    assert drawn[0] == ("efficiency_S1_S2.png", "physical", "paper")
    assert drawn[1] == ("efficiency_S1_S2_paper.png", "paper", "physical")
    digests = {hashlib.sha256(f.read_bytes()).hexdigest() for f in files}
    assert len(digests) == len(files), "two figures are byte-identical copies"
    assert sorted(p.name for p in tmp_path.rglob("*.png")) == sorted(f.name for f in files)


def test_evidence_chart_keeps_small_differences_visible():
    """With the plain model 5e4 BIC units above the best, a candidate 7 units above must still
    be a bar a reader sees (at least 5 % of the axis width), and the axis reaches every bar."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from cyclo_fmu.diagnosis.report import _evidence_chart
    ev = [{"id": "drag", "bic": -1000.0, "selected": True},
          {"id": "inertia", "bic": -993.0},
          {"id": "mesh_ripple", "bic": -968.0},
          {"id": "none", "bic": 5e4}]
    fig, ax = plt.subplots()
    _evidence_chart(ax, ev)
    fig.canvas.draw()
    x0, x1 = ax.get_xlim()
    assert x1 >= 5e4 + 1000
    to_px = ax.transData.transform
    width = to_px((x1, 0))[0] - to_px((x0, 0))[0]
    bar_7 = to_px((7.0, 0))[0] - to_px((0.0, 0))[0]
    assert bar_7 / width > 0.05
    plt.close(fig)


def test_dimensionless_units_print_as_nothing():
    from cyclo_fmu.fmt import unit_suffix
    assert unit_suffix("1") == ""
    assert unit_suffix(None) == ""
    assert unit_suffix("N*m") == " N*m"
    assert unit_suffix("1 per 10 K") == " per 10 K"
    assert unit_suffix("N*m per 10 K") == " N*m per 10 K"
    assert f"p = {0.66667:.5g}{unit_suffix('1')}" == "p = 0.66667"


@pytest.mark.parametrize("profile", ["paper", "physical"])
def test_friction_level_names_the_coefficients_that_act(profile):
    """The coefficients named for a profile's friction level are the ones that move its
    losses: scaling only those gives the same operating point as the friction level itself."""
    from cyclo_fmu.fmt import friction_level_fields
    design = DriveDesign(profile=profile,
                         losses="load_dependent" if profile == "paper" else "all")
    factor = 1.2
    level = scale_friction_level(design, factor)
    names = [n.strip() for n in friction_level_fields(profile).split(",")]
    only = replace(design, friction=replace(
        design.friction, **{n: getattr(design.friction, n) * factor for n in names}))
    w, T = rpm_to_rad_s(2000.0), 0.6
    base, a, b = (operating_point(d, "S1", w, T) for d in (design, level, only))
    assert abs(float(a.eta) - float(base.eta)) > 1e-3           # the level acts
    assert np.isclose(float(a.eta), float(b.eta), rtol=0, atol=1e-12)


def test_long_residual_series_drawn_as_their_envelope():
    """A residual series longer than LINE_POINTS is drawn through the smallest and largest
    block mean of each run of consecutive blocks: at most LINE_POINTS points, every run's
    extremes (NaN blocks aside) in it, in time order; a short series is drawn whole."""
    import numpy as np
    from cyclo_fmu.diagnosis.report import LINE_POINTS, _envelope
    rng = np.random.default_rng(2)
    n = 60_001
    t = np.arange(n) * 0.01
    y = np.cumsum(rng.normal(size=n))
    y[1234] = np.nan
    te, ye = _envelope(t, y)
    assert len(te) == len(ye) <= LINE_POINTS and np.all(np.diff(te) >= 0)
    assert np.nanmax(ye) == np.nanmax(y) and np.nanmin(ye) == np.nanmin(y)
    runs = LINE_POINTS // 2
    starts = (np.arange(runs) * n) // runs
    for k in (0, 7, runs // 2, runs - 1):
        seg = y[starts[k]:(starts[k + 1] if k + 1 < runs else n)]
        assert (ye[2 * k], ye[2 * k + 1]) == (np.nanmin(seg), np.nanmax(seg))
    short = y[:LINE_POINTS]
    assert _envelope(t[:LINE_POINTS], short)[1] is short


def test_decade_ticks_as_plain_text():
    from cyclo_fmu.diagnosis.report import _decade
    assert [_decade(v) for v in (0.0, 10.0, 1e5, 2.5, -100.0)] == [
        "0", "10¹", "10⁵", "2.5", "−10²"]
