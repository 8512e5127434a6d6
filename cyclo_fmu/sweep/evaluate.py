"""Evaluate one design: efficiency and partial losses over the envelope, per mode.

Result layout (chosen for design studies): ONE ROW PER DESIGN x MODE with summary columns, not
one per operating point (a 1000-design sweep then has 2000 rows instead of 128 000; the
operating-point detail of any design is one ``cyclo-fmu efficiency`` or
``model_core.maps.efficiency_map`` call away). Columns:

- ``design_id`` (row of the spec's design list), ``mode``, the varied fields (design-file
  units, e.g. ``geometry.e_mm``);
- ``eta_min``, ``eta_mean``, ``eta_max`` (fractions) over the envelope points where the drive
  runs (not locked, finite), ``n_points`` of them, ``n_locked`` self-locking points;
- ``loss_<PLk>_W``: each partial loss averaged over the envelope [W], ``loss_share_<PLk>``: its
  share of the summed losses;
- ``stiffness_Nm_rad``: tangent torsional stiffness at the rated torque (input locked,
  ``model_core.stiffness``; see :func:`stiffness_hook`), ``torsional_rigidity_Nm_arcmin``
  (catalogue secant between 50 % and 100 % of the rated torque) and ``lost_motion_arcmin``
  (catalogue twist band at +-3 % of the rated torque), see :func:`stiffness_columns`;
- ``error``: empty, or the one-line reason the design could not be built or run (a row is
  never dropped).
"""
from __future__ import annotations

import math

import numpy as np

from model_core import LOSS_NAMES, CycloidInputError
from model_core.maps import efficiency_map


def stiffness_hook(design):
    """Torsional stiffness [N*m/rad] at the rated torque (``model_core.stiffness``), or NaN
    when the contact model cannot give it for this design."""
    from model_core import stiffness as st
    try:
        return float(st.torsional_stiffness(design))
    except (ValueError, FloatingPointError, ZeroDivisionError):
        return math.nan


def stiffness_columns(design) -> dict:
    """The sweep's stiffness columns for one design (NaN where the contact model cannot give
    them): ``stiffness_Nm_rad`` (:func:`stiffness_hook`), ``torsional_rigidity_Nm_arcmin`` and
    ``lost_motion_arcmin`` as a catalogue defines them (``model_core.stiffness``)."""
    from model_core import stiffness as st
    cols = {"stiffness_Nm_rad": stiffness_hook(design),
            "torsional_rigidity_Nm_arcmin": math.nan, "lost_motion_arcmin": math.nan}
    try:
        TR = st.rated_torque(design)
        a, b = st.RIGIDITY_SHARES
        phi_a, phi_b, phi_lm = st.twist(design, [a * TR, b * TR, st.LOST_MOTION_SHARE * TR])
        cols["torsional_rigidity_Nm_arcmin"] = float((b - a) * TR
                                                     / ((phi_b - phi_a) * st.RAD_TO_ARCMIN))
        cols["lost_motion_arcmin"] = float(2 * phi_lm * st.RAD_TO_ARCMIN)
    except (ValueError, FloatingPointError, ZeroDivisionError):
        pass
    return cols


def evaluate_design(spec, design_id: int, values: dict) -> list:
    """Rows (one per mode) for one design of ``spec``."""
    rows = []
    base = {"design_id": design_id, **values}
    try:
        design = spec.build(values)
    except Exception as exc:     # noqa: BLE001 - the design keeps its row, with the reason
        return [{**base, "mode": m, "error": _reason(exc)} for m in spec.modes]
    stiff = stiffness_columns(design)
    env = spec.envelope
    from model_core.stiffness import ring_torque_rating
    from ..limits import ring_share
    rating = ring_torque_rating(design)
    # a calibrated design says so, with what it was fitted to (design [calibration])
    cal = {} if design.calibration.is_default else {
        "calibrated": True, "calibration_mesh_loss_k": design.calibration.mesh_loss_k,
        "calibration_idle_loss_scale": design.calibration.idle_loss_scale,
        "calibration_load_loss_scale": design.calibration.load_loss_scale,
        "calibration_source": design.calibration.source}
    for mode in spec.modes:
        row = {**base, "mode": mode, **stiff, **cal}
        # the envelope's largest torque against this design's static rating (lossless ring
        # share): beyond it the numbers would be a plausible-looking answer for a broken drive
        T_ring = env.torque_max * ring_share(mode, design.z1)
        if T_ring > rating:
            row["error"] = (f"envelope.torque_max = {env.torque_max!r}: puts about "
                            f"{T_ring:.4g} N*m on the ring in mode {mode}, beyond this design's "
                            f"static rating {rating:.4g} N*m")
            rows.append(row)
            continue
        try:
            with np.errstate(all="ignore"):
                m = efficiency_map(design, mode, env.speeds(), env.torques())
        except Exception as exc:     # noqa: BLE001 - kept as a row with its reason
            row["error"] = _reason(exc)
            rows.append(row)
            continue
        row["error"] = ""
        eta = np.asarray(m.eta, float)
        locked = np.asarray(m.locked, bool)
        ok = np.isfinite(eta) & ~locked
        row.update(n_points=int(ok.sum()), n_locked=int(locked.sum()),
                   eta_min=float(eta[ok].min()) if ok.any() else math.nan,
                   eta_mean=float(eta[ok].mean()) if ok.any() else math.nan,
                   eta_max=float(eta[ok].max()) if ok.any() else math.nan)
        means = {k: float(np.nanmean(np.asarray(m.losses[k], float)[ok])) if ok.any()
                 else math.nan for k in LOSS_NAMES}
        total = sum(means.values())
        for k in LOSS_NAMES:
            row[f"loss_{k}_W"] = means[k]
            row[f"loss_share_{k}"] = means[k] / total if total > 0 else math.nan
        row["error"] = row.pop("error")     # last column
        rows.append(row)
    return rows


def _reason(exc) -> str:
    """One line: a CycloidInputError's own message (it names the field), else the exception's
    type and message (a failure of the model on this design, not of the sweep)."""
    msg = " ".join(str(exc).split())
    return msg if isinstance(exc, CycloidInputError) else f"{type(exc).__name__}: {msg}"


def result_schema(spec):
    """The pyarrow schema of the sweep's rows, fixed before the first design is evaluated, so
    that every Parquet partition has the same columns and types (a partition of failed
    designs too): the columns of :func:`evaluate_design` in its order."""
    import pyarrow as pa
    f64 = pa.float64()
    if spec.method == "table":
        names = list(dict.fromkeys(k for row in spec.table for k in row))
        fields = [(k, pa.array([row.get(k) for row in spec.table]).type) for k in names]
        fields = [(k, pa.string() if t == pa.null() else t) for k, t in fields]
    else:
        fields = [(k, f64) for k in spec.fields]
    cols = [("design_id", pa.int64()), *fields, ("mode", pa.string()),
            ("stiffness_Nm_rad", f64), ("torsional_rigidity_Nm_arcmin", f64),
            ("lost_motion_arcmin", f64)]
    from model_core.design import design_from_dict
    calibrated = (any(k.startswith("calibration.") for k, _ in fields)
                  or not design_from_dict(spec.base).calibration.is_default)
    if calibrated:
        cols += [("calibrated", pa.bool_()), ("calibration_mesh_loss_k", f64),
                 ("calibration_idle_loss_scale", f64), ("calibration_load_loss_scale", f64),
                 ("calibration_source", pa.string())]
    cols += [("n_points", pa.int64()), ("n_locked", pa.int64()), ("eta_min", f64),
             ("eta_mean", f64), ("eta_max", f64)]
    for k in LOSS_NAMES:
        cols += [(f"loss_{k}_W", f64), (f"loss_share_{k}", f64)]
    cols.append(("error", pa.string()))
    return pa.schema(cols)


def evaluate_chunk(spec, chunk) -> list:
    """Rows for a list of (design_id, values): the unit of work sent to a worker."""
    out = []
    for i, values in chunk:
        out.extend(evaluate_design(spec, i, values))
    return out
