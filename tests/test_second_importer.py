"""The CycloidDrive FMU in a second, independent importer (libcosimpy: DNV's libcosim with
FMI Library) gives the same numbers as fmpy."""
import numpy as np
import pytest

pytest.importorskip("libcosimpy")
from fmpy import read_model_description, simulate_fmu  # noqa: E402
from libcosimpy.CosimExecution import CosimExecution  # noqa: E402
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level  # noqa: E402
from libcosimpy.CosimManipulator import CosimManipulator  # noqa: E402
from libcosimpy.CosimObserver import CosimObserver  # noqa: E402
from libcosimpy.CosimSlave import CosimLocalSlave  # noqa: E402

NS = 1_000_000_000   # libcosim counts time in nanoseconds


def run_libcosim(fmu, mode, schedule, step=1e-3):
    """schedule: list of (w_in, tau_out), each held for one step; returns outputs per step."""
    log_output_level(CosimLogLevel.ERROR)
    vr = {v.name: v.valueReference for v in read_model_description(fmu).modelVariables}
    ex = CosimExecution.from_step_size(step_size=int(step * NS))
    idx = ex.add_local_slave(local_slave=CosimLocalSlave(fmu_path=fmu, instance_name="drive"))
    obs = CosimObserver.create_last_value()
    ex.add_observer(obs)
    man = CosimManipulator.create_override()
    ex.add_manipulator(man)
    ex.string_initial_value(idx, vr["mode"], mode)
    out = []
    names = ["w_out", "tau_in", "tau_housing", "P_loss", "eta"]
    for k, (w, tau) in enumerate(schedule):
        man.slave_real_values(idx, [vr["w_in"], vr["tau_out"]], [w, tau])
        ex.simulate_until(target_time=int(round((k + 1) * step * NS)))
        out.append(obs.last_real_values(idx, [vr[n] for n in names]))
    return np.array(out)


@pytest.mark.parametrize("mode", ["S1", "S2"])
def test_libcosim_matches_fmpy(fmu, mode):
    schedule = [(250.0, -7.0), (290.0, 8.0), (-150.0, 3.0), (100.0, -2.5)]
    if mode == "S2":
        schedule = [(w, -t) for w, t in schedule]
    cosim = run_libcosim(fmu, mode, schedule)
    times = np.arange(len(schedule) + 1) * 1e-3
    rows = [(t,) + schedule[min(i, len(schedule) - 1)] for i, t in enumerate(times)]
    inp = np.array(rows, dtype=[("time", float), ("w_in", float), ("tau_out", float)])
    res = simulate_fmu(fmu, stop_time=len(schedule) * 1e-3, output_interval=1e-3, input=inp,
                       start_values={"mode": mode},
                       output=["w_out", "tau_in", "tau_housing", "P_loss", "eta"])
    fmpy_rows = np.array([list(r)[1:] for r in res])[1:]
    np.testing.assert_allclose(cosim, fmpy_rows, rtol=1e-12, atol=1e-12)
    # and the numbers are physical: energy balance at every step
    w_in = np.array([s[0] for s in schedule])
    tau_out = np.array([s[1] for s in schedule])
    np.testing.assert_allclose(cosim[:, 1] * w_in + tau_out * cosim[:, 0], cosim[:, 3], rtol=1e-9)


def test_native_fmu_in_libcosim(fmu, tmp_path):
    """CycloidDriveNative.fmu in libcosim (which reads every variable, the constants too) gives
    the Python FMU's numbers (README, Use it in your tool)."""
    from cyclo_fmu.native import build_native_fmu
    native = str(build_native_fmu(dest=tmp_path))
    schedule = [(300.0, -10.0), (-150.0, 4.0), (80.0, 12.0)]
    np.testing.assert_allclose(run_libcosim(native, "S2", schedule),
                               run_libcosim(fmu, "S2", schedule), rtol=1e-9, atol=1e-12)
