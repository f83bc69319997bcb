"""linearize, presets, experiment and study from Python (the CLI's numbers and files, as
typed values); messages in Python's words; and a user's script type-checked against the
results' concrete types."""

import json
import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import agvsim

LAB = "scenes/lab_offset_120mm.toml"


@pytest.fixture(autouse=True)
def in_the_repository(root, monkeypatch):
    monkeypatch.chdir(root)


def test_linearize_gives_the_exported_matrices_and_their_poles(cli, tmp_path):
    cli("linearize", LAB, "--export", tmp_path / "agv.json")
    exported = json.loads((tmp_path / "agv.json").read_text())
    lin = agvsim.linearize(LAB)
    for m in "ABCD":
        assert np.array_equal(getattr(lin, m), np.array(exported[m])), m
    assert lin.Ts_s == exported["Ts_s"] and lin.states == [s["name"] for s in exported["states"]]
    assert lin.A.shape == (lin.n_states, lin.n_states) and lin.B.shape == (lin.n_states, 2)
    # The poles are ln(z)/Ts of A's eigenvalues z (the zero-order-hold equivalent's).
    z = np.linalg.eigvals(lin.A)
    from_a = np.sort_complex(np.log(z.astype(complex)) / lin.Ts_s)
    assert np.allclose(np.sort_complex(lin.poles), from_a, rtol=1e-6, atol=1e-6)
    # The printed analysis is the CLI's; its verdict on the closed loop is the field's.
    printed = cli("linearize", LAB).stdout
    assert lin.report == printed
    assert lin.closed_loop_stable is not None and lin.closed_loop_poles is not None
    assert lin.closed_loop_stable == bool(np.all(lin.closed_loop_poles.real < 0))
    assert lin.controllable_rank <= lin.n_states and set(lin.unobservable_share) == set(lin.states)


def test_linearize_takes_values_set_on_the_scene():
    base = agvsim.linearize(LAB)
    heavier = agvsim.linearize(agvsim.Scene.load(LAB).with_values({"chassis.mass_kg": 240}))
    assert not np.array_equal(base.A, heavier.A)


def test_presets_are_the_printed_table(cli):
    p = agvsim.presets()
    assert p.table == cli("presets").stdout
    soft = p.get("soft_rubber", "bare_concrete")
    painted = p.get("soft_rubber", "painted_concrete")
    # A surface scales friction by its factor, relative to bare concrete.
    factor = p.surfaces["painted_concrete"].friction_factor
    assert painted.peak_mu == pytest.approx(soft.peak_mu * factor, rel=1e-12)
    assert len(p.pairs) == len(p.compounds) * len(p.surfaces)
    with pytest.raises(KeyError, match="soft_rubber"):
        p.get("rubber", "bare_concrete")


def test_an_experiment_writes_the_cli_files_and_identifies(cli, tmp_path):
    args = ["lifted-random-demand", LAB, "--seed", "5", "--duration", "5"]
    cli("experiment", *args, "--set", "gearbox.backlash_rad=0.05", "--out", tmp_path / "cli")
    scene = agvsim.Scene.load(LAB).with_values({"gearbox.backlash_rad": 0.05})
    exp = agvsim.experiment("lifted-random-demand", scene, tmp_path / "py", seed=5, duration_s=5)
    name = "lifted_random_demand.csv"
    assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes()
    assert exp.recording.path == tmp_path / "py" / name and exp.rig.exists()
    assert len(exp.recording) == 201  # 5 s at the 25 ms default
    # The value set on the scene reaches the machine: without the play, other speeds.
    plain = agvsim.experiment("lifted-random-demand", LAB, tmp_path / "plain", seed=5, duration_s=5)
    assert not np.array_equal(plain.recording["left_motor_speed_rad_s"], exp.recording["left_motor_speed_rad_s"])
    fit = agvsim.identify(exp.rig, exp.recording)
    assert isinstance(fit, agvsim.Identification) and all(p.name for p in fit.params)
    # Without a folder the files live as long as the result.
    kept = agvsim.experiment("coast-down", LAB, seed=1)
    assert kept.rig.exists() and kept.recording.path.exists()


def test_experiment_arguments_are_checked_under_their_names():
    with pytest.raises(agvsim.InputError, match="kind=floor_run: .*floor-run"):
        agvsim.experiment("floor_run", LAB)
    with pytest.raises(agvsim.InputError, match="peak_demand_pct=150"):
        agvsim.experiment("lifted-random-demand", LAB, peak_demand_pct=150)
    with pytest.raises(agvsim.InputError, match="hold_samples=9..3"):
        agvsim.experiment("lifted-random-demand", LAB, hold_samples=(9, 3))


def test_a_study_writes_the_cli_summary(cli, tmp_path):
    cli("study", "backlash-tolerance", "--quick", "--out", tmp_path / "cli")
    st = agvsim.study("backlash-tolerance", tmp_path / "py", quick=True, jobs=1)
    assert (tmp_path / "py" / "summary.md").read_bytes() == (tmp_path / "cli" / "summary.md").read_bytes()
    assert st.file("summary.md").read_text() in st.summary + "\n" or st.summary.startswith("# Backlash")
    assert st.name == "backlash-tolerance" and all(f.exists() for f in st.files)
    with pytest.raises(agvsim.InputError, match="name=tyres"):
        agvsim.study("tyres", tmp_path / "x")


def test_messages_name_python_arguments_not_cli_flags(tmp_path):
    scene = agvsim.Scene.load(LAB)
    with pytest.raises(agvsim.InputError) as e:
        scene.with_values({"chasis.mass_kg": 60})
    assert str(e.value).startswith("with_values: chasis.mass_kg=60: unknown field"), e.value
    with pytest.raises(agvsim.InputError) as e:
        agvsim.calibrate(scene, "data/calibrate_example/multisine_inputs.csv", free=["chassis.foo"])
    assert str(e.value).startswith("free: chassis.foo: no such scene key"), e.value
    assert "`agvsim.keys_reference()`" in str(e.value) and "--" not in str(e.value)
    lifted = agvsim.experiment("lifted-random-demand", LAB, tmp_path, duration_s=2)
    with pytest.raises(agvsim.AgvsimError) as e:
        agvsim.diagnose(lifted.recording.path, rig=lifted.rig)
    text = str(e.value)
    assert f"`agvsim.identify(rig={str(lifted.rig)!r}, recordings={str(lifted.recording.path)!r})`" in text, text
    assert "`agvsim.experiment('floor-run', SCENE, out=DIR)`" in text, text
    assert "--" not in text


def plain(type_text):
    """A revealed type as mypy 1.x writes it (older ones: ``Union[builtins.float, None]``)."""
    t = type_text.replace("builtins.", "")
    m = re.fullmatch(r"Union\[(.*), None\]", t)
    return f"{m.group(1)} | None" if m else t


def test_a_users_script_sees_concrete_types(tmp_path):
    pytest.importorskip("mypy")
    script = tmp_path / "user.py"
    script.write_text(textwrap.dedent("""
        import agvsim
        d = agvsim.diagnose("r.csv", rig="r.rig.toml")
        reveal_type(d.effects[0].fit_pct)
        reveal_type(d.baseline.estimates[0].at_bound)
        c = agvsim.calibrate("s.toml", "r.csv")
        reveal_type(c.keys[0].std)
        reveal_type(c.mean_fit_pct.calibrated)
        i = agvsim.identify("r.rig.toml", "r.csv")
        reveal_type(i.params[0].is_estimate)
        reveal_type(agvsim.linearize("s.toml").closed_loop_stable)
        reveal_type(agvsim.Recording.read("r.csv").columns)
        reveal_type(agvsim.experiment("coast-down", "s.toml").rig)
        d.efects
    """))
    p = subprocess.run([sys.executable, "-m", "mypy", "--no-incremental", "--strict-optional", str(script)],
                       capture_output=True, text=True, cwd=tmp_path)
    revealed = [plain(line.split("Revealed type is ", 1)[1].strip('"')) for line in p.stdout.splitlines() if "Revealed type" in line]
    assert revealed == [
        "float", "float | None", "float | None", "float", "bool", "bool | None", "list[str]", "pathlib.Path",
    ], p.stdout
    # A field that is not there is an error, not Any.
    assert '"Diagnosis" has no attribute "efects"' in p.stdout, p.stdout
