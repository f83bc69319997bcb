"""Imports through the Python API: the files the CLI writes (on logs written by others:
the example bag by `rosbags`, the SysId log by WPILib)."""

import pytest

import agvsim


@pytest.fixture(autouse=True)
def in_the_repository(root, monkeypatch):
    monkeypatch.chdir(root)


def not_header(path):
    """A written file's lines but the one that quotes the command."""
    return [l for l in path.read_text().splitlines() if "agvsim import" not in l and "import_ros2(" not in l]


def test_a_ros2_bag_imports_as_the_cli_imports_it(cli, tmp_path):
    bag = "data/ros2_example/robot_square"
    cli("import", "ros2", bag, "--controller-yaml", "data/ros2_example/controller.yaml",
        "--mass-kg", "40", "--out", tmp_path / "cli")
    imported = agvsim.import_ros2(bag, tmp_path / "py", controller_yaml="data/ros2_example/controller.yaml",
                                  mass_kg=40)
    assert (tmp_path / "py" / "robot_square.csv").read_bytes() == (tmp_path / "cli" / "robot_square.csv").read_bytes()
    assert not_header(tmp_path / "py" / "robot_square.scene.toml") == not_header(tmp_path / "cli" / "robot_square.scene.toml")
    rec = imported.recording
    assert rec.rig == "vehicle" and "cmd_linear_m_s" in rec.names
    # The scene has the drawing's geometry, as the URDF in the bag says.
    assert imported.scene["wheel.radius_m"] == pytest.approx(0.08)
    assert imported.scene["chassis.track_width_m"] == pytest.approx(0.4)


def test_a_sysid_log_imports_as_the_cli_imports_it(cli, shared, tmp_path):
    log = shared / "data" / "real" / "frc_drivetrain" / "sysid_data.json"
    cli("import", "wpilib", log, "--out", tmp_path / "cli")
    imported = agvsim.import_wpilib(log, tmp_path / "py")
    names = sorted(p.name for p in (tmp_path / "cli").iterdir())
    assert names == sorted(p.name for p in (tmp_path / "py").iterdir())
    for n in names:
        assert (tmp_path / "py" / n).read_bytes() == (tmp_path / "cli" / n).read_bytes(), n
    assert len(imported.recordings) == 4 and imported.rig is not None
    assert {r.rig for r in imported.recordings} == {"vehicle"}


def test_import_errors_name_the_argument(tmp_path):
    with pytest.raises(agvsim.InputError, match="nothing_here"):
        agvsim.import_ros2(tmp_path / "nothing_here", tmp_path / "out")
    with pytest.raises(agvsim.InputError, match="mechanism=wheelbarrow"):
        agvsim.import_wpilib(tmp_path / "x.json", tmp_path / "out", mechanism="wheelbarrow")
    with pytest.raises(agvsim.InputError, match="motor_no_load_rpm"):
        agvsim.import_ros2("data/ros2_example/robot_square", tmp_path / "out", motor_rated_v=24)
