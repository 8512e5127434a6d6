"""Common base of our slaves: FMI semantics and metadata that pythonfmu 0.7 does not provide.

- ``to_xml`` adds <UnitDefinitions> with display units (r/min, %, mm, ...), ``unit``,
  ``quantity`` and ``displayUnit`` on every Real, ``min``/``max`` on parameters, the model's
  version, license and copyright, a <DefaultExperiment>, and a truthful <ModelStructure>:
  <Outputs> with their input dependencies (Step Mode) and <InitialUnknowns> with their input
  *and parameter* dependencies (Initialization Mode).
- Initialization Mode: outputs are valid there (FMI 2.0 lets a master read ``initial =
  calculated`` outputs after setting inputs). Every get of an output in Initialization Mode
  re-evaluates the slave (``_setup`` when a parameter changed, then ``_evaluate_init``, which
  must not commit any dynamic state), as the native FMU does.
- Errors: ``fail`` logs the message (category logStatusError) and raises; the pythonfmu binary
  reports any Python exception to the host as fmi2Fatal (see README, limits).
"""
from __future__ import annotations

import hashlib
import json
import math
import operator
import os
import sys
import uuid
from pathlib import Path
from xml.etree.ElementTree import Element, SubElement

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability
from pythonfmu.enums import Fmi2Status
from pythonfmu.variables import Boolean, Integer, Real, String

#: Inside an FMU whose binary for this platform is our C front (fmu_build._install_status_shim;
#: ``_status_front`` lists the platforms: linux64, and win64 when the FMU was built with
#: a win64 cross compiler, mingw-w64 or Zig): a failure is reported through the variable ``_failed`` (value reference
#: 0), which the front reads after fmi2ExitInitializationMode and after a step that returned
#: False (fmi2Discard from pythonfmu), and answers with fmi2Error. pythonfmu's own binary turns
#: a raised exception into fmi2Fatal and its exception handling can corrupt the host's
#: interpreter (a crash at a later point), so with the front no exception crosses into
#: pythonfmu. Elsewhere (a platform without the front, the source tree) we raise.
def _front_here() -> bool:
    """Is this platform's binary our C front? (``_status_front`` lists the platforms)"""
    plat = ("linux64" if sys.platform.startswith("linux")
            else "win64" if sys.platform == "win32" and sys.maxsize > 2**32 else None)
    try:
        marker = (Path(__file__).resolve().parent / "_status_front").read_text()
    except OSError:
        return False
    return plat is not None and plat in marker.split()


STATUS_FRONT = _front_here()

#: Model metadata written into every Python FMU's modelDescription.xml (as the native FMU's)
LICENSE = "MIT"
COPYRIGHT = "Copyright (c) the cyclo-fmu authors"

#: display units per unit: (name, factor), display value = factor * SI value (FMI 2.0
#: DisplayUnit, offset 0); the first one is the variables' ``displayUnit``
DISPLAY_UNITS = {
    "rad/s": (("r/min", 30.0 / math.pi),),
    "m": (("mm", 1e3), ("um", 1e6)),
    "m2/s": (("mm2/s", 1e6),),
    "rad": (("deg", 180.0 / math.pi),),
    "1": (("%", 100.0),),
}
#: quantity per unit, when a variable does not name its own
QUANTITIES = {"rad/s": "AngularVelocity", "r/min": "AngularVelocity", "N.m": "Torque", "W": "Power", "m": "Length",
              "m2/s": "KinematicViscosity", "kg/m3": "Density", "kg.m2": "MomentOfInertia",
              "s": "Time", "rad": "Angle", "Hz": "Frequency", "1": "DimensionlessRatio",
              "N.m.s/rad": "RotationalDampingConstant", "N.m/rad": "RotationalSpringConstant",
              "rad/s2": "AngularAcceleration", "K": "ThermodynamicTemperature",
              "J/K": "HeatCapacity", "W/(m2.K)": "CoefficientOfHeatTransfer", "m2": "Area"}

# SI base-unit exponents of the units we use (FMI 2.0 BaseUnit attributes)
UNITS = {
    "rad/s": dict(rad=1, s=-1),
    "r/min": dict(rad=1, s=-1, factor=math.pi / 30),    # a speed sensor's reading
    "rad/s2": dict(rad=1, s=-2),
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
    "K": dict(K=1),
    "J/K": dict(kg=1, m=2, s=-2, K=-1),
    "W/(m2.K)": dict(kg=1, s=-3, K=-1),
    "m2": dict(m=2),
}


def _drop_repeated_path(folder):
    """pythonfmu 0.7 puts the FMU's resources folder in front of the host's ``sys.path`` at
    every fmi2Instantiate and never takes it out: a host creating many instances got a
    ``sys.path`` one entry longer each time (20 instances, 20 copies; every later import walks
    them). The entry just put there is dropped when the same folder stands further down, so
    ``sys.path`` holds it once, as after the first instance (same folder, same imports)."""
    if not folder or len(sys.path) < 2 or not isinstance(sys.path[0], str):
        return
    head = os.path.normpath(sys.path[0])
    if head == os.path.normpath(str(folder)) and any(
            isinstance(p, str) and os.path.normpath(p) == head for p in sys.path[1:]):
        del sys.path[0]


class UnitSlave(Fmi2Slave):
    """Fmi2Slave with units, descriptions and declared output dependencies."""

    #: DefaultExperiment (s): start, stop, communication step
    default_start, default_stop, default_step = 0.0, 10.0, 1e-3
    #: parameters the outputs do not depend on in Initialization Mode (no step yet)
    init_independent: tuple = ()

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        _drop_repeated_path(getattr(self, "resources", None))
        self._failed = False
        self.register_variable(Boolean("_failed", causality=Fmi2Causality.local,
                                       variability=Fmi2Variability.discrete,
                                       description="internal: the last fmi2ExitInitializationMode "
                                       "or fmi2DoStep failed (read by the FMU's C front, which "
                                       "returns fmi2Error)"))
        step = self.do_step

        def guarded_step(t, h):
            # _guarded, inlined: a step is the hot path of a co-simulation
            self._failed = False
            try:
                if not 0.0 <= h < math.inf or not -math.inf < t < math.inf:
                    self.fail(f"fmi2DoStep: currentCommunicationPoint = {t!r}, "
                              f"communicationStepSize = {h!r}: need finite values and a step "
                              ">= 0")
                if self._setup_key is None:
                    self.fail("fmi2DoStep: the instance is not initialized (fmi2ExitInitialization"
                              "Mode was not called or failed; its reason was logged there)")
                result = step(t, h)
            except Exception as exc:   # noqa: BLE001 - reported as fmi2Error, never lost
                return self._failure(exc)
            return True if result is None else result
        self.do_step = guarded_step
        self._real_names = None      # value reference -> attribute, built at the first get/set
        self._getters, self._setters = {}, {}   # per list of value references
        self._units = {}
        self._quantity = {}      # name -> quantity (overrides QUANTITIES)
        self._display = {}       # name -> display unit (overrides DISPLAY_UNITS' first)
        self._limits = {}        # parameter name -> (min, max)
        self._depends = {}       # output name -> list of input names
        self._params = []        # parameter names, in registration order
        self._error_logged = False
        self._in_init = False
        self._setup_key = None
        self._prepared_key = None

    # -- registration helpers -----------------------------------------------------------------
    def parameter(self, name, value, unit=None, description="", kind=Real, min=None, max=None,
                  quantity=None, display=None):
        setattr(self, name, value)
        self.register_variable(kind(name, causality=Fmi2Causality.parameter,
                                    variability=Fmi2Variability.fixed, description=description))
        self._params.append(name)
        if unit:
            self._units[name] = unit
        if min is not None or max is not None:
            self._limits[name] = (min, max)
        if quantity:
            self._quantity[name] = quantity
        if display:
            self._display[name] = display

    def schedule_parameters(self, unit, what):
        """Numbered Real parameters carrying a schedule of at most SCHEDULE_POINTS setpoints
        (every master can set them): ``schedule_points`` (0: none), ``schedule_time_k`` [s] and
        ``schedule_value_k`` [unit]."""
        from . import core
        SCHEDULE_POINTS = core.rig.SCHEDULE_POINTS
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
        from . import core
        SCHEDULE_POINTS = core.rig.SCHEDULE_POINTS
        parse_schedule, schedule_from_points = core.rig.parse_schedule, core.rig.schedule_from_points
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

    def output(self, name, value, unit=None, description="", depends=(), kind=Real,
               quantity=None, display=None):
        if quantity:
            self._quantity[name] = quantity
        if display:
            self._display[name] = display
        setattr(self, name, value)
        variability = Fmi2Variability.discrete if kind is Boolean else None
        self.register_variable(kind(name, causality=Fmi2Causality.output, variability=variability,
                                    description=description))
        if unit:
            self._units[name] = unit
        self._depends[name] = list(depends)

    # -- messages -----------------------------------------------------------------------------
    def log(self, msg, status=Fmi2Status.ok, category=None, debug=None):
        """pythonfmu's ``log`` with every '%' escaped as '%%': pythonfmu's binary hands the
        message to the host's logger as its *format* argument (and our C front reads the text
        the same way), so a user's value in a message (a schedule, a mode) must never carry a
        printf directive."""
        super().log(str(msg).replace("%", "%%"), status, category)

    # -- FMU state ------------------------------------------------------------------------------
    #: internal attributes (JSON values) that, with the registered variables, define what the
    #: slave does from here on; subclasses list theirs (fmi2GetFMUstate/fmi2SetFMUstate)
    state_attributes: tuple = ()

    def _get_fmu_state(self):
        state = super()._get_fmu_state()
        state["_internal"] = {a: _to_json(getattr(self, a, None)) for a in
                              self.state_attributes + _BASE_STATE}
        return json.loads(json.dumps(state))          # a copy, detached from the live values

    def _state_problem(self, state):
        """Why ``state`` is not a state of this FMU (None if it is): every registered variable
        with a value of its type, and only the internal attributes this slave lists."""
        if not isinstance(state, dict):
            return "not a mapping"
        kinds = {v.name: type(v) for v in self.vars.values()}
        extra = set(state) - set(kinds) - {"_internal"}
        if extra:
            return f"unknown entries {sorted(extra)[:3]}"
        for name, kind in kinds.items():
            if name not in state:
                return f"{name} missing"
            v = state[name]
            ok = (isinstance(v, bool) if kind is Boolean else isinstance(v, str) if kind is String
                  else isinstance(v, int) and not isinstance(v, bool) if kind is Integer
                  else isinstance(v, (int, float)) and not isinstance(v, bool))
            if not ok:
                return f"{name} = {v!r} is not a {kind.__name__}"
        internal = state.get("_internal", {})
        if not isinstance(internal, dict):
            return "internal state not a mapping"
        unknown = set(internal) - set(self.state_attributes) - set(_BASE_STATE)
        if unknown:
            return f"unknown internal entries {sorted(unknown)[:3]}"
        return None

    def _set_fmu_state(self, state):
        problem = self._state_problem(state)
        if problem is not None:
            # refused before anything changes; the C front reads _failed (fmi2Error)
            message = f"fmi2SetFMUstate: not a state of this FMU ({problem})"
            self.log(message, Fmi2Status.error, "logStatusError")
            if not STATUS_FRONT:
                raise _Failure(message)
            self._failed = True
            return
        state = dict(state)
        internal = state.pop("_internal", {})
        super()._set_fmu_state(state)
        internal = {a: _from_json(v) for a, v in internal.items()}
        if (internal.get("_setup_key") is not None
                and internal["_setup_key"] != getattr(self, "_prepared_key", None)):
            # a state of an instance set up with other parameters (the state's own are
            # restored above): prepare for them, then restore the dynamic state
            self._setup()
            self._prepared_key = internal["_setup_key"]
        for a, v in internal.items():
            setattr(self, a, v)
        self._getters, self._setters = {}, {}

    # -- errors -------------------------------------------------------------------------------
    def fail(self, message: str):
        """Log an error and raise; ``_guarded`` turns it into fmi2Error (through the C front)."""
        self.log(message, Fmi2Status.error, "logStatusError")
        raise _Failure(message)

    def _guarded(self, fn, *args):
        """Run an FMI callback; with the C front, a failure sets ``_failed`` instead of raising."""
        self._failed = False
        try:
            result = fn(*args)
            return True if result is None else result
        except Exception as exc:   # noqa: BLE001 - reported as fmi2Error, never lost
            return self._failure(exc)

    def _failure(self, exc):
        """Log an exception (``fail`` logged its own) and, with the C front, set ``_failed``
        and return False; elsewhere re-raise it."""
        if not isinstance(exc, _Failure):
            self.log(f"{type(exc).__name__}: {exc}", Fmi2Status.error, "logStatusError")
        if not STATUS_FRONT:
            raise exc
        self._failed = True
        return False        # do_step: fmi2Discard from pythonfmu, which the front reads

    def require_finite(self, **values):
        for name, v in values.items():
            if not (isinstance(v, (int, float)) and math.isfinite(v)):
                self.fail(f"{name} = {v!r}: input must be a finite number")

    def check_limits(self):
        """Every parameter against its declared min/max (the modelDescription's), as
        ValueError naming the parameter and value."""
        for name, (lo, hi) in self._limits.items():
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                continue
            if not math.isfinite(v) or (lo is not None and v < lo) or (hi is not None and v > hi):
                raise ValueError(f"{name} = {v!r}: must be a finite number in "
                                 f"[{'-inf' if lo is None else lo}, {'inf' if hi is None else hi}]")

    # -- Initialization Mode ------------------------------------------------------------------
    def _setup(self):
        """Validate the parameters and prepare the run (raise via ``fail``). Subclasses."""

    def _evaluate_init(self):
        """Outputs from the current inputs and parameters, committing no dynamic state."""

    def _parameter_key(self):
        return tuple(repr(getattr(self, n)) for n in self._params)

    def _ensure_setup(self):
        key = self._parameter_key()
        if key != self._setup_key:
            self._setup()
            self._setup_key = self._prepared_key = key

    def enter_initialization_mode(self):
        self._in_init = True

    def exit_initialization_mode(self):
        self._in_init = False
        self._setup_key = None          # always validate at the exit

        def run():
            self._ensure_setup()
            self._evaluate_init()
        self._guarded(run)

    def _refresh_init(self):
        """In Initialization Mode: bring the outputs up to date (f_init). A parameter or input
        the slave refuses leaves the outputs as they were; the message is logged once and the
        same error is returned by fmi2ExitInitializationMode."""
        if not self._in_init:
            return
        try:
            self._ensure_setup()
            self._evaluate_init()
        except Exception:      # noqa: BLE001 - logged by fail(); reported at the exit
            pass

    def _real_attributes(self):
        self._real_names = {vr: v.local_name for vr, v in self.vars.items()
                            if isinstance(v, Real)}
        self._getters = {}
        self._setters = {}
        return self._real_names

    def get_real(self, vrs):
        # pythonfmu's get_real over value references resolved once per list of references
        # (a master asks for the same list every step)
        if self._in_init:
            self._refresh_init()
        key = tuple(vrs)
        try:
            return self._getters[key](self)
        except (KeyError, TypeError):
            names = self._real_names or self._real_attributes()
            if not all(vr in names for vr in key):
                return super().get_real(vrs)        # its TypeError for a non-Real
            attrs = [names[vr] for vr in key]
            get = operator.attrgetter(*attrs)
            self._getters[key] = ((lambda o: [float(get(o))]) if len(attrs) == 1 else
                                  (lambda o: [float(v) for v in get(o)]))
            return self._getters[key](self)

    def set_real(self, vrs, values):
        key = tuple(vrs)
        try:
            attrs = self._setters[key]
        except (KeyError, TypeError):
            names = self._real_names or self._real_attributes()
            if not all(vr in names for vr in key):
                return super().set_real(vrs, values)
            attrs = self._setters[key] = [names[vr] for vr in key]
        for name, value in zip(attrs, values):
            setattr(self, name, value)

    def get_boolean(self, vrs):
        self._refresh_init()
        return super().get_boolean(vrs)

    def get_integer(self, vrs):
        self._refresh_init()
        return super().get_integer(vrs)

    # -- model description --------------------------------------------------------------------
    def to_xml(self, model_options=dict()) -> Element:
        root = self._to_xml(model_options)
        # a deterministic GUID: a digest of the description itself (its content and the
        # version), without the build time, so that the same model always has the same GUID
        # and a host that cached it does not re-import an unchanged FMU
        from xml.etree.ElementTree import tostring
        root.set("guid", "")
        stamp = root.attrib.pop("generationDateAndTime", None)
        digest = hashlib.sha256(tostring(root) + _version().encode()).digest()
        root.set("guid", "{" + str(uuid.UUID(bytes=digest[:16], version=5)) + "}")
        self.guid = root.get("guid")
        if stamp is not None:
            root.set("generationDateAndTime", stamp)
        return root

    def _to_xml(self, model_options) -> Element:
        root = super().to_xml(model_options)
        root.set("version", _version())
        root.set("license", LICENSE)
        root.set("copyright", COPYRIGHT)
        names = [v.name for v in self.vars.values()]
        index = {n: i + 1 for i, n in enumerate(names)}
        # units, with display units
        used = sorted({self._units[n] for n in self._units})
        unit_defs = Element("UnitDefinitions")
        for u in used:
            el = SubElement(unit_defs, "Unit", name=u)
            SubElement(el, "BaseUnit", {k: str(v) for k, v in UNITS[u].items()})
            for dname, factor in DISPLAY_UNITS.get(u, ()):
                SubElement(el, "DisplayUnit", name=dname, factor=repr(float(factor)))
        children = list(root)
        pos = next(i for i, c in enumerate(children) if c.tag == "CoSimulation") + 1
        root.insert(pos, unit_defs)
        # DefaultExperiment before ModelVariables (schema order)
        old = root.find("DefaultExperiment")
        if old is not None:
            root.remove(old)
        children = list(root)
        pos = next(i for i, c in enumerate(children) if c.tag == "ModelVariables")
        root.insert(pos, Element("DefaultExperiment", startTime=repr(self.default_start),
                                 stopTime=repr(self.default_stop),
                                 stepSize=repr(self.default_step)))
        for sv in root.find("ModelVariables"):
            name = sv.get("name")
            unit = self._units.get(name)
            real = sv.find("Real")
            if real is None:
                lim = self._limits.get(name)
                el = sv.find("Integer")
                if lim and el is not None:
                    for k, v in zip(("min", "max"), lim):
                        if v is not None:
                            el.set(k, str(int(v)))
                continue
            # attribute order as the schema lists them: quantity, unit, displayUnit, ..., min, max
            start = real.attrib.pop("start", None)
            quantity = self._quantity.get(name) or QUANTITIES.get(unit or "1")
            if quantity:
                real.set("quantity", quantity)
            if unit:
                real.set("unit", unit)
                disp = self._display.get(name) or next(iter(DISPLAY_UNITS.get(unit, ())),
                                                         (None,))[0]
                if disp and (unit != "1" or name in self._display):
                    real.set("displayUnit", disp)
            for k, v in zip(("min", "max"), self._limits.get(name, (None, None))):
                if v is not None:
                    real.set(k, repr(float(v)))
            if start is not None:
                real.set("start", start)
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
                SubElement(init, "Unknown", self._unknown(n, index, initial=True))
        return root

    def initial_dependencies(self, name):
        """Inputs and parameters an output depends on in Initialization Mode: its Step-Mode
        inputs and every parameter but ``init_independent`` (a superset is truthful in FMI)."""
        return list(self._depends[name]) + [p for p in self._params
                                            if p not in self.init_independent]

    def _unknown(self, name, index, initial=False):
        attrib = {"index": str(index[name])}
        deps = sorted(index[d] for d in (self.initial_dependencies(name) if initial
                                         else self._depends[name]))
        attrib["dependencies"] = " ".join(map(str, deps))
        if deps:
            attrib["dependenciesKind"] = " ".join(["dependent"] * len(deps))
        return attrib


#: the base class's own internal state
_BASE_STATE = ("_setup_key", "_in_init")


def _to_json(v):
    """A value as JSON data; tuples tagged so that they come back as tuples."""
    if isinstance(v, tuple):
        return {"__tuple__": [_to_json(x) for x in v]}
    if isinstance(v, list):
        return [_to_json(x) for x in v]
    if isinstance(v, dict):
        return {k: _to_json(x) for k, x in v.items()}
    return v


def _from_json(v):
    if isinstance(v, dict):
        if set(v) == {"__tuple__"}:
            return tuple(_from_json(x) for x in v["__tuple__"])
        return {k: _from_json(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_from_json(x) for x in v]
    return v


class _Failure(ValueError):
    """A failure already logged by ``fail``."""


def _version():
    try:
        from cyclo_fmu import __version__
        return __version__
    except ImportError:   # inside an FMU at run time (to_xml runs at build time only)
        return "unknown"


__all__ = ["UnitSlave", "Real", "Integer", "Boolean", "String", "Fmi2Status"]
