"""Format matrix (issue 10, item 1): every dialect of the same recording reads to the numbers of
the plain CSV; what reading did (dialect, skipped lines, mapping, conversions) is reported."""
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from cyclo_fmu.io import load_recording, parse_units
from cyclo_fmu.recordings import RecordingError, read_recording

COLS = ("time_s", "speed_in_rpm", "torque_in_Nm", "speed_out_rpm", "torque_out_Nm",
        "temperature_C")


def reference(n=1500, rate=100.0, seed=3):
    """A plausible S1 run (z1 = 15): speed steps 800..2800 r/min, load 2..18 N*m out,
    efficiency ~0.88, temperature rising 30 -> 45 degC; values rounded like a logger."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    n_in = np.where(t < 5, 800.0, np.where(t < 10, 2800.0, 1500.0)) + rng.normal(0, 0.3, n)
    T_out = 2 + 16 * (0.5 + 0.5 * np.sin(t / 3)) + rng.normal(0, 0.02, n)
    T_in = T_out / 15 / 0.88 + 0.02
    rec = {"time_s": t, "speed_in_rpm": n_in, "torque_in_Nm": T_in,
           "speed_out_rpm": n_in / 15, "torque_out_Nm": T_out,
           "temperature_C": 30 + 15 * t / t[-1]}
    return {k: np.array([float(f"{v:.6g}") for v in a]) for k, a in rec.items()}


REF = reference()


def cells(rec, key, scale=1.0, decimal="."):
    out = [f"{v * scale:.10g}" for v in rec[key]]
    return [c.replace(".", ",") for c in out] if decimal == "," else out


def table(rec, header, delim=",", decimal=".", scales=None, order=COLS):
    scales = scales or {}
    cols = [cells(rec, k, scales.get(k, 1.0), decimal) for k in order]
    lines = [delim.join(header)] + [delim.join(r) for r in zip(*cols)]
    return lines


def assert_same(r, ref=REF, rtol=1e-9):
    plain = ref
    np.testing.assert_allclose(r.time, plain["time_s"], rtol=rtol, atol=1e-12)
    np.testing.assert_allclose(r.speed_in, plain["speed_in_rpm"] * math.pi / 30, rtol=rtol)
    np.testing.assert_allclose(r.torque_in, plain["torque_in_Nm"], rtol=rtol)
    np.testing.assert_allclose(r.speed_out, plain["speed_out_rpm"] * math.pi / 30, rtol=rtol)
    np.testing.assert_allclose(r.torque_out, plain["torque_out_Nm"], rtol=rtol)
    np.testing.assert_allclose(r.temperature, plain["temperature_C"], rtol=rtol)


@pytest.fixture(scope="module")
def plain(tmp_path_factory):
    p = tmp_path_factory.mktemp("plain") / "plain.csv"
    p.write_text("\n".join(table(REF, COLS)) + "\n")
    return p


def test_plain_csv_reads_the_reference(plain):
    r = read_recording(plain)
    assert_same(r)
    assert r.notes[0] == "read as utf-8, delimiter comma, decimal point"


CATMAN = ["catman ASCII export", "Projekt: Zykloidgetriebe Prüfstand 2", "Datum: 22.11.2026",
          "Abtastrate: 100 Hz", ""]
GERMAN = ["Zeit", "Drehzahl_An", "Drehmoment_An", "Drehzahl_Ab", "Drehmoment_Ab", "Temperatur"]


def dialects():
    """name -> (file bytes, expected note fragments)."""
    out = {}
    # catman-style: metadata lines, German names, units row, semicolon and decimal comma, cp1252
    lines = CATMAN + table(REF, GERMAN, ";", ",")
    lines.insert(len(CATMAN) + 1, ";".join(["s", "1/min", "N·m", "1/min", "N·m", "°C"]))
    out["catman_semicolon_decimal_comma_cp1252"] = (
        "\r\n".join(lines).encode("cp1252"),
        ["cp1252", "semicolon", "decimal comma", "4 metadata line", "units row",
         "'Drehzahl_An' read as speed_in_rpm"])
    out["tab_units_in_brackets"] = (
        "\n".join(table(REF, ["time [s]", "speed_in [rpm]", "torque_in [N*m]", "speed_out [1/min]",
                              "torque_out [Nm]", "temperature [°C]"], "\t")).encode(),
        ["tab", "'torque_in [N*m]' read as torque_in_Nm"])
    out["whitespace_units_row"] = (
        "\n".join(table(REF, ["t", "n_in", "T_in", "n_out", "T_out", "temp"], "  ")[:1]
                  + ["s  rpm  Nm  rpm  Nm  degC"]
                  + table(REF, COLS, "   ")[1:]).encode(),
        ["whitespace", "units row"])
    # units in names that need conversion: ms, rad/s, N*mm, K
    k = 30 / math.pi
    out["units_in_names_converted"] = (
        "\n".join(table(REF, ["time_ms", "speed_in_rad_s", "T_in_Nmm", "speed_out [rad/s]",
                              "torque_out [N·mm]", "oil temp °C"],
                        scales={"time_s": 1e3, "speed_in_rpm": 1 / k, "speed_out_rpm": 1 / k,
                                "torque_in_Nm": 1e3, "torque_out_Nm": 1e3})).encode(),
        ["time_s: converted from ms", "torque_in_Nm: converted from Nmm",
         "speed_out_rpm: converted from rad/s"])
    txt = "\n".join(table(REF, COLS)) + "\n"
    out["utf8_bom"] = (b"\xef\xbb\xbf" + txt.encode(), ["utf-8-sig"])
    out["utf16_bom"] = (txt.encode("utf-16"), ["utf-16"])
    out["utf16le_no_bom"] = (txt.encode("utf-16-le"), ["utf-16-le"])
    return out


DIALECTS = dialects()


@pytest.mark.parametrize("name", sorted(DIALECTS))
def test_dialect_reads_to_the_same_numbers(tmp_path, name):
    raw, notes = DIALECTS[name]
    p = tmp_path / f"{name}.txt"
    p.write_bytes(raw)
    if name == "units_in_names_converted":     # the K offset: temperature exact to 1e-9 K
        r = read_recording(p)
        ref = dict(REF)
        assert_same(r, ref, rtol=1e-9)
    else:
        r = read_recording(p)
        assert_same(r)
    text = " | ".join(r.notes)
    for frag in notes:
        assert frag in text, (frag, text)
    assert r.exclusions == ()


def test_duplicated_timestamp_reads_to_the_same_numbers(tmp_path):
    lines = table(REF, COLS)
    lines.insert(101, lines[100])              # sample 99 written twice (a logger flush)
    p = tmp_path / "dup.csv"
    p.write_text("\n".join(lines) + "\n")
    r = read_recording(p)
    assert_same(r)
    (e,) = r.exclusions
    assert e.count == 1 and "duplicated timestamp" in e.reason and "row 102" in e.reason


def test_units_option_overrides_detected_units(tmp_path):
    p = tmp_path / "nmm.csv"
    p.write_text("\n".join(table(REF, COLS, scales={"torque_in_Nm": 1e3, "torque_out_Nm": 1e3,
                                                      "time_s": 1e3})) + "\n")
    r = read_recording(p, units=parse_units("torque_in_Nm=N*mm, torque_out_Nm=N·mm,time_s=ms"))
    assert_same(r)
    assert r.units["torque_in_Nm"] == ("N*mm", "--units")
    with pytest.raises(RecordingError, match="'furlongs' is not a torque unit"):
        parse_units("torque_in_Nm=furlongs")
    with pytest.raises(RecordingError, match="'torqe_in' is not a recording column"):
        parse_units("torqe_in=N*m")


def test_ambiguous_names_are_refused_not_guessed(tmp_path):
    p = tmp_path / "two.csv"
    hdr = ["time", "speed_in", "n_in", "torque_in", "speed_out", "torque_out", "temperature"]
    cols = [REF["time_s"], REF["speed_in_rpm"], REF["speed_in_rpm"], REF["torque_in_Nm"],
            REF["speed_out_rpm"], REF["torque_out_Nm"], REF["temperature_C"]]
    p.write_text(",".join(hdr) + "\n" + "\n".join(",".join(f"{v:.10g}" for v in row)
                                                  for row in zip(*cols)) + "\n")
    with pytest.raises(RecordingError, match="'speed_in', 'n_in' could each be speed_in_rpm"):
        read_recording(p)
    r = read_recording(p, {"speed_in_rpm": "n_in"})
    assert_same(r)


def test_mdf4_written_with_asammdf(tmp_path):
    """Channels with their own units and two rasters: the 10 Hz temperature is interpolated onto
    the 100 Hz raster of the shaft channels, and the notes say so."""
    from asammdf import MDF, Signal
    t = REF["time_s"]
    mdf = MDF(version="4.10")
    mdf.append([Signal(REF["speed_in_rpm"], t, name="n_in", unit="rpm"),
                Signal(REF["torque_in_Nm"] * 1e3, t, name="T_in", unit="N·mm"),
                Signal(REF["speed_out_rpm"] * math.pi / 30, t, name="n_out", unit="rad/s"),
                Signal(REF["torque_out_Nm"], t, name="T_out", unit="Nm")])
    slow = t[::10]
    mdf.append([Signal(REF["temperature_C"][::10], slow, name="oil_temp", unit="°C")])
    p = tmp_path / "run.mf4"
    mdf.save(p, overwrite=True)
    mdf.close()
    r = read_recording(p)
    # the samples after the last slow sample have no temperature: left out (counted)
    assert r.n == len(t) - 9
    np.testing.assert_allclose(r.torque_in, REF["torque_in_Nm"][:r.n], rtol=1e-12)
    np.testing.assert_allclose(r.speed_out, REF["speed_out_rpm"][:r.n] * math.pi / 30, rtol=1e-12)
    np.testing.assert_allclose(r.time, t[:r.n])
    # the temperature is linear in time: interpolation restores it
    np.testing.assert_allclose(r.temperature, REF["temperature_C"][:r.n], atol=2e-3)
    text = " | ".join(r.notes)
    assert "resampled by linear interpolation" in text and "oil_temp (10 Hz)" in text
    assert any(e.count == 9 for e in r.exclusions)


def test_block_means_while_reading(tmp_path, plain):
    """block=0.1 s: means of 10 samples each, computed chunk by chunk (tiny chunks here)."""
    from cyclo_fmu.io.text import read_text
    tab = read_text(plain, block=0.1, chunk_bytes=4096)
    assert tab.raw_samples == REF["time_s"].size and tab.data["time_s"].size == 150
    np.testing.assert_allclose(tab.data["torque_out_Nm"],
                               REF["torque_out_Nm"].reshape(150, 10).mean(axis=1), rtol=1e-12)
    r = read_recording(plain, block=0.1)
    assert r.n == 150 and r.raw_samples == 1500 and "block means" in r.notes[-1]


def test_the_cli_reads_a_catman_file_with_mode_auto(tmp_path):
    raw, _ = DIALECTS["catman_semicolon_decimal_comma_cp1252"]
    p = tmp_path / "catman.txt"
    p.write_bytes(raw)
    rec, mode, checks = load_recording(p, "auto")
    assert mode == "S1" and any("matches mode S1" in c["message"] for c in checks)
    assert_same(rec)


@settings(max_examples=25, deadline=None)
@given(delim=st.sampled_from([",", ";", "\t", " "]), decimal=st.sampled_from([".", ","]),
       meta=st.integers(0, 4), units_row=st.booleans(), crlf=st.booleans(),
       enc=st.sampled_from(["utf-8", "utf-8-sig", "cp1252", "utf-16"]))
def test_dialect_round_trip_property(tmp_path_factory, delim, decimal, meta, units_row, crlf, enc):
    if delim == "," and decimal == ",":
        decimal = "."                           # ambiguous by construction: not a dialect
    ref = {k: v[:300] for k, v in REF.items()}
    lines = table(ref, COLS, delim, decimal)
    if units_row:
        lines.insert(1, delim.join(["s", "rpm", "N*m", "rpm", "N*m", "degC"]))
    lines = [f"meta line {i}: a=b" for i in range(meta)] + lines
    p = tmp_path_factory.mktemp("h") / "r.csv"
    p.write_bytes(("\r\n" if crlf else "\n").join(lines).encode(enc))
    r = read_recording(p, min_duration=1.0)
    assert_same(r, ref)


@pytest.mark.parametrize("delim, edit, words", [
    (",", lambda c: c[:2] + c[3:], "row 42 has 5 fields, the header has 6"),    # a lost field
    ("\t", lambda c: c + ["1.5"], "row 42 has 7 fields, the header has 6"),
    (" ", lambda c: c[:-1], "row 42 has 5 fields, the header has 6"),
    (";", lambda c: c[:2] + ["abc"] + c[3:], "'torque_in_Nm', row 42: 'abc' is not a number"),
])
def test_row_width_and_bad_cells_name_the_row(tmp_path, delim, edit, words):
    lines = table(REF, COLS, delim)
    sep = delim if delim != " " else " "
    lines[41] = sep.join(edit(lines[41].split(sep)))
    p = tmp_path / "bad.txt"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordingError, match=words.replace("(", r"\(")):
        read_recording(p)


def test_block_read_refuses_time_going_backwards(tmp_path):
    lines = table(REF, COLS)
    lines[800], lines[801] = lines[801], lines[800]
    p = tmp_path / "back.csv"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordingError, match="time_s goes backwards at data row 801"):
        read_recording(p, block=0.1)
    with pytest.raises(RecordingError, match="time_s goes backwards at row 802"):
        read_recording(p)


@settings(max_examples=60, deadline=None)
@given(quantity=st.sampled_from(["time", "speed", "torque", "temperature"]), data=st.data())
def test_unit_conversion_round_trip(quantity, data):
    """Writing a value in any accepted unit and reading it back gives the edge-unit value."""
    from cyclo_fmu.io.units import _FACTORS, unit_conversion
    unit = data.draw(st.sampled_from(sorted(_FACTORS[quantity])))
    x = data.draw(st.floats(-1e4, 1e4, allow_nan=False))
    f, off, sign = unit_conversion(quantity, unit)
    written = (x - off) / f                    # what a file in that unit holds
    assert sign == 1.0 and f * written + off == pytest.approx(x, rel=1e-12, abs=1e-9)
    f2, off2, sign2 = unit_conversion(quantity, "-" + unit)
    assert sign2 == -1.0 and (f2, off2) == (f, off)


def test_trailing_delimiter_on_data_rows(tmp_path):
    """Some exports end every data row with the delimiter but not the header."""
    lines = table(REF, COLS, ";")
    lines = lines[:1] + [l + ";" for l in lines[1:]]
    p = tmp_path / "trail.csv"
    p.write_text("\n".join(lines) + "\n")
    assert_same(read_recording(p))


def test_mdf4_channels_by_columns_and_missing_asammdf(tmp_path, monkeypatch):
    from asammdf import MDF, Signal
    t = REF["time_s"]
    mdf = MDF(version="4.10")
    names = ["K1", "K2", "K3", "K4"]                 # nothing a name heuristic could read
    mdf.append([Signal(REF[c], t, name=n, unit=u) for c, n, u in zip(
        COLS[1:5], names, ["1/min", "N*m", "1/min", "N*m"])])
    p = tmp_path / "k.mf4"
    mdf.save(p, overwrite=True)
    mdf.close()
    with pytest.raises(RecordingError, match="'speed_in_rpm' is missing; found: time, K1"):
        read_recording(p)
    r = read_recording(p, dict(zip(COLS[1:5], names)))
    np.testing.assert_allclose(r.torque_out, REF["torque_out_Nm"], rtol=1e-12)
    monkeypatch.setitem(__import__("sys").modules, "asammdf", None)
    with pytest.raises(RecordingError, match=r"reading MDF needs asammdf: pip install"):
        read_recording(p)


def test_binary_files_are_named_not_parsed(tmp_path):
    import zipfile
    z = tmp_path / "run.xlsx"
    with zipfile.ZipFile(z, "w") as f:
        f.writestr("xl/workbook.xml", "<workbook/>")
    with pytest.raises(RecordingError, match="zip archive .*xlsx.*export it as CSV"):
        read_recording(z)
    b = tmp_path / "run.bin"
    b.write_bytes(bytes(range(256)) * 40)
    with pytest.raises(RecordingError, match="is a binary file"):
        read_recording(b)
