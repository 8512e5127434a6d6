"""Design sweeps and batch diagnosis: dask on a 2-worker local cluster gives exactly the serial
results (issue 9, item 6); specs are checked with errors naming the field."""
from __future__ import annotations

import json
import sys
import math

import numpy as np
import pandas as pd
import pytest

from model_core import CycloidInputError, DriveDesign
from model_core.maps import efficiency_map
from model_core.paper import BenchEnvelope

pytest.importorskip("distributed")

from cyclo_fmu.sweep import diagnose_batch, load_spec, run_sweep  # noqa: E402

SPEC = """[sweep]
method = "{method}"
n = 6
seed = 3
modes = ["S1", "S2"]
[envelope]
n_speed = 3
n_torque = 3
[fields]
lam = {lam}
"friction.mu_boundary" = {mu}
"""


def _spec(tmp_path, method="grid", lam="[1.6, 2.0, 2]", mu="[0.08, 0.1, 2]"):
    p = tmp_path / "spec.toml"
    p.write_text(SPEC.format(method=method, lam=lam, mu=mu))
    return load_spec(p)


@pytest.fixture(scope="module")
def cluster():
    """A 2-worker LocalCluster with the settings cyclo_fmu.sweep.cluster.client gives it."""
    import dask
    import distributed

    from cyclo_fmu.sweep.cluster import local_cluster_config
    with dask.config.set(local_cluster_config()), \
            distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                     dashboard_address=None, silence_logs=40) as c:
        yield c.scheduler_address


def _worker_mmap_threshold():
    import os
    return os.environ.get("MALLOC_MMAP_THRESHOLD_")


def test_local_cluster_workers_keep_large_arrays_on_the_heap(cluster):
    """dask's workers run with MALLOC_TRIM_THRESHOLD_ set, which freezes glibc's mmap threshold
    at 128 kB; the sweep's workers get the FMU's 4 MiB (cluster.worker_environ)."""
    import distributed

    from cyclo_fmu.slaves.heap import MMAP_THRESHOLD
    with distributed.Client(cluster) as c:
        seen = c.run(_worker_mmap_threshold)
    assert len(seen) == 2 and set(seen.values()) == {str(MMAP_THRESHOLD)}


def test_sweep_on_dask_equals_serial(tmp_path, cluster):
    spec = _spec(tmp_path, "lhs", "[1.6, 2.0]", "[0.07, 0.12]")
    serial = run_sweep(spec, serial=True, progress=False)
    dask = run_sweep(spec, scheduler=cluster, progress=False, chunk=2)
    pd.testing.assert_frame_equal(serial, dask)
    assert len(serial) == 12 and (serial["error"] == "").all()


def test_sweep_row_is_the_efficiency_map_summary(tmp_path):
    """A row's summary columns are the statistics of model_core's map of that design."""
    spec = _spec(tmp_path)
    df = run_sweep(spec, serial=True, progress=False)
    assert len(df) == 8      # 2 x 2 designs x 2 modes
    row = df[(df["design_id"] == 3) & (df["mode"] == "S2")].iloc[0]
    d = DriveDesign(lam=2.0, friction=DriveDesign().friction.__class__(
        **{**DriveDesign().friction.__dict__, "mu_boundary": 0.1}))
    env = BenchEnvelope(n_speed=3, n_torque=3)
    m = efficiency_map(d, "S2", env.speeds(), env.torques())
    assert row["eta_mean"] == pytest.approx(float(np.nanmean(m.eta)), rel=1e-12)
    assert row["eta_min"] <= row["eta_mean"] <= row["eta_max"] < 1
    shares = [row[c] for c in df.columns if c.startswith("loss_share_")]
    assert sum(shares) == pytest.approx(1.0)


def test_lhs_is_stratified(tmp_path):
    """Latin hypercube: each of the n equal strata of every field holds exactly one design."""
    spec = _spec(tmp_path, "lhs", "[1.6, 2.0]", "[0.07, 0.12]")
    designs = spec.designs()
    for key, (lo, hi) in spec.fields.items():
        strata = sorted(int((d[key] - lo) / (hi - lo) * spec.n) for d in designs)
        assert strata == list(range(spec.n))


def test_invalid_design_is_a_row_not_a_crash(tmp_path):
    spec = _spec(tmp_path, lam="[1.2, 1.6, 2]")
    df = run_sweep(spec, serial=True, progress=False)
    bad = df[df["geometry.lam"] == 1.2]
    assert (bad["error"].str.contains("d_v1")).all() and bad["eta_mean"].isna().all()
    assert (df[df["geometry.lam"] == 1.6]["error"] == "").all()


@pytest.mark.parametrize("text,field", [
    ('[sweep]\nmethod = "random"\n[fields]\nlam = [1, 2, 2]\n', "sweep.method"),
    ('[fields]\nlamda = [1, 2, 2]\n', "lamda"),
    ('[fields]\nlam = [2, 1, 2]\n', "fields.lam"),
    ('[fields]\nlam = [1, 2]\n', "fields.lam"),
    ('[sweep]\nmethod = "lhs"\nn = -1\n[fields]\nlam = [1, 2]\n', "sweep.n"),
    ('[sweep]\nseed = -5\n[fields]\nlam = [1.6, 2, 2]\n', "sweep.seed"),
    ('[fields]\nlam = [1.6, 2, 2000]\nz1 = [10, 20, 1000]\n', "sweep"),
])
def test_bad_spec_names_the_field(tmp_path, text, field):
    p = tmp_path / "spec.toml"
    p.write_text(text)
    with pytest.raises(CycloidInputError) as e:
        load_spec(p)
    assert field in str(e.value)


def test_diagnose_batch_on_dask_equals_serial(tmp_path, cluster):
    from cyclo_fmu.synth import synthesize, write_synth
    rec_dir = tmp_path / "recs"
    rec_dir.mkdir()
    for seed, effect in ((1, "none"), (2, "load_independent_loss")):
        write_synth(rec_dir / f"r{seed}.csv", synthesize(effect, seed, "S1", "tiny"))
    (rec_dir / "broken.csv").write_text("time_s,speed_in_rpm\n0,1\n")
    outs = {}
    for kind in ("serial", "dask"):
        out = tmp_path / kind
        out.mkdir()
        df = diagnose_batch(rec_dir, out, DriveDesign(), "S1", serial=kind == "serial",
                            scheduler=None if kind == "serial" else cluster, progress=False)
        outs[kind] = (df, {p.name: json.loads((out / p.stem / "diagnosis.json").read_text())
                           for p in sorted(rec_dir.glob("r*.csv"))})
    pd.testing.assert_frame_equal(outs["serial"][0], outs["dask"][0])
    assert outs["serial"][1] == outs["dask"][1]
    df = outs["serial"][0].set_index("recording")
    assert df.loc["broken.csv", "error"] and not (tmp_path / "serial" / "broken").exists()
    assert df.loc["r1.csv", "error"] == "" and math.isfinite(df.loc["r1.csv", "rmse_after_mNm"])
    assert (tmp_path / "serial" / "summary.csv").exists()


def test_cli_sweep_writes_parquet(tmp_path, capsys):
    from cyclo_fmu.cli import main
    p = tmp_path / "spec.toml"
    p.write_text(SPEC.format(method="grid", lam="[1.6, 2.0, 2]", mu="[0.08, 0.1, 2]"))
    out = tmp_path / "r.parquet"
    assert main(["sweep", str(p), "--out", str(out), "--serial"]) == 0
    df = pd.read_parquet(out)
    assert len(df) == 8 and sorted(tmp_path.iterdir()) == [out, p]


@pytest.mark.parametrize("extra,field", [(["--workers", "0"], "workers"),
                                         (["--out", "x.csv"], "out")])
def test_cli_sweep_bad_options(tmp_path, capsys, extra, field):
    from cyclo_fmu.cli import main
    p = tmp_path / "spec.toml"
    p.write_text(SPEC.format(method="grid", lam="[1.6, 2.0, 2]", mu="[0.08, 0.1, 2]"))
    argv = ["sweep", str(p), "--out", str(tmp_path / "r.parquet"), *extra]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and field in err[0]
    assert sorted(tmp_path.iterdir()) == [p]


def test_missing_dask_is_one_line(tmp_path, capsys, monkeypatch):
    from cyclo_fmu.cli import main
    monkeypatch.setitem(sys.modules, "distributed", None)     # import fails as if absent
    p = tmp_path / "spec.toml"
    p.write_text(SPEC.format(method="grid", lam="[1.6, 2.0, 2]", mu="[0.08, 0.1, 2]"))
    assert main(["sweep", str(p), "--out", str(tmp_path / "r.parquet")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cyclo-fmu[sweep]" in err[0]
    assert sorted(tmp_path.iterdir()) == [p]
