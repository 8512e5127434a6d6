"""Unit conversions at the reader's edge against a hand-written table (issue 21, item 2).

The expected values are written out by hand from the unit definitions (NIST SP 811), not
computed with the code's factors: a factor or offset changed in ``cyclo_fmu.io.units`` (an
inverted degF, N*mm as 1e-6, r/s as 1/60) fails here. Each row is checked twice: through
``unit_conversion`` and end to end, through a CSV whose header carries the unit.
"""
import math

import numpy as np
import pytest

from cyclo_fmu.io.units import parse_units, quantity_of_unit, unit_conversion
from cyclo_fmu.recordings import RecordingError, read_recording

# (quantity, unit as written in a file, value in that unit, value in the edge unit)
# edge units: s, r/min, N*m, degC
TABLE = [
    ("temperature", "degF", 212.0, 100.0),
    ("temperature", "degF", 32.0, 0.0),
    ("temperature", "degF", -40.0, -40.0),
    ("temperature", "degF", 98.6, 37.0),
    ("temperature", "°F", 50.0, 10.0),
    ("temperature", "K", 273.15, 0.0),
    ("temperature", "K", 373.15, 100.0),
    ("temperature", "degC", 25.0, 25.0),
    ("temperature", "°C", -10.0, -10.0),
    ("torque", "N*mm", 1000.0, 1.0),
    ("torque", "Nmm", 250.0, 0.25),
    ("torque", "N·mm", 850.0, 0.85),
    ("torque", "N*cm", 100.0, 1.0),
    ("torque", "kN*m", 0.002, 2.0),
    ("torque", "mNm", 500.0, 0.5),
    ("torque", "N*m", 0.85, 0.85),
    ("torque", "Nm", 3.0, 3.0),
    ("speed", "r/min", 2800.0, 2800.0),
    ("speed", "rpm", 1500.0, 1500.0),
    ("speed", "1/min", 1000.0, 1000.0),
    ("speed", "min^-1", 1000.0, 1000.0),
    ("speed", "rad/s", 2 * math.pi, 60.0),
    ("speed", "rad/s", 100.0, 954.9296585513720),     # 100 * 60 / (2 pi)
    ("speed", "Hz", 1.0, 60.0),
    ("speed", "r/s", 2.5, 150.0),
    ("speed", "rps", 50.0, 3000.0),
    ("speed", "deg/s", 360.0, 60.0),
    ("time", "s", 1.5, 1.5),
    ("time", "ms", 1500.0, 1.5),
    ("time", "us", 2_000_000.0, 2.0),
    ("time", "min", 1.0, 60.0),
    ("time", "h", 0.5, 1800.0),
]


@pytest.mark.parametrize("q,unit,x,edge", TABLE, ids=[f"{r[1]}={r[2]}" for r in TABLE])
def test_conversion_table(q, unit, x, edge):
    f, off, sign = unit_conversion(q, unit)
    assert sign * (f * x + off) == pytest.approx(edge, rel=1e-12, abs=1e-12)
    assert quantity_of_unit(unit) == q


@pytest.mark.parametrize("q,unit,x,edge", [("torque", "-N*m", 2.0, -2.0),
                                          ("torque", "-N*mm", 500.0, -0.5)])
def test_leading_minus_negates(q, unit, x, edge):
    f, off, sign = unit_conversion(q, unit)
    assert sign * (f * x + off) == pytest.approx(edge, rel=1e-12)


@pytest.mark.parametrize("q,unit", [("torque", "kg"), ("speed", "m/s"), ("time", "N*m"),
                                    ("temperature", "rpm"), ("torque", "MNm")])
def test_foreign_units_are_not_converted(q, unit):
    assert unit_conversion(q, unit) is None


def _csv(path, units):
    """A plain S1 run (15:1, 1000 r/min, 0.5 N*m in, 80 % efficient) written in ``units``."""
    n = 600
    t = np.arange(n) * 0.01
    n_in = np.full(n, 1000.0) + 0.1 * np.sin(t)
    T_in = 0.5 + 0.05 * np.sin(t / 2)
    edge = {"time_s": t, "speed_in_rpm": n_in, "torque_in_Nm": T_in,
            "speed_out_rpm": n_in / 15, "torque_out_Nm": T_in * 15 * 0.8,
            "temperature_C": 30 + 10 * t / t[-1]}
    back = {}                                   # edge -> file unit, by the table's own rows
    for key, (unit, inverse) in units.items():
        back[key] = inverse(edge[key])
    cols = list(edge)
    header = [f"{k.rsplit('_', 1)[0]} [{units[k][0]}]" if k in units else k for k in cols]
    rows = zip(*[back.get(k, edge[k]) for k in cols])
    path.write_text(",".join(header) + "\n" + "\n".join(",".join(f"{v:.12g}" for v in r)
                                                          for r in rows) + "\n")
    return edge


# file unit and its hand-written inverse (edge -> file)
END_TO_END = {
    "degF": ("temperature_C", "degF", lambda c: c * 9 / 5 + 32),
    "K": ("temperature_C", "K", lambda c: c + 273.15),
    "N*mm": ("torque_in_Nm", "N*mm", lambda nm: nm * 1000),
    "N*cm": ("torque_out_Nm", "N*cm", lambda nm: nm * 100),
    "rad/s": ("speed_in_rpm", "rad/s", lambda rpm: rpm * 2 * math.pi / 60),
    "Hz": ("speed_out_rpm", "Hz", lambda rpm: rpm / 60),
    "ms": ("time_s", "ms", lambda s: s * 1000),
}


@pytest.mark.parametrize("name", list(END_TO_END))
def test_end_to_end_through_a_header(tmp_path, name):
    key, unit, inverse = END_TO_END[name]
    edge = _csv(tmp_path / "r.csv", {key: (unit, inverse)})
    rec = read_recording(tmp_path / "r.csv", check=False)
    got = {"time_s": rec.time, "speed_in_rpm": rec.speed_in * 30 / math.pi,
           "torque_in_Nm": rec.torque_in, "speed_out_rpm": rec.speed_out * 30 / math.pi,
           "torque_out_Nm": rec.torque_out, "temperature_C": rec.temperature}
    np.testing.assert_allclose(got[key], edge[key], rtol=1e-9, atol=1e-9)
    assert any(f"{key}: converted from {unit}" in n for n in rec.notes), rec.notes


def test_units_option_overrides_and_refuses_foreign_units():
    assert parse_units("torque_in_Nm=N*mm,time_s=ms") == {"torque_in_Nm": "N*mm",
                                                          "time_s": "ms"}
    with pytest.raises(RecordingError, match="furlong"):
        parse_units("torque_in_Nm=furlong")
    with pytest.raises(RecordingError, match="twice"):
        parse_units("time_s=s,time_s=ms")
