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

import math
from dataclasses import dataclass, field, replace

import numpy as np

REQUIRED = ("time_s", "speed_in_rpm", "torque_in_Nm", "speed_out_rpm", "torque_out_Nm")
OPTIONAL = ("temperature_C",)
SCHEMA = REQUIRED + OPTIONAL
MAX_EXCLUDED = 0.20          # share of samples that may be excluded for NaN
#: [s] a time column whose first stamp lies in this range is Unix time (seconds since
#: 1970-01-01 UTC: 2001-09-09 to 2099-12-04), as data loggers write it; it is referred to its
#: first stamp. A bench run does not last 31 years: a relative time there is no measurement
#: (``io.checks.ABSURD``)
UNIX_TIME_S = (1e9, 4.1e9)
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
    notes: tuple = ()                 # what reading did: dialect, mapping, units, resampling
    units: dict = field(default_factory=dict)   # column -> (unit in the file, where it came from)
    checks: tuple = ()                # plausibility findings (cyclo_fmu.io.checks)
    raw_samples: int = 0              # samples in the file (> n when block means were taken)

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


def read_recording(path, columns: dict | None = None, min_duration: float = 5.0,
                   min_samples: int = 200, units: dict | None = None, block: float | None = None,
                   check: bool = True, raster: float | None = None) -> Recording:
    """Read a recording (CSV/ASCII of any common dialect, or MDF4), check it and convert to SI.

    The front door of ``cyclo_fmu.io``: the format is chosen by content (MDF's identification
    block) and extension; see ``cyclo_fmu.io.text`` and ``cyclo_fmu.io.mdf``. ``columns`` maps
    schema names to the file's names (``{"time_s": "Time"}``); ``units`` gives a column's unit
    (``{"torque_in_Nm": "N*mm"}``); both override anything detected. ``block`` [s] returns means
    over blocks of that length, averaged while reading (chunked: for recordings too large for
    memory). ``min_duration`` s and ``min_samples`` apply after exclusions. ``check`` runs the
    mode-independent plausibility checks (``cyclo_fmu.io.checks.check_units``). ``raster`` [s]:
    the time step MDF channels are resampled onto (default: the fastest channel's). Row numbers in
    messages are file lines (the header is row 1 when there are no metadata lines)."""
    from .io import read_table
    from .io.checks import check_magnitudes, check_units
    tab = read_table(path, columns=columns, units=units, block=block, raster=raster)
    rec = _check(tab.data, tab.source, tab.line_of, min_duration, min_samples,
                 pre_exclusions=tab.exclusions, notes=tuple(tab.notes),
                 units={k: v for k, v in tab.units.items()}, raw_samples=tab.raw_samples,
                 magnitudes=check_magnitudes)
    if check:
        findings = check_units(rec, units_given=tuple(units or ()))
        rec = replace(rec, checks=tuple(findings))
    return rec


def recording_from_arrays(time, speed_in_rpm, torque_in_Nm, speed_out_rpm, torque_out_Nm,
                          temperature_C=None, min_duration=5.0, min_samples=200,
                          source="<array>", check: bool = True) -> Recording:
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
    from .io.checks import check_magnitudes, check_units
    rec = _check(data, source, lambda k: f"sample {k}", min_duration, min_samples,
                 magnitudes=check_magnitudes)
    if check:
        rec = replace(rec, checks=tuple(check_units(rec)))
    return rec


def _unix_time(data: dict, notes) -> tuple:
    """(data, notes) with a Unix time column (``UNIX_TIME_S``) referred to its first stamp and
    a note naming that stamp; unchanged otherwise."""
    t = data["time_s"]
    fin = np.flatnonzero(np.isfinite(t))
    if not fin.size or not UNIX_TIME_S[0] <= t[fin[0]] <= UNIX_TIME_S[1]:
        return data, notes
    import datetime
    t0 = float(t[fin[0]])
    start = datetime.datetime.fromtimestamp(t0, datetime.timezone.utc)
    note = (f"time_s read as Unix time (s since 1970-01-01 UTC): referred to its first stamp, "
            f"{start.isoformat(timespec='milliseconds').replace('+00:00', ' UTC')}")
    return dict(data, time_s=t - t0), tuple(notes) + (note,)


def _check(data: dict, source: str, where, min_duration: float, min_samples: int,
           pre_exclusions=(), notes=(), units=None, raw_samples=None,
           magnitudes=None) -> Recording:
    """Exclude NaN samples, average duplicated timestamps, check order and length;
    ``where(k)`` names sample k. Units and plausibility: ``cyclo_fmu.io.checks``."""
    n = len(data["time_s"])
    if n == 0:
        raise RecordingError(f"recording {source!r} has no samples")
    data, notes = _unix_time(data, notes)
    if magnitudes is not None:
        magnitudes(data, where)
    t = data["time_s"]
    keep = np.ones(n, bool)
    exclusions = [Exclusion(r, int(c), float("nan")) for r, c in pre_exclusions]
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
    if dropped:
        idx = np.flatnonzero(keep)
        data = {k: v[keep] for k, v in data.items()}
    else:
        idx = range(n)                   # no copy of a long recording when nothing is left out
    t = data["time_s"]

    dt = np.diff(t)
    if np.any(dt < 0):
        k = int(np.flatnonzero(dt < 0)[0])
        raise RecordingError(f"time_s goes backwards at {where(idx[k + 1])}: {t[k]:.9g} s then "
                             f"{t[k + 1]:.9g} s (samples must be in time order)")
    if np.any(dt == 0):
        # a repeated timestamp (loggers write one when a buffer is flushed): the samples of
        # one time become their mean, counted as an exclusion
        k = int(np.flatnonzero(dt == 0)[0])
        first = float(t[k])
        starts = np.flatnonzero(np.r_[True, dt != 0])
        counts = np.diff(np.r_[starts, t.size])
        data = {key: np.add.reduceat(v, starts) / counts for key, v in data.items()}
        data["time_s"] = t[starts]
        merged = int(t.size - starts.size)
        exclusions.append(Exclusion(f"duplicated timestamp: {merged} samples averaged into the "
                                    f"sample of the same time (first at {where(idx[k + 1])})",
                                    merged, first))
        t = data["time_s"]
    n_in = data["speed_in_rpm"]

    duration = float(t[-1] - t[0]) if t.size else 0.0
    # block means: the raw samples behind them count (minus the samples excluded)
    n_eff = t.size if not raw_samples or raw_samples <= n else \
        raw_samples - sum(e.count for e in exclusions)
    if n_eff < min_samples or duration < min_duration:
        raise RecordingError(
            f"time_s: the recording is too short: {t.size} samples over {duration:.6g} s after "
            f"exclusions; needs at least {min_samples} samples and {min_duration:g} s")
    return Recording(time=t, speed_in=n_in * RAD_S_PER_RPM, torque_in=data["torque_in_Nm"],
                     speed_out=data["speed_out_rpm"] * RAD_S_PER_RPM,
                     torque_out=data["torque_out_Nm"], temperature=data.get("temperature_C"),
                     exclusions=tuple(exclusions), source=source, notes=tuple(notes),
                     units=dict(units or {}), raw_samples=int(raw_samples or n))
