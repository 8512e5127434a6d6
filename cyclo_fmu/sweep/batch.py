"""Diagnose every recording in a folder (``cyclo-fmu diagnose-batch``).

One result folder per recording (diagnosis.json, design_updated.toml, the plot; as
``cyclo-fmu diagnose --out``) and ``summary.csv``, one row per recording (``error`` holds the
one-line reason for a recording that could not be diagnosed; no recording is dropped). With an
existing scheduler the workers write the folders, so they must see the same file system.
"""
from __future__ import annotations

from functools import partial
from pathlib import Path

#: Recording files picked up from the folder (lower-cased suffixes).
SUFFIXES = (".csv", ".mf4")


def calibration_report(design, d) -> dict | None:
    """The JSON key ``calibration_fit``: the calibration the diagnosis learned (effects
    ``mesh_loss``, ``idle_loss_scale``, ``load_loss_scale``; re-linearised until its changes
    settle, ``diagnosis.estimator.CAL_RELINEARISE``), or None when it named none. ``ci95``: the
    95 % half-widths (noise only), ``rms_*``: the held-out RMS of the input torque before and
    after the diagnosis, ``back_driven``: whether the recording's back-driven blocks tell k
    from a transducer gain (held out, ``select_effects.flow_told_apart``), ``back_driven_share``:
    the share of its moving blocks (above 1 rad/s, the calibration fit's rule) in which the
    input shaft gives power back."""
    from model_core.effects import CALIBRATION_FIELDS
    cal = {e["id"]: e for e in d.effects if e["id"] in CALIBRATION_FIELDS}
    if not cal:
        return None
    c = design.calibration
    out = {"mesh_loss_k": c.mesh_loss_k, "idle_loss_scale": c.idle_loss_scale,
           "load_loss_scale": c.load_loss_scale, "ci95": {},
           "rms_before_Nm": d.rmse_before_Nm, "rms_after_Nm": d.rmse_after_Nm, "notes": []}
    for eid, name in CALIBRATION_FIELDS.items():
        if eid in cal:
            p = cal[eid]["parameters"][f"{name}_change"]
            out[name] = getattr(c, name) + p["value"]
            out["ci95"][name] = 0.5 * (p["ci95"][1] - p["ci95"][0])
            alike = cal[eid].get("indistinguishable_from") or []
            if alike:
                out["notes"].append(f"{eid} cannot be told from {', '.join(alike)} in this "
                                    f"recording; to separate them: "
                                    f"{cal[eid]['separating_run']}")
    stages = getattr(d, "stages", None) or {}
    P = stages.get("replay")
    out["back_driven"] = d.back_driven
    if P is not None:       # the share of moving blocks where the input shaft gives power back
        import numpy as np
        b = P.blocks
        moving = np.abs(b["w_in"]) > 1.0
        out["back_driven_share"] = float(np.mean((b["T_in"] * b["w_in"])[moving] < 0)) \
            if moving.any() else 0.0
    out["source"] = ("cyclo-fmu diagnose: the calibration effects of the diagnosis "
                     "(model_core.effects), fitted on the recording's block means")
    return out


def diagnose_recording(rec, mode, checks, design, progress=False, calibrate=True,
                       bandwidth=None, with_effects=()):
    """Diagnose a loaded recording: ``(diagnosis, result dict)`` with the JSON contract's
    keys (the diagnosis's own, ``mode``, ``checks``, ``read_notes``, ``excluded``, and
    ``calibration_fit`` when a calibration effect is named). ``calibrate`` False leaves the
    calibration effects out of the candidates (``diagnose --no-calibrate``); ``bandwidth``
    [Hz]: the input torque transducer's (None: the Diagnoser's default); ``with_effects``:
    effects of ``model_core.effects.OPT_IN`` added to the candidates."""
    from threadpoolctl import threadpool_limits
    from cyclo_fmu.diagnosis import Diagnoser
    from model_core.effects import DEFAULT_CANDIDATES
    kw = {} if bandwidth is None else {"bandwidth": float(bandwidth)}
    if with_effects:
        kw["candidates"] = DEFAULT_CANDIDATES + tuple(
            e for e in with_effects if e not in DEFAULT_CANDIDATES)
    # one BLAS thread throughout, as in Diagnoser.fit: the updated design's check and the
    # calibration's report give the same numbers on any machine, and no BLAS thread is
    # woken to spin beside the diagnosis
    with threadpool_limits(limits=1, user_api="blas"):
        est = Diagnoser(design, mode, progress=progress, calibrate=calibrate, **kw).fit(rec)
        d = est.diagnosis_
        d.updated = est.updated_design()  # (design, notes), checked against the recording
        result = d.to_json()
        fit = calibration_report(design, d)
    if fit is not None:
        result["calibration_fit"] = fit
    result["mode"] = mode
    result["transducer_bandwidth_Hz"] = float(est.bandwidth)
    result["checks"] = list(checks)
    result["read_notes"] = list(rec.notes)
    excluded = [{"reason": e.reason, "count": e.count, "unit": "samples",
                 "first_time_s": e.first_time if e.first_time == e.first_time else None}
                for e in rec.exclusions]
    if d.excluded_blocks:
        from cyclo_fmu.diagnosis.residual import SPIKE_SIGMA
        excluded.append({"reason": f"residual spikes beyond {SPIKE_SIGMA:g} robust standard "
                         "deviations", "count": d.excluded_blocks, "unit": "blocks",
                         "first_time_s": None})
    result["exclusions"] = excluded
    result["excluded"] = excluded
    return d, result


def diagnose_one(path, design, mode, columns=None, units=None, calibrate=True):
    """Read and diagnose one recording: ``(diagnosis, result dict)``; ``mode`` may be 'auto'
    (resolved per recording from its speed ratio)."""
    from cyclo_fmu.io import load_recording
    rec, mode, checks = load_recording(path, mode, design, columns=columns, units=units)
    return diagnose_recording(rec, mode, checks, design, calibrate=calibrate)


def find_recordings(folder) -> list:
    """Recording files of ``folder`` (not recursive), sorted by name."""
    return sorted(p for p in Path(folder).iterdir()
                  if p.is_file() and p.suffix.lower() in SUFFIXES)


def _folder_names(paths) -> dict:
    stems = [p.stem for p in paths]
    return {p: (p.stem if stems.count(p.stem) == 1 else f"{p.stem}_{p.suffix[1:].lower()}")
            for p in paths}


#: summary.csv's columns, in order
SUMMARY_COLUMNS = ["recording", "folder", "mode", "effect", "rmse_before_mNm", "rmse_after_mNm",
                   "zeta_d_before", "zeta_d_after", "error"]
#: [s] serial cost of diagnosing one recording assumed for the backend choice: a floor, well
#: below the 1.8 s of CPU measured per 42-s "tiny" synthetic recording (benchmarks/bench_sweep.py
#: batch) and far above the pool's start-up (0.05 s), so two recordings already run in the pool.
SECONDS_PER_RECORDING = 0.3


def _task(design, mode, columns, out, item, units=None, calibrate=True):
    path, name = item
    from cyclo_fmu.diagnosis import write_diagnosis
    row = {"recording": path.name, "folder": name, "mode": "", "effect": "", "error": ""}
    try:
        d, result = diagnose_one(path, design, mode, columns, units, calibrate)
        write_diagnosis(Path(out) / name, d, design, result, source=path.name)
    except (ValueError, OSError) as exc:     # RecordingError, CycloidInputError, unreadable
        row["error"] = " ".join(str(exc).split())
        return row
    except Exception as exc:     # noqa: BLE001 - a fault on one file must not end the batch:
        # it is that file's row, named as an internal error (a bug to report, not bad input)
        import shutil
        shutil.rmtree(Path(out) / name, ignore_errors=True)
        row["error"] = " ".join(f"internal error ({type(exc).__name__}: {exc})".split())[:500]
        return row
    row.update(mode=result["mode"], effect=result["effect"],
               rmse_before_mNm=1e3 * result["rmse_before_Nm"],
               rmse_after_mNm=1e3 * result["rmse_after_Nm"],
               zeta_d_before=result["zeta_d_before"], zeta_d_after=result["zeta_d_after"])
    return row


def read_summary(path):
    """``summary.csv`` as a DataFrame (text columns as text: an empty error stays "")."""
    import pandas as pd
    text = {"recording": str, "folder": str, "mode": str, "effect": str, "error": str}
    return pd.read_csv(path, dtype=text, keep_default_na=False,
                       na_values={c: [""] for c in SUMMARY_COLUMNS if c not in text})


def diagnose_batch(folder, out, design, mode, *, columns=None, units=None, scheduler=None,
                   workers=None, serial=False, progress=True, calibrate=True, backend=None):
    """Diagnose every recording of ``folder`` into ``out``; returns the summary DataFrame
    (read back from ``out/summary.csv``, which gets each row as its recording is done, in
    the order of the files: nothing but the rows in flight is held in memory)."""
    import csv
    from .cluster import choose_backend, stream_tasks
    paths = find_recordings(folder)
    names = _folder_names(paths)
    if backend is None:
        backend = choose_backend(len(paths), SECONDS_PER_RECORDING, workers=workers,
                                 scheduler=scheduler, serial=serial)
    summary = Path(out) / "summary.csv"
    with open(summary, "w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=SUMMARY_COLUMNS)
        w.writeheader()
        f.flush()
        for row in stream_tasks(partial(_task, design, mode, columns, str(out), units=units,
                                        calibrate=calibrate),
                                ((p, names[p]) for p in paths), backend=backend,
                                workers=workers, scheduler=scheduler, progress=progress,
                                desc="diagnose", total=len(paths)):
            w.writerow(row)
            f.flush()
    return read_summary(summary)
