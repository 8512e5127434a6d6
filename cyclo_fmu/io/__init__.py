"""Readers of bench recordings (pvlib ``iotools`` style: one reader per format, one schema).

- ``text.read_text``: CSV/ASCII, any common dialect (delimiter, decimal comma, metadata lines,
  units row, units in names, utf-8/utf-8-BOM/cp1252/utf-16);
- ``mdf.read_mdf``: MDF4 through asammdf (optional extra ``mdf``), resampled onto one raster.

Each returns a ``Table`` in the schema's edge units (s, r/min, N*m, degC);
``cyclo_fmu.recordings.read_recording`` turns it into a checked ``Recording`` in SI units, and
``load_recording`` adds the mode-dependent plausibility checks (``checks.check_plausibility``).
"""
from __future__ import annotations

from pathlib import Path

from ..recordings import Recording, RecordingError, parse_column_map, read_recording
from .units import parse_units

__all__ = ["read_table", "read_recording", "load_recording", "parse_units", "parse_column_map",
           "Recording", "RecordingError"]


def read_table(path, columns=None, units=None, block=None, raster=None):
    """Dispatch by content (MDF identification block) and extension."""
    from .mdf import is_mdf, read_mdf
    from .text import read_text
    path = Path(path)
    try:
        with path.open("rb") as f:
            head = f.read(8)
    except OSError as exc:
        raise RecordingError(f"recording {str(path)!r} cannot be read ({exc})") from None
    if is_mdf(path, head):
        return read_mdf(path, columns, units, block, raster)
    return read_text(path, columns, units, block)


#: [bytes] files larger than this are read as 10 ms block means when ``block="auto"``: about
#: 13 million samples of a five-column CSV; the diagnosis works on 10 ms means anyway
AUTO_BLOCK_BYTES = 512 << 20
#: [s] the diagnosis's block length (its residual statistics use 10 ms means)
AUTO_BLOCK_S = 0.01


def load_recording(path, mode, design=None, columns=None, units=None, block="auto"):
    """Read, check and resolve the mode: ``(rec, mode, checks)``.

    ``block`` [s]: read block means of that length (chunked, for recordings larger than memory);
    ``"auto"``: 10 ms block means for files above ``AUTO_BLOCK_BYTES``, every sample otherwise;
    None: every sample.

    ``columns``/``units`` are dicts or the CLI's text ('time_s=t,...', 'torque_in_Nm=N*mm,...');
    ``mode`` one of the six modes or 'auto'. ``checks`` is the list of findings (dicts with
    ``id``, ``status``, ``message``); a finding with status "error" raises ``RecordingError``
    (one line: what was found, the likely cause, the override) instead."""
    from dataclasses import replace
    from .checks import check_plausibility
    if isinstance(columns, str):
        columns = parse_column_map(columns)
    if isinstance(units, str):
        units = parse_units(units)
    if str(mode).strip().lower() != "auto":
        from model_core.kinematics import parse_mode
        try:
            parse_mode(mode)
        except ValueError as exc:
            raise RecordingError(f"mode {mode!r}: {exc}; or 'auto'") from None
    if block == "auto":
        try:
            big = Path(path).stat().st_size > AUTO_BLOCK_BYTES
        except OSError:
            big = False                      # read_recording names the problem
        block = AUTO_BLOCK_S if big else None
    rec = read_recording(path, columns, units=units, block=block, check=False)
    mode, findings = check_plausibility(rec, mode, design, tuple(units or ()))
    rec = replace(rec, checks=tuple(findings))
    return rec, mode, findings
