"""Simulations held in memory (agvsim.Sim, agvsim.VecSim) and the Gymnasium environments,
checked against `run`'s recordings and against each other."""

import math

import numpy as np
import pytest

import agvsim

LAB = "scenes/lab_offset_120mm.toml"


def velocity_base(tmp_path, seconds):
    """The thesis machine made a velocity-commanded base (its square), as `new` makes it."""
    thesis = tmp_path / "thesis.toml"
    thesis.write_text("# every key at its default\n")
    scene = agvsim.Scene.new(tmp_path / "base.toml", from_scene=thesis, guidance="none")
    return scene.with_values({"sim.duration_s": seconds})


def assert_same_as_run(sim_rec, run_rec, decimals):
    """Every column of the run's recording is the Sim's value as `run` writes it: equal to
    within half the last decimal the recording keeps (its rounding), no more."""
    assert np.allclose(sim_rec.t_s, run_rec.t_s, atol=0.5e-4, rtol=0)
    assert sim_rec.names == run_rec.names
    for name, d in zip(run_rec.names, decimals):
        got, want = sim_rec[name], run_rec[name]
        worst = np.max(np.abs(got - want))
        assert worst <= 0.5 * 10.0**-d + 1e-9 * np.max(np.abs(want)), (name, worst)


@pytest.mark.parametrize("kind", ["wire", "velocity"])
def test_a_sim_stepped_through_a_run_gives_the_numbers_run_writes(root, tmp_path, kind):
    if kind == "wire":
        # The thesis's floor run: the P-D law, the gear play's limit cycle, slip.
        scene = agvsim.Scene.load(root / LAB).with_values({"sim.duration_s": 4})
    else:
        # Long enough for the square's first corner (the base controller's limits).
        scene = velocity_base(tmp_path, 8)
    ran = agvsim.run(scene)
    sim = agvsim.Sim(scene)
    assert sim.is_velocity_base == (kind == "velocity")
    stepped = sim.rollout()
    assert len(stepped) == len(ran)
    assert_same_as_run(stepped, ran, sim._native.output_decimals)
    # Something happened: the vehicle moved (a run of zeros would also be "equal").
    assert np.ptp(ran["x_m"]) > 0.2


def test_snapshot_and_restore_repeat_the_run_exactly(root):
    sim = agvsim.Sim(root / LAB)
    sim.step(n=1500)
    saved = sim.snapshot()
    first = np.vstack([sim.step(n=10) for _ in range(100)])
    sim.restore(saved)
    assert sim.time == pytest.approx(saved.time, abs=0)
    again = np.vstack([sim.step(n=10) for _ in range(100)])
    assert np.array_equal(first, again)
    # With coil noise, a reset with the same seed repeats the start, another seed does not.
    noisy = agvsim.Scene.load(root / LAB).with_values({"sensors.noise_adc": 2.0})
    a = np.vstack([agvsim.Sim(noisy, seed=3).step(n=800)])
    sim = agvsim.Sim(noisy)
    sim.reset(seed=3)
    assert np.array_equal(sim.step(n=800), a[0])
    sim.reset(seed=4)
    assert not np.array_equal(sim.step(n=800), a[0])


def test_commands_drive_as_the_scene_controller_takes_them(root, tmp_path):
    sim = agvsim.Sim(root / LAB)
    assert sim.command_names == ["demand_fwd_pct", "demand_turn_pct"]
    # Demands after the DCMC's enable delay drive it; a turn demand turns it left.
    sim.step((0, 0), n=int(round(sim.dcmc_enable_delay / sim.dt)) + 1)
    sim.step((40, 20), n=2000)
    assert sim.dcmc_fault is None
    assert sim.output("yaw_rate_rad_s") > 0.05
    # A demand before the enable delay faults the DCMC, as the real one.
    early = agvsim.Sim(root / LAB)
    early.step((40, 0), n=100)
    assert early.dcmc_fault is not None
    base = agvsim.Sim(velocity_base(tmp_path, 5))
    assert base.command_names == ["cmd_linear_m_s", "cmd_angular_rad_s"]
    base.step((0.3, 0.0), n=3000)
    i = base.state_names.index("forward_speed_m_s")
    assert base.state[i] == pytest.approx(0.3, rel=0.05)
    # Asked past its motors' reach, the base runs at its top speed, not at the command.
    base.step((10.0, 0.0), n=3000)
    assert 0.8 * base.top_speed < base.state[i] <= 1.01 * base.top_speed
    with pytest.raises(agvsim.InputError, match="demand_fwd_pct"):
        sim.step((0.3,))
    with pytest.raises(agvsim.InputError, match="n=0"):
        sim.step(n=0)
    with pytest.raises(agvsim.InputError, match="finite"):
        sim.step((math.nan, 0))


def test_a_vecsim_of_n_scenes_gives_each_sim_numbers(root):
    scene = agvsim.Scene.load(root / LAB)
    gains = [0.5, 1.0, 2.0]
    vec = agvsim.VecSim(scene, values=[{"controller.gain_scale": g} for g in gains], seeds=[1, 2, 3])
    assert len(vec) == 3
    for _ in range(20):
        out = vec.step(n=100)
    assert out.shape == (3, len(vec.output_names))
    for i, g in enumerate(gains):
        one = agvsim.Sim(scene.with_values({"controller.gain_scale": g}), seed=i + 1)
        assert np.array_equal(one.step(n=2000), out[i])
    # n identical scenes: n equal rows; commands per member, shape checked.
    same = agvsim.VecSim(scene, n=4)
    rows = same.step(n=500)
    assert all(np.array_equal(rows[0], r) for r in rows)
    with pytest.raises(agvsim.InputError, match=r"expected \(4, 2\)"):
        same.step(np.zeros((3, 2)))
    np.testing.assert_allclose(same.times, 0.5)


def test_the_gymnasium_environments_pass_gymnasium_checks():
    gym = pytest.importorskip("gymnasium")
    from gymnasium.utils.env_checker import check_env

    import agvsim.gym  # noqa: F401  (registers the environments)

    for env_id in ("agvsim/WireFollowing-v0", "agvsim/VelocityBase-v0"):
        env = gym.make(env_id)
        check_env(env.unwrapped, skip_render_check=True)
        obs, _ = env.reset(seed=7)
        assert env.observation_space.contains(obs)
    # The wire-following vehicle driven straight on ahead never finds the wire 120 mm
    # away: the reward is minus the error each step, and the episode runs to its end.
    env = gym.make("agvsim/WireFollowing-v0")
    env.reset(seed=1)
    total, steps = 0.0, 0
    while True:
        _, r, terminated, truncated, info = env.step(np.array([0.3, 0.0], dtype=np.float32))
        total += r
        steps += 1
        if terminated or truncated:
            break
    assert truncated and not terminated
    assert info["lateral_error_m"] == pytest.approx(0.12, abs=0.01)
    assert total == pytest.approx(-steps * 0.12 / 0.1, rel=0.02)
    # A base told to stand still while its path drives a square falls behind and is lost.
    env = gym.make("agvsim/VelocityBase-v0")
    env.reset(seed=1)
    for _ in range(10_000):
        _, _, terminated, truncated, info = env.step(np.zeros(2, dtype=np.float32))
        if terminated or truncated:
            break
    assert terminated and info["path_error_m"] > 1.0
