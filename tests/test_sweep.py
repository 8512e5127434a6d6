"""Design sweeps and batch diagnosis: the local process pool and dask (a 2-worker local cluster
standing in for a real one) give exactly the serial results (issue 9, item 6; issue 21,
item 5); a local run stays serial below the cut-off; results stream to Parquet partitions that
read as one table; specs are checked with errors naming the field."""
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


def test_three_backends_stream_identical_partitioned_tables(tmp_path, cluster, monkeypatch):
    """serial, the local pool and dask write the same rows, in design order, as Parquet
    partitions that pandas reads as one table; a design that cannot be built keeps its rows
    with the reason (the pool and dask included)."""
    import cyclo_fmu.sweep as sw
    monkeypatch.setattr(sw, "PARTITION_ROWS", 5)     # several partitions from 8 designs
    spec = _spec(tmp_path, lam="[1.2, 2.0, 4]", mu="[0.08, 0.1, 2]")
    tables, plans = {}, {}
    for backend, kw in (("serial", {}), ("pool", {"workers": 2}), ("dask", {"scheduler": cluster})):
        out = tmp_path / f"{backend}.parquet"
        out.mkdir()
        # (dask cuts its tasks for the cluster's workers itself)
        plans[backend] = sw.write_sweep(spec, out, backend=backend, progress=False,
                                        chunk=None if backend == "dask" else 2, **kw)
        assert len(list(out.glob("part-*.parquet"))) == plans[backend].partitions > 1
        tables[backend] = pd.read_parquet(out)
    pd.testing.assert_frame_equal(tables["serial"], tables["pool"])
    pd.testing.assert_frame_equal(tables["serial"], tables["dask"])
    df = tables["pool"]
    assert list(df["design_id"]) == sorted(df["design_id"]) and len(df) == 16
    bad = df[df["geometry.lam"] == 1.2]
    assert len(bad) == 4 and bad["error"].str.contains("d_v1").all()
    assert bad["eta_mean"].isna().all() and (df[df["geometry.lam"] > 1.5]["error"] == "").all()
    assert plans["pool"].errors == (df["error"] != "").sum() >= 4 and plans["pool"].rows == 16


def test_backend_choice_at_the_cut_off():
    """Serial below the cut-off (the pool would not save twice its start-up), the pool above,
    dask only with a scheduler; one worker is always serial."""
    from cyclo_fmu.sweep import cluster as cl
    cut = cl.serial_cutoff_s(2)
    assert cut == pytest.approx(cl.POOL_SAFETY * cl.pool_start_s() * 2)
    c = 0.01                                    # s per design
    n_cut = cut / c
    assert cl.choose_backend(math.floor(n_cut) - 1, c, workers=2) == "serial"
    assert cl.choose_backend(math.ceil(n_cut) + 1, c, workers=2) == "pool"
    assert cl.choose_backend(10_000, c, workers=1) == "serial"
    assert cl.choose_backend(10_000, c, workers=2, serial=True) == "serial"
    assert cl.choose_backend(3, c, workers=2, scheduler="tcp://h:8786") == "dask"
    # with 3 workers the pool gains 2/3 of the work instead of 1/2: a lower cut-off
    assert cl.serial_cutoff_s(3) < cut


def test_task_size_follows_n_and_workers():
    from cyclo_fmu.sweep import cluster as cl
    assert cl.task_size(1000, 0.01, 2) == 125                   # 4 tasks per worker
    assert cl.task_size(1000, 0.01, 8) == 32
    assert cl.task_size(10_000, 0.01, 2) == int(cl.TASK_MAX_S / 0.01)   # capped at 2 s
    assert cl.task_size(3, 0.01, 2) == 1


def test_small_sweep_stays_in_this_process(tmp_path):
    from cyclo_fmu.sweep import SweepPlan
    spec = _spec(tmp_path)
    plan = SweepPlan("", 0, 0, 0.0, 0)
    run_sweep(spec, progress=False, plan=plan, workers=2)
    # the backend follows the rule from the cost measured in this run (a loaded machine may
    # measure a design slow enough for the pool): no timed assertion, the rule applied
    from cyclo_fmu.sweep import PROBE_DESIGNS
    from cyclo_fmu.sweep.cluster import choose_backend
    assert plan.n == 4 and plan.seconds_per_design > 0
    # the rule is applied to the designs left after the probe (evaluated here already)
    assert plan.backend == choose_backend(4 - PROBE_DESIGNS, plan.seconds_per_design, workers=2)


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
    for kind in ("serial", "pool", "dask"):
        out = tmp_path / kind
        out.mkdir()
        df = diagnose_batch(rec_dir, out, DriveDesign(), "S1", serial=kind == "serial",
                            scheduler=cluster if kind == "dask" else None, progress=False,
                            workers=2)
        outs[kind] = (df, {p.name: json.loads((out / p.stem / "diagnosis.json").read_text())
                           for p in sorted(rec_dir.glob("r*.csv"))})
    for kind in ("pool", "dask"):
        pd.testing.assert_frame_equal(outs["serial"][0], outs[kind][0])
        assert outs["serial"][1] == outs[kind][1]
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
    # a second run replaces the earlier results, not adds to them
    assert main(["sweep", str(p), "--out", str(out)]) == 0
    pd.testing.assert_frame_equal(pd.read_parquet(out), df)
    assert sorted(tmp_path.iterdir()) == [out, p]


def test_cli_sweep_never_replaces_another_folder(tmp_path, capsys):
    from cyclo_fmu.cli import main
    p = tmp_path / "spec.toml"
    p.write_text(SPEC.format(method="grid", lam="[1.6, 2.0, 2]", mu="[0.08, 0.1, 2]"))
    out = tmp_path / "mine.parquet"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    assert main(["sweep", str(p), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(out) in err[0]
    assert (out / "notes.txt").read_text() == "keep me" and sorted(tmp_path.iterdir()) == [out, p]


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
    """dask is needed for --scheduler only: without it that is one line; a local run works."""
    from cyclo_fmu.cli import main
    monkeypatch.setitem(sys.modules, "distributed", None)     # import fails as if absent
    p = tmp_path / "spec.toml"
    p.write_text(SPEC.format(method="grid", lam="[1.6, 2.0, 2]", mu="[0.08, 0.1, 2]"))
    assert main(["sweep", str(p), "--out", str(tmp_path / "r.parquet"),
                 "--scheduler", "tcp://127.0.0.1:1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cyclo-fmu[sweep]" in err[0]
    assert sorted(tmp_path.iterdir()) == [p]
    assert main(["sweep", str(p), "--out", str(tmp_path / "r.parquet"), "--workers", "2"]) == 0
    assert len(pd.read_parquet(tmp_path / "r.parquet")) == 8
