"""``cyclo-fmu build --design X`` builds every FMU with the design (issue 19 item 7): each
reducer FMU (Python, native FMI 2, native FMI 3) carries the design's values and behaves as the
design, and the FMUs that hold no design (motor, brake, transducers: their parameters come
from the bench) are the default ones. Built here with the calibrated preset ``mackic-rig``
against the default build, in two fresh processes (pythonfmu cannot build a Python FMU in a
process that has loaded one of the same bundle)."""
import shutil
import subprocess
import sys
import zipfile
from xml.etree import ElementTree as ET

import pytest

from model_core.lossmap import ModeMap
from model_core.presets import load_preset

from test_native_fmu import Inst

#: FMUs whose build depends on the design, and how it shows in their model description
REDUCERS = ("CycloidDrive", "CycloidDriveNative", "CycloidDriveNative3")
#: attributes that differ between any two builds (time of generation)
VOLATILE = ("generationDateAndTime",)


def _build(dest, *design):
    r = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "build", *design, "--dest",
                        str(dest)], capture_output=True, text=True, timeout=1200)
    assert r.returncode == 0, r.stderr
    return dest


@pytest.fixture(scope="module")
def builds(tmp_path_factory):
    if not (shutil.which("gcc") or shutil.which("cc")):
        pytest.skip("no C compiler")
    base = tmp_path_factory.mktemp("build_design")
    return (_build(base / "default"),
            _build(base / "preset", "--design", "mackic-rig"))


def _variables(path):
    """{name: start (or None)} and the root's attributes of an FMU's model description (FMI 2
    and 3)."""
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    out = {}
    for sv in root.iter("ScalarVariable"):                  # FMI 2.0
        out[sv.get("name")] = sv[0].get("start")
    mv = root.find("ModelVariables")
    if root.get("fmiVersion", "").startswith("3") and mv is not None:
        for v in mv:
            out[v.get("name")] = v.get("start")
    attrs = {k: v for k, v in root.attrib.items() if k not in VOLATILE}
    return out, attrs


@pytest.mark.slow
def test_build_design_changes_every_fmu_that_carries_a_design(builds):
    default, preset = builds
    names = sorted(p.stem for p in default.glob("*.fmu"))
    assert names == sorted(p.stem for p in preset.glob("*.fmu"))
    assert set(REDUCERS) <= set(names)
    d = load_preset("mackic-rig")
    for name in names:
        a, attrs_a = _variables(default / f"{name}.fmu")
        b, attrs_b = _variables(preset / f"{name}.fmu")
        assert set(a) == set(b), name            # the same variables either way
        changed = {k for k in a if a[k] != b[k]}
        if name in REDUCERS:
            # the calibration is the preset's: its start values (Python) or constants (native)
            # (a model description's start holds 16 significant digits)
            assert float(b["mesh_loss_k"]) == pytest.approx(d.calibration.mesh_loss_k,
                                                            rel=1e-15), name
            assert float(b["idle_loss_scale"]) == pytest.approx(
                d.calibration.idle_loss_scale, rel=1e-15), name
            assert float(a["mesh_loss_k"]) == 0.0 and float(a["idle_loss_scale"]) == 1.0
            assert {"mesh_loss_k", "idle_loss_scale"} <= changed
            if name != "CycloidDrive":           # the native ones: their map's digest
                assert attrs_a["guid" if "guid" in attrs_a else "instantiationToken"] != \
                    attrs_b["guid" if "guid" in attrs_b else "instantiationToken"]
        else:
            # motor, brake, transducers: no design in them; only their digest may differ
            assert not changed, (name, sorted(changed))


@pytest.mark.slow
def test_fmus_built_with_the_preset_behave_as_the_preset(builds):
    """A step of the FMI 2 reducers of each build at one operating point: the preset's
    reducers give the preset's map (calibrated: more loss), the default's the default's; Python
    and native agree within each build."""
    default, preset = builds
    w, t = 250.0, -6.0
    want = {}
    for folder, design in ((default, None), (preset, load_preset("mackic-rig"))):
        from model_core import DriveDesign
        mm = ModeMap(design or DriveDesign(), "S1", 30.0, 350.0)
        got = []
        for name in ("CycloidDrive", "CycloidDriveNative"):
            i = Inst(str(folder / f"{name}.fmu"), use_T_oil_input=True)
            got.append(i.step(w, t))
            i.close()
        assert got[0]["tau_in"] == pytest.approx(got[1]["tau_in"], rel=1e-9)
        assert got[1]["tau_in"] == pytest.approx(mm.solve(w, t)[1][2], rel=1e-9)
        want[folder] = got[1]
    assert want[preset]["PL_mesh"] > 0 == want[default]["PL_mesh"]
    assert want[preset]["eta"] < want[default]["eta"] - 0.05


def test_every_extra_field_has_one_home():
    """Each field of a design's [extra] is carried by exactly one of: the reducer FMUs (a
    parameter), the bench's input torque transducer (ExtraPhysics.TRANSDUCER: the bench reads
    it into t_in's parameters), or the diagnosis's replay alone (ExtraPhysics.REPLAY_ONLY)."""
    import dataclasses

    from cyclo_fmu.bench import Scenario, bench_parameters
    from cyclo_fmu.slaves.cycloid_drive import ALL_DESIGN_PARAMETERS
    from model_core import DriveDesign
    from model_core.design import ExtraPhysics
    names = {f.name for f in dataclasses.fields(ExtraPhysics)} - {"discovered"}
    fmu = {field for _n, section, field, *_ in ALL_DESIGN_PARAMETERS if section == "extra"}
    homes = (fmu, set(ExtraPhysics.TRANSDUCER), set(ExtraPhysics.REPLAY_ONLY))
    assert set().union(*homes) == names
    assert sum(len(h) for h in homes) == len(names)          # no field in two homes
    base = bench_parameters(Scenario("x"), design=DriveDesign())
    for name in ExtraPhysics.TRANSDUCER:
        d = DriveDesign()
        value = {"torque_in_zero_tau": 5.0, "torque_in_zero_T_ref": 310.0}.get(name, 0.01)
        d = dataclasses.replace(d, extra=dataclasses.replace(
            d.extra, **{name: value, "torque_in_zero_drift": 0.002,
                        "torque_in_zero_per_10K": 0.003}))
        p = bench_parameters(Scenario("x"), design=d)
        assert any(p[k] != base[k] for k in p if k.startswith("t_in.")), name
