"""The FMUs' variables as Markdown tables, rendered from the modelDescription.xml that their
build writes, so that the documentation lists exactly what a host sees.

The Python FMUs' description comes from the slave itself (pythonfmu's ``to_xml``, which
``FmuBuilder`` writes into the FMU); the native FMU's from ``cyclo_fmu.native.build
.model_description`` for the default design (the one ``build_native_fmu`` writes, without
compiling). The docs hook ``docs/_hooks/cli_reference.py`` replaces the marker
``<!-- fmu-variables NAME -->`` with :func:`render_fmu_variables`.
"""
from __future__ import annotations

import importlib
import re
import tempfile
import xml.etree.ElementTree as ET

#: Marker of a generated table: ``<!-- fmu-variables CycloidDrive -->``.
MARKER = re.compile(r"<!-- fmu-variables (\w+) -->")


def model_description(name: str) -> ET.Element:
    """The ``fmiModelDescription`` element of FMU ``name`` (a Python FMU of
    ``cyclo_fmu.fmu_build.SLAVES`` or ``CycloidDriveNative``, default design)."""
    from .fmu_build import NATIVE, SLAVES
    if name in SLAVES:
        module = importlib.import_module(f"cyclo_fmu.slaves.{SLAVES[name]}")
        with tempfile.TemporaryDirectory(prefix="cyclofmu_doc_") as tmp:
            slave = getattr(module, name)(instance_name="doc", resources=tmp)
            return slave.to_xml()
    if name in NATIVE:
        from model_core import DriveDesign
        from .native.build import (MAP_SPEED_MAX, MAP_TORQUE_MAX, design_constants,
                                   model_description as native_md)
        design = DriveDesign()
        return ET.fromstring(native_md(design, design_constants(design), "{guid}",
                                       MAP_TORQUE_MAX, MAP_SPEED_MAX, name))
    raise ValueError(f"unknown FMU {name!r}; known: {', '.join(tuple(SLAVES) + NATIVE)}")


def variables(md: ET.Element) -> list[dict]:
    """One dict per ScalarVariable: name, causality, variability, type, unit, display unit
    (the variable's own ``displayUnit``; a host may offer the unit's other display units),
    start, min, max, description (absent attributes as empty strings; FMI's defaults filled:
    causality local, variability continuous)."""
    out = []
    for sv in md.findall("ModelVariables/ScalarVariable"):
        typed = next(iter(sv))
        unit = typed.get("unit", "")
        shown = typed.get("displayUnit", "")
        out.append({"name": sv.get("name"), "causality": sv.get("causality", "local"),
                    "variability": sv.get("variability", "continuous"), "type": typed.tag,
                    "unit": unit, "display": shown or "", "start": typed.get("start", ""),
                    "min": typed.get("min", ""), "max": typed.get("max", ""),
                    "description": sv.get("description", "")})
    return out


def _cell(text) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def render_fmu_variables(name: str) -> str:
    """Markdown: the FMU's variables in the order of its modelDescription.xml, grouped by
    causality (inputs, outputs, parameters, the rest); internal variables (names starting
    with ``_``) are left out and counted."""
    rows = variables(model_description(name))
    hidden = [r for r in rows if r["name"].startswith("_")]
    rows = [r for r in rows if not r["name"].startswith("_")]
    order = {"input": 0, "output": 1, "parameter": 2, "calculatedParameter": 3}
    rows.sort(key=lambda r: order.get(r["causality"], 4))
    lines = ["| variable | causality, variability | type | unit (display) | start | range | "
             "description |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        unit = r["unit"] + (f" ({r['display']})" if r["display"] else "")
        rng = (f"{r['min'] or '−∞'} … {r['max'] or '∞'}" if (r["min"] or r["max"]) else "")
        lines.append(f"| `{r['name']}` | {r['causality']}, {r['variability']} | {r['type']} | "
                     f"{_cell(unit)} | {_cell(r['start'])} | {_cell(rng)} | "
                     f"{_cell(r['description'])} |")
    note = (f"\n\n{len(rows)} variables" + (f" (and {len(hidden)} internal, not for hosts: "
            + ", ".join(f"`{r['name']}`" for r in hidden) + ")" if hidden else "")
            + ", generated from the modelDescription.xml the build writes.")
    return "\n".join(lines) + note
