# %% [markdown]
# # agvsim from Python: run, plot, calibrate
#
# A notebook as a script (cells marked `# %%`: VS Code, Spyder and Jupyter with jupytext
# open it as a notebook). Run it from the repository's folder:
#
#     python docs/python_tour.py [OUT_FOLDER]
#
# It runs the thesis's floor experiment, plots it, makes a "worn" machine's recording
# (0.05 N m of Coulomb friction, a supply that clips at 11 V) by replaying shipped inputs
# on it, calibrates the scene against that recording, and plots the fit before and after.
# A test (`python/tests/test_tour.py`) runs it and checks what it prints.

# %%
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files, not windows: remove this line in a notebook
import matplotlib.pyplot as plt

import agvsim

out = Path(sys.argv[1] if len(sys.argv) > 1 else "runs/python_tour")
out.mkdir(parents=True, exist_ok=True)

# %% [markdown]
# ## Run a scene
# The thesis machine starts 120 mm beside its guide wire; at the thesis's gains the gear
# play keeps a limit cycle going. `with_values` is the CLI's `--set`.

# %%
scene = agvsim.Scene.load("scenes/lab_offset_120mm.toml")
runs = {gain: agvsim.run(scene.with_values({"controller.gain_scale": gain}), duration_s=15)
        for gain in (1.0, 2.0)}
for gain, rec in runs.items():  # the summary's lines on the error and the limit cycle
    print(f"gain {gain:g}:", *[l for l in rec.report.splitlines() if l.startswith(("error", "cycle"))], sep="\n  ")

fig, ax = plt.subplots(figsize=(8, 3.5))
for gain, rec in runs.items():
    ax.plot(rec.t_s, 1000 * rec["lateral_error_m"], label=f"controller.gain_scale = {gain:g}")
ax.set(xlabel="time, s", ylabel="lateral error, mm", title="Following the wire from 120 mm off it")
ax.legend(loc="upper right")
ax.grid(alpha=0.3)
fig.tight_layout()
fig.savefig(out / "run_lateral_error.png", dpi=100)

# %% [markdown]
# ## A recording as a DataFrame
# Every column is a numpy array; `to_pandas()` gives a DataFrame indexed by time.

# %%
df = runs[1.0].to_pandas()
print(df[["lateral_error_m", "left_current_A", "right_current_A"]].describe().loc[["mean", "max"]].round(3))

# %% [markdown]
# ## Calibrate against a worn machine's recording
# The shipped inputs (a multisine terminal voltage) replayed on the worn machine give the
# "measured" recording; the scene knows neither its friction nor its clipping.

# %%
axis = scene.with_values({"gearbox.backlash_rad": 0, "motor.coulomb_Nm": 0})
inputs = "data/calibrate_example/multisine_inputs.csv"
measured = agvsim.replay(axis.with_values({"motor.coulomb_Nm": 0.05, "battery.drive_limit_V": 11}), inputs)
result = agvsim.calibrate(axis, measured, effects=["coulomb_friction", "voltage_saturation", "battery_sag"])
for e in result.effects:
    verdict = "accepted" if e.accepted else "not supported"
    print(f"{e.name:<20} {e.key:<32} {verdict}")
print(f"motor.coulomb_Nm      {result.scene['motor.coulomb_Nm']:.4f} N m (the worn machine: 0.05)")
print(f"battery.drive_limit_V {result.scene['battery.drive_limit_V']:.3f} V (the worn machine: 11)")
print(f"mean fit {result.mean_fit_pct.original:.1f} % -> {result.mean_fit_pct.calibrated:.1f} %")

# %% [markdown]
# ## The fit before and after
# The scene as it was and the calibrated scene, each replayed on the measured inputs.

# %%
before = agvsim.replay(axis, measured)
after = agvsim.replay(result.scene, measured)
fig, axes = plt.subplots(2, 1, figsize=(10, 5.5), sharex=True)
for ax, name, label in zip(axes, ["motor_speed_rad_s", "current_A"], ["motor speed, rad/s", "current, A"]):
    fits = result.replay_fit[name]
    ax.plot(measured.t_s, measured[name], color="0.6", lw=2.5, label="measured (worn machine)")
    ax.plot(before.t_s, before[name], color="tab:orange", lw=1, label=f"scene: fit {fits.original_pct:.1f} %")
    ax.plot(after.t_s, after[name], color="tab:blue", lw=1, ls="--", label=f"calibrated: fit {fits.calibrated_pct:.1f} %")
    ax.set(ylabel=label)
    # Beside the plot, not on the data.
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    ax.grid(alpha=0.3)
axes[-1].set(xlabel="time, s")
axes[0].set_title("Calibration: the scene before and after, against the measurement")
fig.tight_layout()
fig.savefig(out / "calibration_fit.png", dpi=100)
print(f"figures in {out}")
