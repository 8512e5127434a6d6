"""MDF4 (ASAM MDF, ``.mf4``/``.mdf``) recordings through ``asammdf`` (optional extra ``mdf``).

Channels are chosen by ``--columns`` or recognised by name (reported); units come from the
channels' own unit field (``--units`` overrides). Channels sampled on different rasters are
linearly interpolated onto one raster, the fastest channel's unless ``raster`` [s] is given;
the notes state which channels were resampled and from which rate.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..recordings import RecordingError
from .text import Table, _BlockAverager, _convert, resolve_units
from .units import map_columns

MDF_SUFFIXES = (".mf4", ".mdf", ".mf3", ".dat")


def is_mdf(path, head: bytes) -> bool:
    """MDF files start with the identification block 'MDF     '."""
    return head.startswith(b"MDF ") or Path(path).suffix.lower() in (".mf4", ".mdf", ".mf3")


def read_mdf(path, columns=None, units=None, block=None, raster=None) -> Table:
    path = Path(path)
    try:
        from asammdf import MDF
    except ImportError:
        raise RecordingError("reading MDF needs asammdf: pip install 'cyclo-fmu[mdf]'") from None
    try:
        mdf = MDF(str(path))
    except Exception as exc:                       # asammdf raises many kinds
        raise RecordingError(f"recording {str(path)!r} cannot be read as MDF ({exc})") from None
    try:
        masters = {mdf.groups[g].channels[i].name for g, i in mdf.masters_db.items()}
        names = [n for n in mdf.channels_db if not n.startswith("$") and n not in masters]
        # a master (time) channel is implicit in MDF; offer it under the name 'time'
        header = ["time"] + [n for n in names if n.lower() not in ("time", "t")]
        mapping, notes = map_columns(header, columns, units)
        sigs, rates = {}, {}
        for key, (j, name) in mapping.items():
            if key == "time_s" and name == "time" and (name in masters
                                                         or name not in mdf.channels_db):
                continue
            try:
                s = mdf.get(name)
            except Exception as exc:
                raise RecordingError(f"MDF channel {name!r} ({key}) cannot be read ({exc})") \
                    from None
            if s.samples.dtype.kind not in "fiu" or s.samples.ndim != 1:
                raise RecordingError(f"MDF channel {name!r} ({key}) is not a numeric scalar "
                                     f"signal ({s.samples.dtype})")
            sigs[key] = s
            dt = np.diff(s.timestamps)
            rates[key] = 1.0 / float(np.median(dt)) if dt.size else 0.0
        if not sigs:
            raise RecordingError(f"recording {str(path)!r}: no channels to read")
        # units: --units, then the channel's unit field (as a units row), then assumed
        unit_row = [""] * len(header)
        for key, s in sigs.items():
            unit_row[mapping[key][0]] = (s.unit or "").strip()
        unit_map, unit_notes = resolve_units(
            {k: v for k, v in mapping.items() if k in sigs or k != "time_s"}, header, unit_row,
            units)
        if "time_s" not in unit_map:
            unit_map["time_s"] = ("s", "MDF master channel")
        notes += unit_notes
        if raster:
            t = np.arange(min(s.timestamps[0] for s in sigs.values()),
                          max(s.timestamps[-1] for s in sigs.values()), float(raster))
            notes.append(f"all channels resampled onto a stated raster of {raster:g} s")
            ref = None
        else:
            ref = max(rates, key=rates.get)
            t = sigs[ref].timestamps.astype(float)
        data = {"time_s": t.copy()}
        resampled = []
        for key, s in sigs.items():
            if key == "time_s":
                continue
            ts = s.timestamps.astype(float)
            y = s.samples.astype(float)
            if ts.shape == t.shape and np.array_equal(ts, t):
                data[key] = y
            else:
                data[key] = np.interp(t, ts, y, left=np.nan, right=np.nan)
                resampled.append(f"{mapping[key][1]} ({rates[key]:.6g} Hz)")
        if resampled:
            notes.append(f"resampled by linear interpolation onto the "
                         f"{'stated' if raster else mapping[ref][1] + chr(39) + 's'} raster "
                         f"({1 / float(np.median(np.diff(t))):.6g} Hz): {', '.join(resampled)}; "
                         "samples outside a channel's span are left out as NaN")
        notes.insert(0, f"read as MDF {mdf.version}")
    finally:
        mdf.close()
    data = _convert(data, unit_map)
    n_raw = len(data["time_s"])
    excl = []
    if block:
        acc = _BlockAverager(list(data), block)
        acc.add(data)
        data, n_raw, excl = acc.result()
        notes.append(f"block means over {block:g} s: {n_raw} samples -> "
                     f"{len(data['time_s'])} blocks")
    return Table(data, notes, unit_map, str(path), lambda k: f"sample {k}", n_raw, block, excl)
