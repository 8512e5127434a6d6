"""Units and column names of bench recordings: recognise, convert once to the schema's edge units.

The schema (``cyclo_fmu.recordings.SCHEMA``) keeps time in s, speeds in signed r/min, torques in
N*m and temperature in degC; every other unit a file declares (in the column name, in a units row
or with ``--units``) is converted here, once, by a factor (and an offset for temperature). A unit
written with a leading minus (``-N*m``) also negates the column: the override for a torque
recorded with the opposite sign convention.
"""
from __future__ import annotations

import math
import re

from ..recordings import REQUIRED, SCHEMA, RecordingError

#: quantity of each schema column and its edge unit
QUANTITY = {"time_s": "time", "speed_in_rpm": "speed", "speed_out_rpm": "speed",
            "torque_in_Nm": "torque", "torque_out_Nm": "torque", "temperature_C": "temperature"}
EDGE_UNIT = {"time": "s", "speed": "r/min", "torque": "N*m", "temperature": "degC"}

# factor to the edge unit, keyed by the normalised spelling (see ``_norm_unit``)
_FACTORS = {
    "time": {"s": 1.0, "sec": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "ns": 1e-9,
             "min": 60.0, "h": 3600.0},
    "speed": {"rpm": 1.0, "r/min": 1.0, "1/min": 1.0, "u/min": 1.0, "min^-1": 1.0,
              "min-1": 1.0, "rev/min": 1.0, "rad/s": 30.0 / math.pi, "rads": 30.0 / math.pi,
              "rad_s": 30.0 / math.pi, "hz": 60.0, "1/s": 60.0, "r/s": 60.0, "rps": 60.0,
              "rev/s": 60.0, "deg/s": 1.0 / 6.0},
    "torque": {"n*m": 1.0, "nm": 1.0, "n*mm": 1e-3, "nmm": 1e-3, "n*cm": 1e-2, "ncm": 1e-2,
               "kn*m": 1e3, "knm": 1e3, "mn*m": 1e-3, "mnm": 1e-3},
    "temperature": {"degc": 1.0, "c": 1.0, "celsius": 1.0, "k": 1.0, "degf": 5.0 / 9.0},
}
_OFFSETS = {("temperature", "k"): -273.15, ("temperature", "degf"): -32.0 * 5.0 / 9.0}
# torque "mNm" is milli-newton-metre: keep case for that one spelling before lower-casing
_CASE_SENSITIVE = {"mNm": "mnm", "mN*m": "mn*m", "MNm": None, "MN*m": None}


def _norm_unit(text: str) -> str:
    u = text.strip().strip("[](){}").strip()
    u = (u.replace("·", "*").replace("⋅", "*").replace("×", "*").replace("°", "deg")
         .replace("²", "^2").replace("−", "-"))
    u = re.sub(r"\s+", "", u)
    u = u.replace("n.m", "n*m").replace("N.m", "N*m").replace("N.mm", "N*mm")
    if u in _CASE_SENSITIVE:
        return _CASE_SENSITIVE[u] or "?"
    u = u.lower()
    return {"deg_c": "degc", "degreec": "degc", "grad_c": "degc", "gradc": "degc",
            "degk": "k", "min⁻¹": "min^-1", "1/min": "1/min"}.get(u, u)


def unit_conversion(quantity: str, unit: str):
    """``(factor, offset, sign)`` so that ``edge = sign * (factor * x + offset)``, or None when
    ``unit`` is not a unit of ``quantity``. A leading '-' sets sign = -1."""
    u = unit.strip()
    sign = 1.0
    if u.startswith("-"):
        sign, u = -1.0, u[1:]
    n = _norm_unit(u)
    f = _FACTORS[quantity].get(n)
    if f is None:
        return None
    return f, _OFFSETS.get((quantity, n), 0.0), sign


def quantity_of_unit(unit: str):
    """The quantity a unit text measures ("time", "speed", ...), or None."""
    n = _norm_unit(unit.lstrip("-"))
    for q, table in _FACTORS.items():
        if n in table and not (q == "temperature" and n in ("c", "k")):
            return q
    if n in ("c", "k"):
        return "temperature"
    return None


def parse_units(text: str) -> dict:
    """``"torque_in_Nm=N*mm,time_s=ms"`` -> ``{"torque_in_Nm": "N*mm", "time_s": "ms"}``.

    Keys are schema names, each once; each unit must be one of its quantity's units."""
    out = {}
    for part in (p.strip() for p in str(text).split(",")):
        if not part:
            continue
        key, sep, unit = (x.strip() for x in part.partition("="))
        if not sep or not key or not unit:
            raise RecordingError(f"units = {text!r}: entry {part!r} must be 'schema_name=unit'")
        if key not in SCHEMA:
            raise RecordingError(f"units: {key!r} is not a recording column ({', '.join(SCHEMA)})")
        if key in out:
            raise RecordingError(f"units: {key!r} is given twice ({out[key]!r}, {unit!r})")
        q = QUANTITY[key]
        if unit_conversion(q, unit) is None:
            raise RecordingError(f"units: {unit!r} is not a {q} unit for {key} (e.g. "
                                 f"{', '.join(list(_FACTORS[q])[:6])})")
        out[key] = unit
    return out


# ---- column names ----------------------------------------------------------------------------
_BRACKET = re.compile(r"^(.*?)[\s_]*[\[\(\{]([^\]\)\}]*)[\]\)\}]\s*$")
_IN = {"in", "input", "an", "antrieb", "motor", "drive", "driving", "ein", "eingang"}
_OUT = {"out", "output", "ab", "abtrieb", "load", "brake", "driven", "aus", "ausgang"}
_SPEED = {"speed", "n", "drehzahl", "omega", "w", "rpm", "velocity", "rotspeed"}
_TORQUE = {"torque", "t", "m", "tq", "drehmoment", "moment", "trq"}
_TIME = {"time", "t", "zeit", "timestamp", "times", "sec"}
_TEMP = {"temperature", "temp", "temperatur", "oil", "oiltemp", "theta", "t_oil", "toil"}
# unit words that may close a column name (``torque_in_Nm``, ``n_out_1/min``)
_NAME_UNITS = ("n*mm", "nmm", "n*m", "nm", "knm", "mnm", "ncm", "rpm", "r/min", "1/min",
               "u/min", "rad/s", "rads", "rad_s", "hz", "rps", "ms", "us", "s", "min",
               "degc", "c", "k", "degf")


def split_name_unit(name: str):
    """``"torque_in [N*m]"`` -> ``("torque_in", "N*m")``; ``"T_in_Nm"`` -> ``("T_in", "Nm")``;
    ``"speed_in"`` -> ``("speed_in", None)``."""
    name = name.strip()
    m = _BRACKET.match(name)
    if m and m.group(1):
        return m.group(1).strip(), m.group(2).strip()
    for sep in ("_", " ", "/"):
        if sep in name:
            base, _, last = name.rpartition(sep)
            if base and _norm_unit(last) in _NAME_UNITS:
                # 'rad_s' spans two tokens
                if last.lower() == "s" and base.lower().endswith("_rad"):
                    return base[:-4], "rad/s"
                return base, last
    if name.lower().endswith("rpm") and len(name) > 3:
        return name[:-3].rstrip("_ "), "rpm"
    return name, None


def _tokens(base: str):
    return [t for t in re.split(r"[^0-9a-zäöüß]+", base.lower()) if t]


def recognise(base: str):
    """The schema column a file's column name (unit stripped) stands for, or None."""
    toks = _tokens(base)
    if not toks:
        return None
    s = set(toks)
    if toks == ["time"] or toks == ["t"] or toks[0] in ("time", "zeit", "timestamp") and \
            not (s & (_IN | _OUT)):
        return "time_s"
    if s & {"temperature", "temp", "temperatur", "oiltemp", "toil", "theta"} or \
            toks[:2] == ["t", "oil"]:
        return "temperature_C"
    side = "in" if s & _IN else "out" if s & _OUT else None
    if side is None:
        return None
    if s & _SPEED:
        return f"speed_{side}_rpm"
    if s & _TORQUE:
        return f"torque_{side}_Nm"
    return None


def map_columns(header, columns: dict | None, units: dict | None):
    """Decide which file column feeds each schema column and in which unit.

    Returns ``(mapping, notes)``: ``mapping[key] = (index, file_name, unit_text, source)`` where
    ``source`` says where the unit came from ("--units", "name", "units row", "schema default").
    Explicit ``columns`` win over the name heuristics; every heuristic mapping is reported."""
    columns, units = dict(columns or {}), dict(units or {})
    for key in columns:
        if key not in SCHEMA:
            raise RecordingError(f"columns: {key!r} is not a recording column ({', '.join(SCHEMA)})")
    names = [h.strip() for h in header]
    mapping, notes = {}, []
    # 1. explicit mapping, then the schema's own names
    for key in SCHEMA:
        name = columns.get(key)
        if name is None and key in names:
            name = key
        if name is None:
            continue
        label = repr(name) if name == key else f"{name!r} ({key})"
        if name not in names:
            if key in columns:
                raise RecordingError(f"column {label} is missing; found: {', '.join(names)}")
            continue
        if names.count(name) > 1:
            raise RecordingError(f"column {label} appears {names.count(name)} times in the header")
        mapping[key] = names.index(name)
    # 2. recognised names for the rest
    taken = set(mapping.values())
    guessed = {}
    for j, name in enumerate(names):
        if j in taken:
            continue
        base, _ = split_name_unit(name)
        key = recognise(base)
        if key is None or key in mapping:
            continue
        guessed.setdefault(key, []).append(j)
    for key, js in guessed.items():
        if len(js) > 1:
            raise RecordingError(
                f"columns {', '.join(repr(names[j]) for j in js)} could each be {key}; "
                f"choose one with --columns {key}=NAME")
        mapping[key] = js[0]
        notes.append(f"column {names[js[0]]!r} read as {key} (recognised by name; "
                     f"override with --columns {key}=NAME)")
    for key in REQUIRED:
        if key not in mapping:
            label = repr(columns.get(key, key))
            if key in columns:
                label = f"{columns[key]!r} ({key})"
            raise RecordingError(f"column {label} is missing; found: {', '.join(names)} "
                                 f"(map it with --columns {key}=NAME)")
    for key, unit in units.items():            # an override for nothing is not ignored
        if key not in mapping:
            raise RecordingError(f"units: {key}={unit} names a column the recording does not "
                                 f"have (found: {', '.join(names)}); drop it or map the column "
                                 f"with --columns {key}=NAME")
    out = {}
    for key, j in mapping.items():
        out[key] = (j, names[j])
    return out, notes
