"""Reader fuzz (issue 21, item 1): a recording mutated in its bytes, encoding, line endings,
delimiters and length is read identically, refused with one line, or read with a stated note;
never a traceback.

Each example mutates one clean recording (800 rows, six columns, S1-like) and reads it with
``read_recording`` (the mode-independent checks included). Outcomes allowed:

* a dialect-preserving mutation (encoding, BOM, CRLF, delimiter with decimal comma, aligned
  whitespace, quoted names, blank lines): the samples read identically;
* any other mutation: a ``RecordingError``/``CycloidInputError`` whose message is one line
  (at most 1000 characters), or a read whose samples are all finite, in time order and at
  least 200, and that equals the clean recording except in at most ``LOCAL_ROWS`` rows (the
  rows a local edit touched: reading cannot know a changed digit) unless its notes or
  exclusions state something the clean read does not (a unit converted, samples excluded, ...).

Default run: 50 examples; ``-m slow``: 600. Hypothesis is derandomised (tests/conftest.py), so
a failure replays.
"""
import codecs

import numpy as np
import pytest
from hypothesis import event, given, settings, strategies as st

from cyclo_fmu.recordings import RecordingError, read_recording
from model_core import CycloidInputError

COLS = ["time_s", "speed_in_rpm", "torque_in_Nm", "speed_out_rpm", "torque_out_Nm",
        "temperature_C"]
#: rows of the result that may differ from the clean read after a local edit without a note
LOCAL_ROWS = 3


def clean_rows(n=800, rate=100.0):
    t = np.arange(n) / rate
    n_in = 1500 + 400 * np.sin(t / 2)
    T_out = 6 + 2 * np.sin(t / 3)
    T_in = T_out / 15 / 0.8
    temp = 30 + 5 * t / t[-1]
    return [[f"{a:.2f}", f"{b:.3f}", f"{c:.5f}", f"{b / 15:.4f}", f"{d:.4f}", f"{e:.3f}"]
            for a, b, c, d, e in zip(t, n_in, T_in, T_out, temp)]


ROWS = clean_rows()


def render(delim=",", decimal=".", newline="\n", quote=False, blank=False, align=False):
    head = [f'"{c}"' if quote else c for c in COLS]
    rows = [[c.replace(".", ",") for c in r] if decimal == "," else r for r in ROWS]
    if align:
        lines = ["  ".join(f"{c:>14}" for c in head)] + ["  ".join(f"{c:>14}" for c in r)
                                                          for r in rows]
    else:
        lines = [delim.join(head)] + [delim.join(r) for r in rows]
    text = newline.join(lines) + newline
    return text + (newline * 3 if blank else "")


CLEAN = render().encode()

# dialect-preserving variants: (name, bytes)
PRESERVING = {
    "utf8_bom": codecs.BOM_UTF8 + CLEAN,
    "utf16": render().encode("utf-16"),
    "utf16_le_no_bom": render().encode("utf-16-le"),
    "cp1252": render().encode("cp1252"),
    "crlf": render(newline="\r\n").encode(),
    "semicolon_decimal_comma": render(";", ",").encode(),
    "tab": render("\t").encode(),
    "tab_decimal_comma": render("\t", ",").encode(),
    "whitespace_aligned": render(align=True).encode(),
    "quoted_names": render(quote=True).encode(),
    "trailing_blank_lines": render(blank=True).encode(),
}


def _read(tmp_path, raw, name="r.csv"):
    p = tmp_path / name
    p.write_bytes(raw)
    return read_recording(p)


def _arrays(rec):
    return np.stack([rec.time, rec.speed_in, rec.torque_in, rec.speed_out, rec.torque_out,
                     rec.temperature if rec.temperature is not None else 0 * rec.time], -1)


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    rec = _read(tmp_path_factory.mktemp("base"), CLEAN)
    return rec, _arrays(rec)


@pytest.mark.parametrize("name", list(PRESERVING))
def test_dialect_preserving_variants_read_identically(tmp_path, base, name):
    rec = _read(tmp_path, PRESERVING[name])
    np.testing.assert_allclose(_arrays(rec), base[1], rtol=1e-12, atol=1e-12)


# ---- mutations --------------------------------------------------------------------------------
def _flip(raw, pos, byte):
    pos %= len(raw)
    return raw[:pos] + bytes([byte]) + raw[pos + 1:]


def _insert(raw, pos, chunk):
    pos %= len(raw) + 1
    return raw[:pos] + chunk + raw[pos:]


def _delete(raw, pos, k):
    pos %= len(raw)
    return raw[:pos] + raw[pos + k:]


def _truncate(raw, pos):
    return raw[:pos % (len(raw) + 1)]


def _lines(raw):
    return raw.split(b"\n")


def _dup_line(raw, i):
    ls = _lines(raw)
    i = 1 + i % (len(ls) - 2)
    return b"\n".join(ls[:i] + [ls[i]] + ls[i:])


def _swap_lines(raw, i, j):
    ls = _lines(raw)
    i, j = 1 + i % (len(ls) - 2), 1 + j % (len(ls) - 2)
    ls[i], ls[j] = ls[j], ls[i]
    return b"\n".join(ls)


def _cell(raw, i, col, text):
    ls = _lines(raw)
    i = 1 + i % (len(ls) - 2)
    cells = ls[i].split(b",")
    cells[col % len(cells)] = text
    ls[i] = b",".join(cells)
    return b"\n".join(ls)


def _header(raw, text):
    ls = _lines(raw)
    ls[0] = text
    return b"\n".join(ls)


def _reencode(raw, enc):
    return raw.decode("utf-8", "replace").encode(enc, "replace")


def _delim(raw, old, new):
    return raw.replace(old, new)


CELL_TEXT = st.sampled_from([b"", b"nan", b"NaN", b"inf", b"-inf", b"1e308", b"-1e308", b"abc",
                             b"1,5", b"1..2", b"0x10", b"\xff\xfe", b"\x00", b'"', b'"1"',
                             b"1e999", b"9" * 400, b" ", b"--1", b"+", b"1e-400", b"\t"])
POS = st.integers(0, 10 ** 6)

MUTATIONS = st.one_of(
    st.builds(lambda p, b: ("flip", _flip(CLEAN, p, b)), POS, st.integers(0, 255)),
    st.builds(lambda p, c: ("insert", _insert(CLEAN, p, c)), POS,
              st.binary(min_size=1, max_size=8)),
    st.builds(lambda p, c: ("insert", _insert(CLEAN, p, c)), POS,
              st.sampled_from([b"\n", b",", b";", b"\r", b"\x00\x00", b"\xef\xbb\xbf",
                               b"# comment\n", b"\n\n", b'"', b"\t"])),
    st.builds(lambda p, k: ("delete", _delete(CLEAN, p, k)), POS, st.integers(1, 4000)),
    st.builds(lambda p: ("truncate", _truncate(CLEAN, p)), POS),
    st.builds(lambda i: ("dup_line", _dup_line(CLEAN, i)), POS),
    st.builds(lambda i, j: ("swap_lines", _swap_lines(CLEAN, i, j)), POS, POS),
    st.builds(lambda i, c, t: ("cell", _cell(CLEAN, i, c, t)), POS, st.integers(0, 5),
              CELL_TEXT),
    st.builds(lambda h: ("header", _header(CLEAN, h)), st.sampled_from([
        b"", b"a,b,c,d,e,f", b"time_s,speed_in_rpm,torque_in_Nm", b"time [ms]," +
        b",".join(c.encode() for c in COLS[1:]), b"time_s,speed_in [rad/s],torque_in [N*mm]," +
        b"speed_out_rpm,torque_out_Nm,temperature [degF]", b"1,2,3,4,5,6",
        b"time_s,time_s,torque_in_Nm,speed_out_rpm,torque_out_Nm,temperature_C"])),
    st.builds(lambda e: ("reencode", _reencode(CLEAN, e)),
              st.sampled_from(["utf-16-be", "utf-32", "latin-1", "cp1252", "utf-7"])),
    st.builds(lambda o, n: ("delimiter", _delim(CLEAN, o, n)),
              st.sampled_from([b",", b"."]), st.sampled_from([b";", b"\t", b" ", b"|", b","])),
    st.builds(lambda k, b: ("binary_block", _insert(CLEAN, k, b)), POS,
              st.binary(min_size=64, max_size=512)),
    st.builds(lambda p: ("prefix_meta", b"Project: bench 2\nRate: 100 Hz\n\n" +
                         _truncate(CLEAN, 10 ** 9)), POS),
)


def _signature(rec):
    return set(rec.notes) | {(e.reason, e.count) for e in rec.exclusions}


def _check_outcome(tmp_path, base, kind, raw):
    base_rec, base_arr = base
    try:
        rec = _read(tmp_path, raw, f"{kind}.csv")
    except (RecordingError, CycloidInputError) as exc:
        msg = str(exc)
        assert "\n" not in msg and "\r" not in msg, (kind, msg[:300])
        assert 0 < len(msg) <= 1000, (kind, len(msg))
        return "refused"
    arr = _arrays(rec)
    assert rec.n >= 200 and np.isfinite(arr).all(), kind
    assert np.all(np.diff(rec.time) > 0), kind
    if arr.shape == base_arr.shape and np.allclose(arr, base_arr, rtol=1e-12, atol=1e-12):
        return "identical"
    if _signature(rec) - _signature(base_rec):
        return "noted"
    # no new note: only a local edit may differ, row by row against the clean read (by time)
    index = {round(t, 6): i for i, t in enumerate(base_rec.time)}
    differ = 0
    for row in arr:
        i = index.get(round(float(row[0]), 6))
        if i is None or not np.allclose(row, base_arr[i], rtol=1e-9, atol=1e-12):
            differ += 1
    assert differ <= LOCAL_ROWS, (kind, differ, rec.notes)
    return "local"


@settings(max_examples=50)
@given(m=MUTATIONS)
def test_reader_fuzz(tmp_path_factory, base, m):
    event(f"{m[0]}: {_check_outcome(tmp_path_factory.mktemp('fuzz'), base, *m)}")


@pytest.mark.slow
@settings(max_examples=600)
@given(m=MUTATIONS)
def test_reader_fuzz_600(tmp_path_factory, base, m):
    event(_check_outcome(tmp_path_factory.mktemp("fuzz"), base, *m))


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(24))
def test_diagnose_cli_on_mutated_recordings(tmp_path_factory, seed):
    """The whole command on a mutated 42 s recording (synth, tiny): exit 0, or one line and
    exit 2; never a traceback (the checks and the diagnosis after the reader included)."""
    import os
    import random
    import subprocess
    import sys
    from pathlib import Path
    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=str(root))
    base = tmp_path_factory.getbasetemp() / "cli_fuzz_base.csv"
    if not base.exists():
        subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "synth", "--effect", "none",
                        "--size", "tiny", "--out", str(base)], env=env, check=True,
                       capture_output=True, timeout=300)
    raw = base.read_bytes()
    rng = random.Random(seed)
    kind = ["flip", "insert", "cell", "dup_line", "truncate", "delete"][seed % 6]
    p = rng.randrange(len(raw))
    if kind == "flip":
        raw = _flip(raw, p, rng.randrange(256))
    elif kind == "insert":
        raw = _insert(raw, p, bytes(rng.randrange(256) for _ in range(rng.randint(1, 6))))
    elif kind == "cell":
        raw = _cell(raw, p, rng.randrange(5), rng.choice([b"", b"nan", b"1e308", b"abc",
                                                         b"-5", b"99999"]))
    elif kind == "dup_line":
        raw = _dup_line(raw, p)
    elif kind == "truncate":
        raw = _truncate(raw, p)
    else:
        raw = _delete(raw, p, rng.randint(1, 50000))
    f = tmp_path_factory.mktemp("cli_fuzz") / f"m_{kind}.csv"
    f.write_bytes(raw)
    r = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "diagnose", str(f), "--mode",
                        "auto"], env=env, capture_output=True, text=True, timeout=600)
    assert "Traceback" not in r.stderr, r.stderr[-2000:]
    assert r.returncode == 0 or (r.returncode == 2 and
                                 len(r.stderr.strip().splitlines()) == 1), r.stderr[-500:]
