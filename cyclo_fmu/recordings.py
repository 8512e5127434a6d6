"""Read and check a bench recording before a diagnosis.

Schema (what ``cyclo-fmu bench`` and a real bench write, see ``bench.write_recording``):
``time_s, speed_in_rpm, torque_in_Nm, speed_out_rpm, torque_out_Nm`` and optionally
``temperature_C``; comma separated, one header row. Time in s; speeds signed r/min; torques in
N*m (``torque_in``: delivered into the reducer's input shaft; ``torque_out``: delivered by the
output shaft to the load, in the output shaft's sense of rotation); temperature in degC.
Speeds become rad/s here, once. A column mapping names other files' columns; extra columns
are ignored.

Nothing is dropped silently: a failed check raises ``RecordingError`` (one line naming the
column and the value); empty or NaN cells exclude their sample and are listed as
``Exclusion`` records on the ``Recording``.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REQUIRED = ("time_s", "speed_in_rpm", "torque_in_Nm", "speed_out_rpm", "torque_out_Nm")
OPTIONAL = ("temperature_C",)
SCHEMA = REQUIRED + OPTIONAL
MAX_EXCLUDED = 0.20          # share of samples that may be excluded for NaN
RAD_S_SUSPECT_RPM = 350.0    # a non-integer input speed at most this high looks like rad/s
N_MM_SUSPECT_NM = 1000.0     # an input torque above this looks like N*mm
POWER_RATIO_MIN = 0.01       # output/input power outside 0.01..100: a torque unit is off
RAD_S_PER_RPM = math.pi / 30


class RecordingError(ValueError):
    """A recording that cannot be diagnosed; the message names the column and the value."""


@dataclass(frozen=True)
class Exclusion:
    """Samples left out of a recording and why.

    ``reason`` e.g. "NaN in torque_in_Nm"; ``count`` samples; ``first_time`` s, time of the
    first excluded sample (NaN when that sample's time is itself missing)."""

    reason: str
    count: int
    first_time: float


@dataclass(frozen=True)
class Recording:
    """A checked recording in SI units; samples in time order, exclusions already removed."""

    time: np.ndarray                  # s
    speed_in: np.ndarray              # rad/s, signed
    torque_in: np.ndarray             # N*m, delivered into the reducer's input shaft
    speed_out: np.ndarray             # rad/s, signed
    torque_out: np.ndarray            # N*m, delivered by the output shaft to the load
    temperature: np.ndarray | None    # degC, or None when the file has no temperature
    exclusions: tuple                 # Exclusion records: what was left out and why
    source: str                       # file name or "<array>"

    @property
    def n(self) -> int:
        """Number of samples."""
        return len(self.time)

    @property
    def duration(self) -> float:
        """Last minus first time, s."""
        return float(self.time[-1] - self.time[0]) if self.n else 0.0

    @property
    def sample_rate(self) -> float:
        """Median of 1/dt, Hz (sampling need not be uniform)."""
        return float(np.median(1.0 / np.diff(self.time))) if self.n > 1 else float("nan")


def parse_column_map(text: str) -> dict:
    """``"time_s=t,torque_in_Nm=T22"`` -> ``{"time_s": "t", "torque_in_Nm": "T22"}``.

    Keys must be schema names; each may appear once."""
    out = {}
    for part in (p.strip() for p in text.split(",")):
        if not part:
            continue
        key, sep, name = (x.strip() for x in part.partition("="))
        if not sep or not key or not name or "=" in name:
            raise RecordingError(f"columns = {text!r}: entry {part!r} must be 'schema_name=file_name'")
        if key not in SCHEMA:
            raise RecordingError(f"columns: {key!r} is not a recording column ({', '.join(SCHEMA)})")
        if key in out:
            raise RecordingError(f"columns: {key!r} is mapped twice ({out[key]!r}, {name!r})")
        out[key] = name
    return out


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_recording(path, columns: dict | None = None, min_duration: float = 5.0,
                   min_samples: int = 200) -> Recording:
    """Read a recording CSV, check it and convert r/min to rad/s.

    ``columns`` maps schema names to the file's names (``{"time_s": "Time"}``); unmapped
    schema names are looked up under their own name. ``min_duration`` s and ``min_samples``
    apply after exclusions. Row numbers in messages are file lines (the header is row 1)."""
    path = Path(path)
    columns = dict(columns or {})
    for key in columns:
        if key not in SCHEMA:
            raise RecordingError(f"columns: {key!r} is not a recording column ({', '.join(SCHEMA)})")
    try:
        with path.open(newline="", encoding="utf-8-sig") as f:
            rows = [(i, r) for i, r in enumerate(csv.reader(f), start=1)
                    if any(c.strip() for c in r)]            # blank lines carry no samples
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise RecordingError(f"recording {str(path)!r} cannot be read ({exc})") from None
    if not rows:
        raise RecordingError(f"recording {str(path)!r} is empty")
    header = [h.strip() for h in rows[0][1]]
    if all(_is_number(h) for h in header if h):
        raise RecordingError(f"recording {str(path)!r} has no header row; the first row is "
                             f"{','.join(header)!r}, expected names like {','.join(REQUIRED)}")
    body = rows[1:]
    line = np.array([i for i, _ in body], int)
    data = {}
    for key in SCHEMA:
        name = columns.get(key, key)
        label = repr(name) if name == key else f"{name!r} ({key})"
        if name not in header:
            if key in OPTIONAL and key not in columns:
                continue
            raise RecordingError(f"column {label} is missing; found: {', '.join(header)}")
        if header.count(name) > 1:
            raise RecordingError(f"column {label} appears {header.count(name)} times in the header")
        j = header.index(name)
        vals = np.empty(len(body))
        for k, (i, row) in enumerate(body):
            text = row[j].strip() if j < len(row) else ""
            try:
                vals[k] = float(text) if text else np.nan      # empty or NaN: excluded later
            except ValueError:
                vals[k] = np.inf
            if np.isinf(vals[k]):
                raise RecordingError(f"column {label}, row {i}: {text!r} is not a number")
        data[key] = vals
    return _check(data, str(path), lambda k: f"row {line[k]}", min_duration, min_samples)


def recording_from_arrays(time, speed_in_rpm, torque_in_Nm, speed_out_rpm, torque_out_Nm,
                          temperature_C=None, min_duration=5.0, min_samples=200,
                          source="<array>") -> Recording:
    """The same checks and conversion as ``read_recording`` on arrays: time in s, speeds in
    r/min, torques in N*m, temperature in degC (or None). NaN marks a missing sample."""
    arrays = dict(zip(REQUIRED, (time, speed_in_rpm, torque_in_Nm, speed_out_rpm, torque_out_Nm)))
    if temperature_C is not None:
        arrays["temperature_C"] = temperature_C
    data = {k: np.asarray(v, float).ravel() for k, v in arrays.items()}
    n = len(data["time_s"])
    for key, v in data.items():
        if len(v) != n:
            raise RecordingError(f"column {key!r} has {len(v)} samples, time_s has {n}")
        bad = np.flatnonzero(np.isinf(v))
        if bad.size:
            raise RecordingError(f"column {key!r}, sample {bad[0]}: {v[bad[0]]} is not a number")
    return _check(data, source, lambda k: f"sample {k}", min_duration, min_samples)


def _check(data: dict, source: str, where, min_duration: float, min_samples: int) -> Recording:
    """Exclude NaN samples, check order, units and length; ``where(k)`` names sample k."""
    n = len(data["time_s"])
    if n == 0:
        raise RecordingError(f"recording {source!r} has no samples")
    t = data["time_s"]
    keep = np.ones(n, bool)
    exclusions = []
    for key, v in data.items():          # a sample is counted once, under its first NaN column
        bad = np.isnan(v) & keep
        if bad.any():
            first = t[np.flatnonzero(bad)[0]]
            exclusions.append(Exclusion(f"NaN in {key}", int(bad.sum()), float(first)))
            keep &= ~bad
    dropped = n - int(keep.sum())
    if dropped > MAX_EXCLUDED * n:
        raise RecordingError(
            f"{dropped} of {n} samples have NaN cells (more than {MAX_EXCLUDED:.0%}): "
            + "; ".join(f"{e.count} in {e.reason[7:]}" for e in exclusions))
    idx = np.flatnonzero(keep)
    data = {k: v[keep] for k, v in data.items()}
    t = data["time_s"]

    dt = np.diff(t)
    if np.any(dt <= 0):
        k = int(np.flatnonzero(dt <= 0)[0])
        how = "goes backwards" if dt[k] < 0 else "repeats"
        raise RecordingError(f"time_s {how} at {where(idx[k + 1])}: {t[k]:.9g} s then "
                             f"{t[k + 1]:.9g} s (samples must be in time order)")

    n_in = data["speed_in_rpm"]
    n_max = float(np.max(np.abs(n_in))) if n_in.size else 0.0
    if 0 < n_max <= RAD_S_SUSPECT_RPM and np.any(np.abs(n_in - np.round(n_in)) > 1e-6):
        raise RecordingError(
            f"speed_in_rpm peaks at {n_max:.6g}: that looks like rad/s, not r/min "
            f"(multiply by 30/pi = 9.549, or map the r/min column with columns=)")
    T_max = float(np.max(np.abs(data["torque_in_Nm"]))) if t.size else 0.0
    if T_max > N_MM_SUSPECT_NM:
        raise RecordingError(
            f"torque_in_Nm peaks at {T_max:.6g}: that looks like N*mm, not N*m "
            f"(divide by 1000, or map the N*m column with columns=)")

    # a factor 1000 on either torque (N*mm) shows in the power balance: a reducer passes between
    # a few per cent and 1/eta of the power between its shafts, driven or back-driven; the
    # bounds 1/100..100 leave all that room. Judged on samples where both shafts carry power.
    p_in = np.abs(data["torque_in_Nm"] * n_in)
    p_out = np.abs(data["torque_out_Nm"] * data["speed_out_rpm"])
    moving = ((p_in > 0.05 * float(np.max(p_in))) & (p_out > 0.05 * float(np.max(p_out)))
              if t.size else p_in > 0)
    if moving.sum() >= 10:
        ratio = float(np.mean(p_out[moving]) / max(np.mean(p_in[moving]), 1e-300))
        if not POWER_RATIO_MIN < ratio < 1 / POWER_RATIO_MIN:
            col = "torque_in_Nm" if ratio < 1 else "torque_out_Nm"
            raise RecordingError(
                f"{col}: the mean output power is {ratio:.3g} times the input power; a torque "
                "in N*mm (or a speed in the wrong unit) would do that")

    duration = float(t[-1] - t[0]) if t.size else 0.0
    if t.size < min_samples or duration < min_duration:
        raise RecordingError(
            f"time_s: the recording is too short: {t.size} samples over {duration:.6g} s after "
            f"exclusions; needs at least {min_samples} samples and {min_duration:g} s")
    return Recording(time=t, speed_in=n_in * RAD_S_PER_RPM, torque_in=data["torque_in_Nm"],
                     speed_out=data["speed_out_rpm"] * RAD_S_PER_RPM,
                     torque_out=data["torque_out_Nm"], temperature=data.get("temperature_C"),
                     exclusions=tuple(exclusions), source=source)
