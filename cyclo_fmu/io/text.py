"""CSV / ASCII recordings (comma, semicolon, tab or whitespace separated; decimal point or comma).

The dialect is detected on the first 64 KiB: encoding (BOM, NUL bytes, else utf-8 then cp1252),
delimiter and decimal separator (the choice that makes the most lines numeric with one field
count), the header (the last text line of that width before the data), a units row under the
header and metadata lines above it (catman-style ASCII exports); each is reported in the
recording's notes. The bulk is parsed by pyarrow's C++ CSV reader (pandas' C engine for
whitespace); Python walks the lines only to name the row of an error.
"""
from __future__ import annotations

import codecs
import csv
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..recordings import RecordingError
from .units import (EDGE_UNIT, QUANTITY, map_columns, quantity_of_unit, split_name_unit,
                    unit_conversion)

SNIFF_BYTES = 64 * 1024         # enough for a metadata block plus hundreds of data lines
SNIFF_LINES = 300               # lines the dialect is scored on
DATA_RUN = 3                    # consecutive numeric lines that mark the start of the data
_NUM = re.compile(r"^[+-]?(\d+([.,]\d*)?|[.,]\d+)([eE][+-]?\d+)?$|^[+-]?(inf|nan|infinity)$",
                  re.IGNORECASE)
_DELIMS = (";", "\t", ",", " ")  # " " stands for runs of whitespace


@dataclass
class Dialect:
    encoding: str
    delimiter: str              # ";", "\t", "," or " " (whitespace)
    decimal: str                # "." or ","
    header_line: int            # 0-based file line of the header
    units_line: int | None      # 0-based file line of the units row, or None
    first_data_line: int        # 0-based
    header: list
    units_row: list | None
    meta: list = field(default_factory=list)    # metadata lines above the header


def detect_encoding(raw: bytes) -> str:
    """Encoding from the BOM, NUL bytes (UTF-16 without BOM) or a trial decode."""
    if raw.startswith(codecs.BOM_UTF8):
        return "utf-8-sig"
    if raw.startswith(codecs.BOM_UTF16_LE) or raw.startswith(codecs.BOM_UTF16_BE):
        return "utf-16"
    if raw[:4096].count(b"\x00") > len(raw[:4096]) // 4:
        even_nuls = raw[0:4096:2].count(b"\x00")
        odd_nuls = raw[1:4096:2].count(b"\x00")
        return "utf-16-le" if odd_nuls > even_nuls else "utf-16-be"
    try:
        raw.decode("utf-8")
        return "utf-8"
    except UnicodeDecodeError as exc:
        if exc.start > len(raw) - 4:          # cut in the middle of a character
            return "utf-8"
        return "cp1252"


def _split(line: str, delim: str):
    if delim == " ":
        return line.split()
    if '"' in line:
        return next(csv.reader([line], delimiter=delim))
    return line.split(delim)


def _is_num(cell: str, decimal: str) -> bool:
    c = cell.strip()
    if not c:
        return True                            # an empty cell is a missing sample
    if not _NUM.match(c):
        return False
    return decimal == "," or "," not in c


def _numeric(cells, decimal):
    """A data line: at least two numbers and numbers in most filled cells (a text column such
    as a comment may ride along)."""
    filled = [c for c in cells if c.strip()]
    nums = sum(_is_num(c, decimal) for c in filled)
    return nums >= 2 and nums > len(filled) / 2


def _best_dialect(lines):
    """(score, delimiter, decimal, width): the choice that makes the most lines numeric with
    one field count; None when no line is numeric."""
    best = None
    filled = [l for l in lines if l.strip()]
    for delim in _DELIMS:
        split = [_split(l, delim) for l in filled]      # once for both decimals
        for decimal in ((".",) if delim == "," else (".", ",")):
            widths = {}
            for cells in split:
                if len(cells) >= 2 and _numeric(cells, decimal):
                    widths[len(cells)] = widths.get(len(cells), 0) + 1
            if not widths:
                continue
            width, count = max(widths.items(), key=lambda kv: (kv[1], kv[0]))
            # prefer the point when both decimals read the same lines (no comma in numbers)
            score = (count, width, decimal == ".")
            if best is None or score > best[0]:
                best = (score, delim, decimal, width)
    return best


#: characters of a cell or line echoed in an error message (a 20 MB cell is not echoed whole)
ECHO_CHARS = 60


def clip(text: str, n: int = ECHO_CHARS) -> str:
    """``repr`` of ``text`` cut to ``n`` characters, saying how long it was."""
    text = str(text)
    if len(text) <= n:
        return repr(text)
    return f"{text[:n]!r}... ({len(text)} characters)"


def sniff(text: str, encoding: str, source: str) -> Dialect:
    lines = text.splitlines()
    cut = False
    if len(text) >= SNIFF_BYTES // 2 and not text.endswith("\n") and lines:
        lines = lines[:-1]                     # the sample may end mid-line
        cut = True
    if not any(l.strip() for l in lines):
        if cut:
            raise RecordingError(f"recording {source!r}: its first {SNIFF_BYTES // 1024} KiB "
                                 "hold no line break (one line longer than that is no "
                                 "recording's row); a CSV/ASCII recording has one sample a line")
        raise RecordingError(f"recording {source!r} is empty")
    best = _best_dialect(lines[:SNIFF_LINES]) or _best_dialect(lines[SNIFF_LINES:])
    if best is None and cut and len(lines) < SNIFF_LINES:
        raise RecordingError(f"recording {source!r}, line {len(lines) + 1}: longer than "
                             f"{SNIFF_BYTES // 1024} KiB with no line break (no recording's "
                             "row is); a CSV/ASCII recording has one sample a line")
    if best is None:
        first = next(l for l in lines if l.strip())
        delim = max(_DELIMS[:3], key=first.count) if any(d in first for d in _DELIMS[:3]) else " "
        cells = [c.strip() for c in _split(first, delim)]
        if all(_is_num(c, ".") for c in cells):
            raise RecordingError(f"recording {source!r} has too few columns to be a recording")
        raise RecordingError(f"recording {source!r} has no samples (only text lines, the "
                             f"first is {clip(first.strip())})")
    _, delim, decimal, width = best
    cells = [_split(l, delim) if l.strip() else None for l in lines]
    num = [c is not None and len(c) == width and _numeric(c, decimal) for c in cells]
    start = None
    nonblank = [i for i, c in enumerate(cells) if c is not None]
    for pos, i in enumerate(nonblank):
        run = nonblank[pos:pos + DATA_RUN]
        if all(num[j] for j in run):
            start = i
            break
    if start is None:
        start = next(i for i in nonblank if num[i])
    above = [i for i in nonblank if i < start]
    if not above:
        raise RecordingError(
            f"recording {source!r} has no header row; the first row is "
            f"{clip(lines[start].strip())}, expected names like "
            "time_s,speed_in_rpm,torque_in_Nm,speed_out_rpm,torque_out_Nm")
    # header: the last text line of the data's width above the data; a line between it and
    # the data is a units row
    header_line, units_line = None, None
    for i in reversed(above):
        c = _header_cells(lines[i], delim, width)
        if c is not None and not _numeric(c, decimal):
            if header_line is not None:
                units_line, header_line = header_line, i
                break
            header_line = i
            # is it a units row under a header?
            if _looks_like_units(c):
                continue
            break
    if header_line is None:
        raise RecordingError(f"recording {source!r}: no header row of {width} names found above "
                             f"the first data row (line {start + 1})")
    if units_line is not None and not _looks_like_units(_header_cells(lines[units_line], delim,
                                                                      width)):
        units_line = None
    between = [i for i in above if header_line < i < start and i != units_line]
    if between:
        raise RecordingError(f"recording {source!r}, line {between[0] + 1}: "
                             f"{lines[between[0]].strip()[:60]!r} between the header and the "
                             "data is neither a units row nor data")
    header = [h.strip().strip('"') for h in _header_cells(lines[header_line], delim, width)]
    units_row = ([u.strip().strip('"') for u in _header_cells(lines[units_line], delim, width)]
                 if units_line is not None else None)
    meta = [lines[i].strip() for i in above if i < header_line]
    return Dialect(encoding, delim, decimal, header_line, units_line, start, header, units_row,
                   meta)


def _header_cells(line, delim, width):
    c = _split(line, delim)
    if len(c) == width:
        return c
    if len(c) == width - 1:                    # data rows end with a delimiter, the header not
        return c + [""]
    if len(c) == width + 1 and not c[-1].strip():
        return c[:-1]
    if delim == " ":                           # names with spaces: 'time [s]  torque_in [N*m]'
        c = [x for x in re.split(r"\t|\s{2,}", line.strip()) if x]
        if len(c) == width:
            return c
    return None


def _looks_like_units(cells) -> bool:
    vals = [c.strip().strip('"') for c in cells if c.strip()]
    return bool(vals) and sum(quantity_of_unit(v) is not None for v in vals) >= len(vals) / 2


@dataclass
class Table:
    """Columns in the schema's edge units (s, r/min, N*m, degC) plus what reading did."""
    data: dict
    notes: list
    units: dict                 # schema column -> (unit text, where it came from)
    source: str
    line_of: object             # k -> "row N" (file line of the k-th data row), on demand
    raw_samples: int
    block: float | None = None
    exclusions: list = field(default_factory=list)   # (reason, count) found while reading


def resolve_units(mapping, header, units_row, units):
    """Unit of every mapped column: --units, then the column name, then the units row, then
    the schema's edge unit (reported as assumed unless the name is the schema name)."""
    out, notes = {}, []
    for key, (j, name) in mapping.items():
        q = QUANTITY[key]
        if key in (units or {}):
            out[key] = (units[key], "--units")
            continue
        base, u = split_name_unit(name)
        if name == key:                        # the schema's own name carries its unit
            out[key] = (EDGE_UNIT[q], "schema name")
            continue
        if u is not None and unit_conversion(q, u) is not None:
            out[key] = (u, "column name")
            continue
        if units_row is not None and units_row[j] and unit_conversion(q, units_row[j]):
            out[key] = (units_row[j], "units row")
            continue
        if u is not None or (units_row is not None and units_row[j]):
            bad = u if u is not None else units_row[j]
            raise RecordingError(f"column {name!r} ({key}): unit {bad!r} is not a {q} unit; "
                                 f"give it with --units {key}=UNIT")
        out[key] = (EDGE_UNIT[q], "assumed")
        notes.append(f"column {name!r} ({key}) has no unit; {EDGE_UNIT[q]} assumed "
                     f"(override with --units {key}=UNIT)")
    for key, (u, src) in out.items():
        q = QUANTITY[key]
        f, off, sign = unit_conversion(q, u)
        if (f, off, sign) != (1.0, 0.0, 1.0):
            notes.append(f"{key}: converted from {u} ({src}) to {EDGE_UNIT[q]}")
    return out, notes


def _convert(data, units):
    for key, (u, _) in units.items():
        f, off, sign = unit_conversion(QUANTITY[key], u)
        if (f, off, sign) != (1.0, 0.0, 1.0):
            with np.errstate(over="ignore"):
                data[key] = sign * (f * data[key] + off)
    return data


class _Locator:
    """Row-level detail for error messages only: walks the file's lines with the dialect."""

    def __init__(self, path, d: Dialect, mapping):
        self.path, self.d, self.mapping = path, d, mapping

    def _rows(self):
        # bytes the detected encoding cannot decode (beyond the sniffed sample) show as U+FFFD
        with open(self.path, encoding=self.d.encoding, errors="replace", newline="") as f:
            for i, line in enumerate(f):
                if i < self.d.first_data_line:
                    continue
                line = line.rstrip("\r\n")
                if line.strip():
                    yield i + 1, line

    def line_of(self, k: int) -> str:
        for n, (line_no, _) in enumerate(self._rows()):
            if n == k:
                return f"row {line_no}"
        return f"data row {k + 1}"

    def cell_of(self, parser_message: str) -> str | None:
        """The row of a cell the bulk parser refused ("In CSV column #2: ... invalid value
        '-0.30 '") that the line-wise check reads (spaces around a number): named as written."""
        m = re.search(r"column #(\d+).*?invalid value '(.*?)'", parser_message, re.S)
        if not m:
            return None
        j, text = int(m.group(1)), m.group(2)
        if j >= len(self.d.header):
            return None
        name = self.d.header[j].strip()
        for line_no, line in self._rows():
            try:
                cells = _split(line, self.d.delimiter)
            except csv.Error:
                continue
            if len(cells) > j and cells[j] == text:
                return (f"column {name!r}, row {line_no}: {clip(text)} is not a number as "
                        "written (spaces or characters around it); fix that cell")
        return None

    def first_problem(self) -> str | None:
        width = len(self.d.header)
        for line_no, line in self._rows():
            if "\ufffd" in line:
                return (f"row {line_no}: bytes that are not {self.d.encoding} (the encoding "
                        f"detected on the first {SNIFF_BYTES // 1024} KiB): "
                        f"{clip(line.strip())}; fix that row or save the file in one encoding")
            if line.count('"') % 2:
                return (f"row {line_no}: an unbalanced quote (\") in {clip(line.strip())}: the "
                        "rows after it would be read as one text cell; fix or delete that row")
            try:
                cells = _split(line, self.d.delimiter)
            except csv.Error:
                return f"row {line_no}: {clip(line.strip())} cannot be split into fields"
            if len(cells) != width:
                return (f"row {line_no} has {len(cells)} fields, the header has {width} "
                        f"({clip(line.strip())}); fix or delete that row")
            for key, (j, name) in self.mapping.items():
                text = cells[j].strip()
                label = repr(name) if name == key else f"{name!r} ({key})"
                if text and not _is_num(text, self.d.decimal):
                    return f"column {label}, row {line_no}: {clip(text)} is not a number"
                if text and math.isinf(float(text.replace(",", "."))):
                    return f"column {label}, row {line_no}: {clip(text)} is not a number"
        return None


def read_text(path, columns=None, units=None, block=None, chunk_bytes=8 << 20) -> Table:
    """Read a CSV/ASCII recording into edge units; see the module docstring."""
    path = Path(path)
    source = str(path)
    try:
        with path.open("rb") as f:
            raw = f.read(SNIFF_BYTES)
    except OSError as exc:
        raise RecordingError(f"recording {source!r} cannot be read ({exc})") from None
    enc = detect_encoding(raw)
    text = raw.decode(enc, errors="ignore" if enc.startswith("utf-16") else "replace")
    _refuse_binary(raw, text, source)
    if not text.strip():
        raise RecordingError(f"recording {source!r} is empty")
    d = sniff(text, enc, source)
    mapping, notes = map_columns(d.header, columns, units)
    unit_map, unit_notes = resolve_units(mapping, d.header, d.units_row, units)
    dialect_note = (f"read as {enc}, delimiter "
                    f"{ {';': 'semicolon', chr(9): 'tab', ',': 'comma', ' ': 'whitespace'}[d.delimiter]}, "
                    f"decimal {'comma' if d.decimal == ',' else 'point'}")
    notes = [dialect_note] + notes
    if d.meta:
        notes.append(f"{len(d.meta)} metadata line(s) above the header skipped (first: "
                     f"{d.meta[0][:60]!r})")
    if d.units_row is not None:
        notes.append(f"units row under the header skipped (line {d.units_line + 1}: "
                     f"{', '.join(u for u in d.units_row if u)})")
    notes += unit_notes
    used = {j for j, _ in mapping.values()}
    unread = [h.strip() for j, h in enumerate(d.header) if j not in used and h.strip()]
    if unread:                                # nothing dropped without a word
        notes.append(f"{len(unread)} column(s) not read (not a recording column): "
                     f"{', '.join(clip(h, 40) for h in unread[:5])}"
                     f"{', ...' if len(unread) > 5 else ''} (map one with --columns KEY=NAME)")
    loc = _Locator(path, d, mapping)
    data_text = text.splitlines()[d.first_data_line:]
    loc.bytes_per_row = (len(raw) * sum(map(len, data_text)) / max(1, len(text))
                         / max(1, len(data_text)))
    keys = list(mapping)
    idx = [mapping[k][0] for k in keys]
    if d.delimiter == " ":
        data, n_raw, excl = _read_whitespace(path, d, keys, idx, unit_map, block, loc)
    else:
        data, n_raw, excl = _read_arrow(path, d, keys, idx, unit_map, block, loc, chunk_bytes)
    if block:
        notes.append(f"block means over {block:g} s while reading: {n_raw} raw samples -> "
                     f"{len(data['time_s'])} blocks")
    return Table(data, notes, unit_map, source, loc.line_of, n_raw, block, excl)


#: share of control characters (other than tab, CR, LF) above which a file is not text
BINARY_SHARE = 0.01
_CONTROL = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f]")


def _refuse_binary(raw: bytes, text: str, source: str):
    if raw.startswith(b"PK\x03\x04"):
        raise RecordingError(f"recording {source!r} is a zip archive (an .xlsx workbook?), not "
                             "CSV/ASCII or MDF; export it as CSV")
    sample = text[:65536]
    ctrl = len(_CONTROL.findall(sample))      # control characters other than tab, CR, LF
    if sample and ctrl > BINARY_SHARE * len(sample):
        raise RecordingError(f"recording {source!r} is a binary file, neither CSV/ASCII nor MDF "
                             f"(first bytes {raw[:8]!r})")


def _fail(loc: _Locator, exc) -> RecordingError:
    msg = loc.first_problem() or loc.cell_of(str(exc))
    # the parser's own text may quote many lines of the file: one line, clipped
    why = " ".join(str(exc).split())
    return RecordingError(msg or f"recording {str(loc.path)!r} cannot be parsed "
                          f"({why[:200]}{'...' if len(why) > 200 else ''})")


def _check_inf(arrs, keys, loc):
    for k, a in zip(keys, arrs):
        if np.isinf(a).any():
            raise _fail(loc, f"{k} holds an infinite value")


def _to_float(chunks) -> np.ndarray:
    """float64 pyarrow arrays -> one numpy array, nulls as NaN, straight from the buffers
    (pyarrow's own to_numpy imports pandas, 0.2 s)."""
    parts = []
    for c in chunks:
        bufs = c.buffers()
        y = np.frombuffer(bufs[1], dtype=np.float64, count=c.offset + len(c))[c.offset:]
        if c.null_count:
            valid = np.unpackbits(np.frombuffer(bufs[0], np.uint8), bitorder="little")
            y = np.where(valid[c.offset:c.offset + len(c)].astype(bool), y, np.nan)
        parts.append(y)
    if len(parts) == 1:
        return parts[0].copy()
    return np.concatenate(parts) if parts else np.empty(0)


def _read_arrow(path, d, keys, idx, unit_map, block, loc, chunk_bytes):
    import pyarrow as pa
    import pyarrow.csv as pc
    width = len(d.header)
    names = [f"c{j}" for j in range(width)]
    ro = pc.ReadOptions(skip_rows=d.first_data_line, column_names=names,
                        encoding=d.encoding.replace("utf-8-sig", "utf8"),
                        block_size=min(chunk_bytes, 1 << 30))
    po = pc.ParseOptions(delimiter=d.delimiter, ignore_empty_lines=True)
    co = pc.ConvertOptions(column_types={names[j]: pa.float64() for j in idx},
                           include_columns=[names[j] for j in idx], decimal_point=d.decimal,
                           null_values=["", "NaN", "nan", "NA", "N/A", "-nan", "null"],
                           strings_can_be_null=True)
    try:
        if not block:
            t = pc.read_csv(path, read_options=ro, parse_options=po, convert_options=co)
            arrs = []
            for j in idx:                      # column by column, freeing the table's as we go
                arrs.append(_to_float(t.column(names[j]).chunks))
                t = t.drop_columns([names[j]])
            del t
            _release_arrow_pool(pa)
            _check_inf(arrs, keys, loc)
            data = _convert(dict(zip(keys, arrs)), unit_map)
            return data, len(arrs[0]), []
        reader = pc.open_csv(path, read_options=ro, parse_options=po, convert_options=co)
        acc = _BlockAverager(keys, block)
        bar = _progress(path, loc)
        for batch in reader:
            bar.update(batch.num_rows)
            arrs = [_to_float([batch.column(names[j])]) for j in idx]
            _check_inf(arrs, keys, loc)
            acc.add(_convert(dict(zip(keys, arrs)), unit_map))
        bar.close()
        reader = batch = None            # (the last batch's buffers too)
        _release_arrow_pool(pa)
        return acc.result()
    except (pa.ArrowInvalid, UnicodeDecodeError, ValueError) as exc:
        if isinstance(exc, RecordingError):
            raise
        raise _fail(loc, exc) from None


def _release_arrow_pool(pa):
    """Hand the pages pyarrow's memory pool (mimalloc, jemalloc) keeps after a parse back to
    the kernel: the parse is done and numpy never reuses them (66 MB kept after a 30 MB CSV of
    600 000 samples, the diagnosis's peak memory raised by as much)."""
    release = getattr(pa.default_memory_pool(), "release_unused", None)
    if release is not None:
        release()


#: [bytes] a progress bar (stderr, terminals only) for block reads of files larger than this
PROGRESS_BYTES = 200 << 20


def _progress(path, loc):
    """tqdm bar over the estimated row count (file size / mean line length of the sample)."""
    import sys
    from tqdm import tqdm
    size = Path(path).stat().st_size
    per_row = max(1.0, loc.bytes_per_row)
    return tqdm(total=int(size / per_row), unit=" rows", unit_scale=True, leave=False,
                desc="reading", disable=size < PROGRESS_BYTES or not sys.stderr.isatty())


def _read_whitespace(path, d, keys, idx, unit_map, block, loc):
    import pandas as pd
    kw = dict(sep=r"\s+", header=None, skiprows=d.first_data_line, usecols=idx,
              dtype={j: "float64" for j in idx}, decimal=d.decimal, engine="c",
              encoding=d.encoding, skip_blank_lines=True)
    try:
        if not block:
            df = pd.read_csv(path, **kw)
            if df.isna().to_numpy().any():      # whitespace files have no empty cells:
                msg = loc.first_problem()       # a NaN is a 'nan' cell or a short row
                if msg:
                    raise RecordingError(msg)
            arrs = [df[j].to_numpy(float) for j in idx]
            _check_inf(arrs, keys, loc)
            return _convert(dict(zip(keys, arrs)), unit_map), len(arrs[0]), []
        acc = _BlockAverager(keys, block)
        for df in pd.read_csv(path, chunksize=2_000_000, **kw):
            arrs = [df[j].to_numpy(float) for j in idx]
            _check_inf(arrs, keys, loc)
            acc.add(_convert(dict(zip(keys, arrs)), unit_map))
        return acc.result()
    except (pd.errors.ParserError, ValueError) as exc:
        if isinstance(exc, RecordingError):
            raise
        raise _fail(loc, exc) from None


class _BlockAverager:
    """Means over fixed time blocks [t0 + k*block, t0 + (k+1)*block), accumulated chunk by
    chunk; a sample with a NaN cell is left out of its block (counted); a block left with no
    sample is dropped (counted)."""

    def __init__(self, keys, block):
        self.keys, self.block = keys, float(block)
        self.t0 = None
        self.carry = None              # (block id, sums dict, count) of the open block
        self.out = {k: [] for k in keys}
        self.n_raw = 0
        self.nan_samples = {}
        self.last_t = -math.inf
        self.backwards = None

    def add(self, data):
        t = data["time_s"]
        n = len(t)
        if n == 0:
            return
        self.n_raw += n
        good = np.ones(n, bool)
        for k in self.keys:
            bad = np.isnan(data[k]) & good
            if bad.any():
                self.nan_samples[k] = self.nan_samples.get(k, 0) + int(bad.sum())
                good &= ~bad
        tg = t[good]
        if tg.size == 0:
            return
        if self.t0 is None:
            self.t0 = float(tg[0])
        if tg[0] < self.last_t or np.any(np.diff(tg) < 0):
            if self.backwards is None:
                self.backwards = self.n_raw - n + int(np.flatnonzero(good)[
                    np.flatnonzero(np.diff(np.r_[self.last_t, tg]) < 0)[0]])
            return
        self.last_t = float(tg[-1])
        # 1e-6 of a block: a time written as 0.3 lands in block 3, not 2 (0.3/0.1 = 2.9999..)
        b = np.floor((tg - self.t0) / self.block + 1e-6).astype(np.int64)
        b0 = int(b[0])
        rel = b - b0
        nb = int(rel[-1]) + 1
        cnt = np.bincount(rel, minlength=nb).astype(float)
        sums = {k: np.bincount(rel, weights=data[k][good], minlength=nb) for k in self.keys}
        if self.carry is not None:
            cb, csum, ccnt = self.carry
            if cb == b0:
                for k in self.keys:
                    sums[k][0] += csum[k]
                cnt[0] += ccnt
            else:
                self._emit({k: np.array([csum[k]]) for k in self.keys}, np.array([ccnt]))
        last = nb - 1
        self.carry = (b0 + last, {k: sums[k][last] for k in self.keys}, cnt[last])
        self._emit({k: v[:last] for k, v in sums.items()}, cnt[:last])

    def _emit(self, sums, cnt):
        keep = cnt > 0
        for k in self.keys:
            self.out[k].append(sums[k][keep] / cnt[keep])

    def result(self):
        if self.backwards is not None:
            raise RecordingError(f"time_s goes backwards at data row {self.backwards + 1} "
                                 "(samples must be in time order)")
        if self.carry is not None:
            cb, csum, ccnt = self.carry
            self._emit({k: np.array([csum[k]]) for k in self.keys}, np.array([ccnt]))
        data = {k: (np.concatenate(v) if v else np.empty(0)) for k, v in self.out.items()}
        excl = [(f"NaN in {k} (left out of its block)", c) for k, c in self.nan_samples.items()]
        return data, self.n_raw, excl
