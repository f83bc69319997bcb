"""A sweep and a fleet calibration over dask.distributed (a LocalCluster): every task calls
the Python API, and the merged tables are the CLI's bytes."""

import re

import numpy as np
import pytest

import agvsim
from agvsim import cluster

LAB = "scenes/lab_offset_120mm.toml"
INPUTS = "data/calibrate_example/multisine_inputs.csv"


@pytest.fixture(autouse=True)
def in_the_repository(root, monkeypatch):
    monkeypatch.chdir(root)


@pytest.fixture(scope="module")
def dask_client():
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as lc, distributed.Client(lc) as client:
        yield client


def test_a_sweep_over_dask_merges_to_the_cli_sweep(cli, dask_client, tmp_path):
    cli("sweep", LAB, "--vary", "controller.gain_scale=0.5,1,2,3,4", "--duration", "3",
        "--out", tmp_path / "cli")
    table = cluster.sweep(LAB, {"controller.gain_scale": [0.5, 1, 2, 3, 4]}, tmp_path / "dask",
                          shards=3, submit=dask_client.submit, gather=dask_client.gather, duration_s=3)
    assert (tmp_path / "dask" / "results.csv").read_bytes() == (tmp_path / "cli" / "results.csv").read_bytes()
    assert len(table) == 5
    np.testing.assert_array_equal(table["controller.gain_scale"], [0.5, 1, 2, 3, 4])
    # Each shard ran on a worker: three shard folders, merged.
    assert len(list((tmp_path / "dask" / "shards").iterdir())) == 3
    df = table.to_pandas()
    assert list(df["controller.gain_scale"]) == [0.5, 1, 2, 3, 4]


def test_a_fleet_calibration_over_dask_merges_to_the_cli_batch(cli, dask_client, tmp_path):
    # A fleet of three axes without play, each with its own Coulomb friction, made by the
    # CLI; a scene with none to calibrate against.
    scene = agvsim.Scene.load(LAB).with_values({"gearbox.backlash_rad": 0, "motor.coulomb_Nm": 0})
    scene_file = scene.save(tmp_path / "no_play.toml")
    fleet = tmp_path / "fleet"
    fleet.mkdir()
    truth = {"axis_a": 0.03, "axis_b": 0.05, "axis_c": 0.08}
    for name, coulomb in truth.items():
        cli("replay", "--scene", scene_file, "--recording", INPUTS, "--out", tmp_path / name,
            "--set", f"motor.coulomb_Nm={coulomb}")
        (fleet / f"{name}.csv").write_bytes((tmp_path / name / "multisine_inputs.replay.csv").read_bytes())
    cli("batch", "calibrate", fleet, "--scene", scene_file, "--effects", "coulomb_friction",
        "--out", tmp_path / "cli")
    table = cluster.batch(fleet, tmp_path / "dask", shards=2, submit=dask_client.submit,
                          gather=dask_client.gather, scene=scene_file, effects="coulomb_friction")
    assert (tmp_path / "dask" / "summary.csv").read_bytes() == (tmp_path / "cli" / "summary.csv").read_bytes()
    # Each axis's friction is found.
    for row in table.rows:
        found = float(re.search(r"motor.coulomb_Nm=([0-9.e-]+)", row["effects"]).group(1))
        assert found == pytest.approx(truth[row["recording"][:-4]], rel=0.02), row


def test_the_engine_can_be_a_thread_pool(tmp_path):
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(2) as pool:
        table = cluster.sweep(LAB, {"controller.gain_scale": [1, 2]}, tmp_path, shards=2,
                              submit=pool.submit, gather=lambda fs: [f.result() for f in fs], duration_s=1)
    assert len(table) == 2
    whole = agvsim.sweep(LAB, {"controller.gain_scale": [1, 2]}, duration_s=1, out=tmp_path / "one")
    assert (tmp_path / "results.csv").read_bytes() == (tmp_path / "one" / "results.csv").read_bytes()
