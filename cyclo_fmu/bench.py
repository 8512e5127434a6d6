"""The motor - reducer - brake test bench of the paper as an SSP of FMUs, run by fmpy.

Components (TestBench.ssp, SSP 1.0): ``motor`` (InductionMotor), ``drive`` (CycloidDrive),
``brake`` (FeltBrake) and four ``Transducer`` instances: ``t_in`` (HBM T22/20 on the input
shaft), ``n_in`` (optical speed sensor), ``t_out`` and ``n_out`` (HBM T30FN on the output).
Causality: the motor integrates the rigid drive train and outputs speed and acceleration;
reducer and brake take speed and give torque. The output-side inertia (brake drum, coupling,
T30FN rotor) is a parameter of the reducer, which reflects it to the motor's integrator
(``tau_in_static``, ``J_load`` speeding up, ``J_load_dec`` slowing down): no component
differentiates a co-simulation input. The reducer's grease temperature ``T_oil`` is the input
torque transducer's ``temperature`` (its zero's drift per 10 K). Parameters: resources/<component>.ssv bound to each component in the .ssd
(libcosim applies them) and the same values in resources/TestBench.ssv, which ``run_ssp``
passes to fmpy as ``parameter_set`` (fmpy ignores ParameterBindings). The paper's series steps the motor
frequency and the brake torque; each pair is held to steady state.
"""
from __future__ import annotations

import csv
import math
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from model_core import MODES, DriveDesign, operating_point
from model_core.kinematics import parse_mode

RPM_PER_RAD_S = 30 / math.pi

#: component name -> connectors [(name, kind)]
CONNECTORS = {
    "motor": [("tau_shaft", "input"), ("J_load", "input"), ("J_load_dec", "input"),
              ("w", "output"), ("alpha", "output"), ("T_em", "output"), ("frequency", "output")],
    "drive": [("w_in", "input"), ("tau_out", "input"), ("alpha_in", "input"),
              ("w_out", "output"), ("tau_in", "output"), ("tau_in_static", "output"),
              ("J_load", "output"), ("J_load_dec", "output"), ("torque_out", "output"),
              ("tau_housing", "output"), ("P_loss", "output"), ("eta", "output"),
              ("T_oil", "output")],
    "brake": [("w", "input"), ("tau_out", "output"), ("torque_shaft", "output")],
    "t_in": [("x", "input"), ("temperature", "input"), ("y", "output")],
    "n_in": [("x", "input"), ("y", "output")],
    "t_out": [("x", "input"), ("y", "output")],
    "n_out": [("x", "input"), ("y", "output")],
}
#: the FMU of every component, per FMU set: "python" (pythonfmu slaves: need Python in the
#: host) and "native" (C, no Python: any host; cyclo-fmu bench's default). The native ones
#: are the Python ones' twins, tested equal to 1e-9 on the bench scenarios
FMU_SETS = {
    "python": {"motor": "InductionMotor", "drive": "CycloidDrive", "brake": "FeltBrake",
               "t_in": "TorqueTransducer", "n_in": "SpeedTransducer",
               "t_out": "TorqueTransducer", "n_out": "SpeedTransducer"},
}
FMU_SETS["native"] = {c: f + "Native" for c, f in FMU_SETS["python"].items()}
#: the native set as FMI 3.0 co-simulation FMUs (the same C code behind an FMI 3 adapter), for
#: SSP hosts that run FMI 3.0 (OMSimulator); the lean master and fmpy's SSP master run FMI 2.0
FMU_SETS["native3"] = {c: f + "3" for c, f in FMU_SETS["native"].items()}


def components(fmus: str = "python") -> dict:
    """component name -> (FMU, connectors) of the FMU set ``fmus``."""
    if fmus not in FMU_SETS:
        raise ValueError(f"fmus = {fmus!r}: must be one of {', '.join(FMU_SETS)}")
    return {c: (FMU_SETS[fmus][c], cons) for c, cons in CONNECTORS.items()}


def fmu_set(fmu_dir, fmus=None) -> str:
    """``fmus``, or when None the set ``fmu_dir`` holds: native when all its FMUs are there."""
    if fmus is not None:
        components(fmus)
        return fmus
    have = all((Path(fmu_dir) / f"{f}.fmu").is_file() for f in FMU_SETS["native"].values())
    return "native" if have else "python"


def fmu_names(fmus: str = "python") -> list:
    return sorted(set(FMU_SETS[fmus].values()))


#: component name -> (FMU, connectors [(name, kind)]) of the Python set
COMPONENTS = components("python")
CONNECTIONS = [
    ("motor", "w", "drive", "w_in"),
    ("motor", "alpha", "drive", "alpha_in"),
    ("drive", "tau_in_static", "motor", "tau_shaft"),
    ("drive", "J_load", "motor", "J_load"),
    ("drive", "J_load_dec", "motor", "J_load_dec"),
    ("drive", "w_out", "brake", "w"),
    ("brake", "tau_out", "drive", "tau_out"),
    ("drive", "tau_in", "t_in", "x"),
    # the input torque transducer's temperature (its zero's drift per 10 K) is the reducer's
    # grease temperature: the T22 sits on the input shaft next to the housing, and a replay
    # feeds the recording's temperature column to T_oil_in, so the transducer reads at the
    # temperature the diagnosis fitted its drift to
    ("drive", "T_oil", "t_in", "temperature"),
    ("motor", "w", "n_in", "x"),
    ("drive", "torque_out", "t_out", "x"),
    ("drive", "w_out", "n_out", "x"),
]
RECORDING_COLUMNS = ["time_s", "speed_in_rpm", "torque_in_Nm", "speed_out_rpm", "torque_out_Nm"]


@dataclass(frozen=True)
class Scenario:
    """A scripted test series: frequencies x brake torques, each pair held ``hold`` s."""

    name: str
    mode: str = "S1"
    f_first: float = 20.0
    f_last: float = 50.0
    f_count: int = 4
    T_first: float = 3.0
    T_last: float = 8.0
    T_count: int = 4
    hold: float = 3.0
    settle: float = 1.5            # s from the start of each slot excluded from the window
    frequency_schedule: str = ""   # overrides the frequency series when given
    torque_schedule: str = ""      # overrides the torque series when given
    duration: float = 0.0          # 0: f_count * T_count * hold
    J_out: float = 2.0e-3          # kg m^2 on the output shaft (brake drum, coupling, T30FN)

    @property
    def stop_time(self) -> float:
        return self.duration or self.f_count * self.T_count * self.hold


def paper_scenario(mode="S1") -> Scenario:
    """The paper's series: 20-50 Hz (1000-2800 r/min input) x brake loads giving 0.3-0.85 N*m
    on the input shaft (about 3-8 N*m at the output in S1, 2.7-7.4 N*m in S2)."""
    if mode == "S2":
        return Scenario("paper", mode="S2", T_first=2.7, T_last=7.4)
    return Scenario("paper", mode=mode)


def scenario(name: str, mode: str = "S1") -> Scenario:
    """Named scenarios: paper, runup, loadstep, reversal."""
    if name == "paper":
        return paper_scenario(mode)
    if name == "runup":
        return Scenario("runup", mode=mode, f_first=50, f_last=50, f_count=1, T_first=5,
                        T_last=5, T_count=1, hold=4.0, settle=2.5, duration=4.0)
    if name == "loadstep":
        return Scenario("loadstep", mode=mode, f_first=40, f_last=40, f_count=1,
                        torque_schedule="0 2; 3 7", hold=3.0, settle=1.5, duration=6.0)
    if name == "reversal":
        # +40 Hz, then the regulator reverses to -40 Hz. A flywheel on the output (0.2 kg m^2,
        # e.g. a steel disc of 300 mm x 36 mm) and a light brake: while the regulator
        # decelerates (25 Hz/s), the flywheel drives the reducer backwards (power flows from the
        # output to the motor) until it has slowed down. The flywheel must be that large: at
        # 160 r/min and 10.5 rad/s^2 it delivers J w dw/dt = 35 W, more than the physical
        # profile's load-independent losses at 2400 r/min (about 18 W); 0.05 kg m^2 (9 W) does
        # not back-drive the reducer, the drag eats it.
        return Scenario("reversal", mode=mode, frequency_schedule="0 40; 3 -40", T_first=0.05,
                        T_last=0.05, T_count=1, hold=3.0, settle=2.0, duration=8.0, J_out=0.2)
    raise ValueError(f"scenario = {name!r}: must be one of paper, runup, loadstep, reversal")


@dataclass(frozen=True)
class Sensors:
    """Transducer settings. Defaults: assumptions for the paper's HBM transducers, calibrated
    (no gain or offset error); noise and quantisation at the level of the acquisition chain."""

    ideal: bool = False
    torque_noise: float = 0.003        # N*m
    torque_resolution: float = 0.0005  # N*m
    speed_noise: float = 0.5           # r/min
    speed_resolution: float = 0.1      # r/min
    bandwidth: float = 200.0           # Hz
    torque_in_gain_error: float = 0.0
    torque_in_offset: float = 0.0
    torque_out_gain_error: float = 0.0
    torque_out_offset: float = 0.0
    torque_in_zero_drift: float = 0.0  # N*m, the input transducer's zero drift when warm
    torque_in_zero_tau: float = 300.0  # s, its time constant
    torque_in_zero_per_10K: float = 0.0    # N*m per 10 K of its temperature (the reducer's T_oil)
    torque_in_zero_T_ref: float = 293.15   # K, where that zero is right
    seed: int = 1


def drive_parameters(design: DriveDesign) -> dict:
    """The reducer FMU's design parameters ('drive.<name>') for a design, where they differ from
    the FMU's defaults (the paper's drive)."""
    from .slaves.cycloid_drive import ALL_DESIGN_PARAMETERS
    default = DriveDesign()
    out = {}
    for name, section, fld, unit, desc, kind in ALL_DESIGN_PARAMETERS:
        owner = design if section is None else getattr(design, section)
        base = default if section is None else getattr(default, section)
        v, v0 = getattr(owner, fld), getattr(base, fld)
        if v == v0:
            continue
        out[f"drive.{name}"] = (str(v) if kind.__name__ == "String" else
                                int(v) if kind.__name__ == "Integer" else float(v))
    if design.friction.rolling_disc != design.friction.rolling_ring:
        raise ValueError("friction.rolling_disc: the FMU has one rolling coefficient (mu_rolling)")
    from .slaves.cycloid_drive import discovered_values
    out.update({f"drive.{k}": v for k, v in discovered_values(design).items() if v != 0.0})
    return out


def bench_parameters(sc: Scenario, sensors: Sensors = Sensors(), design: DriveDesign = None,
                     fmus: str = "python") -> dict:
    """Parameter values 'component.variable' -> value for the SSV. With the native set the
    design is the one the native reducer was built for (its map is compiled in), so only the
    Python reducer takes the design as parameters."""
    if sc.mode not in MODES:
        raise ValueError(f"mode = {sc.mode!r}: must be one of {', '.join(MODES)}")
    # Python types decide the SSV types: float -> Real, int -> Integer, bool -> Boolean
    p = {
        "drive.mode_number": MODES.index(sc.mode) + 1,
        "motor.f_first": float(sc.f_first), "motor.f_last": float(sc.f_last),
        "motor.f_count": int(sc.f_count), "motor.hold_time": float(sc.hold),
        "motor.loads_per_frequency": int(sc.T_count),
        "brake.T_first": float(sc.T_first), "brake.T_last": float(sc.T_last),
        "brake.T_count": int(sc.T_count), "brake.hold_time": float(sc.hold),
        # the output inertia is integrated on the motor's side through the reducer (README,
        # "Where the inertias are integrated"); the brake then has no drum of its own
        "drive.J_out": float(sc.J_out), "brake.J_out": 0.0,
    }
    # schedules as numbered Real parameters: every master (fmpy's SSP master, libcosim,
    # run_fmus) sets them, unlike the String form
    from model_core.rig import parse_schedule, schedule_parameters
    if sc.frequency_schedule:
        p.update(schedule_parameters("motor.", parse_schedule(sc.frequency_schedule,
                                                               "frequency_schedule")))
    if sc.torque_schedule:
        p.update(schedule_parameters("brake.", parse_schedule(sc.torque_schedule,
                                                               "torque_schedule")))
    if design is not None and fmus == "python":
        p.update(drive_parameters(design))
    # the input torque transducer's offset and gain error a diagnosis found (design_updated.toml
    # [extra] torque_in_offset, torque_in_gain_error; model_core.effects.reading_model: y =
    # (1 + g) T + offset), on top of the sensors' own: the bench reads as the diagnosed bench did
    g_in, off_in = sensors.torque_in_gain_error, sensors.torque_in_offset
    drift, tau = sensors.torque_in_zero_drift, sensors.torque_in_zero_tau
    per_10K, T_ref = sensors.torque_in_zero_per_10K, sensors.torque_in_zero_T_ref
    if design is not None:
        ex = design.extra
        g_in = (1 + g_in) * (1 + ex.torque_in_gain_error) - 1
        off_in = off_in + ex.torque_in_offset
        # and the zero's drift in time form (torque_in_zero_drift, torque_in_zero_tau)
        if ex.torque_in_zero_drift:
            if drift and abs(tau - ex.torque_in_zero_tau) > 1e-9:
                raise ValueError("torque_in_zero_tau: the sensors' and the design's zero drifts "
                                 "have different time constants; the transducer has one")
            drift, tau = drift + ex.torque_in_zero_drift, ex.torque_in_zero_tau
        # and per 10 K of its temperature (torque_in_zero_per_10K from torque_in_zero_T_ref;
        # the transducer's temperature input is the reducer's T_oil). The transducer has one
        # reference: the sensors' drift c1 (T - T1)/10 K beside the design's c2 (T - T2)/10 K
        # is (c1 + c2) (T - T2)/10 K + c1 (T2 - T1)/10 K, the constant in the offset (exact)
        if ex.torque_in_zero_per_10K:
            from model_core.rig import zero_drift_per_10K
            off_in = off_in + zero_drift_per_10K(per_10K, ex.torque_in_zero_T_ref, T_ref)
            per_10K, T_ref = per_10K + ex.torque_in_zero_per_10K, ex.torque_in_zero_T_ref
    for name, scale, noise, res, gain, off in (
            ("t_in", 1.0, sensors.torque_noise, sensors.torque_resolution, g_in, off_in),
            ("n_in", RPM_PER_RAD_S, sensors.speed_noise, sensors.speed_resolution, 0.0, 0.0),
            ("t_out", 1.0, sensors.torque_noise, sensors.torque_resolution,
             sensors.torque_out_gain_error, sensors.torque_out_offset),
            ("n_out", RPM_PER_RAD_S, sensors.speed_noise, sensors.speed_resolution, 0.0, 0.0)):
        p.update({f"{name}.zero_drift": float(drift if name == "t_in" else 0.0),
                  f"{name}.zero_drift_tau": float(tau if name == "t_in" else 300.0),
                  f"{name}.zero_per_10K": float(per_10K if name == "t_in" else 0.0),
                  f"{name}.zero_T_ref": float(T_ref if name == "t_in" else 293.15)})
        p.update({f"{name}.scale": float(scale), f"{name}.noise": float(noise),
                  f"{name}.resolution": float(res), f"{name}.gain_error": float(gain),
                  f"{name}.offset": float(off), f"{name}.bandwidth": float(sensors.bandwidth),
                  f"{name}.ideal": bool(sensors.ideal),
                  f"{name}.seed": int(sensors.seed + list(COMPONENTS).index(name))})
    return p


def _ssv(params: dict) -> str:
    rows = []
    for k, v in params.items():
        if isinstance(v, str):
            kind, val = "String", v
        elif isinstance(v, bool):
            kind, val = "Boolean", "true" if v else "false"
        elif isinstance(v, int):
            kind, val = "Integer", str(v)
        else:
            kind, val = "Real", repr(float(v))
        rows.append(f'    <ssv:Parameter name={quoteattr(k)}><ssv:{kind} value={quoteattr(val)}/>'
                    '</ssv:Parameter>')
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            '<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" '
            'version="1.0" name="TestBench">\n  <ssv:Parameters>\n' + "\n".join(rows)
            + "\n  </ssv:Parameters>\n</ssv:ParameterSet>\n")


#: OMSimulator's vendor annotation (namespace as OMSimulator writes it): its command line
#: builds a system only from an SSD that names its master; other importers skip annotations
OMS_NS = "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd"


_MODEL_DESCRIPTIONS = {}


def model_description(path):
    """fmpy's model description of the FMU at ``path``, parsed once per file version (path,
    size, modification time) in a process: the bench reads each FMU's twice."""
    from fmpy import read_model_description
    st = Path(path).stat()
    key = (str(Path(path).resolve()), st.st_size, st.st_mtime_ns)
    if key not in _MODEL_DESCRIPTIONS:
        _MODEL_DESCRIPTIONS[key] = read_model_description(str(path))
    return _MODEL_DESCRIPTIONS[key]


def _extract(path) -> str:
    """Unpack an FMU for running it: everything, except that an FMU without resources/ (the
    native ones) needs only its model description and this platform's binaries (not the
    sources and documentation: fewer files to write and delete)."""
    import tempfile
    from fmpy import extract, platform
    with zipfile.ZipFile(path) as z:
        names = z.namelist()
        if any(n.startswith("resources/") for n in names):
            return extract(str(path))
        tmp = tempfile.mkdtemp(prefix="cyclofmu_run_")
        keep = [n for n in names if n == "modelDescription.xml"
                or n.startswith(f"binaries/{platform}/")]
        z.extractall(tmp, members=keep)
    return tmp


def _fmu_units(fmu_dir, comps=COMPONENTS) -> tuple:
    """(unit of every bench connector {(fmu, connector): unit or None}, the units' definitions
    {unit: BaseUnit}) read from the FMUs' model descriptions, so that the SSD states what the
    FMUs declare."""
    units, defs = {}, {}
    for fmu in sorted({f for f, _ in comps.values()}):
        md = model_description(Path(fmu_dir) / f"{fmu}.fmu")
        var = {v.name: v for v in md.modelVariables}
        for _, cons in (c for c in comps.values() if c[0] == fmu):
            for c, _k in cons:
                if c not in var:
                    raise ValueError(f"{fmu}.fmu has no variable {c!r} (bench connector)")
                units[(fmu, c)] = var[c].unit
        for u in md.unitDefinitions:
            defs[u.name] = u.baseUnit
    for a, b, c, d in CONNECTIONS:   # OMSimulator refuses what we would not notice otherwise
        ua, ub = units[(comps[a][0], b)], units[(comps[c][0], d)]
        if ua != ub:
            raise ValueError(f"{c}.{d}: unit {ub!r} differs from {a}.{b}'s {ua!r}")
    return units, {u: defs[u] for u in sorted({u for u in units.values() if u})}


def _base_unit(b) -> str:
    at = [f'{k}="{getattr(b, k)}"' for k in ("kg", "m", "s", "A", "K", "mol", "cd", "rad")
          if getattr(b, k)]
    if b.factor != 1.0:
        at.append(f'factor="{b.factor!r}"')
    if b.offset != 0.0:
        at.append(f'offset="{b.offset!r}"')
    return f'<ssc:BaseUnit {" ".join(at)}/>'


def _ssd(stop_time: float, bound: set, units: dict, unit_defs: dict, step: float,
         components_=COMPONENTS) -> str:
    comps = []
    for name, (fmu, connectors) in components_.items():
        cons = "\n".join(
            f'          <ssd:Connector name="{c}" kind="{k}"><ssc:Real'
            + (f' unit="{units[(fmu, c)]}"' if units.get((fmu, c)) else "")
            + '/></ssd:Connector>' for c, k in connectors)
        binding = (f'        <ssd:ParameterBindings>\n          <ssd:ParameterBinding '
                   f'source="resources/{name}.ssv"/>\n        </ssd:ParameterBindings>\n'
                   if name in bound else "")
        comps.append(f'      <ssd:Component name="{name}" type="application/x-fmu-sharedlibrary" '
                     f'source="resources/{fmu}.fmu">\n        <ssd:Connectors>\n{cons}\n'
                     f'        </ssd:Connectors>\n{binding}      </ssd:Component>')
    conns = "\n".join(f'      <ssd:Connection startElement="{a}" startConnector="{b}" '
                      f'endElement="{c}" endConnector="{d}"/>' for a, b, c, d in CONNECTIONS)
    unit_xml = "\n".join(f'    <ssc:Unit name="{u}">{_base_unit(b)}</ssc:Unit>'
                         for u, b in unit_defs.items())
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            '<ssd:SystemStructureDescription '
            'xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" '
            'xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" '
            f'xmlns:oms="{OMS_NS}" '
            'version="1.0" name="TestBench">\n'
            '  <ssd:System name="TestBench">\n'
            '    <ssd:Elements>\n' + "\n".join(comps) + '\n    </ssd:Elements>\n'
            '    <ssd:Connections>\n' + conns + '\n    </ssd:Connections>\n'
            '    <ssd:Annotations>\n'
            '      <ssc:Annotation type="org.openmodelica">\n'
            '        <oms:Annotations>\n'
            '          <oms:SimulationInformation>\n'
            f'            <oms:FixedStepMaster description="oms-ma" stepSize="{step!r}" '
            'absoluteTolerance="0.0001" relativeTolerance="0.0001"/>\n'
            '          </oms:SimulationInformation>\n'
            '        </oms:Annotations>\n'
            '      </ssc:Annotation>\n'
            '    </ssd:Annotations>\n'
            '  </ssd:System>\n'
            + (f'  <ssd:Units>\n{unit_xml}\n  </ssd:Units>\n' if unit_xml else "")
            + f'  <ssd:DefaultExperiment startTime="0.0" stopTime="{stop_time!r}">\n'
            # without this annotation OMSimulator warns "Wrong/deprecated content"
            '    <ssd:Annotations>\n'
            '      <ssc:Annotation type="org.openmodelica">\n'
            '        <oms:Annotations>\n'
            '          <oms:SimulationInformation resultFile="TestBench_res.mat"/>\n'
            '        </oms:Annotations>\n'
            '      </ssc:Annotation>\n'
            '    </ssd:Annotations>\n'
            '  </ssd:DefaultExperiment>\n'
            '</ssd:SystemStructureDescription>\n')


def build_ssp(path, fmu_dir, sc: Scenario, sensors: Sensors = Sensors(),
              design: DriveDesign = None, step: float = 1e-3, fmus: str = None) -> Path:
    """Write TestBench.ssp with the FMUs from ``fmu_dir`` (built by build_fmu); ``design``
    sets the reducer's parameters (default: the FMU's, the paper's drive). ``step`` (s) is
    the communication step the SSD proposes to OMSimulator (its FixedStepMaster).

    The SSD is standard SSP 1.0 (fmpy, libcosim) with OMSimulator's vendor annotation, a unit
    on every connector as the FMUs declare it (connected units agree) and the parameters bound
    per component (resources/<component>.ssv, applied by libcosim and OMSimulator) and as one
    set (resources/TestBench.ssv, which ``run_ssp`` hands to fmpy). ``fmus``: the FMU set
    (``fmu_set``: native when ``fmu_dir`` holds it)."""
    import os
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fmus = fmu_set(fmu_dir, fmus)
    comps = components(fmus)
    if fmus != "python":
        check_native_design(fmu_dir, design, fmus)
    params = bench_parameters(sc, sensors, design, fmus)
    per_component = {}
    for key, value in params.items():
        comp, var = key.split(".", 1)
        per_component.setdefault(comp, {})[var] = value
    units, unit_defs = _fmu_units(fmu_dir, comps)
    partial = path.with_name(f".{path.name}.partial-{os.getpid()}")
    try:
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("SystemStructure.ssd", _ssd(sc.stop_time, set(per_component), units,
                                                   unit_defs, step, comps))
            # one parameter set for fmpy (names 'component.variable', passed as parameter_set;
            # fmpy does not apply ParameterBindings) and one per component, bound in the .ssd,
            # for SSP importers that apply bindings (libcosim, OMSimulator)
            z.writestr("resources/TestBench.ssv", _ssv(params))
            for comp, values in per_component.items():
                z.writestr(f"resources/{comp}.ssv", _ssv(values))
            for fmu in sorted({f for f, _ in comps.values()}):
                z.write(Path(fmu_dir) / f"{fmu}.fmu", f"resources/{fmu}.fmu")
        os.replace(partial, path)
    finally:
        if partial.exists():
            partial.unlink()
    return path


def check_native_design(fmu_dir, design: DriveDesign = None, fmus: str = "native"):
    """The native reducer in ``fmu_dir`` carries ``design`` (default: the paper's drive), or
    ValueError naming the first differing value: its map is compiled in, so a bench of another
    design needs its own build."""
    from .native.design_check import fmu_design_mismatch
    fmu = Path(fmu_dir) / f"{FMU_SETS[fmus]['drive']}.fmu"
    why = fmu_design_mismatch(fmu, design)
    if why is not None:
        raise ValueError(f"design: {fmu.name} in {fmu_dir} was built for another design "
                         f"({why}); build it for this one (cyclo-fmu build CycloidDriveNative "
                         "--design FILE) or run the Python set (fmus='python')")


def run_ssp(ssp_path, stop_time: float, step: float = 1e-3):
    """Simulate the bench with fmpy's SSP master; returns fmpy's structured result."""
    from fmpy.ssp.simulation import simulate_ssp
    from fmpy.ssp.ssd import read_ssv
    params = read_ssv(str(ssp_path), "resources/TestBench.ssv")
    strings = [p.name for p in params.parameters if p.type == "String"]
    if strings:
        raise ValueError(f"{strings[0]}: fmpy's SSP master cannot set String parameters; "
                         "run_bench's lean master runs this bench (run_fmus sets them)")
    for prm in params.parameters:
        # fmpy sets Booleans as value != 0.0, so the string "false" would read as true
        if prm.type == "Boolean":
            prm.value = str(prm.value).strip().lower() in ("true", "1")
    return simulate_ssp(str(ssp_path), stop_time=stop_time, step_size=step, parameter_set=params)


#: the lean master's order of the components within a step (Gauss-Seidel): the motor (the
#: train's integrator) first, then the brake (at the output speed of the last step and the
#: setpoint of the step's start), then the reducer at the motor's new speed and acceleration
#: and the brake's torque, then the transducers reading the values of the same instant
ORDER = ("motor", "brake", "drive", "t_in", "n_in", "t_out", "n_out")
COUPLINGS = ("gauss-seidel", "jacobi")


def run_fmus(fmu_dir, params: dict, stop_time: float, step: float = 1e-3, progress=False,
             coupling: str = "gauss-seidel", fmus: str = None, signals: dict = None):
    """The bench of ``run_ssp`` (components, connections, parameters, fixed step, all connector
    values starting at 0, rows holding post-step values) run by a lean master that calls the
    FMUs' C functions over value references and buffers resolved once, and that can also set
    String parameters (fmpy's SSP master cannot). ``progress``: a tqdm bar on stderr.

    ``coupling``: ``"gauss-seidel"`` (default) steps the components in ``ORDER``, each after
    its inputs were updated from the outputs already computed in this step, so that a row holds
    the values of one instant (the reducer and the transducers are quasi-static); ``"jacobi"``
    steps all components from the previous step's outputs, as fmpy's SSP master does (the same
    numbers to 1e-9, a test), which delays every signal by one step per connection it passes.
    ``fmus``: the FMU set (``fmu_set``: native when ``fmu_dir`` holds it).

    ``signals``: external signals {"component.input": values} for inputs no connection feeds
    (a replay's measured speed and torque, ``bench_replay``), each n_steps + 1 values: [0] in
    Initialization Mode, [k + 1] during step k (the value at the step's end, the time of the
    row the step writes). With signals the result starts with the row of the initial values
    (time 0, then time k*step holds the values at k*step: the signals' own time base).
    Returns a structured array with the same fields as ``run_ssp``."""
    import ctypes

    from fmpy.fmi2 import FMU2Slave, fmi2Real, fmi2ValueReference

    if coupling not in COUPLINGS:
        raise ValueError(f"coupling = {coupling!r}: must be one of {', '.join(COUPLINGS)}")
    fmus = fmu_set(fmu_dir, fmus)
    if fmus == "native3":
        raise ValueError("fmus = 'native3': this master runs FMI 2.0 FMUs; run the FMI 3.0 set "
                         "as an SSP in an FMI 3.0 host (build_ssp(..., fmus='native3'))")
    COMPONENTS = components(fmus)
    n_steps = int(round(stop_time / step))
    ext = {}
    for key, values in (signals or {}).items():
        comp, _, var = key.partition(".")
        if comp not in COMPONENTS:
            raise ValueError(f"signals: {key!r}: no such bench component ({', '.join(COMPONENTS)})")
        values = np.ascontiguousarray(values, dtype=float)
        if values.shape != (n_steps + 1,):
            raise ValueError(f"signals: {key!r} has {values.size} values; the run needs "
                             f"{n_steps + 1} (the start and one per step)")
        if not np.all(np.isfinite(values)):
            raise ValueError(f"signals: {key!r} holds a value that is not finite")
        fmu, cons = COMPONENTS[comp]
        if any(c == var for c, _ in cons):
            raise ValueError(f"signals: {key!r} is a bench connector, fed by the bench")
        COMPONENTS[comp] = (fmu, cons + [(var, "input")])
        ext[(comp, var)] = values
    unknown = sorted({k.split(".", 1)[0] for k in params} - set(COMPONENTS))
    if unknown:
        raise ValueError(f"{unknown[0]}: no such bench component ({', '.join(COMPONENTS)})")
    # one buffer: every output, then every input; each FMU reads and writes its slice, and a
    # row of the recording is one copy of the whole buffer
    outputs = [(n, c) for n, (_, cons) in COMPONENTS.items() for c, k in cons if k == "output"]
    inputs = [(n, c) for n, (_, cons) in COMPONENTS.items() for c, k in cons if k == "input"]
    n_out = len(outputs)
    buf = (fmi2Real * (n_out + len(inputs)))()
    view = np.frombuffer(buf, dtype=np.float64)
    out_index = {key: i for i, key in enumerate(outputs)}
    in_index = {key: n_out + i for i, key in enumerate(inputs)}
    feeds = {(c, d): (a, b) for a, b, c, d in CONNECTIONS}
    dst = np.array([in_index[key] for key in inputs if key in feeds], dtype=np.intp)
    src = np.array([out_index[feeds[key]] for key in inputs if key in feeds], dtype=np.intp)
    ext_keys = list(ext)
    ext_dst = [in_index[key] for key in ext_keys]
    ext_rows = (np.ascontiguousarray(np.column_stack([ext[k] for k in ext_keys]))
                if ext else np.zeros((n_steps + 1, 0)))
    for i, key in zip(ext_dst, ext_keys):
        buf[i] = ext[key][0]
    size = ctypes.sizeof(fmi2Real)
    fmi2Status = ctypes.c_int
    comps, calls, unpacked, libs, raw = [], {}, {}, [], {}
    try:
        for name, (fmu, connectors) in COMPONENTS.items():
            path = str(Path(fmu_dir) / f"{fmu}.fmu")
            if path not in unpacked:     # one extraction per FMU, shared by its instances
                unpacked[path] = (model_description(path), _extract(path))
            md, unzipped = unpacked[path]
            var = {v.name: v for v in md.modelVariables}
            f = FMU2Slave(guid=md.guid, unzipDirectory=unzipped,
                          modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
            f.instantiate()
            comps.append(f)
            f.setupExperiment(startTime=0.0)
            for key, value in params.items():
                comp, vname = key.split(".", 1)
                if comp != name:
                    continue
                if vname not in var:
                    raise ValueError(f"{key}: {fmu} has no variable {vname!r}")
                v = var[vname]
                if v.type == "Real":
                    f.setReal([v.valueReference], [float(value)])
                elif v.type == "Integer":
                    f.setInteger([v.valueReference], [int(value)])
                elif v.type == "Boolean":
                    f.setBoolean([v.valueReference], [bool(value)])
                else:
                    f.setString([v.valueReference], [str(value)])
            f.enterInitializationMode()

            def block(index):
                sel = [index[(name, c)] for c, _ in connectors if (name, c) in index]
                if not sel:
                    return None
                vrs = (fmi2ValueReference * len(sel))(
                    *[var[c].valueReference for c, _ in connectors if (name, c) in index])
                ptr = ctypes.cast(ctypes.addressof(buf) + sel[0] * size,
                                  ctypes.POINTER(fmi2Real))
                return vrs, ctypes.c_size_t(len(sel)), ptr
            # the same functions through ctypes.PyDLL: called with the GIL held (a pythonfmu
            # FMU takes the GIL for every call; releasing it first, as CDLL does, costs more
            # than the call)
            lib = ctypes.PyDLL(f.dll._name)
            libs.append(lib)
            set_real, do_step, get_real = (lib.fmi2SetReal, lib.fmi2DoStep, lib.fmi2GetReal)
            for fn in (set_real, get_real):
                fn.argtypes = [ctypes.c_void_p, ctypes.POINTER(fmi2ValueReference),
                               ctypes.c_size_t, ctypes.POINTER(fmi2Real)]
                fn.restype = fmi2Status
            do_step.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_int]
            do_step.restype = fmi2Status
            links = [(in_index[(name, c)], out_index[feeds[(name, c)]])
                     for c, k in connectors if k == "input" and (name, c) in feeds]
            calls[name] = (name, ctypes.c_void_p(f.component), set_real, do_step, get_real,
                           block(in_index), block(out_index), links)
            raw[name] = (f.component, *(ctypes.cast(fn, ctypes.c_void_p).value
                                        for fn in (set_real, do_step, get_real)))
        calls = [calls[name] for name in ORDER]
        gauss = coupling == "gauss-seidel"
        if gauss:
            # consistent initial values: in Initialization Mode the slaves' outputs follow
            # their inputs and parameters (FMI 2.0 lets a master read them there); propagated
            # in ORDER, twice (the brake precedes the reducer whose w_out it reads; no loop: the
            # motor's outputs depend on its state only,
            # the brake's on the drive's w_out, which depends on the motor's speed alone)
            for _ in range(2):
                for name, comp, set_real, do_step, get_real, ins, outs, links in calls:
                    if ins is not None:
                        for i, j in links:
                            buf[i] = buf[j]
                        if set_real(comp, ins[0], ins[1], ins[2]) > 1:
                            raise _fmu_error(name, "fmi2SetReal", 0.0)
                    if outs is not None and get_real(comp, outs[0], outs[1], outs[2]) > 1:
                        raise _fmu_error(name, "fmi2GetReal", 0.0)
        # jacobi: all connector values start at 0, like fmpy's SSP master
        for f in comps:
            f.exitInitializationMode()
        fields = [f"{n}.{c}" for n, c in outputs] + [f"{n}.{c}" for n, c in inputs]
        first = 1 if ext else 0          # with signals: the initial row first
        all_rows = np.empty((n_steps + first, len(fields)))
        if first:
            all_rows[0] = view
        rows = all_rows[first:]
        bar = _progress(progress, n_steps, "bench")
        tick = max(1, n_steps // 100)
        loop = _c_loop()
        if loop is not None:
            loop(calls, raw, buf, rows, n_steps, step, gauss, bar, ext_dst, ext_rows[1:])
            n_steps = 0                  # done
        for k in range(n_steps):
            t = k * step
            for i, value in zip(ext_dst, ext_rows[k + 1]):
                buf[i] = value
            for name, comp, set_real, do_step, get_real, ins, outs, links in calls:
                if ins is not None:
                    if gauss:
                        for i, j in links:
                            buf[i] = buf[j]
                    if set_real(comp, ins[0], ins[1], ins[2]) > 1:
                        raise _fmu_error(name, "fmi2SetReal", t)
                if do_step(comp, t, step, 1) > 1:
                    raise _fmu_error(name, "fmi2DoStep", t)
                if outs is not None and get_real(comp, outs[0], outs[1], outs[2]) > 1:
                    raise _fmu_error(name, "fmi2GetReal", t)
            if not gauss:
                view[dst] = view[src]
            rows[k] = view
            if bar is not None and k % tick == 0:
                bar.update(min(tick, n_steps - k))
        if bar is not None:
            bar.close()
        n_steps = len(all_rows)
        rows = all_rows
    finally:
        import _ctypes
        for lib in libs:         # our reference to the library; fmpy frees its own
            _ctypes.dlclose(lib._handle)
        for f in comps:
            f.terminate()
            f.freeInstance()
        import shutil
        for _, unzipped in unpacked.values():
            shutil.rmtree(unzipped, ignore_errors=True)
    out = np.empty(n_steps, dtype=[("time", float)] + [(fl, float) for fl in fields])
    out["time"] = np.arange(n_steps) * step
    for i, fl in enumerate(fields):
        out[fl] = rows[:, i]
    return out


#: the C loop's source (cyclo_fmu/native/bench_loop.c), compiled once per source version into
#: the user's cache folder; without a C compiler run_fmus keeps its Python loop
_LOOP_SOURCE = Path(__file__).resolve().parent / "native" / "bench_loop.c"
_LOOP = {}


def _c_loop():
    """The C inner loop as a callable (calls, raw, buf, rows, n_steps, step, gauss, bar), or
    None when it cannot be compiled (the Python loop runs instead)."""
    if "fn" in _LOOP:
        return _LOOP["fn"]
    _LOOP["fn"] = None
    try:
        _LOOP["fn"] = _compile_loop()
    except Exception as exc:   # noqa: BLE001 - the Python loop is the same master, slower
        import sys
        print(f"note: the bench runs its Python loop ({exc})", file=sys.stderr)
    return _LOOP["fn"]


#: the bench loop's compiler flags (with the hardening of every native binary)
def _loop_flags():
    from .native.build import HARDEN
    return ("-std=c99", "-O2", "-shared", "-Wall", *HARDEN)


def _cached_loop(cc, cache=None):
    """The compiled bench loop in the user's cache, built if needed: named by a digest of its
    source, the compiler and its flags and the platform, and verified before it is loaded:
    the SHA-256 of the library is stored beside it (``.sha256``) when it is built, and a
    library whose digest differs (changed, truncated, replaced) is rebuilt, not loaded."""
    import hashlib
    import os
    import subprocess
    import sys

    flags = _loop_flags()
    source = _LOOP_SOURCE.read_bytes()
    key = hashlib.sha256(b"\0".join([source, sys.platform.encode(), cc.encode(),
                                      " ".join(flags).encode()])).hexdigest()[:16]
    cache = Path(cache or (os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")) \
        / "cyclo-fmu"
    lib_path = cache / f"bench_loop_{key}.so"
    sum_path = lib_path.with_name(lib_path.name + ".sha256")

    def digest(path):
        return hashlib.sha256(path.read_bytes()).hexdigest()
    try:
        if lib_path.is_file() and sum_path.read_text().strip() == digest(lib_path):
            return lib_path
    except OSError:
        pass
    cache.mkdir(parents=True, exist_ok=True, mode=0o700)
    tmp = lib_path.with_name(f"{lib_path.name}.{os.getpid()}.tmp")
    r = subprocess.run([cc, *flags, "-o", str(tmp), str(_LOOP_SOURCE)], capture_output=True,
                       text=True)
    if r.returncode != 0:
        raise RuntimeError(f"cc failed: {r.stderr.strip()[:200]}")
    tmp_sum = sum_path.with_name(f"{sum_path.name}.{os.getpid()}.tmp")
    tmp_sum.write_text(digest(tmp) + "\n")
    os.replace(tmp, lib_path)
    os.replace(tmp_sum, sum_path)
    return lib_path


def _compile_loop():
    import ctypes
    import os

    from .native.build import find_compiler
    if os.environ.get("CYCLOFMU_PYTHON_LOOP"):
        return None
    lib_path = _cached_loop(find_compiler())
    # PyDLL: the GIL stays held through the loop, as the pythonfmu slaves it calls need it
    fn = ctypes.PyDLL(str(lib_path)).bench_loop
    fn.restype = ctypes.c_long
    P = ctypes.c_void_p

    def run(calls, raw, buf, rows, n_steps, step, gauss, bar, ext_dst=(), ext=None):
        n = len(calls)
        arr = lambda ctype, values: (ctype * max(1, len(values)))(*values)   # noqa: E731
        comps = arr(P, [raw[c[0]][0] for c in calls])
        sets = arr(P, [raw[c[0]][1] for c in calls])
        steps_ = arr(P, [raw[c[0]][2] for c in calls])
        gets = arr(P, [raw[c[0]][3] for c in calls])
        vr_p = ctypes.POINTER(ctypes.c_uint)
        base = ctypes.addressof(buf)
        size = ctypes.sizeof(ctypes.c_double)

        def part(i):
            blocks = [c[5 + i] for c in calls]
            vrs = arr(vr_p, [ctypes.cast(b[0], vr_p) if b else None for b in blocks])
            cnt = arr(ctypes.c_size_t, [b[1].value if b else 0 for b in blocks])
            off = arr(ctypes.c_int, [(ctypes.cast(b[2], P).value - base) // size if b else 0
                                     for b in blocks])
            return vrs, cnt, off
        in_vrs, n_in, in_off = part(0)
        out_vrs, n_out, out_off = part(1)
        starts, dst, src = [0], [], []
        for c in calls:
            for i, j in c[7]:
                dst.append(i)
                src.append(j)
            starts.append(len(dst))
        starts, dst, src = arr(ctypes.c_int, starts), arr(ctypes.c_int, dst), arr(ctypes.c_int, src)
        fail = (ctypes.c_int * 3)()
        n_ext = len(ext_dst)
        ext_idx = arr(ctypes.c_int, list(ext_dst))
        if n_ext:
            ext = np.ascontiguousarray(ext, dtype=float)
            if ext.shape != (n_steps, n_ext):
                raise ValueError("bench loop: external signals of the wrong shape")
        chunk = n_steps if bar is None else max(1, n_steps // 100)
        width = rows.shape[1]
        for k0 in range(0, n_steps, chunk):
            m = min(chunk, n_steps - k0)
            ptr = rows.ctypes.data + k0 * width * size
            bad = fn(n, comps, sets, steps_, gets, in_vrs, n_in, in_off, out_vrs, n_out, out_off,
                     starts, dst, src, int(gauss), buf, len(buf), P(ptr),
                     ctypes.c_long(rows.shape[0] - k0), int(width), ctypes.c_long(k0),
                     ctypes.c_long(m), ctypes.c_double(step), fail, int(n_ext), ext_idx,
                     P(ext.ctypes.data + k0 * n_ext * size) if n_ext else None)
            if bad < 0:
                raise RuntimeError(f"bench loop: inconsistent arguments (check {fail[0]}, "
                                   f"item {fail[1]})")
            if bad:
                function = ("fmi2SetReal", "fmi2DoStep", "fmi2GetReal")[fail[1]]
                raise _fmu_error(calls[fail[0]][0], function, (bad - 1) * step)
            if bar is not None:
                bar.update(m)
    return run


def _fmu_error(name, function, t):
    from fmpy.fmi1 import FMICallException
    return FMICallException(function=f"{name}: {function} at t = {t:.6g} s", status=3)


def _progress(enabled, total, desc):
    """A tqdm bar on stderr when ``enabled`` and stderr is a terminal; else None."""
    import sys
    if not enabled or not sys.stderr.isatty():
        return None
    from tqdm import tqdm
    return tqdm(total=total, desc=desc, unit="step", file=sys.stderr, leave=False,
                mininterval=0.5)


def recording_from_result(result) -> dict:
    """The bench's recording (the schema a real bench writes) from the SSP result."""
    return {
        "time_s": np.asarray(result["time"]) + (result["time"][1] - result["time"][0]),
        "speed_in_rpm": np.asarray(result["n_in.y"]),
        "torque_in_Nm": np.asarray(result["t_in.y"]),
        "speed_out_rpm": np.asarray(result["n_out.y"]),
        "torque_out_Nm": np.asarray(result["t_out.y"]),
    }


def write_recording(path, rec: dict, columns=None) -> Path:
    """Write the recording as CSV (time with 6 decimals, the channels with 6 significant
    digits), formatted in one call and written atomically."""
    import os
    path = Path(path)
    columns = list(columns or RECORDING_COLUMNS)
    data = np.column_stack([np.asarray(rec[c], dtype=float) for c in columns])
    row = ",".join(["%.6f"] + ["%.6g"] * (len(columns) - 1)) + "\r\n"
    text = ",".join(columns) + "\r\n" + (row * len(data)) % tuple(data.ravel().tolist())
    tmp = path.with_name(f".{path.name}.partial-{os.getpid()}")
    with tmp.open("w", newline="") as f:
        f.write(text)
    os.replace(tmp, path)
    return path


def steady_windows(rec: dict, sc: Scenario, design: DriveDesign = None):
    """Efficiency per steady window (means over the window, like the paper) next to the core's
    efficiency at the window's mean input speed and torque."""
    t = rec["time_s"]
    slots = int(round(sc.stop_time / sc.hold))
    rows = []
    for k in range(slots):
        sel = (t > k * sc.hold + sc.settle) & (t <= (k + 1) * sc.hold)
        if sel.sum() < 10:
            continue
        n_in, T_in = rec["speed_in_rpm"][sel].mean(), rec["torque_in_Nm"][sel].mean()
        n_out = rec["speed_out_rpm"][sel].mean()
        p_in = np.mean(rec["torque_in_Nm"][sel] * rec["speed_in_rpm"][sel]) / RPM_PER_RAD_S
        p_out = np.mean(rec["torque_out_Nm"][sel] * rec["speed_out_rpm"][sel]) / RPM_PER_RAD_S
        row = {"t_start_s": k * sc.hold + sc.settle, "t_end_s": (k + 1) * sc.hold,
               "speed_in_rpm": n_in, "torque_in_Nm": T_in, "speed_out_rpm": n_out,
               "input_power_W": p_in, "output_power_W": p_out,
               "eta": p_out / p_in if p_in > 0 else float("nan")}
        if design is not None and p_in > 0:
            op = operating_point(design, sc.mode, n_in / RPM_PER_RAD_S, T_in)
            row["eta_core"] = float(op.eta)
        rows.append(row)
    return rows


@dataclass
class BenchRun:
    scenario: Scenario
    recording: dict
    windows: list
    result: object = field(repr=False)


MASTERS = ("lean", "fmpy")


def run_bench(sc: Scenario, fmu_dir, out_dir=None, sensors: Sensors = Sensors(),
              step: float = 1e-3, design: DriveDesign = None, master: str = "lean",
              progress=False, plot: bool = False, fmus: str = None) -> BenchRun:
    """Build the SSP, simulate it, and (with ``out_dir``) write the SSP, the recording and the
    windows, and with ``plot`` the figure ``bench_<mode>_<scenario>.png`` (matplotlib: about
    0.8 s, so opt-in).

    ``master``: ``"lean"`` runs the SSP's components, connections and parameters in this
    package's fixed-step Jacobi master (``run_fmus``: cached value references, direct FMI
    calls; the same numbers as fmpy's SSP master, a test), ``"fmpy"`` in fmpy's SSP master.
    ``fmus``: "native" or "python" (default: native when ``fmu_dir`` holds the native set; a
    native reducer must have been built for ``design``)."""
    parse_mode(sc.mode)
    fmus = fmu_set(fmu_dir, fmus)
    if master not in MASTERS:
        raise ValueError(f"master = {master!r}: must be one of {', '.join(MASTERS)}")
    out = Path(out_dir) if out_dir else None
    if master == "fmpy" or out is not None:     # the SSP is an output, or what fmpy runs
        ssp = build_ssp((out or Path(fmu_dir)) / "TestBench.ssp", fmu_dir, sc, sensors, design,
                        step, fmus)
    if master == "fmpy":
        result = run_ssp(ssp, sc.stop_time, step)
    else:
        if fmus == "native":
            check_native_design(fmu_dir, design)
        result = run_fmus(fmu_dir, bench_parameters(sc, sensors, design, fmus), sc.stop_time,
                          step, progress=progress, fmus=fmus)
    rec = recording_from_result(result)
    windows = steady_windows(rec, sc, design or DriveDesign())
    run = BenchRun(sc, rec, windows, result)
    if out is not None:
        write_recording(out / f"recording_{sc.mode}_{sc.name}.csv", rec)
        with (out / f"efficiency_{sc.mode}_{sc.name}.csv").open("w", newline="") as f:
            if windows:
                w = csv.DictWriter(f, fieldnames=list(windows[0]))
                w.writeheader()
                w.writerows(windows)
        if plot:
            plot_bench(run, out)
    return run


def plot_bench(run: BenchRun, out: Path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    sc, rec, win = run.scenario, run.recording, run.windows
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5))
    # speed and torque each on their own axis (a twin axis for the torque)
    for ax, side, title in ((axes[0, 0], "in", f"input shaft, mode {sc.mode}, scenario {sc.name}"),
                            (axes[0, 1], "out", "output shaft")):
        ax.plot(rec["time_s"], rec[f"speed_{side}_rpm"], lw=0.6, color="C0")
        ax.set(xlabel="time / s", ylabel=f"{side}put speed / (r/min)", title=title)
        ax.yaxis.label.set_color("C0")
        tx = ax.twinx()
        tx.plot(rec["time_s"], rec[f"torque_{side}_Nm"], lw=0.6, color="C3")
        tx.set_ylabel(f"{side}put torque / N*m", color="C3")
    if win:
        T = np.array([w["torque_in_Nm"] for w in win])
        n = np.array([w["speed_in_rpm"] for w in win])
        eta = np.array([w["eta"] for w in win])
        ax = axes[1, 0]
        sc_ = ax.scatter(T, 100 * eta, c=n, cmap="viridis", label="bench (window means)")
        if "eta_core" in win[0]:
            ax.scatter(T, [100 * w["eta_core"] for w in win], marker="x", c="k", label="core")
        fig.colorbar(sc_, ax=ax, label="input speed / (r/min)")
        ax.set(xlabel="input torque / N*m", ylabel="efficiency / %", title="steady windows")
        ax.legend(fontsize=7)
        ax = axes[1, 1]
        ax.scatter([w["input_power_W"] for w in win], [w["output_power_W"] for w in win])
        ax.set(xlabel="input power / W", ylabel="output power / W", title="output over input power")
    fig.tight_layout()
    fig.savefig(out / f"bench_{sc.mode}_{sc.name}.png", dpi=100)
    plt.close(fig)


#: convergence check of the step for steady scenarios: the window efficiencies at a step and
#: at 1 ms agree within this (a tenth of the 0.2 percentage-point agreement with the core that
#: the bench's tests ask for)
STEP_ETA_TOL = 2e-4
#: and the window mean input speeds within this (the speed sensor's resolution, r/min)
STEP_SPEED_TOL = 0.1
#: the step the check chose for the paper scenario among 2, 5, 10 and 20 ms (README, "Step
#: size": with ideal sensors the windows agree to 1e-15 at every candidate, the reducer being
#: quasi-static and the slots long against the motor's ~5 ms); 20 ms is the largest candidate
#: because the windows should keep >= 75 samples. test_bench_scenarios repeats the check on a
#: shorter steady series. Recordings keep 1 ms (the diagnosis resolves ripple orders in them)
STEADY_STEP = 20e-3


def steady_step() -> float:
    """Communication step for steady scenarios (s), chosen by ``converged_step``."""
    return STEADY_STEP


def converged_step(fmu_dir, sc: Scenario, candidates=(2e-3, 5e-3, 10e-3, 20e-3),
                   reference: float = 1e-3, sensors: Sensors = Sensors(ideal=True)):
    """The largest of ``candidates`` (s) for which every steady window's efficiency agrees with
    the ``reference`` step's within STEP_ETA_TOL and its mean input speed within STEP_SPEED_TOL,
    every smaller candidate agreeing too. Returns (step, {step: largest differences})."""
    ref = run_bench(sc, fmu_dir, sensors=sensors, step=reference).windows
    chosen, report = reference, {}
    for h in sorted(candidates):
        win = run_bench(sc, fmu_dir, sensors=sensors, step=h).windows
        d_eta = max(abs(a["eta"] - b["eta"]) for a, b in zip(ref, win))
        d_n = max(abs(a["speed_in_rpm"] - b["speed_in_rpm"]) for a, b in zip(ref, win))
        report[h] = (d_eta, d_n)
        if len(win) != len(ref) or d_eta > STEP_ETA_TOL or d_n > STEP_SPEED_TOL:
            break
        chosen = h
    return chosen, report
