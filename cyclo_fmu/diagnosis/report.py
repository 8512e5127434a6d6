"""What a diagnosis writes: the figures, a self-contained ``report.html`` and the updated design."""
from __future__ import annotations

import base64
import html
import io
import math
import textwrap

import numpy as np

from model_core import DriveDesign
from model_core.effects import EFFECTS, resolve_effect

from ..fmt import friction_level_fields, unit_suffix
from .result import Diagnosis


def updated_design(design: DriveDesign, d: Diagnosis):
    """The design with every selected effect switched on, in the form it was fitted in (time
    constant or per 10 K of the temperature column), and the friction level corrected; notes
    for what is not physics of the drive (transducer faults)."""
    notes = [f"updated by cyclo-fmu diagnose: {', '.join(e['id'] for e in d.effects) or 'none'}"]
    fixed = design
    done = set()
    for e in ([{"id": "friction_miscalibrated", "parameters": d.calibration}]
              if d.calibration else []) + d.effects:
        if e["id"] in done or e["id"] == "none":
            continue
        done.add(e["id"])
        # an id of an earlier version (load_ripple, now the mesh ripple's load law 1)
        eid, _, _ = resolve_effect(e["id"])
        eff = EFFECTS[eid]
        # next to a discovered form the selected effects' values change (``library_change``)
        change = ((d.unexplained.get("proposed") or {}).get("library_change") or {}).get(
            e["id"], {})
        values = {k: v["value"] + change.get(k, 0.0) for k, v in e["parameters"].items()}
        shape = eff.shape_from(values) if eff.shape else None
        if eid != e["id"]:
            eid, values, shape = resolve_effect(e["id"], values, shape)
        form = e.get("form", "").startswith("per 10 K")
        if form and e.get("reference_temperature_C") is not None:
            # the temperature the per-10 K form was referred to, K (extra.thermal_T_ref)
            from model_core.design import KELVIN
            form = float(e["reference_temperature_C"]) + KELVIN
        fixed, more = eff.apply(fixed, values, shape, temperature=form)
        notes += more
    if d.unexplained.get("present"):
        notes.append("a mismatch remains that no library effect explains: "
                     + d.unexplained["statement"])
    fixed, more = _discovered(fixed, d.unexplained.get("proposed"))
    notes += more
    return fixed, notes


def _discovered(design, proposed):
    """The discovery stage's steady terms (``unexplained.proposed.design_terms``) added to the
    design's ``[[extra.discovered]]``; terms the design cannot carry are said in a note."""
    if not proposed or not proposed.get("formula"):
        return design, []
    from model_core.discovered import DiscoveredTerm
    from .discover import apply_terms
    terms = [DiscoveredTerm(t["coefficient_Nm"], t["speed_exponent"], t["load_exponent"])
             for t in proposed.get("design_terms", [])]
    fixed, notes = apply_terms(design, terms, proposed["formula"])
    if proposed.get("not_in_design"):
        notes.append("discovered terms the design does not carry (the FMUs evaluate steady "
                     "power laws in speed and load only): " + ", ".join(proposed["not_in_design"]))
    return fixed, notes


def _proposed_html(p) -> str:
    """The discovery stage's proposal (``unexplained.proposed``) for the report."""
    e = html.escape
    if not p:
        return ""
    if not p.get("formula"):
        return f"<p>No closed form proposed: {e(str(p.get('refused')))}.</p>"
    rows = "".join(f"<tr><td>{e(t['feature'])}</td><td>{_fmt(t['coefficient'])} {e(t['unit'])}"
                   f"</td><td>[{_fmt(t['ci95'][0])}, {_fmt(t['ci95'][1])}]</td>"
                   f"<td>{100 * t['stability']:.0f} %</td></tr>" for t in p["terms"])
    return (f"<p>Proposed closed form (written to the updated design): <b>{e(p['formula'])}"
            f"</b>. Held-out RMS {1e3 * p['heldout_rms_before_Nm']:.3g} &rarr; "
            f"{1e3 * p['heldout_rms_after_Nm']:.3g} mN*m (noise {1e3 * p['noise_Nm']:.3g}). "
            f"Reading: {e(p['reading'])}.</p><table><tr><th>feature</th><th>coefficient</th>"
            f"<th>95 % interval</th><th>stable across folds</th></tr>{rows}</table>")


#: the residual maps are drawn as points up to this many blocks, above it as cell means
#: (``_cell_means``): 5000 points stay legible as points and draw in about 30 ms
MAP_POINTS = 5000
#: cells of the residual map (speed x torque) above MAP_POINTS: 120 x 80, finer than the
#: figure's panels resolve a speed or load step (about 3 pixels per cell at 100 dpi)
MAP_CELLS = (120, 80)
#: points of a residual's time series drawn at most (``_envelope``): 4000, the smallest and
#: largest block mean of 2000 runs, about four runs per pixel column of the 450-pixel panel
LINE_POINTS = 4000


def _figure(d: Diagnosis):
    # a Figure of its own, not pyplot's (no figure manager to import, register and close);
    # savefig gives it the Agg canvas
    from matplotlib import rcParams
    from matplotlib.figure import Figure
    s = d.series
    fig = Figure(figsize=(11, 7.5))
    axes = fig.subplots(2, 2)
    # the map's points: the discs of scatter(s=2) with their edge stroke in the face colour
    # (patch.linewidth, 1 pt) drawn as one fill of the same outer diameter, without the
    # stroke: the same picture (pixels within 9/255, mean 0.2/255) in half the drawing time
    # of 2 x 60 000 points at 600 000 samples
    marker_s = (math.sqrt(2.0) + rcParams["patch.linewidth"]) ** 2
    ax = axes[0, 0]
    ax.plot(*_envelope(s["t"], 1e3 * s["residual_before"]), lw=0.4, label="model as given")
    label = ", ".join(e["id"] for e in d.effects) or "none"
    ax.plot(*_envelope(s["t"][:len(s["residual_after"])], 1e3 * s["residual_after"]), lw=0.4,
            label=f"with {label}")
    ax.set(xlabel="time / s", ylabel="input torque residual / mN·m",
           title="measured - model input torque (block means)")
    ax.legend(fontsize=7)
    lim = float(np.nanpercentile(np.abs(1e3 * s["residual_before"]), 99)) or 1.0
    n = len(s["residual_after"])
    for ax, key, title in ((axes[0, 1], "residual_before", "model as given"),
                           (axes[1, 0], "residual_after",
                            textwrap.shorten(f"with {label}", 60, placeholder=" ..."))):
        x, y, c = s["speed_in"][:n] * 30 / math.pi, s["torque_out"][:n], 1e3 * s[key][:n]
        if n > MAP_POINTS:
            sc = _cell_means(ax, x, y, c, lim)
        else:
            sc = ax.scatter(x, y, c=c, s=marker_s, linewidths=0, cmap="coolwarm",
                            vmin=-lim, vmax=lim)
        fig.colorbar(sc, ax=ax, label="residual / mN·m"
                     + (" (cell mean)" if n > MAP_POINTS else ""))
        ax.set(xlabel="input speed / (r/min)", ylabel="output torque / N·m",
               title=f"residual over the operating map,\n{title}")
    _evidence_chart(axes[1, 1], d.evidence)
    fig.tight_layout()
    # laid out: without a layout engine left behind, savefig draws the figure once (with one,
    # matplotlib draws it a second time to lay it out again; half the figure's cost, the
    # 2 x 60 000 points of the scatters at 600 000 samples)
    fig.set_layout_engine(None)
    return fig


def _envelope(t, y):
    """A time series of more than ``LINE_POINTS`` values as the smallest and largest value
    of each of ``LINE_POINTS / 2`` consecutive runs (at the run's middle time): the line drawn
    through them covers, at the figure's resolution, what the whole series covers (several
    runs per pixel column), and costs a fraction of drawing every block mean."""
    n = len(y)
    if n <= LINE_POINTS:
        return t, y
    starts = (np.arange(LINE_POINTS // 2) * n) // (LINE_POINTS // 2)
    lo, hi = np.fmin.reduceat(y, starts), np.fmax.reduceat(y, starts)
    mid = t[np.minimum(starts + np.diff(np.r_[starts, n]) // 2, n - 1)]
    return np.repeat(mid, 2), np.column_stack([lo, hi]).ravel()


def _cell_means(ax, x, y, c, lim):
    """The operating map as MAP_CELLS cells, each coloured by the mean residual of the blocks
    in it (empty cells blank): an image, drawn in milliseconds whatever the recording's
    length, where a scatter of tens of thousands of blocks costs a third of a second and
    hides all but the last point drawn on each spot."""
    nx, ny = MAP_CELLS
    ok = np.isfinite(x) & np.isfinite(y) & np.isfinite(c)
    x, y, c = x[ok], y[ok], c[ok]
    x0, x1 = (float(x.min()), float(x.max())) if x.size else (0.0, 1.0)
    y0, y1 = (float(y.min()), float(y.max())) if y.size else (0.0, 1.0)
    x1, y1 = (x1 if x1 > x0 else x0 + 1.0), (y1 if y1 > y0 else y0 + 1.0)
    i = np.minimum(((x - x0) / (x1 - x0) * nx).astype(int), nx - 1)
    j = np.minimum(((y - y0) / (y1 - y0) * ny).astype(int), ny - 1)
    k = j * nx + i
    count = np.bincount(k, minlength=nx * ny)
    total = np.bincount(k, weights=c, minlength=nx * ny)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(count > 0, total / np.maximum(count, 1), np.nan).reshape(ny, nx)
    return ax.imshow(mean, origin="lower", extent=(x0, x1, y0, y1), aspect="auto",
                     interpolation="nearest", cmap="coolwarm", vmin=-lim, vmax=lim)


_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def _decade(v, pos=None) -> str:
    """A tick of a logarithmic axis: 0, a decade as 10 with a superscript exponent (10³),
    any other value as %g."""
    if v == 0:
        return "0"
    k = math.log10(abs(v))
    if abs(k - round(k)) > 1e-9:
        return f"{v:g}"
    return ("−" if v < 0 else "") + "10" + str(int(round(k))).translate(_SUPERSCRIPT)


def _evidence_chart(ax, ev) -> None:
    """BIC of each candidate (with the selection) above the best, on a symmetric-log axis:
    linear below ``DELTA_BIC``, logarithmic above, so that the plain model's bar ("none",
    often 10^4-10^5 above) does not flatten the candidates that differ by a few units; the
    selection threshold is drawn and each bar carries its value."""
    from .selection import DELTA_BIC
    if not ev:
        ax.set_axis_off()
        return
    best = min(e["bic"] for e in ev)
    vals = [max(e["bic"] - best, 0.0) for e in ev]
    names = [e["id"] + (" (selected)" if e.get("selected") else "") for e in ev]
    colors = ["tab:green" if e.get("selected") else "tab:blue" for e in ev]
    y = np.arange(len(ev))
    ax.barh(y, vals, color=colors)
    ax.set_yticks(y, names, fontsize=8)
    ax.invert_yaxis()
    ax.set_xscale("symlog", linthresh=DELTA_BIC)
    # the decades as plain text with superscript digits (10³): the look of matplotlib's
    # LogFormatterSciNotation without its mathtext, whose parser is a fifth of the figure's
    # drawing time
    from matplotlib.ticker import FuncFormatter
    ax.xaxis.set_major_formatter(FuncFormatter(_decade))
    ax.set_xlim(0, max(max(vals), DELTA_BIC) * 3)
    ax.axvline(DELTA_BIC, color="k", ls="--", lw=0.8)
    for yi, v in zip(y, vals):
        ax.text(v, yi, f" {v:.3g}", va="center", fontsize=7)
    ax.set(xlabel=f"BIC − best BIC (symmetric log scale)\ndashed: ΔBIC = {DELTA_BIC:g}, "
           "the selection threshold",
           title="evidence: candidates next to the selection")
    ax.grid(axis="x", alpha=0.3)


def plot_diagnosis(d: Diagnosis, out) -> list:
    """Residual over time and over the operating map, before and after (PNG)."""
    import matplotlib
    matplotlib.use("Agg")
    from pathlib import Path
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    fig = _figure(d)
    f = out / "diagnosis.png"
    fig.savefig(f, dpi=100)
    return [f]


def _png(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _fmt(v):
    if isinstance(v, float):
        return f"{v:.4g}"
    return html.escape(str(v))


def write_report(d: Diagnosis, path, result: dict, source: str = "",
                 profile: str = "physical", png: bytes = None) -> None:
    """A self-contained HTML report (figures embedded) an engineer can attach to a test report:
    the statement, the effects with their parameters and intervals, what remains, the checks,
    the evidence table and the residual before and after, over time and over the map.
    ``profile``: the design's model profile, which names the coefficients the friction level
    scales."""
    import matplotlib
    matplotlib.use("Agg")
    e = html.escape
    rows = []
    for eff in d.effects:
        ps = "<br>".join(
            f"{e(k)} = {_fmt(v['value'])}{e(unit_suffix(v['unit']))}"
            + (f" [{_fmt(v['ci95'][0])}, {_fmt(v['ci95'][1])}]" if v.get("ci95") else "")
            for k, v in eff["parameters"].items())
        rows.append(f"<tr><td>{e(eff['id'])}</td><td>{e(eff['description'])}</td><td>{ps}</td>"
                    f"<td>{1e3 * eff['explained_rms_Nm']:.3g}</td>"
                    f"<td>{100 * eff.get('stability', 1):.0f} %</td>"
                    f"<td>{e(', '.join(eff.get('indistinguishable_from', [])))}</td></tr>")
    ev = "".join(f"<tr><td>{e(r['id'])}{' (selected)' if r.get('selected') else ''}</td>"
                 f"<td>{r['bic'] - d.evidence[0]['bic']:.1f}</td>"
                 f"<td>{1e3 * r['cv_rmse_Nm']:.3g}</td><td>{'yes' if r['admissible'] else 'no'}"
                 f"</td></tr>" for r in d.evidence)
    checks = "".join(f"<li>{e(str(c.get('status', '')))}: {e(str(c.get('message', c)))}</li>"
                     if isinstance(c, dict) else f"<li>{e(str(c))}</li>"
                     for c in result.get("checks", []))
    excl = "".join(f"<li>{e(str(x.get('reason')))}: {x.get('count')}</li>"
                   for x in result.get("excluded", []))
    u = d.unexplained
    cal = "".join(f"<li>{e(k)} = {_fmt(v['value'])}{e(unit_suffix(v['unit']))}</li>"
                  for k, v in d.calibration.items())
    # (``png``: the figure already drawn for diagnosis.png, embedded as it is)
    img = base64.b64encode(png).decode("ascii") if png is not None else _png(_figure(d))
    text = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>cyclo-fmu diagnosis: {e(source)}</title>
<style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto;line-height:1.4}}
table{{border-collapse:collapse}}td,th{{border:1px solid #bbb;padding:4px 8px;vertical-align:top}}
.warn{{background:#fff3cd;padding:8px}}</style></head><body>
<h1>Diagnosis of {e(source) or 'a recording'}</h1>
<p>Mode {e(str(result.get('mode', '')))}. Held-out RMS of the input torque residual
{1e3 * d.rmse_before_Nm:.3g} &rarr; {1e3 * d.rmse_after_Nm:.3g} mN·m; additional-loss factor
zeta_d (paper Eq. 31) {100 * d.zeta_d_before:.2f} &rarr; {100 * d.zeta_d_after:.2f} %.</p>
<h2>Statement</h2><p>{e(d.located.get('statement', ''))}</p>
<h2>Effects the data supports</h2>
{('<table><tr><th>effect</th><th>what</th><th>parameters [95 % interval]</th>'
  '<th>explained RMS / mN·m</th><th>stable across folds</th><th>cannot be told apart from</th>'
  '</tr>' + ''.join(rows) + '</table>') if rows else '<p>none</p>'}
{f'<p>Friction level (model calibration; scales {e(friction_level_fields(profile))} together):</p><ul>{cal}</ul>' if cal else ''}
<h2>What remains</h2>
<p class="{'warn' if u.get('present') else ''}">{e(u.get('statement', ''))}</p>
{_proposed_html(u.get('proposed'))}
{f"<p>A run that would separate look-alikes: {e(d.suggested_test)}</p>" if d.suggested_test else ''}
<h2>Checks before fitting</h2><ul>{checks or '<li>none</li>'}</ul>
<h2>Left out</h2><ul>{excl or '<li>nothing</li>'}
<li>{d.excluded_blocks} blocks excluded as spikes</li></ul>
<h2>Residual</h2><img alt="residual before and after" src="data:image/png;base64,{img}">
<h2>Evidence</h2><table><tr><th>candidate (with the selection)</th><th>BIC - best</th>
<th>held-out RMS / mN·m</th><th>inside bounds</th></tr>{ev}</table>
<p><small>cyclo-fmu diagnose; notes: {e('; '.join(d.notes)) or 'none'}</small></p>
</body></html>"""
    from pathlib import Path
    Path(path).write_text(text, encoding="utf-8")


def write_diagnosis(out_dir, d, design, result, source=""):
    """Write one diagnosis' folder (diagnosis.png, report.html, diagnosis.json,
    design_updated.toml); removed again if any of it fails."""
    import json
    from model_core import design_to_toml
    from ..outputs import staged_dir
    import matplotlib
    matplotlib.use("Agg")
    with staged_dir("out", out_dir) as out:
        fig = _figure(d)           # drawn once: the PNG file and the report's embedded image
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=100)
        (out / "diagnosis.png").write_bytes(buf.getvalue())
        write_report(d, out / "report.html", result, source, design.profile,
                     png=buf.getvalue())
        (out / "diagnosis.json").write_text(json.dumps(result, indent=2))
        fixed, notes = d.updated or updated_design(design, d)
        (out / "design_updated.toml").write_text(design_to_toml(fixed) + "".join(
            f"# {n}\n" for n in notes))
