"""``cyclo-fmu paper``: the paper's Section 5 comparison, theory side, with figures."""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from model_core import LOSS_NAMES, efficiency_map, operating_point, rpm_to_rad_s
from model_core.losses import LOSS_DESCRIPTIONS
from model_core.drag import IDLE_DESCRIPTIONS, IDLE_NAMES
from model_core.paper import (PAPER_EXPERIMENT, PAPER_THEORY, BenchEnvelope, envelope_statistics,
                              experiment_gap)


#: [r/min] input speeds of the efficiency curves: the bench's test speeds
BENCH_SPEEDS_RPM = (1000.0, 1500.0, 2000.0, 2500.0, 2800.0)


def _efficiency_figure(design, envelope, path: Path, reference=None) -> Path:
    """Efficiency over input torque at the bench's speeds (left) and output over input power
    (right), S1 and S2, in ``design``'s profile, against the paper's band (experiment for the
    physical profile, theory for the paper profile). ``reference``: another design (the other
    profile) drawn at 2800 r/min as a dotted line for comparison."""
    import matplotlib.pyplot as plt

    torques = np.linspace(envelope.torque_min, envelope.torque_max, 30)
    fig, axes = plt.subplots(2, 2, figsize=(10, 7.5))
    for row, mode in enumerate(("S1", "S2")):
        # the curves at the speeds a test engineer runs on the bench
        m = efficiency_map(design, mode, rpm_to_rad_s(np.asarray(BENCH_SPEEDS_RPM)), torques)
        ax = axes[row, 0]
        for i, n in enumerate(BENCH_SPEEDS_RPM):
            ax.plot(torques, 100 * m.eta[i], label=f"{n:.0f} r/min")
        if reference is not None:
            r = efficiency_map(reference, mode, rpm_to_rad_s(np.asarray([2800.0])), torques)
            ax.plot(torques, 100 * r.eta[0], color="0.3", ls=":", lw=1.5,
                    label=f"{reference.profile} profile, 2800 r/min")
        what = "experiment" if design.profile == "physical" else "theory"
        ref = (PAPER_EXPERIMENT if design.profile == "physical" else PAPER_THEORY)[mode]
        ax.axhspan(100 * ref["min"], 100 * ref["max"], color="0.85", label=f"paper {what} range")
        ax.axhline(100 * ref["mean"], color="k", ls="--", lw=0.8, label=f"paper {what} mean")
        ax.set(xlabel="input torque / N·m", ylabel=f"efficiency in {mode} / %",
               title=f"{mode}, {design.profile} profile: efficiency over input torque")
        ax.legend(fontsize=7, loc="lower right", ncol=2)
        ax.grid(alpha=0.3)
        ax = axes[row, 1]
        p_in = m.input_power
        p_out = p_in * m.eta
        sc = ax.scatter(p_in.ravel(), p_out.ravel(), c=100 * m.eta.ravel(), s=8, cmap="viridis")
        fig.colorbar(sc, ax=ax, label="efficiency / %")
        ax.set(xlabel="input power / W", ylabel="output power / W",
               title=f"{mode}: output over input power")
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _partial_losses_figure(design, path: Path) -> Path:
    """Fig. 7-like: partial losses at the rated point (2800 r/min, 0.85 N·m, S1 and S2), both
    profiles, plain rollers against needle-bearing rollers. Horizontal bars, so that each loss
    is named in full next to its bars."""
    import textwrap
    import matplotlib.pyplot as plt

    w_rated, t_rated = rpm_to_rad_s(2800.0), 0.85
    names = list(LOSS_NAMES) + list(IDLE_NAMES)
    descr = {**LOSS_DESCRIPTIONS, **IDLE_DESCRIPTIONS}
    if not design.calibration.is_default:   # the calibrated mesh loss, on its own bar
        from model_core.losses import MESH_LOSS_DESCRIPTION, MESH_LOSS_NAME
        names.append(MESH_LOSS_NAME)
        descr[MESH_LOSS_NAME] = MESH_LOSS_DESCRIPTION
    labels = [f"{n}: " + textwrap.fill(descr[n], 30) for n in names]
    y = np.arange(len(names))
    height = 0.2
    fig, axes = plt.subplots(1, 2, figsize=(13, 6.5), sharey=True, sharex=True)
    for ax, (pname, base) in zip(axes, (("paper", paper_profile(design)),
                                        ("physical", physical_profile(design)))):
        variants = [("plain rollers", base),
                    ("needle rollers", replace(base, ring_rollers="needle",
                                               disc_rollers="needle"))]
        for j, mode in enumerate(("S1", "S2")):
            for k, (label, d) in enumerate(variants):
                op = operating_point(d, mode, w_rated, t_rated)
                vals = [float(getattr(op.losses, n)) for n in names]
                ax.barh(y + (2 * j + k - 1.5) * height, vals, height,
                        label=f"{mode}, {label}: efficiency {100 * float(op.eta):.1f} %")
        ax.set_yticks(y, labels, fontsize=8)
        ax.invert_yaxis()
        ax.set(xlabel="power loss / W",
               title=f"{pname} profile: partial losses at 2800 r/min, 0.85 N·m input")
        ax.grid(axis="x", alpha=0.3)
        ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _figures(design, envelope, out: Path) -> list[Path]:
    """The figures of ``cyclo-fmu paper``: ``efficiency_S1_S2.png`` in the design's own profile
    (the default: physical, against the paper's experiment, with the paper profile's 2800 r/min
    curve dotted), ``efficiency_S1_S2_<other>.png`` in the other profile, and
    ``partial_losses.png`` (both profiles in one figure). Each file is written once."""
    import matplotlib
    matplotlib.use("Agg")

    out.mkdir(parents=True, exist_ok=True)
    other = paper_profile(design) if design.profile == "physical" else physical_profile(design)
    return [_efficiency_figure(design, envelope, out / "efficiency_S1_S2.png", reference=other),
            _efficiency_figure(other, envelope, out / f"efficiency_S1_S2_{other.profile}.png",
                               reference=design),
            _partial_losses_figure(design, out / "partial_losses.png")]


def paper_profile(design):
    """The design computed as the paper did (Eq. 24, calibrated mu_boundary, load-dependent),
    without the design's ``[calibration]``: the paper profile reproduces the paper's theory,
    which a calibration to a measurement does not belong to."""
    from model_core.design import Calibration
    return replace(design, profile="paper", losses="load_dependent", calibration=Calibration())


def physical_profile(design):
    """The design in the physical profile (its own ``losses`` setting)."""
    return replace(design, profile="physical")


def paper_comparison(design, envelope=BenchEnvelope()) -> dict:
    """The envelope statistics (fractions) of both profiles and the paper's numbers:
    ``S1``/``S2`` the paper profile, ``physical`` the physical one, ``theory`` and
    ``experiment`` the paper's Section 5 ranges."""
    out = {mode: envelope_statistics(paper_profile(design), mode, envelope) for mode in ("S1", "S2")}
    out["physical"] = {mode: envelope_statistics(physical_profile(design), mode, envelope)
                       for mode in ("S1", "S2")}
    out["theory"] = PAPER_THEORY
    out["experiment"] = PAPER_EXPERIMENT
    out["experiment_gap"] = experiment_gap(design, envelope)
    if not design.calibration.is_default:
        # a calibrated value is reported as calibrated, with what it was fitted to
        out["calibration"] = design.calibration.report()
    return out


def band_statistics(design, envelope=BenchEnvelope()) -> dict:
    """The physical profile's envelope statistics, nominal and of the conservative variant
    (``model_core.design.conservative_variant``): ``{"variant", "nominal", "conservative"}``."""
    from model_core.design import CONSERVATIVE_DESCRIPTION, conservative_variant
    phys = physical_profile(design)
    cons = conservative_variant(phys)
    return {"variant": CONSERVATIVE_DESCRIPTION,
            "nominal": {m: envelope_statistics(phys, m, envelope) for m in ("S1", "S2")},
            "conservative": {m: envelope_statistics(cons, m, envelope) for m in ("S1", "S2")}}


def run_paper_comparison(design, out, as_json: bool, band: bool = False) -> int:
    envelope = BenchEnvelope()
    stats = paper_comparison(design, envelope)
    if band:
        stats["band"] = band_statistics(design, envelope)
    files = _figures(design, envelope, Path(out)) if out else []
    if as_json:
        print(json.dumps(stats, indent=2))
        return 0
    print("Paper, Section 5: efficiency over the bench envelope")
    print(f"  envelope: input speed {envelope.speed_min_rpm:.0f}-{envelope.speed_max_rpm:.0f} r/min, "
          f"input torque {envelope.torque_min}-{envelope.torque_max} N*m "
          f"(250 W, 2800 r/min motor on a frequency regulator), {envelope.n_speed}x{envelope.n_torque} grid")
    print(f"  {'mode':4}  {'profile':9} {'model min/mean/max %':>24}   {'paper min/mean/max %':>24}")
    rows = (("paper", stats, PAPER_THEORY, "theory"),
            ("physical", stats["physical"], PAPER_EXPERIMENT, "experiment"))
    for mode in ("S1", "S2"):
        for pname, st, ref, what in rows:
            s, r = st[mode], ref[mode]
            print(f"  {mode:4}  {pname:9} {100 * s['min']:7.2f} {100 * s['mean']:7.2f} "
                  f"{100 * s['max']:7.2f}   {100 * r['min']:7.2f} {100 * r['mean']:7.2f} "
                  f"{100 * r['max']:7.2f} ({what})")
    if band:
        b = stats["band"]
        for mode in ("S1", "S2"):
            s, r = b["conservative"][mode], PAPER_EXPERIMENT[mode]
            print(f"  {mode:4}  {'conserv.':9} {100 * s['min']:7.2f} {100 * s['mean']:7.2f} "
                  f"{100 * s['max']:7.2f}   {100 * r['min']:7.2f} {100 * r['mean']:7.2f} "
                  f"{100 * r['max']:7.2f} (experiment)")
        print(f"  band: 'physical' is nominal, 'conserv.' the {b['variant']}")
    if "calibration" in stats:
        c = stats["calibration"]
        print(f"  physical profile CALIBRATED: mesh_loss_k = {c['mesh_loss_k']:.4g}, "
              f"idle_loss_scale = {c['idle_loss_scale']:.4g}, load_loss_scale = "
              f"{c.get('load_loss_scale', 1.0):.4g} (fitted to: "
              f"{c['source'] or 'not stated'}); the paper profile is not calibrated")
    g = stats["experiment_gap"]
    print("  What the physical profile lacks to predict the experiment (an inference: two numbers "
          "fitted to S1's min/mean/max, S2 predicted):")
    print(f"    a load-proportional meshing loss k = {100 * g['k']:.2f} % of the basic mechanism's "
          f"power: {g['load_proportional_W']:.1f} W at 2800 r/min, 0.85 N*m (the model's "
          f"load-dependent losses there: {g['load_dependent_W']:.1f} W)")
    print(f"    load-independent losses at a = {g['a']:.2f} of the model's catalogue estimate: "
          f"{g['load_independent_inferred_W']:.1f} W instead of {g['load_independent_W']:.1f} W")
    for mode in ("S1", "S2"):
        s, r = g["inferred"][mode], PAPER_EXPERIMENT[mode]
        print(f"  {mode:4}  {'inferred':9} {100 * s['min']:7.2f} {100 * s['mean']:7.2f} "
              f"{100 * s['max']:7.2f}   {100 * r['min']:7.2f} {100 * r['mean']:7.2f} "
              f"{100 * r['max']:7.2f} (experiment)")
    for f in files:
        print(f"  figure: {f}")
    return 0
