"""Memory of the Python FMUs' instances in one host process (issue 20): instances of one design
share one copy of its loss-map tables, freeing the last one releases them, and neither
pythonfmu's sys.path insert nor its per-instance run of the entry script accumulates.
Numbers: benchmarks/bench_fmu_memory.py."""
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = str(Path(__file__).resolve().parents[1])

CODE = """
import gc, json, sys
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
fmu = sys.argv[1]
md = read_model_description(fmu)
d = extract(fmu)
vr = {v.name: v.valueReference for v in md.modelVariables}


def make(i, mode="S1"):
    f = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier="CycloidDrive",
                  instanceName=f"i{i}")
    f.instantiate()
    f.setString([vr["mode"]], [mode])
    f.setReal([vr["w_in"], vr["tau_out"]], [150.0, -20.0])
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.exitInitializationMode()
    f.doStep(0.0, 1e-3)
    return f


def tables():
    gc.collect()
    mod = next(m for k, m in sys.modules.items() if k.endswith("_slaves.cycloid_drive"))
    return len(mod._TABLES)


def classes():
    gc.collect()
    return sum(1 for o in gc.get_objects()
               if isinstance(o, type) and o.__name__ == "CycloidDrive")


out = {}
first = make(0)
out["one"] = tables()
out["path"] = len(sys.path)
out["classes"] = classes()
out["eta_first"] = first.getReal([vr["eta"]])[0]
more = [make(i + 1) for i in range(5)]
out["six"] = tables()
out["path_six"] = len(sys.path)
out["classes_six"] = classes()
out["eta_more"] = [f.getReal([vr["eta"]])[0] for f in more]
other = make(9, "S2")
out["with_s2"] = tables()
out["eta_s2"] = other.getReal([vr["eta"]])[0]
for f in [first, other] + more:
    f.terminate()
    f.freeInstance()
del f, first, other, more
out["freed"] = tables()
print(json.dumps(out))
"""


def test_instances_share_the_loss_map_tables_and_free_them(fmu_dir):
    r = subprocess.run([sys.executable, "-c", textwrap.dedent(CODE),
                        str(fmu_dir / "CycloidDrive.fmu")], capture_output=True, text=True,
                       timeout=300, env=dict(os.environ, PYTHONPATH=ROOT))
    assert r.returncode == 0, r.stderr[-2000:]
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["one"] >= 1                       # the S1 node(s) the first instance uses
    assert out["six"] == out["one"]              # five more of the same design: no new table
    assert out["eta_more"] == [out["eta_first"]] * 5        # the same tables, the same numbers
    assert out["with_s2"] > out["six"]           # another mode: tables of its own
    assert 0 < out["eta_s2"] < 1 and out["eta_s2"] != out["eta_first"]
    assert out["freed"] == 0                     # the last instance freed takes them along
    assert out["path_six"] == out["path"]        # pythonfmu's sys.path insert: once
    assert out["classes_six"] == out["classes"]  # no slave class per instance
