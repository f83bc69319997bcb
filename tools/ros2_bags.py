#!/usr/bin/env python3
"""Writes ROS 2 bags with the `rosbags` package (an independent writer of both rosbag2
storages), for agvsim's import tests.

  ros2_bags.py fixtures OUT_DIR
      every message type agvsim decodes, at known values, as MCAP and as SQLite3 bags,
      and the malformed cases (an unknown message type, a topic with no messages)

  ros2_bags.py shapes OUT_DIR
      the bag shapes beside the usual one: a pose only (PoseStamped and
      PoseWithCovarianceStamped, no JointState), odometry only with /tf chains
      (map -> odom -> base_link, world -> mocap -> base_link), and ROS 1 .bag files (the
      `fixtures` messages, with rosbags' ROS 1 writer, uncompressed, bz2 and lz4)

  ros2_bags.py hostile OUT_DIR [--tiny-messages N]
      bags that lie about their topics: `two_types.bag` (ROS 1) and `two_types_mcap`
      with /cmd_vel published as Twist (80 messages) and as TwistStamped (20), and
      `tiny_messages.bag` (ROS 1, bz2): N empty JointState messages (default 1,100,000)
      beside ten /cmd_vel, a few hundred kilobytes that decompress to millions of messages

  ros2_bags.py from-recording RECORDING.csv OUT_BAG --wheel-radius-m R --track-m B
                [--storage mcap|sqlite3]
      a bag of a robot as ROS logs it, from an agvsim recording's columns: /cmd_vel
      (Twist) from cmd_linear_m_s and cmd_angular_rad_s, /joint_states (wheel angles and
      speeds), /imu (yaw rate), /odom (odometry integrated from the wheels), /tf (the
      tracked pose, mocap -> base_link), /battery and /robot_description (a URDF)
      --clock KIND stamps the messages on clocks that disagree with the log times:
        sim-cmd     /cmd_vel as TwistStamped stamped on a simulation clock (from 0 s)
        skew-cmd    /cmd_vel as TwistStamped stamped 5 s after its log times
        jump-back   every stamp from the middle on an hour earlier than its log time
        y2038       one /joint_states message stamped in 2038
        half-unstamped  every other /joint_states, /imu and /odom message unstamped
      --joints KIND writes /joint_states as drivers that do not match the URDF do:
        renamed        joints `wheel_l` and `wheel_r` (the URDF says left_wheel_joint, ...)
        short-velocity a velocity array holding the left wheel's speed only
        position-only  positions, no velocities
        nan            velocities all NaN
      --description none|dtd writes no /robot_description, or the URDF behind a DTD

Install: python3 -m pip install rosbags
"""

import argparse
import csv
import math
import sys
from pathlib import Path

from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore, get_types_from_msg

TS = get_typestore(Stores.ROS2_HUMBLE)
T = TS.types
# ROS 1 (Noetic) types, with tf2's TFMessage, which the base store lacks.
TS1 = get_typestore(Stores.ROS1_NOETIC)
TS1.register(get_types_from_msg('geometry_msgs/TransformStamped[] transforms', 'tf2_msgs/msg/TFMessage'))
T0_NS = 1_700_000_000 * 10**9  # an epoch time, as a real log has


def stamp(t_ns):
    return T['builtin_interfaces/msg/Time'](sec=t_ns // 10**9, nanosec=t_ns % 10**9)


def header(t_ns, frame):
    if T is TS1.types:
        return T['std_msgs/msg/Header'](seq=7, stamp=stamp(t_ns), frame_id=frame)
    return T['std_msgs/msg/Header'](stamp=stamp(t_ns), frame_id=frame)


def vec3(x, y, z):
    return T['geometry_msgs/msg/Vector3'](x=x, y=y, z=z)


def quat_yaw(yaw):
    return T['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))


def twist(v, w):
    return T['geometry_msgs/msg/Twist'](linear=vec3(v, 0.0, 0.0), angular=vec3(0.0, 0.0, w))


def odometry(t_ns, x, y, yaw, v, w):
    import numpy as np
    pose = T['geometry_msgs/msg/PoseWithCovariance'](
        pose=T['geometry_msgs/msg/Pose'](position=T['geometry_msgs/msg/Point'](x=x, y=y, z=0.0),
                                         orientation=quat_yaw(yaw)),
        covariance=np.zeros(36))
    tw = T['geometry_msgs/msg/TwistWithCovariance'](twist=twist(v, w), covariance=np.zeros(36))
    return T['nav_msgs/msg/Odometry'](header=header(t_ns, 'odom'), child_frame_id='base_link',
                                      pose=pose, twist=tw)


def joint_state(t_ns, names, pos, vel, eff):
    import numpy as np
    return T['sensor_msgs/msg/JointState'](header=header(t_ns, ''), name=names,
                                           position=np.array(pos, dtype=np.float64),
                                           velocity=np.array(vel, dtype=np.float64),
                                           effort=np.array(eff, dtype=np.float64))


def imu(t_ns, yaw_rate):
    import numpy as np
    return T['sensor_msgs/msg/Imu'](header=header(t_ns, 'imu_link'), orientation=quat_yaw(0.0),
                                    orientation_covariance=np.zeros(9),
                                    angular_velocity=vec3(0.0, 0.0, yaw_rate),
                                    angular_velocity_covariance=np.zeros(9),
                                    linear_acceleration=vec3(0.0, 0.0, 9.81),
                                    linear_acceleration_covariance=np.zeros(9))


def battery(t_ns, volts):
    import numpy as np
    B = T['sensor_msgs/msg/BatteryState']
    return B(header=header(t_ns, ''), voltage=volts, temperature=25.0, current=-1.5, charge=10.0,
             capacity=20.0, design_capacity=20.0, percentage=0.5, power_supply_status=2,
             power_supply_health=1, power_supply_technology=3, present=True,
             cell_voltage=np.array([volts / 2, volts / 2], dtype=np.float32),
             cell_temperature=np.array([25.0, 25.0], dtype=np.float32),
             location='base', serial_number='SN1')


def tf(t_ns, parent, child, x, y, yaw):
    tr = T['geometry_msgs/msg/Transform'](translation=vec3(x, y, 0.0), rotation=quat_yaw(yaw))
    ts = T['geometry_msgs/msg/TransformStamped'](header=header(t_ns, parent), child_frame_id=child,
                                                 transform=tr)
    return T['tf2_msgs/msg/TFMessage'](transforms=[ts])


def urdf(track_m, radius_m):
    half = track_m / 2
    wheel = lambda side, y: f'''
  <link name="{side}_wheel_link">
    <collision><geometry><cylinder radius="{radius_m}" length="0.04"/></geometry></collision>
  </link>
  <joint name="{side}_wheel_joint" type="continuous">
    <parent link="base_link"/><child link="{side}_wheel_link"/>
    <origin xyz="0 {y} {radius_m}" rpy="-1.5708 0 0"/><axis xyz="0 0 1"/>
  </joint>'''
    return f'''<?xml version="1.0"?>
<robot name="fixture_bot">
  <link name="base_link"/>{wheel("left", half)}{wheel("right", -half)}
</robot>
'''


def string_msg(text):
    return T['std_msgs/msg/String'](data=text)


class Bag:
    def __init__(self, path, storage):
        plugin = StoragePlugin.MCAP if storage == 'mcap' else StoragePlugin.SQLITE3
        self.w = Writer(path, version=8, storage_plugin=plugin)
        self.w.open()
        self.conns = {}

    def topic(self, name, msgtype):
        self.conns[name] = (self.w.add_connection(name, msgtype, typestore=TS), msgtype)

    def write(self, name, t_ns, msg):
        conn, msgtype = self.conns[name]
        self.w.write(conn, t_ns, bytes(TS.serialize_cdr(msg, msgtype)))

    def close(self):
        self.w.close()


class Bag1:
    """A ROS 1 bag, written by rosbags' ROS 1 writer, with the messages of the types in TS1."""

    def __init__(self, path, compression):
        from rosbags.rosbag1 import Writer as Writer1
        path.unlink(missing_ok=True)
        self.w = Writer1(path)
        if compression != 'none':
            self.w.set_compression(getattr(Writer1.CompressionFormat, compression.upper()))
        self.w.open()
        self.conns = {}

    def topic(self, name, msgtype):
        self.conns[name] = (self.w.add_connection(name, msgtype, typestore=TS1), msgtype)

    def write(self, name, t_ns, msg):
        conn, msgtype = self.conns[name]
        self.w.write(conn, t_ns, bytes(TS1.serialize_ros1(msg, msgtype)))

    def close(self):
        self.w.close()


def use_types(store):
    """Builds the messages below from `store`'s types (ROS 2's or ROS 1's)."""
    global T
    T = store.types


def every_type(b):
    """Every message type agvsim decodes, at the values tests/ros2_import.rs expects."""
    for name, ty in [('/cmd_vel', 'geometry_msgs/msg/Twist'),
                     ('/cmd_vel_stamped', 'geometry_msgs/msg/TwistStamped'),
                     ('/odom', 'nav_msgs/msg/Odometry'),
                     ('/joint_states', 'sensor_msgs/msg/JointState'),
                     ('/imu', 'sensor_msgs/msg/Imu'),
                     ('/battery', 'sensor_msgs/msg/BatteryState'),
                     ('/tf', 'tf2_msgs/msg/TFMessage'),
                     ('/tf_static', 'tf2_msgs/msg/TFMessage'),
                     ('/robot_description', 'std_msgs/msg/String')]:
        b.topic(name, ty)
    b.write('/robot_description', T0_NS, string_msg(urdf(0.42, 0.1)))
    b.write('/tf_static', T0_NS, tf(T0_NS, 'base_link', 'imu_link', 0.1, 0.0, 0.0))
    for k in range(5):
        t = T0_NS + k * 20_000_000  # 50 Hz
        # Values that tell every field apart: k/10 plus a field's own offset.
        b.write('/cmd_vel', t, twist(0.1 * k + 0.01, -0.2 * k - 0.02))
        b.write('/cmd_vel_stamped', t,
                T['geometry_msgs/msg/TwistStamped'](header=header(t + 1_000_000, 'base_link'),
                                                    twist=twist(0.3 * k, 0.05 * k)))
        b.write('/odom', t, odometry(t, 1.0 + k, 2.0 - k, 0.25 * k, 0.5 + k, -0.1 * k))
        b.write('/joint_states', t, joint_state(t, ['left_wheel_joint', 'right_wheel_joint'],
                                                [0.1 * k, -0.1 * k], [1.5 + k, 2.5 + k], [0.3, -0.3]))
        b.write('/imu', t, imu(t, 0.07 * k - 0.1))
        b.write('/battery', t, battery(t, 24.5 - 0.1 * k))
        b.write('/tf', t, tf(t, 'mocap', 'base_link', 3.0 + 0.2 * k, -1.0 + 0.1 * k, 0.3 - 0.05 * k))


def fixtures(out):
    out.mkdir(parents=True, exist_ok=True)
    for storage in ('mcap', 'sqlite3'):
        b = Bag(out / f'types_{storage}', storage)
        every_type(b)
        b.close()
        # A topic of a type agvsim does not decode, on the commands' topic name.
        b = Bag(out / f'unknown_type_{storage}', storage)
        b.topic('/cmd_vel', 'std_msgs/msg/String')
        b.topic('/joint_states', 'sensor_msgs/msg/JointState')
        for k in range(3):
            t = T0_NS + k * 20_000_000
            b.write('/cmd_vel', t, string_msg('forward'))
            b.write('/joint_states', t, joint_state(t, ['left_wheel_joint', 'right_wheel_joint'],
                                                    [0.0, 0.0], [1.0, 1.0], [0.0, 0.0]))
        b.close()
        # A command topic with no messages.
        b = Bag(out / f'empty_topic_{storage}', storage)
        b.topic('/cmd_vel', 'geometry_msgs/msg/Twist')
        b.topic('/joint_states', 'sensor_msgs/msg/JointState')
        for k in range(3):
            t = T0_NS + k * 20_000_000
            b.write('/joint_states', t, joint_state(t, ['left_wheel_joint', 'right_wheel_joint'],
                                                    [0.0, 0.0], [1.0, 1.0], [0.0, 0.0]))
        b.close()


def pose_stamped(t_ns, frame, x, y, yaw):
    pose = T['geometry_msgs/msg/Pose'](position=T['geometry_msgs/msg/Point'](x=x, y=y, z=0.0),
                                       orientation=quat_yaw(yaw))
    return T['geometry_msgs/msg/PoseStamped'](header=header(t_ns, frame), pose=pose)


def pose_with_covariance_stamped(t_ns, frame, x, y, yaw):
    import numpy as np
    pose = T['geometry_msgs/msg/Pose'](position=T['geometry_msgs/msg/Point'](x=x, y=y, z=0.0),
                                       orientation=quat_yaw(yaw))
    return T['geometry_msgs/msg/PoseWithCovarianceStamped'](
        header=header(t_ns, frame),
        pose=T['geometry_msgs/msg/PoseWithCovariance'](pose=pose, covariance=np.full(36, 0.01)))


def shapes(out):
    """The bag shapes tests/ros2_import.rs reads (message k = 0..5 at 50 Hz)."""
    out.mkdir(parents=True, exist_ok=True)
    # /cmd_vel and two poses, no wheels: PoseStamped (1 + 0.1k, -0.2k, yaw 0.1k) and
    # PoseWithCovarianceStamped (5 + k, k, yaw -0.2k); a URDF (0.3 m track, 0.05 m wheels).
    b = Bag(out / 'pose_only_mcap', 'mcap')
    for name, ty in [('/cmd_vel', 'geometry_msgs/msg/Twist'),
                     ('/mocap/pose', 'geometry_msgs/msg/PoseStamped'),
                     ('/amcl_pose', 'geometry_msgs/msg/PoseWithCovarianceStamped'),
                     ('/robot_description', 'std_msgs/msg/String')]:
        b.topic(name, ty)
    b.write('/robot_description', T0_NS, string_msg(urdf(0.3, 0.05)))
    for k in range(5):
        t = T0_NS + k * 20_000_000
        b.write('/cmd_vel', t, twist(0.2, 0.1 * k))
        b.write('/mocap/pose', t, pose_stamped(t, 'mocap', 1.0 + 0.1 * k, -0.2 * k, 0.1 * k))
        b.write('/amcl_pose', t, pose_with_covariance_stamped(t, 'map', 5.0 + k, 1.0 * k, -0.2 * k))
    b.close()
    # /cmd_vel, /odom (pose (0.1k, 0.05k, yaw 0.02k), twist (0.5 + 0.1k, 0.2k)), no
    # wheels, no URDF; /tf: odom -> base_link (the odometry), map -> odom (a localiser's
    # correction, (2, 1, yaw pi/2), then (2.1, 1, pi/2) from k = 3), mocap -> base_link
    # (0.1k + 0.01, 0.05k, 0.02k); /tf_static world -> mocap (0.5, -0.5, 0).
    b = Bag(out / 'odom_tf_mcap', 'mcap')
    for name, ty in [('/cmd_vel', 'geometry_msgs/msg/Twist'),
                     ('/odom', 'nav_msgs/msg/Odometry'),
                     ('/tf', 'tf2_msgs/msg/TFMessage'),
                     ('/tf_static', 'tf2_msgs/msg/TFMessage')]:
        b.topic(name, ty)
    b.write('/tf_static', T0_NS, tf(T0_NS, 'world', 'mocap', 0.5, -0.5, 0.0))
    for k in range(5):
        t = T0_NS + k * 20_000_000
        ox, oy, oyaw = 0.1 * k, 0.05 * k, 0.02 * k
        b.write('/cmd_vel', t, twist(0.5, 0.2))
        b.write('/odom', t, odometry(t, ox, oy, oyaw, 0.5 + 0.1 * k, 0.2 * k))
        b.write('/tf', t, tf(t, 'odom', 'base_link', ox, oy, oyaw))
        b.write('/tf', t, tf(t, 'mocap', 'base_link', ox + 0.01, oy, oyaw))
        if k in (0, 3):
            b.write('/tf', t, tf(t, 'map', 'odom', 2.0 if k == 0 else 2.1, 1.0, math.pi / 2))
    b.close()
    # ROS 1 bags of the `fixtures` messages.
    use_types(TS1)
    try:
        for compression in ('none', 'bz2', 'lz4'):
            b = Bag1(out / f'ros1_{compression}.bag', compression)
            every_type(b)
            b.close()
    finally:
        use_types(TS)


def hostile(out, tiny_messages):
    """Bags whose topics lie (see the module's doc)."""
    from rosbags.rosbag1 import Writer as Writer1
    out.mkdir(parents=True, exist_ok=True)
    use_types(TS1)
    try:
        path = out / 'two_types.bag'
        path.unlink(missing_ok=True)
        w = Writer1(path)
        w.open()
        plain = w.add_connection('/cmd_vel', 'geometry_msgs/msg/Twist', typestore=TS1)
        stamped = w.add_connection('/cmd_vel', 'geometry_msgs/msg/TwistStamped', typestore=TS1)
        for k in range(100):
            t = T0_NS + k * 20_000_000
            if k % 5 == 4:
                w.write(stamped, t, bytes(TS1.serialize_ros1(
                    twist_stamped(t, 0.3, 0.1), 'geometry_msgs/msg/TwistStamped')))
            else:
                w.write(plain, t, bytes(TS1.serialize_ros1(twist(0.3, 0.1), 'geometry_msgs/msg/Twist')))
        w.close()
        path = out / 'tiny_messages.bag'
        path.unlink(missing_ok=True)
        w = Writer1(path)
        w.set_compression(Writer1.CompressionFormat.BZ2)
        w.chunk_threshold = 8 << 20
        w.open()
        cmd = w.add_connection('/cmd_vel', 'geometry_msgs/msg/Twist', typestore=TS1)
        joints = w.add_connection('/joint_states', 'sensor_msgs/msg/JointState', typestore=TS1)
        for k in range(10):
            w.write(cmd, T0_NS + k * 10**8, bytes(TS1.serialize_ros1(twist(0.3, 0.0), 'geometry_msgs/msg/Twist')))
        empty = bytes(TS1.serialize_ros1(joint_state(T0_NS, [], [], [], []), 'sensor_msgs/msg/JointState'))
        for k in range(tiny_messages):
            w.write(joints, T0_NS, empty)
        w.close()
    finally:
        use_types(TS)
    use_types(TS)
    b = Bag(out / 'two_types_mcap', 'mcap')
    plain = b.w.add_connection('/cmd_vel', 'geometry_msgs/msg/Twist', typestore=TS)
    stamped = b.w.add_connection('/cmd_vel', 'geometry_msgs/msg/TwistStamped', typestore=TS)
    for k in range(100):
        t = T0_NS + k * 20_000_000
        if k % 5 == 4:
            b.w.write(stamped, t, bytes(TS.serialize_cdr(twist_stamped(t, 0.3, 0.1), 'geometry_msgs/msg/TwistStamped')))
        else:
            b.w.write(plain, t, bytes(TS.serialize_cdr(twist(0.3, 0.1), 'geometry_msgs/msg/Twist')))
    b.close()


def read_recording(path):
    with open(path, newline='') as f:
        lines = [l for l in f if not l.startswith('#')]
    rows = list(csv.reader(lines))
    names = rows[0]
    cols = {n: [] for n in names}
    for r in rows[1:]:
        for n, v in zip(names, r):
            cols[n].append(float(v) if v != '' else None)
    return cols


def twist_stamped(t_ns, v, w):
    return T['geometry_msgs/msg/TwistStamped'](header=header(t_ns, 'base_link'), twist=twist(v, w))


def clock_stamp(clock, topic, k, n, t_ns):
    """The header stamp a message logged at t_ns gets under the hostile clock `clock`."""
    if clock == 'sim-cmd' and topic == '/cmd_vel':
        return t_ns - T0_NS
    if clock == 'skew-cmd' and topic == '/cmd_vel':
        return t_ns + 5 * 10**9
    if clock == 'jump-back' and k >= n // 2:
        return t_ns - 3600 * 10**9
    if clock == 'y2038' and topic == '/joint_states' and k == n // 3:
        return 2_147_000_000 * 10**9
    if clock == 'half-unstamped' and topic in ('/joint_states', '/imu', '/odom') and k % 2:
        return 0
    return t_ns


def driver_joints(kind, names, pos, vel):
    """The names, positions and speeds a /joint_states message carries under `kind`."""
    if kind == 'renamed':
        return ['wheel_l', 'wheel_r'], pos, vel
    if kind == 'short-velocity':
        return names, pos, vel[:1]
    if kind == 'position-only':
        return names, pos, []
    if kind == 'nan':
        return names, pos, [float('nan')] * len(vel)
    return names, pos, vel


def from_recording(rec, out, radius, track, storage, battery_v, noise, clock=None, joints=None, description='urdf'):
    import random
    rng = random.Random(1)
    n = lambda sd: rng.gauss(0.0, sd) if noise else 0.0
    c = read_recording(rec)
    b = Bag(out, storage)
    cmd_type = 'geometry_msgs/msg/TwistStamped' if clock in ('sim-cmd', 'skew-cmd') else 'geometry_msgs/msg/Twist'
    for name, ty in [('/cmd_vel', cmd_type),
                     ('/joint_states', 'sensor_msgs/msg/JointState'),
                     ('/imu', 'sensor_msgs/msg/Imu'),
                     ('/odom', 'nav_msgs/msg/Odometry'),
                     ('/tf', 'tf2_msgs/msg/TFMessage'),
                     ('/battery', 'sensor_msgs/msg/BatteryState'),
                     ('/robot_description', 'std_msgs/msg/String')]:
        if name != '/robot_description' or description != 'none':
            b.topic(name, ty)
    if description == 'urdf':
        b.write('/robot_description', T0_NS, string_msg(urdf(track, radius)))
    elif description == 'dtd':
        doc = urdf(track, radius)
        b.write('/robot_description', T0_NS, string_msg(
            '<?xml version="1.0"?>\n<!DOCTYPE robot [<!ENTITY r "x">]>\n' + doc.split('?>', 1)[-1].lstrip()
            if doc.startswith('<?xml') else '<!DOCTYPE robot [<!ENTITY r "x">]>\n' + doc))
    t_s = c['t_s']
    pos = [0.0, 0.0]
    ox = oy = oyaw = 0.0
    last_cmd = None
    n_rows = len(t_s)
    for k, t in enumerate(t_s):
        t_ns = T0_NS + round(t * 1e9)
        at = lambda topic: clock_stamp(clock, topic, k, n_rows, t_ns)
        cmd = (c['cmd_linear_m_s'][k], c['cmd_angular_rad_s'][k])
        # A teleop node publishes on change and at its own rate; here every change and
        # every tenth row.
        if cmd != last_cmd or k % 10 == 0:
            b.write('/cmd_vel', t_ns, twist_stamped(at('/cmd_vel'), *cmd) if cmd_type.endswith('Stamped') else twist(*cmd))
            last_cmd = cmd
        vl, vr = c['left_wheel_speed_m_s'][k], c['right_wheel_speed_m_s'][k]
        if k > 0:
            h = t - t_s[k - 1]
            pl, pr = c['left_wheel_speed_m_s'][k - 1], c['right_wheel_speed_m_s'][k - 1]
            pos[0] += 0.5 * (vl + pl) / radius * h
            pos[1] += 0.5 * (vr + pr) / radius * h
            v, w = 0.5 * (vl + vr), (vr - vl) / track
            ox += v * math.cos(oyaw) * h
            oy += v * math.sin(oyaw) * h
            oyaw += w * h
        # Encoder speeds and a gyro with their noise (0.05 rad/s at the wheel, 0.01 rad/s).
        names, jpos, jvel = driver_joints(joints, ['left_wheel_joint', 'right_wheel_joint'], list(pos),
                                          [vl / radius + n(0.05), vr / radius + n(0.05)])
        b.write('/joint_states', t_ns, joint_state(at('/joint_states'), names, jpos, jvel, [0.0] * len(jvel)))
        b.write('/imu', t_ns, imu(at('/imu'), c['yaw_rate_rad_s'][k] + n(0.01)))
        b.write('/odom', t_ns, odometry(at('/odom'), ox, oy, oyaw, 0.5 * (vl + vr), (vr - vl) / track))
        if k % 2 == 0 and c.get('x_m') and c['x_m'][k] is not None:  # a slower tracker
            b.write('/tf', t_ns, tf(at('/tf'), 'mocap', 'base_link', c['x_m'][k], c['y_m'][k], c['heading_rad'][k]))
        if k % 20 == 0:
            b.write('/battery', t_ns, battery(at('/battery'), battery_v))
    b.close()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest='cmd', required=True)
    f = sub.add_parser('fixtures')
    f.add_argument('out', type=Path)
    f = sub.add_parser('shapes')
    f.add_argument('out', type=Path)
    h = sub.add_parser('hostile')
    h.add_argument('out', type=Path)
    h.add_argument('--tiny-messages', type=int, default=1_100_000)
    r = sub.add_parser('from-recording')
    r.add_argument('recording', type=Path)
    r.add_argument('out', type=Path)
    r.add_argument('--wheel-radius-m', type=float, required=True)
    r.add_argument('--track-m', type=float, required=True)
    r.add_argument('--battery-v', type=float, default=24.0)
    r.add_argument('--storage', choices=['mcap', 'sqlite3'], default='mcap')
    r.add_argument('--noise', action='store_true', help='add encoder and gyro noise (seeded)')
    r.add_argument('--clock', choices=['sim-cmd', 'skew-cmd', 'jump-back', 'y2038', 'half-unstamped'],
                   help='stamp messages on clocks that disagree with the log times')
    r.add_argument('--description', choices=['urdf', 'none', 'dtd'], default='urdf',
                   help='/robot_description: the URDF, none, or the URDF behind a DTD')
    r.add_argument('--joints', choices=['renamed', 'short-velocity', 'position-only', 'nan'],
                   help='write /joint_states as a driver that does not match the URDF')
    a = ap.parse_args()
    if a.cmd == 'fixtures':
        fixtures(a.out)
    elif a.cmd == 'shapes':
        shapes(a.out)
    elif a.cmd == 'hostile':
        hostile(a.out, a.tiny_messages)
    else:
        from_recording(a.recording, a.out, a.wheel_radius_m, a.track_m, a.storage, a.battery_v, a.noise,
                       a.clock, a.joints, a.description)


if __name__ == '__main__':
    sys.exit(main())
