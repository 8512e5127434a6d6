"""Which design a built native reducer carries, read from its model description.

The design is compiled into ``CycloidDriveNative`` (its loss map): the model description lists
the design's values as constants and the design's extra physics as parameter start values
(cyclo_fmu/native/build.py, ``design_constants`` and ``EXTRA``). Comparing them with a design
tells whether an FMU on disk was built for it, without rebuilding the map.
"""
from __future__ import annotations

import math
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET


def fmu_design_mismatch(path, design) -> str | None:
    """None when the native reducer at ``path`` was built for ``design`` (default: the
    paper's drive), else the first differing field as 'name: FMU value != design value'."""
    from model_core import DriveDesign

    from .build import EXTRA, design_constants
    design = design or DriveDesign()
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    starts = {}
    for sv in root.iter("ScalarVariable"):          # FMI 2.0
        el = sv[0]
        starts[sv.get("name")] = (el.tag, el.get("start"))
    mv = root.find("ModelVariables") if root.get("fmiVersion", "").startswith("3") else None
    for v in mv if mv is not None else ():         # FMI 3.0: start attribute or <Start value>
        start = v.get("start")
        if start is None and v.find("Start") is not None:
            start = v.find("Start").get("value")
        starts[v.get("name")] = (v.tag, start)
    want = [(name, kind, value) for name, kind, value, _unit, _desc in design_constants(design)]
    want += [(name, "Real", getattr(design.extra, name)) for name, *_ in EXTRA]
    for name, kind, value in want:
        if name not in starts:
            return f"{name}: not in the FMU"
        tag, text = starts[name]
        if kind == "Real":
            same = text is not None and (float(text) == float(value)
                                         or (math.isnan(float(text)) and math.isnan(value)))
        elif kind == "Integer":
            same = text is not None and int(text) == int(value)
        else:
            same = (text or "") == str(value)
        if not same:
            return f"{name}: {text} != {value}"
    return None


def fmu_carries_design(path, design) -> bool:
    return Path(path).is_file() and fmu_design_mismatch(path, design) is None
