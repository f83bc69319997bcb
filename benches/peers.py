#!/usr/bin/env python3
"""agvsim against its peers, side by side in one run (by hand, not in CI).

1. The drive axis (DC motor, gear train with backlash and tooth contact, Coulomb and
   viscous friction, wheel inertia) written plainly in Python and integrated with scipy's
   solve_ivp (RK45, steps capped at agvsim's 1 ms), against agvsim's lifted-wheel run of
   the same machine (which also runs the DCMC, battery and firmware).
2. The vehicle (chassis, two driven wheels with DC motors, four swivelling castors) in
   MuJoCo at agvsim's 1 ms time step, against agvsim's `full` level (rapier chassis,
   bristle tyres, castors, drivetrains with backlash, sensors, firmware).

Both sides take the machine's numbers from the scene agvsim actually runs (written by
`agvsim run` as NAME.scene.toml). Prints simulated seconds per wall second for each and the
ratios.

    pip install scipy mujoco
    cargo build --release
    python3 benches/peers.py [--agvsim target/release/agvsim] [--seconds 30]
"""

import argparse
import math
import pathlib
import subprocess
import sys
import tempfile
import time
import tomllib

import numpy as np


def scene_values(agvsim, scene):
    out = pathlib.Path(tempfile.mkdtemp(prefix="agvsim_peers_"))
    subprocess.run([agvsim, "run", scene, "--duration", "0.01", "--out", str(out)],
                   check=True, capture_output=True)
    stem = pathlib.Path(scene).stem
    return tomllib.loads((out / f"{stem}.scene.toml").read_text())


def agvsim_rate(agvsim, scene, seconds, extra):
    """Simulated seconds per wall second of one agvsim run (a one-run sweep: metrics only,
    no recording written), best of three."""
    best = math.inf
    for _ in range(3):
        out = tempfile.mkdtemp(prefix="agvsim_peers_run_")
        t0 = time.perf_counter()
        subprocess.run([agvsim, "sweep", scene, "--vary", "sim.seed=1", "--jobs", "1",
                        "--duration", str(seconds), "--out", out, *extra],
                       check=True, capture_output=True)
        best = min(best, time.perf_counter() - t0)
    return seconds / best


def drive_axis_scipy(s, seconds):
    from scipy.integrate import solve_ivp
    m, g, w = s["motor"], s["gearbox"], s["wheel"]
    R, L, K = m["resistance_ohm"], m["inductance_H"], m["torque_constant_Nm_A"]
    Jm, b, Tc = m["rotor_inertia_kg_m2"], m["viscous_Nm_s_rad"], m["coulomb_Nm"]
    N, play = g["ratio"], g["backlash_rad"]
    k, c = g["tooth_stiffness_Nm_rad"], g["tooth_damping_Nm_s_rad"]
    Jw = w["inertia_kg_m2"]

    def tooth(twist, rate):
        half = 0.5 * play
        if twist > half:
            return max(k * (twist - half) + c * rate, 0.0)
        if twist < -half:
            return min(k * (twist + half) + c * rate, 0.0)
        return 0.0

    def rhs(t, x):
        i, wm, th_m, ww, th_w = x
        v = 12.0 if (t % 1.0) < 0.5 else -12.0  # reversals every half second
        T = tooth(th_m / N - th_w, wm / N - ww)
        di = (v - R * i - K * wm) / L
        dwm = (K * i - b * wm - Tc * math.tanh(wm / 0.5) - T / N) / Jm
        dww = T / Jw
        return [di, dwm, wm, dww, ww]

    t0 = time.perf_counter()
    sol = solve_ivp(rhs, (0.0, seconds), [0, 0, 0, 0, 0], method="RK45", max_step=1e-3,
                    rtol=1e-6, atol=1e-9)
    wall = time.perf_counter() - t0
    assert sol.success, sol.message
    return seconds / wall, sol.t.size


def vehicle_mujoco(s, seconds):
    import mujoco
    c, k, m, g, w = s["chassis"], s["castors"], s["motor"], s["gearbox"], s["wheel"]
    N, K, R = g["ratio"], m["torque_constant_Nm_A"], m["resistance_ohm"]
    r, half = w["radius_m"], 0.5 * c["track_width_m"]
    # DC motor with L neglected, through the gear: torque = (N K / R) V - ((N K)^2 / R) w.
    gear = N * K / R
    damping = (N * K) ** 2 / R + m["viscous_Nm_s_rad"] * N * N
    cr = 0.04  # castor wheel radius, m
    castors = ""
    for name, x, y in [("fl", k["front_x_m"], k["half_spacing_m"]),
                       ("fr", k["front_x_m"], -k["half_spacing_m"]),
                       ("rl", k["rear_x_m"], k["half_spacing_m"]),
                       ("rr", k["rear_x_m"], -k["half_spacing_m"])]:
        castors += f"""
      <body name="swivel_{name}" pos="{x} {y} {cr - r}">
        <joint name="sw_{name}" type="hinge" axis="0 0 1" damping="0.01"/>
        <inertial pos="0 0 0" mass="0.3" diaginertia="1e-3 1e-3 1e-3"/>
        <body name="castor_{name}" pos="-0.03 0 0">
          <joint type="hinge" axis="0 1 0" damping="0.001"/>
          <geom type="cylinder" size="{cr} 0.015" euler="90 0 0" mass="{k['mass_kg']}"/>
        </body>
      </body>"""
    xml = f"""
<mujoco>
  <option timestep="0.001" integrator="implicitfast"/>
  <worldbody>
    <geom type="plane" size="50 50 0.1" friction="0.5 0.005 0.0001"/>
    <body name="chassis" pos="0 0 {r}">
      <freejoint/>
      <geom type="box" size="0.5 0.3 0.05" pos="{c['cg_x_m']} 0 0.1" mass="{c['mass_kg']}"/>
      <body name="left" pos="0 {half} 0">
        <joint name="jl" type="hinge" axis="0 1 0" damping="{damping}"/>
        <geom type="cylinder" size="{r} 0.025" euler="90 0 0" mass="2"/>
      </body>
      <body name="right" pos="0 {-half} 0">
        <joint name="jr" type="hinge" axis="0 1 0" damping="{damping}"/>
        <geom type="cylinder" size="{r} 0.025" euler="90 0 0" mass="2"/>
      </body>{castors}
    </body>
  </worldbody>
  <actuator>
    <motor joint="jl" gear="{gear}"/>
    <motor joint="jr" gear="{gear}"/>
  </actuator>
</mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    data.ctrl[:] = [20.0, 18.0]  # a gentle turn
    steps = int(round(seconds / model.opt.timestep))
    t0 = time.perf_counter()
    # All steps in one call: MuJoCo's C loop, no Python between steps.
    mujoco.mj_step(model, data, nstep=steps)
    wall = time.perf_counter() - t0
    assert np.all(np.isfinite(data.qpos)), "MuJoCo diverged"
    return seconds / wall, float(np.linalg.norm(data.qvel[:2]))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--agvsim", default="target/release/agvsim")
    ap.add_argument("--seconds", type=float, default=30.0, help="simulated time per run")
    a = ap.parse_args()
    scene = "scenes/lab_offset_120mm.toml"
    s = scene_values(a.agvsim, scene)

    lifted = ["--set", "sim.wheels_lifted=true", "--set", "sim.fidelity=complex",
              "--set", "controller.kind=open_loop", "--set",
              "controller.open_loop_forward_pct=50"]
    ours_axis = agvsim_rate(a.agvsim, scene, a.seconds, lifted)
    scipy_axis, n_steps = drive_axis_scipy(s, min(a.seconds, 10.0))
    ours_vehicle = agvsim_rate(a.agvsim, scene, a.seconds, [])
    mj_vehicle, speed = vehicle_mujoco(s, a.seconds)

    print(f"{'model':<44} {'sim s / wall s':>15}")
    print(f"{'drive axis, agvsim (lifted wheel, complex level)':<44} {ours_axis:>15.0f}")
    print(f"{'drive axis, Python + scipy solve_ivp RK45':<44} {scipy_axis:>15.1f}"
          f"   ({n_steps} steps for {min(a.seconds, 10.0):g} s)")
    print(f"{'vehicle, agvsim full level':<44} {ours_vehicle:>15.0f}")
    print(f"{'vehicle, MuJoCo (dt 1 ms)':<44} {mj_vehicle:>15.0f}"
          f"   (chassis speed at the end {speed:.2f} m/s)")
    print(f"\nratios: drive axis agvsim / scipy = {ours_axis / scipy_axis:.0f}x; "
          f"vehicle agvsim / MuJoCo = {ours_vehicle / mj_vehicle:.2f}x")


if __name__ == "__main__":
    sys.exit(main())
