"""replay, calibrate, diagnose and identify through the Python API: the same files as the
CLI's, and the physics recovered."""

import json

import numpy as np
import pytest

import agvsim
from agvsim.results import uncovered


def assert_typed(cls, data):
    """Every field of the JSON the library wrote is a field of the typed result (none is
    dropped on the way to Python)."""
    missing = uncovered(cls, data)
    assert not missing, f"{cls.__name__} has no field for: {missing}"

LAB = "scenes/lab_offset_120mm.toml"
INPUTS = "data/calibrate_example/multisine_inputs.csv"


@pytest.fixture(autouse=True)
def in_the_repository(root, monkeypatch):
    """Paths as the CLI is given them (relative to the repository): reports and files
    name them as given."""
    monkeypatch.chdir(root)


@pytest.fixture(scope="module")
def machine(cli, tmp_path_factory):
    """The lab scene's machine with 0.05 N m of Coulomb friction and no play, replayed on
    the shipped multisine inputs by the CLI: a recording whose answer is known."""
    out = tmp_path_factory.mktemp("machine")
    cli("replay", "--scene", LAB, "--recording", INPUTS, "--out", out,
        "--set", "gearbox.backlash_rad=0", "--set", "motor.coulomb_Nm=0.05")
    return out / "multisine_inputs.replay.csv"


def test_replay_writes_the_cli_bytes(root, cli, tmp_path):
    cli("replay", "--scene", LAB, "--recording", INPUTS, "--out", tmp_path / "cli")
    sim = agvsim.replay(LAB, INPUTS, out=tmp_path / "py")
    name = "multisine_inputs.replay.csv"
    assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes()
    assert "fit" in sim.report and len(sim) > 100


def test_calibrate_gives_the_cli_json_and_scene(root, cli, machine, tmp_path):
    args = ["--scene", LAB, "--set", "gearbox.backlash_rad=0", "--set", "motor.coulomb_Nm=0",
            "--recording", machine, "--effects", "coulomb_friction"]
    cli("calibrate", *args, "--json", tmp_path / "cli.json", "--write", tmp_path / "cli.toml")
    scene = agvsim.Scene.load(LAB).with_values({"gearbox.backlash_rad": 0, "motor.coulomb_Nm": 0})
    result = agvsim.calibrate(scene, machine, effects=["coulomb_friction"], out=tmp_path / "py")
    assert (tmp_path / "py" / "calibrate.json").read_bytes() == (tmp_path / "cli.json").read_bytes()
    assert (tmp_path / "py" / "calibrated.toml").read_bytes() == (tmp_path / "cli.toml").read_bytes()
    # The fields are the JSON's; the calibrated scene carries the friction found.
    assert result.data == json.loads((tmp_path / "cli.json").read_text())
    assert [e.name for e in result.accepted] == ["coulomb_friction"], result.effects
    assert result.scene["motor.coulomb_Nm"] == pytest.approx(0.05, rel=0.02)
    assert result.mean_fit_pct.calibrated > result.mean_fit_pct.original + 10
    assert_typed(agvsim.Calibration, result.data)
    # Typed fields carry the JSON's numbers.
    effect = result.accepted[0]
    assert (effect.value, effect.std) == (result.data["effects"][0]["value"], result.data["effects"][0]["std"])
    assert effect.key == "motor.coulomb_Nm" and effect.at_bound is None


def test_calibrate_takes_a_recording_in_memory(root, machine):
    rec = agvsim.Recording.read(machine)
    scene = agvsim.Scene.load(root / LAB).with_values({"gearbox.backlash_rad": 0, "motor.coulomb_Nm": 0})
    result = agvsim.calibrate(scene, rec, effects="coulomb_friction")
    assert result.scene["motor.coulomb_Nm"] == pytest.approx(0.05, rel=0.02)
    # The calibrated scene runs (its file lives as long as the object).
    assert len(agvsim.run(result.scene, duration_s=0.5)) == 51


def test_diagnose_gives_the_contract_json_of_the_cli(shared, cli, tmp_path):
    dev = shared / "data" / "dev"
    cli("diagnose", "--rig", dev / "dev_axis_03.rig.toml", "--recording", dev / "dev_axis_03.csv",
        "--json", tmp_path / "cli.json")
    result = agvsim.diagnose(dev / "dev_axis_03.csv", rig=dev / "dev_axis_03.rig.toml", out=tmp_path / "py")
    assert (tmp_path / "py" / "diagnosis.json").read_bytes() == (tmp_path / "cli.json").read_bytes()
    data = json.loads((tmp_path / "cli.json").read_text())
    assert result.data == data
    assert_typed(agvsim.Diagnosis, data)
    assert result.names == [e["name"] for e in data["effects"]] and result.names
    found = result.effects[0]
    assert found.params == data["effects"][0]["params"] and found.fit_pct == data["effects"][0]["fit_pct"]
    assert result.final.fit_pct > result.baseline.fit_pct
    assert [p.name for p in result.final.estimates] == [p["name"] for p in data["final"]["estimates"]]
    assert "Found" in result.report or "found" in result.report


def test_identify_gives_the_cli_json(shared, cli, tmp_path):
    dev = shared / "data" / "dev"
    cli("identify", "--rig", dev / "dev_axis_01.rig.toml", "--recording", dev / "dev_axis_01.csv",
        "--json", tmp_path / "cli.json")
    result = agvsim.identify(dev / "dev_axis_01.rig.toml", dev / "dev_axis_01.csv", out=tmp_path / "py")
    assert (tmp_path / "py" / "identify.json").read_bytes() == (tmp_path / "cli.json").read_bytes()
    data = json.loads((tmp_path / "cli.json").read_text())
    assert_typed(agvsim.Identification, data)
    assert [p.name for p in result.params] == [p["name"] for p in data["params"]] and result.params
    first = result.params[0]
    assert (first.value, first.std, first.at_bound) == tuple(data["params"][0][k] for k in ("value", "std", "at_bound"))
    assert result.estimation.fit_pct == data["estimation"]["fit_pct"]
    assert result.converged == data["converged"]


def test_fitting_errors_name_what_is_wrong(root, shared, tmp_path):
    with pytest.raises(agvsim.InputError, match="no_such_effect"):
        agvsim.calibrate(root / LAB, root / INPUTS, effects=["no_such_effect"])
    with pytest.raises(agvsim.InputError, match="missing.csv"):
        agvsim.replay(root / LAB, tmp_path / "missing.csv")
    with pytest.raises(agvsim.InputError, match="one of rig= or scene="):
        agvsim.diagnose(root / INPUTS)
    dev = shared / "data" / "dev"
    with pytest.raises(agvsim.InputError, match="model=wheel"):
        agvsim.identify(dev / "dev_axis_01.rig.toml", dev / "dev_axis_01.csv", model="wheel")


def test_a_fleet_diagnosis_gives_the_cli_summary(shared, cli, tmp_path):
    fleet = tmp_path / "fleet"
    fleet.mkdir()
    for name in ["dev_axis_01", "dev_axis_03"]:
        for ext in [".csv", ".rig.toml"]:
            (fleet / (name + ext)).write_bytes((shared / "data" / "dev" / (name + ext)).read_bytes())
    cli("batch", "diagnose", fleet, "--out", tmp_path / "cli")
    table = agvsim.batch_diagnose(fleet, out=tmp_path / "py")
    assert (tmp_path / "py" / "summary.csv").read_bytes() == (tmp_path / "cli" / "summary.csv").read_bytes()
    assert list(table["recording"]) == ["dev_axis_01.csv", "dev_axis_03.csv"]
    assert list(table["status"]) == ["ok", "ok"]
    # The summary in memory is the same without an output folder.
    again = agvsim.batch_diagnose(fleet)
    assert again.rows == table.rows


def test_a_diagnosis_through_the_simulator_is_typed_too(machine, tmp_path):
    axis = agvsim.Scene.load(LAB).with_values({"gearbox.backlash_rad": 0, "motor.coulomb_Nm": 0})
    result = agvsim.diagnose(machine, scene=axis.save(tmp_path / "axis.toml"), effects=["coulomb_friction"])
    assert_typed(agvsim.Diagnosis, result.data)
    assert result.names == ["coulomb_friction"], result.report
    found = result.effects[0]
    assert found.scene_key == "motor.coulomb_Nm" and not found.outside_vocabulary
    assert found.params["coulomb_torque_Nm"] == pytest.approx(0.05, rel=0.02)
    assert result.final.fit_pct > result.baseline.fit_pct + 10
