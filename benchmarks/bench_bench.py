"""Speed of the bench: the paper scenario (48 s simulated, 7 FMUs), in simulated seconds per
wall-clock second ("x real time"), every number next to a floor measured in the same run.

1. The whole command, ``cyclo-fmu bench --scenario paper`` (native FMUs, the default), on its
   first run (FMUs built into an empty cache) and on later runs (FMUs from the cache): wall
   time of the process, and its CPU time (user + system), which the machine's load does not
   inflate. Target (issue 20): >= 50x real time on the second run.
2. The stepping loop alone (``run_fmus``, the lean master's C loop, 1 ms), setup excluded (a
   10 ms run measures it): the native set next to seven trivial native FMUs (the same FMI
   front, no physics: the floor), and the Python set next to seven trivial pythonfmu FMUs.
   Target: >= 500x real time with the native components.
3. When the host tools are present (cyclo_fmu.hosts.hosts_dir): OMSimulator's command line
   running the TestBench.ssp the command wrote, with a plain environment.

Run: python benchmarks/bench_bench.py   (prints the machine's load average with the numbers)
"""
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from cyclo_fmu.bench import (CONNECTORS, FMU_SETS, Sensors, bench_parameters, paper_scenario,
                             run_fmus)
from cyclo_fmu.fmu_build import build_any, build_fmu

HERE = Path(__file__).resolve().parent


def trivial_pythonfmu(dest: Path):
    """One trivial pythonfmu FMU per Python bench FMU, with the same connector names."""
    from pythonfmu.builder import FmuBuilder
    for comp, fmu in FMU_SETS["python"].items():
        if (dest / f"{fmu}.fmu").exists():
            continue
        src = ["from pythonfmu import Fmi2Causality, Fmi2Slave, Real", "", "",
               f"class {fmu}(Fmi2Slave):", "    def __init__(self, **kwargs):",
               "        super().__init__(**kwargs)"]
        for c, k in CONNECTORS[comp]:
            src += [f"        self.{c} = 0.0",
                    f"        self.register_variable(Real({c!r}, causality=Fmi2Causality.{k}))"]
        src += ["", "    def do_step(self, t, dt):", "        return True", ""]
        script = dest / f"{fmu}.py"
        script.write_text("\n".join(src))
        FmuBuilder.build_FMU(script, dest=dest, needsExecutionTool="false")


def trivial_native(dest: Path):
    """Seven trivial native FMUs: the native front with a step that does nothing, each with
    the interface of the Python slave it stands for."""
    from cyclo_fmu.native.rig_build import build_rig_fmu
    for comp, fmu in FMU_SETS["native"].items():
        build_rig_fmu(fmu, dest, slave=FMU_SETS["python"][comp],
                      physics=HERE / "trivial_component.c")


def cpu_of(fn):
    """(wall s, CPU s of this process) of fn()."""
    t, c = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - t, time.process_time() - c


def command(args, env):
    """(wall s, CPU s user + system) of a child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    r = subprocess.run(args, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        raise RuntimeError(r.stderr[-2000:])
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def row(label, wall, cpu, stop):
    cpu_s = "" if cpu is None else f"{cpu:7.2f} s  {stop / cpu:8.1f}x"
    print(f"  {label:<58} {wall:7.2f} s  {stop / wall:8.1f}x   {cpu_s}")


def main():
    sc = paper_scenario("S1")
    stop = sc.stop_time
    print(f"paper scenario S1, {stop:.0f} s simulated; load average {os.getloadavg()[0]:.1f} "
          f"on {os.cpu_count()} CPUs")
    print(f"  {'':<58} {'wall':>9}  {'x real':>9}   {'CPU':>9}  {'x real':>9}")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        env = dict(os.environ, CYCLOFMU_CACHE=str(tmp / "cache"))
        cmd = [sys.executable, "-m", "cyclo_fmu.cli", "bench", "--scenario", "paper",
               "--out", str(tmp / "out"), "--quiet"]
        print("1. the whole command (cyclo-fmu bench --scenario paper, native FMUs)")
        wall, cpu = command(cmd, env)
        row("first run (builds the FMUs into an empty cache)", wall, cpu, stop)
        for k in (2, 3):
            wall, cpu = command(cmd, env)
            row(f"run {k} (FMUs from the cache)", wall, cpu, stop)
        wall, cpu = command(cmd + ["--plot"], env)
        row("with --plot (the figure)", wall, cpu, stop)
        wall, cpu = command(cmd[:-2] + [str(tmp / "out_python"), "--quiet", "--fmus", "python"],
                            env)
        row("--fmus python (the pythonfmu slaves, cached)", wall, cpu, stop)

        print("2. the stepping loop (run_fmus, C loop, 1 ms; setup of a 10 ms run subtracted)")
        sets = {}
        for label in ("native", "python", "trivial native", "trivial pythonfmu"):
            d = tmp / label.replace(" ", "_")
            d.mkdir()
            sets[label] = d
        for name in FMU_SETS["native"].values():
            build_any(name, sets["native"])
        for name in set(FMU_SETS["python"].values()):
            build_fmu(name, sets["python"])
        trivial_native(sets["trivial native"])
        trivial_pythonfmu(sets["trivial pythonfmu"])
        for label, d in sets.items():
            fmus = "native" if "native" in label else "python"
            params = {} if "trivial" in label else bench_parameters(sc, Sensors(), fmus=fmus)
            run_fmus(d, params, 0.01, 1e-3, fmus=fmus)               # warm: C loop compiled
            w0, c0 = cpu_of(lambda: run_fmus(d, params, 0.01, 1e-3, fmus=fmus))
            w1, c1 = cpu_of(lambda: run_fmus(d, params, stop, 1e-3, fmus=fmus))
            row(f"{label} set", w1 - w0, c1 - c0, stop)

        from cyclo_fmu.hosts import hosts_dir
        oms = hosts_dir(HERE.parent) / "omsimulator" / "bin" / "OMSimulator"
        if oms.is_file():
            print("3. OMSimulator's command line on the TestBench.ssp of the native runs (plain "
                  "environment: no LD_PRELOAD, PYTHONHOME, PYTHONPATH)")
            plain = {"PATH": "/usr/bin:/bin", "HOME": str(tmp)}
            args = [str(oms), str(tmp / "out" / "TestBench.ssp"), f"--stopTime={stop}",
                    "--stepSize=1e-3", f"--tempDir={tmp / 'oms'}"]
            for rf in ("r.mat", "r.csv"):
                wall, cpu = command(args + [f"--resultFile={tmp / rf}"], plain)
                row(f"result file {rf}", wall, cpu, stop)
        else:
            print(f"3. OMSimulator not found ({oms}): skipped")


if __name__ == "__main__":
    main()
