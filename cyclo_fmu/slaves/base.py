"""Common base of our slaves: SI units, descriptions and a truthful ModelStructure.

pythonfmu writes neither units nor output dependencies nor InitialUnknowns; ``to_xml`` adds
them: <UnitDefinitions> (schema position after <CoSimulation>), a ``unit`` on every Real, and
<Outputs>/<InitialUnknowns> with the dependencies each slave declares.
"""
from __future__ import annotations

import math
from xml.etree.ElementTree import Element, SubElement

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability
from pythonfmu.enums import Fmi2Status
from pythonfmu.variables import Boolean, Integer, Real, String

# SI base-unit exponents of the units we use (FMI 2.0 BaseUnit attributes)
UNITS = {
    "rad/s": dict(rad=1, s=-1),
    "N.m": dict(kg=1, m=2, s=-2),
    "W": dict(kg=1, m=2, s=-3),
    "m": dict(m=1),
    "m2/s": dict(m=2, s=-1),
    "kg/m3": dict(kg=1, m=-3),
    "kg.m2": dict(kg=1, m=2),
    "s": dict(s=1),
    "1": dict(),
    "rad": dict(rad=1),
    "Hz": dict(s=-1),
    "N.m.s/rad": dict(kg=1, m=2, s=-1, rad=-1),
    "N.m/rad": dict(kg=1, m=2, s=-2, rad=-1),
}


class UnitSlave(Fmi2Slave):
    """Fmi2Slave with units, descriptions and declared output dependencies."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._units = {}
        self._depends = {}       # output name -> list of input names
        self._error_logged = False

    # -- registration helpers -----------------------------------------------------------------
    def parameter(self, name, value, unit=None, description="", kind=Real):
        setattr(self, name, value)
        self.register_variable(kind(name, causality=Fmi2Causality.parameter,
                                    variability=Fmi2Variability.fixed, description=description))
        if unit:
            self._units[name] = unit

    def schedule_parameters(self, unit, what):
        """Numbered Real parameters carrying a schedule of at most SCHEDULE_POINTS setpoints
        (every master can set them): ``schedule_points`` (0: none), ``schedule_time_k`` [s] and
        ``schedule_value_k`` [unit]."""
        from model_core.rig import SCHEDULE_POINTS
        self.parameter("schedule_points", 0, None, f"number of {what} setpoints carried by "
                       f"schedule_time_k/schedule_value_k (0: none; at most {SCHEDULE_POINTS})",
                       Integer)
        for k in range(1, SCHEDULE_POINTS + 1):
            self.parameter(f"schedule_time_{k}", 0.0, "s", f"time of {what} setpoint {k}")
            self.parameter(f"schedule_value_{k}", 0.0, unit, f"{what} setpoint {k}, held until "
                           "the next")

    def schedule_from_parameters(self, text_name):
        """The schedule of the String parameter ``text_name`` or of the numbered parameters
        (not both), or None."""
        from model_core.rig import SCHEDULE_POINTS, parse_schedule, schedule_from_points
        text = getattr(self, text_name).strip()
        n = int(self.schedule_points)
        if text and n:
            raise ValueError(f"{text_name} and schedule_points = {n}: give the schedule one way")
        if text:
            return parse_schedule(text, text_name)
        if n:
            k = range(1, SCHEDULE_POINTS + 1)
            return schedule_from_points(n, [getattr(self, f"schedule_time_{i}") for i in k],
                                        [getattr(self, f"schedule_value_{i}") for i in k],
                                        "schedule")
        if not 0 <= n <= SCHEDULE_POINTS:
            raise ValueError(f"schedule_points = {n}: must be 0 to {SCHEDULE_POINTS}")
        return None

    def input(self, name, value, unit, description=""):
        setattr(self, name, value)
        self.register_variable(Real(name, causality=Fmi2Causality.input, description=description))
        self._units[name] = unit

    def output(self, name, value, unit=None, description="", depends=(), kind=Real):
        setattr(self, name, value)
        variability = Fmi2Variability.discrete if kind is Boolean else None
        self.register_variable(kind(name, causality=Fmi2Causality.output, variability=variability,
                                    description=description))
        if unit:
            self._units[name] = unit
        self._depends[name] = list(depends)

    # -- errors -------------------------------------------------------------------------------
    def fail(self, message: str):
        """Log an error and raise, which pythonfmu turns into fmi2Error (the host survives)."""
        self.log(message, Fmi2Status.error, "logStatusError")
        raise ValueError(message)

    def require_finite(self, **values):
        for name, v in values.items():
            if not (isinstance(v, (int, float)) and math.isfinite(v)):
                self.fail(f"{name} = {v!r}: input must be a finite number")

    # -- model description --------------------------------------------------------------------
    def to_xml(self, model_options=dict()) -> Element:
        root = super().to_xml(model_options)
        names = [v.name for v in self.vars.values()]
        index = {n: i + 1 for i, n in enumerate(names)}
        # units
        used = sorted({self._units[n] for n in self._units})
        unit_defs = Element("UnitDefinitions")
        for u in used:
            el = SubElement(unit_defs, "Unit", name=u)
            SubElement(el, "BaseUnit", {k: str(v) for k, v in UNITS[u].items()})
        children = list(root)
        pos = next(i for i, c in enumerate(children) if c.tag == "CoSimulation") + 1
        root.insert(pos, unit_defs)
        for sv in root.find("ModelVariables"):
            unit = self._units.get(sv.get("name"))
            real = sv.find("Real")
            if unit and real is not None:
                real.set("unit", unit)
        # structure: outputs with their dependencies, and the same as initial unknowns
        structure = root.find("ModelStructure")
        for child in list(structure):
            structure.remove(child)
        outs = [n for n in names if n in self._depends]
        if outs:
            o = SubElement(structure, "Outputs")
            for n in outs:
                SubElement(o, "Unknown", self._unknown(n, index))
            init = SubElement(structure, "InitialUnknowns")
            for n in sorted(outs, key=index.get):
                SubElement(init, "Unknown", self._unknown(n, index))
        return root

    def _unknown(self, name, index):
        attrib = {"index": str(index[name])}
        deps = sorted(index[d] for d in self._depends[name])
        attrib["dependencies"] = " ".join(map(str, deps))
        if deps:
            attrib["dependenciesKind"] = " ".join(["dependent"] * len(deps))
        return attrib


__all__ = ["UnitSlave", "Real", "Integer", "Boolean", "String", "Fmi2Status"]
