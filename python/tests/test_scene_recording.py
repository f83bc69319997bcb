"""Scenes and recordings through the Python API, checked against the CLI's files."""

import math

import numpy as np
import pytest

import agvsim

LAB = "scenes/lab_offset_120mm.toml"


def test_keys_are_the_scene_reference_and_values_set_are_read_back(root):
    scene = agvsim.Scene.load(root / LAB)
    keys = scene.keys()
    # Every numeric key of the reference, with its declared unit.
    reference = agvsim.keys_reference()
    assert all(f"`{k}`" in reference for k in keys), [k for k in keys if f"`{k}`" not in reference][:5]
    assert scene.units()["chassis.mass_kg"] == "kg"
    heavier = scene.with_values({"chassis.mass_kg": 61.25, "controller.gain_scale": 2})
    assert heavier["chassis.mass_kg"] == 61.25
    assert heavier["controller.gain_scale"] == 2.0
    # The original is untouched: scenes are values.
    assert scene["chassis.mass_kg"] == keys["chassis.mass_kg"]
    assert "mass_kg = 61.25" in heavier.to_toml()


def test_a_wrong_key_or_value_is_an_input_error_naming_it(root):
    scene = agvsim.Scene.load(root / LAB)
    with pytest.raises(agvsim.InputError, match="mass_kgg"):
        scene.with_values({"chassis.mass_kgg": 3})
    with pytest.raises(agvsim.InputError, match="chassis.mass_kg"):
        scene.with_values({"chassis.mass_kg": -3})
    with pytest.raises(agvsim.InputError, match="no_such.toml"):
        agvsim.Scene.load(root / "no_such.toml")
    with pytest.raises(KeyError, match="keys_reference"):
        scene["chassis.mass"]


def test_new_writes_the_scene_the_cli_writes(cli, tmp_path):
    numbers = dict(mass_kg=12.5, track_m=0.3, wheel_radius_m=0.05, battery_v=12,
                   motor_no_load_rpm=6000, motor_stall_current_a=20, gear_ratio=30, guidance="none")
    py = agvsim.Scene.new(tmp_path / "py.toml", **numbers)
    flags = ["--mass-kg", "12.5", "--track-m", "0.3", "--wheel-radius-m", "0.05", "--battery-V", "12",
             "--motor-no-load-rpm", "6000", "--motor-stall-current-A", "20", "--gear-ratio", "30",
             "--guidance", "none"]
    cli("new", tmp_path / "cli.toml", *flags)
    body = lambda p: [l for l in p.read_text().splitlines() if not l.startswith("# Written by:")]
    # The same scene but for the header line that quotes the command.
    assert body(tmp_path / "py.toml") == body(tmp_path / "cli.toml")
    assert py.keys() == agvsim.Scene.load(tmp_path / "cli.toml").keys()
    assert "derived:" in py.report
    # A scene of no file lives in a temporary folder as long as the object.
    temp = agvsim.Scene.new(**numbers)
    assert temp.path.exists() and temp["chassis.mass_kg"] is not None


def test_new_errors_name_the_python_arguments(tmp_path):
    with pytest.raises(agvsim.InputError, match=r"battery_v.*gear_ratio.*from_scene"):
        agvsim.Scene.new(tmp_path / "x.toml", mass_kg=12, track_m=0.3, wheel_radius_m=0.05)
    with pytest.raises(agvsim.InputError, match=r"mass_kg=-1"):
        agvsim.Scene.new(tmp_path / "x.toml", mass_kg=-1)
    with pytest.raises(agvsim.InputError, match="guidance=rails"):
        agvsim.Scene.new(tmp_path / "x.toml", guidance="rails")
    assert not (tmp_path / "x.toml").exists()


def test_check_reports_what_the_cli_reports(root, cli):
    scene = agvsim.Scene.load(root / LAB).with_values({"chassis.yaw_inertia_kg_m2": 0.001})
    check = scene.check()
    expected = cli("check", LAB, "--set", "chassis.yaw_inertia_kg_m2=0.001").stdout
    assert check.report.replace(str(root) + "/", "") == expected
    assert not check and any("yaw_inertia" in w for w in check.warnings), check.report
    assert agvsim.Scene.load(root / LAB).check()


def test_run_writes_the_cli_bytes_and_returns_them(root, cli, tmp_path):
    cli("run", LAB, "--duration", "2", "--set", "controller.gain_scale=2", "--out", tmp_path / "cli")
    scene = agvsim.Scene.load(root / LAB).with_values({"controller.gain_scale": 2})
    rec = agvsim.run(scene, duration_s=2, out=tmp_path / "py")
    name = "lab_offset_120mm.csv"
    assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes()
    # The returned columns are the file's; the summary is the run's.
    again = agvsim.Recording.read(tmp_path / "cli" / name)
    assert rec.names == again.names
    for n in rec.names:
        np.testing.assert_array_equal(rec[n], again[n])
    assert rec.t_s[-1] == pytest.approx(2.0)
    assert "simulated  2.00 s" in rec.report
    # Same scene and seed, same numbers, without an output folder too.
    np.testing.assert_array_equal(agvsim.run(scene, duration_s=2)["lateral_error_m"], rec["lateral_error_m"])


def test_a_recording_written_reads_back_exactly_and_pandas_reads_it(tmp_path):
    t = np.arange(0, 1.0, 0.01)
    v = 6.0 * np.sin(2 * math.pi * 1.3 * t) + 1e-9
    speed = np.where(t > 0.5, np.nan, 0.1 * t)  # not measured after 0.5 s
    rec = agvsim.Recording(t, {"voltage_V": v, "speed_rad_s": speed}, rig="drive_axis",
                           meta={"source": "a test, with a newline\nin it"})
    path = rec.write(tmp_path / "made.csv")
    back = agvsim.Recording.read(path)
    np.testing.assert_array_equal(back.t_s, t)
    np.testing.assert_array_equal(back["voltage_V"], v)  # every bit
    np.testing.assert_array_equal(np.isnan(back["speed_rad_s"]), np.isnan(speed))
    assert back.rig == "drive_axis" and back.meta["source"] == "a test, with a newline in it"
    # An independent reader sees the same numbers (empty cells as NaN).
    import pandas as pd
    theirs = pd.read_csv(path, comment="#")
    np.testing.assert_array_equal(theirs["voltage_V"].to_numpy(), v)
    np.testing.assert_array_equal(theirs["speed_rad_s"].isna().to_numpy(), np.isnan(speed))
    df = back.to_pandas()
    assert list(df.columns) == ["voltage_V", "speed_rad_s"] and df.index.name == "t_s"
    # The columns are the names, as a DataFrame's; a column is indexed by its name.
    assert back.columns == list(df.columns) and "voltage_V" in back and "current_A" not in back
    back["power_W"] = back["voltage_V"] ** 2
    assert back.columns[-1] == "power_W" and back.to_dict()["power_W"][3] == v[3] ** 2
    with pytest.raises(ValueError, match="power_W: 2 values for 100 rows"):
        back["power_W"] = [1.0, 2.0]


def test_a_recording_the_contract_refuses_is_not_written(tmp_path):
    t = [0.0, 0.01, 0.005]  # time going back
    with pytest.raises(agvsim.InputError):
        agvsim.Recording(t, {"voltage_V": [1, 2, 3]}, rig="drive_axis").write(tmp_path / "bad.csv")
    with pytest.raises(agvsim.InputError, match="voltage_V: 2 values"):
        agvsim.Recording([0, 1, 2], {"voltage_V": [1, 2]}, rig="drive_axis").write(tmp_path / "bad.csv")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(agvsim.InputError, match="missing.csv"):
        agvsim.Recording.read(tmp_path / "missing.csv")
