"""Read and check a bench recording before a diagnosis.

Schema (what ``cyclo-fmu bench`` and a real bench write): ``time_s, speed_in_rpm,
torque_in_Nm, speed_out_rpm, torque_out_Nm`` and optionally ``temperature_C``. Speeds are
signed r/min and become rad/s here, once. A column mapping renames other files' columns.
Nothing is dropped silently: a failed check raises ``RecordingError`` naming the column and
the value; NaN samples are excluded and listed as ``Exclusion`` records.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REQUIRED = ("time_s", "speed_in_rpm", "torque_in_Nm", "speed_out_rpm", "torque_out_Nm")
OPTIONAL = ("temperature_C",)
MAX_EXCLUDED = 0.2


class RecordingError(ValueError):
    """A recording that cannot be diagnosed; the message names the column and the value."""


@dataclass(frozen=True)
class Exclusion:
    reason: str
    count: int
    first_time: float


@dataclass(frozen=True)
class Recording:
    time: np.ndarray          # s
    speed_in: np.ndarray      # rad/s
    torque_in: np.ndarray     # N*m, delivered into the reducer's input shaft
    speed_out: np.ndarray     # rad/s
    torque_out: np.ndarray    # N*m, delivered by the output shaft to the load
    temperature: np.ndarray | None
    exclusions: tuple
    source: str

    @property
    def n(self) -> int:
        return len(self.time)

    @property
    def duration(self) -> float:
        return float(self.time[-1] - self.time[0]) if self.n else 0.0

    @property
    def sample_rate(self) -> float:
        return float(1.0 / np.median(np.diff(self.time)))


def parse_column_map(text: str) -> dict:
    """'time_s=t,torque_in_Nm=T22' -> {'time_s': 't', 'torque_in_Nm': 'T22'}."""
    out = {}
    for part in (p.strip() for p in text.split(",") if p.strip()):
        if part.count("=") != 1:
            raise RecordingError(f"columns = {text!r}: each entry must be 'schema_name=file_name'")
        k, v = (x.strip() for x in part.split("="))
        if k not in REQUIRED + OPTIONAL:
            raise RecordingError(f"columns: {k!r} is not a recording column "
                                 f"({', '.join(REQUIRED + OPTIONAL)})")
        out[k] = v
    return out


def read_recording(path, columns: dict | None = None, min_duration: float = 5.0,
                   min_samples: int = 200) -> Recording:
    """Read a recording CSV, check it, convert r/min to rad/s."""
    path = Path(path)
    try:
        with path.open(newline="") as f:
            rows = list(csv.reader(f))
    except OSError as exc:
        raise RecordingError(f"recording {str(path)!r} cannot be read ({exc.strerror})")
    if not rows or not rows[0]:
        raise RecordingError(f"recording {str(path)!r} is empty")
    header = [h.strip() for h in rows[0]]
    names = {k: (columns or {}).get(k, k) for k in REQUIRED + OPTIONAL}
    data = {}
    for key in REQUIRED + OPTIONAL:
        col = names[key]
        if col not in header:
            if key in OPTIONAL:
                continue
            raise RecordingError(f"column {col!r} ({key}) is missing; found: {', '.join(header)}")
        j = header.index(col)
        vals = np.empty(len(rows) - 1)
        for i, row in enumerate(rows[1:]):
            text = row[j].strip() if j < len(row) else ""
            if text == "" or text.lower() == "nan":
                vals[i] = np.nan
                continue
            try:
                vals[i] = float(text)
            except ValueError:
                raise RecordingError(f"column {col!r}, row {i + 2}: {text!r} is not a number")
        data[key] = vals
    return recording_from_arrays(data["time_s"], data["speed_in_rpm"], data["torque_in_Nm"],
                                 data["speed_out_rpm"], data["torque_out_Nm"],
                                 data.get("temperature_C"), min_duration, min_samples,
                                 source=str(path))


def recording_from_arrays(time, speed_in_rpm, torque_in_Nm, speed_out_rpm, torque_out_Nm,
                          temperature_C=None, min_duration=5.0, min_samples=200,
                          source="<array>") -> Recording:
    cols = {"time_s": np.asarray(time, float), "speed_in_rpm": np.asarray(speed_in_rpm, float),
            "torque_in_Nm": np.asarray(torque_in_Nm, float),
            "speed_out_rpm": np.asarray(speed_out_rpm, float),
            "torque_out_Nm": np.asarray(torque_out_Nm, float)}
    if temperature_C is not None:
        cols["temperature_C"] = np.asarray(temperature_C, float)
    n = len(cols["time_s"])
    if any(len(v) != n for v in cols.values()):
        raise RecordingError("columns have different lengths")
    if n == 0:
        raise RecordingError("the recording has no samples")
    keep = np.ones(n, bool)
    exclusions = []
    t = cols["time_s"]
    for key, v in cols.items():
        bad = ~np.isfinite(v) & keep
        if bad.any():
            first = t[np.flatnonzero(bad)[0]]
            exclusions.append(Exclusion(f"NaN in {key}", int(bad.sum()),
                                        float(first) if math.isfinite(first) else float("nan")))
            keep &= ~bad
    if (~keep).sum() > MAX_EXCLUDED * n:
        raise RecordingError(f"{int((~keep).sum())} of {n} samples have NaN values "
                             f"(more than {MAX_EXCLUDED:.0%}): " + "; ".join(
                                 f"{e.reason}: {e.count}" for e in exclusions))
    cols = {k: v[keep] for k, v in cols.items()}
    t = cols["time_s"]
    dt = np.diff(t)
    if np.any(dt <= 0):
        i = int(np.flatnonzero(dt <= 0)[0])
        raise RecordingError(f"time_s goes {'backwards' if dt[i] < 0 else 'nowhere'} at sample "
                             f"{i + 2}: {t[i]!r} then {t[i + 1]!r}")
    vmax = float(np.max(np.abs(cols["speed_in_rpm"])))
    if 0 < vmax <= 350 and np.any(np.abs(cols["speed_in_rpm"] - np.round(cols["speed_in_rpm"], 1)) > 1e-9):
        raise RecordingError(f"speed_in_rpm peaks at {vmax:.4g}: that looks like rad/s, not r/min "
                             "(convert, or map the right column)")
    # a torque or speed column in the wrong unit shows in the power balance: a reducer passes
    # between about 5 % and 100 % of its input power; a factor of 1000 (N*mm) or 9.5 (r/min vs
    # rad/s on one shaft) cannot hide
    p_in = float(np.mean(np.abs(cols["torque_in_Nm"] * cols["speed_in_rpm"])))
    p_out = float(np.mean(np.abs(cols["torque_out_Nm"] * cols["speed_out_rpm"])))
    if p_in > 0 and p_out > 0 and not 0.05 < p_out / p_in < 1.2:
        ratio = p_out / p_in
        col = "torque_in_Nm" if ratio < 1 else "torque_out_Nm"
        raise RecordingError(f"{col}: the mean output power is {ratio:.3g} times the input power; "
                             "a torque in N*mm (or a speed in the wrong unit) would do that")
    duration = float(t[-1] - t[0]) if len(t) else 0.0
    if len(t) < min_samples or duration < min_duration:
        raise RecordingError(f"the recording is too short: {len(t)} samples over {duration:.3g} s "
                             f"(needs at least {min_samples} samples and {min_duration} s)")
    rpm = math.pi / 30
    return Recording(time=t, speed_in=cols["speed_in_rpm"] * rpm, torque_in=cols["torque_in_Nm"],
                     speed_out=cols["speed_out_rpm"] * rpm, torque_out=cols["torque_out_Nm"],
                     temperature=cols.get("temperature_C"), exclusions=tuple(exclusions),
                     source=source)
