#!/usr/bin/env bash
# Remakes data/ros2_example: a velocity-commanded robot whose right wheel rolls on 1 % less
# than its 0.08 m radius and whose wheels are 2 % further apart than their 0.4 m, its
# odometry and base controller configured with the drawing's, driven through
# data/ros2_example/commands.csv (UMBmark's square both ways, then circles) by agvsim's
# simulator, and written as a ROS 2 bag (MCAP) by the independent rosbags writer
# (tools/ros2_bags.py: a motion-capture pose on /tf, encoder joint states with noise, a gyro,
# odometry, a URDF with the nominal geometry). Needs `python3 -m pip install rosbags`.
set -euo pipefail
cd "$(dirname "$0")/.."
out="$(mktemp -d)"
cargo run --quiet --release -- new "$out/robot.toml" --mass-kg 40 --track-m 0.4 --wheel-radius-m 0.08 \
  --battery-V 24 --motor-no-load-rpm 3000 --motor-stall-current-A 40 --gear-ratio 20 --force > /dev/null
# The robot's driver publishes its joint states at 25 Hz, each speed the encoder's count
# difference since the last message (the mean over the 40 ms interval, as the contract's
# encoder speeds are), and the base controller acts on the commands at the same 25 Hz: the
# machine is driven by every second row of commands.csv, so what the bag records is what drove
# it (a command changing between two published rows would reach the machine 20 ms before the
# bag says, which a fit reads as a lead the robot does not have).
python3 - "$out" <<'PY'
import sys
d = sys.argv[1]
lines = open("data/ros2_example/commands.csv").read().splitlines()
h = next(i for i, l in enumerate(lines) if not l.startswith('#'))
out = lines[:h + 1] + [l for j, l in enumerate(lines[h + 1:]) if j % 2 == 0]
open(f"{d}/commands25.csv", "w").write("\n".join(out) + "\n")
PY
cargo run --quiet --release -- replay --scene "$out/robot.toml" --recording "$out/commands25.csv" \
  --out "$out/machine" --set base.wheel_radius_m=0.08 --set base.wheel_separation_m=0.4 \
  --set wheel.right_rolling_radius_m=0.0792 --set chassis.track_width_m=0.408 \
  --set base.max_linear_accel_m_s2=0.5 --set base.max_angular_accel_rad_s2=2 \
  --set base.max_linear_m_s=0.6 --set base.max_angular_rad_s=1.5 > /dev/null
rm -rf data/ros2_example/robot_square
python3 tools/ros2_bags.py from-recording "$out/machine/commands25.replay.csv" data/ros2_example/robot_square \
  --wheel-radius-m 0.08 --track-m 0.4 --noise
