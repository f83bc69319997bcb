//! `agvsim import ros2` on bags written by an independent writer (the Python `rosbags`
//! package, `tools/ros2_bags.py`): every decoded message type at its known values from
//! both storages, malformed bags refused naming the topic or record, and a round trip of a
//! velocity-commanded robot through the simulator, a bag, the import and a calibration.

mod common;
use common::{text, tmp as scratch};

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn agvsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_agvsim"))
        .args(args)
        .output()
        .expect("agvsim runs")
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/ros2")
        .join(name)
}

/// A recording's columns by name (empty cells as NaN).
fn columns(path: &Path) -> Vec<(String, Vec<f64>)> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let names: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let mut cols: Vec<(String, Vec<f64>)> = names.into_iter().map(|n| (n, vec![])).collect();
    for l in lines {
        for (c, v) in cols.iter_mut().zip(l.split(',')) {
            c.1.push(v.parse().unwrap_or(f64::NAN));
        }
    }
    cols
}

fn col<'a>(cols: &'a [(String, Vec<f64>)], name: &str) -> &'a [f64] {
    &cols
        .iter()
        .find(|c| c.0 == name)
        .unwrap_or_else(|| panic!("no column {name}"))
        .1
}

fn close(a: &[f64], b: &[f64], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: {a:?} vs {b:?}");
    for (x, y) in a.iter().zip(b) {
        assert!((x - y).abs() < 1e-6, "{what}: {a:?} vs {b:?}");
    }
}

fn import(bag: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "import",
        "ros2",
        bag.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(extra);
    agvsim(&args)
}

/// The columns the `fixtures` messages (described below) convert to, from any storage.
fn every_type_values(c: &[(String, Vec<f64>)]) {
    let k: Vec<f64> = (0..5).map(f64::from).collect();
    let of = |f: &dyn Fn(f64) -> f64| k.iter().map(|&k| f(k)).collect::<Vec<f64>>();
    close(col(c, "t_s"), &of(&|k| 0.02 * k), "t_s");
    close(
        col(c, "cmd_linear_m_s"),
        &of(&|k| 0.1 * k + 0.01),
        "Twist linear.x",
    );
    close(
        col(c, "cmd_angular_rad_s"),
        &of(&|k| -0.2 * k - 0.02),
        "Twist angular.z",
    );
    // Rim speeds: joint speed times the URDF's 0.1 m wheel.
    close(
        col(c, "left_wheel_speed_m_s"),
        &of(&|k| 0.1 * (1.5 + k)),
        "JointState velocity",
    );
    close(
        col(c, "right_wheel_speed_m_s"),
        &of(&|k| 0.1 * (2.5 + k)),
        "JointState velocity",
    );
    close(
        col(c, "left_wheel_angle_rad"),
        &of(&|k| 0.1 * k),
        "JointState position",
    );
    close(
        col(c, "right_wheel_effort_Nm"),
        &of(&|_| -0.3),
        "JointState effort",
    );
    close(
        col(c, "yaw_rate_rad_s"),
        &of(&|k| 0.07 * k - 0.1),
        "Imu angular_velocity.z",
    );
    close(col(c, "odom_x_m"), &of(&|k| 1.0 + k), "Odometry x");
    close(col(c, "odom_y_m"), &of(&|k| 2.0 - k), "Odometry y");
    close(
        col(c, "odom_heading_rad"),
        &of(&|k| 0.25 * k),
        "Odometry yaw",
    );
    close(
        col(c, "odom_linear_m_s"),
        &of(&|k| 0.5 + k),
        "Odometry twist",
    );
    close(
        col(c, "odom_angular_rad_s"),
        &of(&|k| -0.1 * k),
        "Odometry twist",
    );
    close(col(c, "x_m"), &of(&|k| 3.0 + 0.2 * k), "tf x");
    close(col(c, "y_m"), &of(&|k| -1.0 + 0.1 * k), "tf y");
    close(col(c, "heading_rad"), &of(&|k| 0.3 - 0.05 * k), "tf yaw");
    // float32 voltages as written.
    close(
        col(c, "battery_voltage_V"),
        &of(&|k| 24.5 - 0.1 * k),
        "BatteryState voltage",
    );
}

/// The fixture's messages (tools/ros2_bags.py `fixtures`): message k (0..5, 50 Hz) has
/// Twist (0.1k + 0.01, -0.2k - 0.02), TwistStamped (0.3k, 0.05k) stamped 1 ms late,
/// Odometry pose (1 + k, 2 - k, yaw 0.25k) twist (0.5 + k, -0.1k), JointState velocities
/// (1.5 + k, 2.5 + k) rad/s, positions (0.1k, -0.1k), efforts (0.3, -0.3), Imu yaw rate
/// 0.07k - 0.1, battery 24.5 - 0.1k V, /tf mocap -> base_link (3 + 0.2k, -1 + 0.1k,
/// 0.3 - 0.05k), and a URDF with a 0.42 m track and 0.1 m wheels.
#[test]
fn every_message_type_decodes_to_its_values_from_both_storages() {
    for storage in ["mcap", "sqlite3"] {
        let dir = scratch(&format!("types_{storage}"));
        let map = dir.join("map.toml");
        std::fs::write(&map, "cmd_vel = \"/cmd_vel\"\n").unwrap();
        let o = import(
            &fixture(&format!("types_{storage}")),
            &dir,
            &["--map", map.to_str().unwrap()],
        );
        assert!(o.status.success(), "{}", text(&o));
        every_type_values(&columns(&dir.join(format!("types_{storage}.csv"))));
        // The odometry is not taken for the pose, and the scene has the URDF's geometry.
        let scene =
            std::fs::read_to_string(dir.join(format!("types_{storage}.scene.toml"))).unwrap();
        assert!(scene.contains("track_width_m = 0.42"), "{scene}");
        assert!(scene.contains("radius_m = 0.1"), "{scene}");

        // The stamped commands: placed at their header stamps (1 ms after the rows), so
        // each row holds the previous command; the first row is the first one at or after
        // the first command.
        std::fs::write(&map, "cmd_vel = \"/cmd_vel_stamped\"\n").unwrap();
        let dir2 = scratch(&format!("stamped_{storage}"));
        let o = import(
            &fixture(&format!("types_{storage}")),
            &dir2,
            &["--map", map.to_str().unwrap()],
        );
        assert!(o.status.success(), "{}", text(&o));
        let c = columns(&dir2.join(format!("types_{storage}.csv")));
        close(
            col(&c, "cmd_linear_m_s"),
            &[0.0, 0.3, 0.6, 0.9],
            "TwistStamped linear.x",
        );
        close(
            col(&c, "cmd_angular_rad_s"),
            &[0.0, 0.05, 0.1, 0.15],
            "TwistStamped angular.z",
        );
        // With log times instead, every row has its own command.
        std::fs::write(&map, "cmd_vel = \"/cmd_vel_stamped\"\ntime = \"log\"\n").unwrap();
        let o = import(
            &fixture(&format!("types_{storage}")),
            &dir2,
            &["--map", map.to_str().unwrap()],
        );
        assert!(o.status.success(), "{}", text(&o));
        let c = columns(&dir2.join(format!("types_{storage}.csv")));
        close(
            col(&c, "cmd_linear_m_s"),
            &[0.0, 0.3, 0.6, 0.9, 1.2],
            "TwistStamped at log time",
        );
    }
}

#[test]
fn malformed_bags_are_refused_naming_the_topic_or_record() {
    let dir = scratch("malformed");
    let refused = |bag: &Path, extra: &[&str], wanted: &[&str]| {
        let out = dir.join("out");
        let o = import(bag, &out, extra);
        let t = text(&o);
        assert!(!o.status.success(), "{} was accepted: {t}", bag.display());
        // A bag to mend is the user's input: status 2, as a bad scene or recording.
        assert_eq!(o.status.code(), Some(2), "{t}");
        assert!(!t.contains("panicked"), "{t}");
        for w in wanted {
            assert!(t.contains(w), "wanted `{w}` in: {t}");
        }
        assert!(!out.join("types_mcap.csv").exists(), "half-written output");
    };
    for storage in ["mcap", "sqlite3"] {
        // Several command topics: the map must choose.
        refused(
            &fixture(&format!("types_{storage}")),
            &[],
            &["/cmd_vel", "/cmd_vel_stamped", "--map"],
        );
        // /cmd_vel of a type that is not a command.
        refused(
            &fixture(&format!("unknown_type_{storage}")),
            &[],
            &["no velocity command topic", "/cmd_vel (std_msgs/msg/String"],
        );
        let map = dir.join("map.toml");
        std::fs::write(&map, "cmd_vel = \"/cmd_vel\"\n").unwrap();
        refused(
            &fixture(&format!("unknown_type_{storage}")),
            &["--map", map.to_str().unwrap()],
            &["topic `/cmd_vel` is `std_msgs/msg/String`"],
        );
        // A command topic with no messages.
        refused(
            &fixture(&format!("empty_topic_{storage}")),
            &[],
            &["topic `/cmd_vel`", "no messages"],
        );
    }
    // A folder without its metadata.yaml.
    let bare = dir.join("bare");
    std::fs::create_dir_all(&bare).unwrap();
    std::fs::copy(
        fixture("types_mcap/types_mcap.mcap"),
        bare.join("types_mcap.mcap"),
    )
    .unwrap();
    refused(&bare, &[], &["no metadata.yaml"]);
    // A truncated MCAP file, alone and in its folder.
    let bytes = std::fs::read(fixture("types_mcap/types_mcap.mcap")).unwrap();
    let cut = dir.join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
    refused(
        &cut,
        &[],
        &["cut.mcap", ": record ", "truncated or damaged"],
    );
    let folder = dir.join("cut_folder");
    std::fs::create_dir_all(&folder).unwrap();
    std::fs::copy(
        fixture("types_mcap/metadata.yaml"),
        folder.join("metadata.yaml"),
    )
    .unwrap();
    std::fs::write(folder.join("types_mcap.mcap"), &bytes[..bytes.len() / 2]).unwrap();
    refused(&folder, &[], &["types_mcap.mcap"]);
    // Not a bag at all.
    let junk = dir.join("junk.db3");
    std::fs::write(&junk, b"not sqlite").unwrap();
    refused(&junk, &[], &["junk.db3"]);
}

/// Writes `text` as a topic map in `dir`, returning its path as an argument.
fn map_file(dir: &Path, text: &str) -> String {
    let map = dir.join("map.toml");
    std::fs::write(&map, text).unwrap();
    map.to_str().unwrap().to_string()
}

/// ROS 1 bags (tools/ros2_bags.py `shapes`: rosbags' ROS 1 writer, the `fixtures` messages in
/// ROS 1's serialisation with its `Header.seq`), uncompressed and in bz2 and lz4 chunks.
#[test]
fn ros1_bags_decode_to_the_same_values_in_every_compression() {
    for compression in ["none", "bz2", "lz4"] {
        let dir = scratch(&format!("ros1_{compression}"));
        let bag = fixture(&format!("ros1_{compression}.bag"));
        let map = map_file(&dir, "cmd_vel = \"/cmd_vel\"\n");
        let o = import(&bag, &dir, &["--map", &map]);
        assert!(o.status.success(), "{compression}: {}", text(&o));
        assert!(text(&o).contains("ROS 1 bag"), "{}", text(&o));
        let stem = format!("ros1_{compression}");
        every_type_values(&columns(&dir.join(format!("{stem}.csv"))));
        let scene = std::fs::read_to_string(dir.join(format!("{stem}.scene.toml"))).unwrap();
        assert!(scene.contains("track_width_m = 0.42"), "{scene}");
        // Header stamps (after ROS 1's seq) place the stamped commands 1 ms late.
        let map = map_file(&dir, "cmd_vel = \"/cmd_vel_stamped\"\n");
        let o = agvsim(&[
            "import",
            "ros1",
            bag.to_str().unwrap(),
            "--out",
            dir.to_str().unwrap(),
            "--map",
            &map,
        ]);
        assert!(o.status.success(), "{}", text(&o));
        let c = columns(&dir.join(format!("{stem}.csv")));
        close(
            col(&c, "cmd_linear_m_s"),
            &[0.0, 0.3, 0.6, 0.9],
            "TwistStamped linear.x",
        );
    }
    // A bag cut short names the byte where it ends; a .bag that is not one says what a
    // ROS 1 bag starts with.
    let dir = scratch("ros1_bad");
    let whole = std::fs::read(fixture("ros1_none.bag")).unwrap();
    let cut = dir.join("cut.bag");
    std::fs::write(&cut, &whole[..whole.len() / 2]).unwrap();
    let o = import(&cut, &dir, &[]);
    assert!(!o.status.success());
    assert!(
        text(&o).contains("cut.bag") && text(&o).contains("cut short"),
        "{}",
        text(&o)
    );
    let not = dir.join("not.bag");
    std::fs::write(&not, "hello, world\n").unwrap();
    let o = import(&not, &dir, &[]);
    assert!(!o.status.success());
    assert!(
        text(&o).contains("not.bag") && text(&o).contains("#ROSBAG V2.0"),
        "{}",
        text(&o)
    );
}

/// A bag with commands and poses only (no wheels): rows at the chosen pose's rate.
#[test]
fn a_bag_of_commands_and_a_pose_gives_rows_at_the_pose_rate() {
    let bag = fixture("pose_only_mcap");
    let dir = scratch("pose_only");
    // Two pose topics: refused, naming both.
    let o = import(&bag, &dir, &[]);
    assert!(!o.status.success());
    let t = text(&o);
    assert!(
        t.contains("several pose topics") && t.contains("/amcl_pose") && t.contains("/mocap/pose"),
        "{t}"
    );
    let k: Vec<f64> = (0..5).map(f64::from).collect();
    let of = |f: &dyn Fn(f64) -> f64| k.iter().map(|&k| f(k)).collect::<Vec<f64>>();
    for (topic, x, y, yaw) in [
        (
            "/mocap/pose",
            of(&|k| 1.0 + 0.1 * k),
            of(&|k| -0.2 * k),
            of(&|k| 0.1 * k),
        ),
        (
            "/amcl_pose",
            of(&|k| 5.0 + k),
            of(&|k| k),
            of(&|k| -0.2 * k),
        ),
    ] {
        let map = map_file(&dir, &format!("pose = \"{topic}\"\n"));
        let o = import(&bag, &dir, &["--map", &map]);
        assert!(o.status.success(), "{}", text(&o));
        let c = columns(&dir.join("pose_only_mcap.csv"));
        close(
            col(&c, "t_s"),
            &of(&|k| 0.02 * k),
            "rows at the pose's stamps",
        );
        close(col(&c, "x_m"), &x, topic);
        close(col(&c, "y_m"), &y, topic);
        close(col(&c, "heading_rad"), &yaw, topic);
        close(col(&c, "cmd_angular_rad_s"), &of(&|k| 0.1 * k), "Twist");
        assert!(
            c.iter().all(|(n, _)| n != "left_wheel_speed_m_s"),
            "no wheels, no wheel speeds"
        );
        let head = std::fs::read_to_string(dir.join("pose_only_mcap.csv")).unwrap();
        assert!(
            head.contains(&format!("{topic} (geometry_msgs/msg/Pose")),
            "{head}"
        );
    }
}

/// A bag with commands and odometry only (no joint states): the odometry's twist becomes
/// the wheels' rim speeds through the track, and /tf chains are composed to the base.
#[test]
fn odometry_gives_the_wheel_speeds_and_tf_chains_compose() {
    let bag = fixture("odom_tf_mcap");
    let dir = scratch("odom_tf");
    let track = ["--track-m", "0.4", "--wheel-radius-m", "0.05"];
    // Two chains from root frames (the localiser's and the motion capture's): refused.
    let o = import(&bag, &dir, &track);
    assert!(!o.status.success());
    let t = text(&o);
    assert!(
        t.contains("map -> odom -> base_link") && t.contains("world -> mocap -> base_link"),
        "{t}"
    );
    let k: Vec<f64> = (0..5).map(f64::from).collect();
    let of = |f: &dyn Fn(f64) -> f64| k.iter().map(|&k| f(k)).collect::<Vec<f64>>();
    let map = map_file(&dir, "pose = \"world:base_link\"\n");
    let mut args = track.to_vec();
    args.extend(["--map", &map]);
    let o = import(&bag, &dir, &args);
    assert!(o.status.success(), "{}", text(&o));
    let c = columns(&dir.join("odom_tf_mcap.csv"));
    close(
        col(&c, "t_s"),
        &of(&|k| 0.02 * k),
        "rows at the odometry's stamps",
    );
    // v -/+ w track/2, with v = 0.5 + 0.1k, w = 0.2k, track 0.4 m.
    close(
        col(&c, "left_wheel_speed_m_s"),
        &of(&|k| 0.5 + 0.1 * k - 0.04 * k),
        "left rim",
    );
    close(
        col(&c, "right_wheel_speed_m_s"),
        &of(&|k| 0.5 + 0.1 * k + 0.04 * k),
        "right rim",
    );
    // world -> mocap (0.5, -0.5, 0) then mocap -> base_link (0.1k + 0.01, 0.05k, 0.02k).
    close(col(&c, "x_m"), &of(&|k| 0.51 + 0.1 * k), "composed x");
    close(col(&c, "y_m"), &of(&|k| -0.5 + 0.05 * k), "composed y");
    close(
        col(&c, "heading_rad"),
        &of(&|k| 0.02 * k),
        "composed heading",
    );
    // map -> odom, turned a quarter: x = X - y_odom, y = 1 + x_odom, with X the nearest
    // correction (2 at k = 0, 1; 2.1 from k = 2, nearer the one at k = 3).
    let map = map_file(&dir, "pose = \"map:base_link\"\n");
    let mut args = track.to_vec();
    args.extend(["--map", &map]);
    let o = import(&bag, &dir, &args);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("localiser"), "{}", text(&o));
    let c = columns(&dir.join("odom_tf_mcap.csv"));
    let corr = [2.0, 2.0, 2.1, 2.1, 2.1];
    close(
        col(&c, "x_m"),
        &of(&|k| corr[k as usize] - 0.05 * k),
        "map x",
    );
    close(col(&c, "y_m"), &of(&|k| 1.0 + 0.1 * k), "map y");
    close(
        col(&c, "heading_rad"),
        &of(&|k| std::f64::consts::FRAC_PI_2 + 0.02 * k),
        "map heading",
    );
    // A nav_msgs/Odometry topic named as the pose (what VRPN, OptiTrack and Vicon bridges
    // publish) gives its pose.pose.
    let map = map_file(&dir, "pose = \"/odom\"\n");
    let mut args = track.to_vec();
    args.extend(["--map", &map]);
    let o = import(&bag, &dir, &args);
    assert!(o.status.success(), "{}", text(&o));
    let c = columns(&dir.join("odom_tf_mcap.csv"));
    close(col(&c, "x_m"), &of(&|k| 0.1 * k), "odometry pose x");
    close(col(&c, "y_m"), &of(&|k| 0.05 * k), "odometry pose y");
    close(
        col(&c, "heading_rad"),
        &of(&|k| 0.02 * k),
        "odometry pose heading",
    );
    let head = std::fs::read_to_string(dir.join("odom_tf_mcap.csv")).unwrap();
    assert!(
        head.contains("/odom (nav_msgs/msg/Odometry pose.pose"),
        "{head}"
    );
}

/// Runs `tools/ros2_bags.py` (needs `python3 -m pip install rosbags`, which `.ci/run` does).
fn write_bag(recording: &Path, bag: &Path, extra: &[&str]) {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/ros2_bags.py");
    let o = Command::new("python3")
        .arg(script)
        .args([
            "from-recording",
            recording.to_str().unwrap(),
            bag.to_str().unwrap(),
        ])
        .args(["--wheel-radius-m", "0.075", "--track-m", "0.5", "--noise"])
        .args(extra)
        .output()
        .expect("python3 runs");
    assert!(
        o.status.success(),
        "tools/ros2_bags.py failed (is `rosbags` installed? python3 -m pip install rosbags): {}",
        text(&o)
    );
}

/// A command sequence: steps of forward speed and yaw rate every second, from rest.
fn commands(path: &Path) {
    let mut s = String::from("# agvsim-recording: 1\n# rig: vehicle\nt_s,cmd_linear_m_s,cmd_angular_rad_s,left_wheel_speed_m_s,right_wheel_speed_m_s,yaw_rate_rad_s\n");
    let v = [0.0, 0.4, 0.6, 0.2, -0.3, 0.0, 0.5, -0.2, 0.3, 0.0];
    let w = [0.0, 0.0, 0.6, -0.4, 0.8, -0.8, 0.0, 0.4, -0.6, 0.0];
    for k in 0..1000 {
        let i = k / 100;
        s.push_str(&format!("{},{},{},0,0,0\n", k as f64 * 0.01, v[i], w[i]));
    }
    std::fs::write(path, s).unwrap();
}

/// The simulator's machine on the commands, written as a bag by rosbags, imported: the
/// scene from the bag's description, the truth's run as its recording.
fn truth_bag(dir: &Path, truth_sets: &[&str], storage: &str) -> (PathBuf, PathBuf) {
    let cmd = dir.join("cmd.csv");
    commands(&cmd);
    // The robot's scene: the import's own, from a first bag of the same robot.
    let first = dir.join("first");
    write_bag(&cmd, &first, &[]);
    let o = import(&first, &dir.join("imp0"), &["--mass-kg", "120"]);
    assert!(o.status.success(), "{}", text(&o));
    let scene = dir.join("imp0/first.scene.toml");
    let mut args = vec![
        "replay",
        "--scene",
        scene.to_str().unwrap(),
        "--recording",
        cmd.to_str().unwrap(),
    ];
    let truth = dir.join("truth");
    args.extend(["--out", truth.to_str().unwrap()]);
    for s in truth_sets {
        args.extend(["--set", s]);
    }
    let o = agvsim(&args);
    assert!(o.status.success(), "{}", text(&o));
    let bag = dir.join("robot");
    write_bag(&truth.join("cmd.replay.csv"), &bag, &["--storage", storage]);
    let o = import(&bag, &dir.join("imp"), &["--mass-kg", "120"]);
    assert!(o.status.success(), "{}", text(&o));
    (dir.join("imp/robot.scene.toml"), dir.join("imp/robot.csv"))
}

fn calibrated(o: &Output, key: &str) -> f64 {
    let t = text(o);
    let line = t
        .lines()
        .find(|l| l.starts_with(key))
        .unwrap_or_else(|| panic!("no {key} in {t}"));
    // `KEY  UNIT  SCENE  CALIBRATED ± STD`: the calibrated value stands before the `±`
    // (a unit may be several words).
    let before_pm = line.split(" ± ").next().unwrap();
    before_pm
        .split_whitespace()
        .last()
        .unwrap()
        .parse()
        .unwrap()
}

#[test]
fn a_velocity_commanded_robot_calibrates_back_from_its_bag() {
    let dir = scratch("round_trip");
    let (scene, rec) = truth_bag(
        &dir,
        &["base.speed_kp_V_s_rad=0.3", "base.speed_ki_V_rad=3"],
        "mcap",
    );
    let o = agvsim(&[
        "calibrate",
        "--scene",
        scene.to_str().unwrap(),
        "--recording",
        rec.to_str().unwrap(),
        "--free",
        "chassis.mass_kg,base.speed_kp_V_s_rad,base.speed_ki_V_rad",
        "--effects",
        "none",
        // 15 % off the truth in every key.
        "--set",
        "chassis.mass_kg=138",
        "--set",
        "base.speed_kp_V_s_rad=0.345",
        "--set",
        "base.speed_ki_V_rad=3.45",
    ]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    for (key, truth) in [
        ("chassis.mass_kg", 120.0),
        ("base.speed_kp_V_s_rad", 0.3),
        ("base.speed_ki_V_rad", 3.0),
    ] {
        let v = calibrated(&o, key);
        assert!(
            (v / truth - 1.0).abs() < 0.05,
            "{key}: {v} against {truth}\n{t}"
        );
    }
    let mean = t.lines().find(|l| l.starts_with("mean")).unwrap();
    let fits: Vec<f64> = mean
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    assert!(
        fits[1] > fits[0] + 1.0,
        "the replay fit did not rise: {mean}"
    );
}

/// Wheel slip on a low-friction floor, the IMU's yaw rate the output the wheels cannot
/// explain: `diagnose --scene` (through the simulator, as the fitting models take no
/// velocity commands) names it in the contract's JSON, its friction near the truth's, and
/// does not take castor drag, the other floor effect, for it.
#[test]
fn slip_on_a_slippery_floor_is_diagnosed_from_the_bag() {
    let dir = scratch("slip");
    let (scene, rec) = truth_bag(&dir, &["tyre.peak_mu=0.12"], "sqlite3");
    let json = dir.join("diagnosis.json");
    let o = agvsim(&[
        "diagnose",
        "--scene",
        scene.to_str().unwrap(),
        "--recording",
        rec.to_str().unwrap(),
        "--effects",
        "wheel_slip,castor_drag",
        "--json",
        json.to_str().unwrap(),
    ]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let d: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let effects = d["effects"].as_array().unwrap();
    assert_eq!(effects.len(), 1, "{d:#}");
    assert_eq!(effects[0]["name"], "wheel_slip", "{d:#}");
    let mu = effects[0]["params"]["peak_mu"].as_f64().unwrap();
    assert!((mu / 0.12 - 1.0).abs() < 0.05, "peak_mu {mu}\n{t}");
    let (base, fin) = (
        d["baseline"]["fit_pct"].as_f64().unwrap(),
        d["final"]["fit_pct"].as_f64().unwrap(),
    );
    assert!(fin > base + 20.0, "{base} -> {fin}");
    // Said as `diagnose --rig` says it: a Found line with the value, then the fit from the
    // baseline (the scene's keys fitted, no effect), the JSON's numbers.
    assert!(t.contains("Found: wheel_slip — "), "{t}");
    assert!(
        t.contains(&format!(
            "fit        {base:.1} % (baseline: the scene's keys fitted, no effect) -> {fin:.1} % diagnosed"
        )),
        "{t}"
    );
    assert!(
        d["baseline"]["fit_pct_per_output"]
            .as_object()
            .unwrap()
            .len()
            >= 2,
        "{d:#}"
    );
}

/// The data rows of an imported recording (its comment lines left out).
fn data_rows(csv: &Path) -> String {
    std::fs::read_to_string(csv)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Header stamps on clocks that disagree with the log times (commands on a simulation
/// clock, a 5 s skew, a jump back an hour, one stamp in 2038): each bag is imported at
/// its log times with a note saying why, its rows those of the same robot stamped on one
/// clock; a map asking for header stamps is refused naming the topic. Half a stream
/// unstamped beside stamps on the log clock loses no row.
#[test]
fn stamps_on_clocks_that_disagree_are_found_and_log_times_used() {
    let dir = scratch("clocks");
    let cmd = dir.join("cmd.csv");
    commands(&cmd);
    let clean = dir.join("clean");
    write_bag(&cmd, &clean, &[]);
    let args = ["--wheel-radius-m", "0.075", "--track-m", "0.5"];
    let o = import(&clean, &dir.join("clean_out"), &args);
    assert!(o.status.success(), "{}", text(&o));
    assert!(!text(&o).contains("header stamps not used"), "{}", text(&o));
    let expected = data_rows(&dir.join("clean_out/clean.csv"));
    let header_map = dir.join("header.toml");
    std::fs::write(&header_map, "time = \"header\"\n").unwrap();
    for (kind, topic) in [
        ("sim-cmd", "/cmd_vel"),
        ("skew-cmd", "/cmd_vel"),
        ("jump-back", "/battery"),
        ("y2038", "/joint_states"),
    ] {
        let bag = dir.join(kind);
        write_bag(&cmd, &bag, &["--clock", kind]);
        let out = dir.join(format!("{kind}_out"));
        let o = import(&bag, &out, &args);
        let t = text(&o);
        assert!(o.status.success(), "{kind}: {t}");
        assert!(t.contains("header stamps not used"), "{kind}: {t}");
        assert!(t.contains(&format!("`{topic}`")), "{kind}: {t}");
        assert_eq!(
            data_rows(&out.join(format!("{kind}.csv"))),
            expected,
            "{kind}: the rows differ from the same robot's on one clock"
        );
        let mut with_map = args.to_vec();
        with_map.extend(["--map", header_map.to_str().unwrap()]);
        let o = import(&bag, &dir.join(format!("{kind}_header")), &with_map);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{kind}: {t}");
        assert!(t.contains("asks for header stamps"), "{t}");
        assert!(t.contains(&format!("`{topic}`")), "{kind}: {t}");
    }
    let bag = dir.join("half-unstamped");
    write_bag(&cmd, &bag, &["--clock", "half-unstamped"]);
    let o = import(&bag, &dir.join("half_out"), &args);
    assert!(o.status.success(), "{}", text(&o));
    assert!(!text(&o).contains("header stamps not used"), "{}", text(&o));
    assert_eq!(
        data_rows(&dir.join("half_out/half-unstamped.csv")),
        expected
    );
}

/// Joint states that do not give the wheels' speeds (joints named differently from the
/// URDF's, a velocity array shorter than `name`, positions only, NaN speeds): refused,
/// naming the topic and the joint, never imported without wheel columns.
#[test]
fn joint_states_without_the_wheels_speeds_are_refused_naming_the_joint() {
    let dir = scratch("joints");
    let cmd = dir.join("cmd.csv");
    commands(&cmd);
    let args = ["--wheel-radius-m", "0.075", "--track-m", "0.5"];
    for (kind, says) in [
        (
            "renamed",
            &[
                "no joint named `left_wheel_joint`",
                "`wheel_l`, `wheel_r`",
                "--map left_wheel_joint",
            ][..],
        ),
        (
            "short-velocity",
            &[
                "joint `right_wheel_joint` (the right wheel) gives no speed",
                "shorter than `name`",
            ],
        ),
        (
            "position-only",
            &["joint `left_wheel_joint`", "positions only"],
        ),
        ("nan", &["joint `left_wheel_joint`", "NaN"]),
    ] {
        let bag = dir.join(kind);
        write_bag(&cmd, &bag, &["--joints", kind]);
        let o = import(&bag, &dir.join(format!("{kind}_out")), &args);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{kind}: {t}");
        assert!(t.contains("topic `/joint_states`"), "{kind}: {t}");
        for s in says {
            assert!(t.contains(s), "{kind}: expected `{s}` in: {t}");
        }
    }
}

/// A battery topic in millivolts and a URDF wheel of infinite radius: the warning names
/// the topic, the error the robot description, neither an option never given.
#[test]
fn numbers_from_a_bag_are_named_by_the_topic_they_came_from() {
    let dir = scratch("absurd");
    let cmd = dir.join("cmd.csv");
    commands(&cmd);
    let mv = dir.join("millivolts");
    write_bag(&cmd, &mv, &["--battery-v", "24000"]);
    let o = import(&mv, &dir.join("mv_out"), &["--mass-kg", "120"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("warning: the median voltage of /battery ("),
        "{t}"
    );
    assert!(t.contains("`battery.open_circuit_V` = 24000 V"), "{t}");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/ros2_bags.py");
    let inf = dir.join("infinite");
    let o = Command::new("python3")
        .arg(script)
        .args([
            "from-recording",
            cmd.to_str().unwrap(),
            inf.to_str().unwrap(),
        ])
        .args(["--wheel-radius-m", "inf", "--track-m", "0.5"])
        .output()
        .expect("python3 runs");
    assert!(o.status.success(), "{}", text(&o));
    let o = import(&inf, &dir.join("inf_out"), &[]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains("wheel radius inf from /robot_description: joint `left_wheel_joint`"),
        "{t}"
    );
    assert!(!t.contains("--track-m") && !t.contains(".csv:"), "{t}");
    assert!(!dir.join("inf_out").exists());
}

/// The shipped example bag holds what drove the robot it was made from
/// (data/ros2_example/README.md): imported as docs/ros2.md imports it, that robot (its
/// right wheel 1 % small, its track 2 % wide) replays the wheel speeds to the noise the
/// bag's encoders were given (0.05 rad/s at a 0.08 m wheel: 0.004 m/s) and the pose to a
/// millimetre. A bag whose commands reached the robot a row before it says (the example's
/// earlier make) left 0.008 m/s.
#[test]
fn the_example_bag_replays_to_its_noise_on_the_robot_it_was_made_from() {
    let dir = scratch("example_bag");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/ros2_example");
    let o = import(&root.join("robot_square"), &dir, &common::EXAMPLE_BAG_ROBOT);
    assert!(o.status.success(), "{}", text(&o));
    let out = dir.join("replayed");
    let o = agvsim(&[
        "replay",
        "--scene",
        dir.join("robot_square.scene.toml").to_str().unwrap(),
        "--recording",
        dir.join("robot_square.csv").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--set",
        "wheel.right_rolling_radius_m=0.0792",
        "--set",
        "chassis.track_width_m=0.408",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let measured = columns(&dir.join("robot_square.csv"));
    let simulated = columns(&out.join("robot_square.replay.csv"));
    let rms = |name: &str| {
        let (m, s) = (col(&measured, name), col(&simulated, name));
        let d: Vec<f64> = m
            .iter()
            .zip(s)
            .filter(|(a, b)| a.is_finite() && b.is_finite())
            .map(|(a, b)| a - b)
            .collect();
        (d.iter().map(|v| v * v).sum::<f64>() / d.len() as f64).sqrt()
    };
    for side in ["left", "right"] {
        let r = rms(&format!("{side}_wheel_speed_m_s"));
        // The noise's RMS over 1200 rows is known to about 2 %; 10 % leaves room for the
        // solver's own rounding, not for a row's timing (which doubles it).
        assert!(r < 0.0044, "{side} wheel speed RMS {r} m/s");
    }
    for name in ["x_m", "y_m"] {
        assert!(rms(name) < 1e-3, "{name} RMS {} m", rms(name));
    }
}

/// Bags that lie about their topics (tools/ros2_bags.py `hostile`, rosbags' writers): a
/// topic published under two types is refused naming both with their counts (its second
/// type's messages would decode as the first's: a TwistStamped read as a Twist gives
/// zeros), from a ROS 1 bag and from MCAP; a bag of 1.1 million empty messages, 13 MB of
/// bz2, is refused by what its messages cost to keep (512 bytes of bookkeeping each beside
/// their bytes: past 512 MiB at about a million), inside an address space of 1 GiB.
#[test]
fn bags_that_lie_about_their_topics_are_refused_naming_what_they_hold() {
    let dir = scratch("hostile_bags");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/ros2_bags.py");
    let o = Command::new("python3")
        .arg(script)
        .args(["hostile", dir.to_str().unwrap()])
        .output()
        .expect("python3 runs");
    assert!(o.status.success(), "{}", text(&o));
    let geometry = [
        "--mass-kg",
        "4",
        "--wheel-radius-m",
        "0.05",
        "--track-m",
        "0.3",
    ];
    for bag in ["two_types.bag", "two_types_mcap"] {
        let out = dir.join(format!("{bag}_out"));
        let o = import(&dir.join(bag), &out, &geometry);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{t}");
        assert!(
            t.contains("topic `/cmd_vel` is published under more than one type: geometry_msgs/msg/Twist (80 messages) and geometry_msgs/msg/TwistStamped (20 messages)"),
            "{bag}: {t}"
        );
        assert!(!out.exists(), "{bag}");
    }
    let out = dir.join("tiny_out");
    let bag = dir.join("tiny_messages.bag");
    let mut args = vec![
        "import".to_string(),
        "ros2".into(),
        bag.display().to_string(),
        "--out".into(),
        out.display().to_string(),
    ];
    args.extend(geometry.iter().map(|s| s.to_string()));
    let o = Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 1048576; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_agvsim"))
        .args(&args)
        .output()
        .expect("sh runs");
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains("tiny_messages.bag: its messages cost more than 512 MiB to keep"),
        "{t}"
    );
    assert!(!out.exists());
}

/// A bag without `/robot_description` takes the wheel radius and separation from
/// `--controller-yaml` (docs/ros2.md names it as a source), each column saying so; a
/// broken controller file is named as such, not as a missing radius. A description behind
/// a DTD is refused with that reason named, not as a bag without one.
#[test]
fn the_controller_file_gives_the_geometry_a_bag_does_not_describe() {
    let dir = scratch("controller_geometry");
    let cmd = dir.join("cmd.csv");
    commands(&cmd);
    let bag = dir.join("nodesc");
    write_bag(&cmd, &bag, &["--description", "none"]);
    let yaml = dir.join("controller.yaml");
    std::fs::write(
        &yaml,
        "diff_drive:\n  ros__parameters:\n    wheel_separation: 0.5\n    wheel_radius: 0.075\n",
    )
    .unwrap();
    let out = dir.join("out");
    let o = import(
        &bag,
        &out,
        &[
            "--controller-yaml",
            yaml.to_str().unwrap(),
            "--mass-kg",
            "40",
        ],
    );
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let csv = std::fs::read_to_string(out.join("nodesc.csv")).unwrap();
    assert!(
        csv.contains("times the wheel radius 0.075 m (wheel_radius in ")
            && csv.contains("controller.yaml (--controller-yaml))"),
        "{}",
        &csv[..2000.min(csv.len())]
    );
    let scene = std::fs::read_to_string(out.join("nodesc.scene.toml")).unwrap();
    assert!(scene.contains("track_width_m = 0.5"), "{scene}");
    std::fs::write(&yaml, "diff_drive: [unclosed\n").unwrap();
    let o = import(
        &bag,
        &dir.join("broken"),
        &["--controller-yaml", yaml.to_str().unwrap()],
    );
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains("controller.yaml") && t.contains("not YAML"),
        "{t}"
    );
    assert!(!t.contains("give --wheel-radius-m"), "{t}");
    let dtd = dir.join("dtd");
    write_bag(&cmd, &dtd, &["--description", "dtd"]);
    let o = import(&dtd, &dir.join("dtd_out"), &[]);
    let t = text(&o);
    assert!(t.contains("declares a DTD"), "{t}");
}

/// The example bag on the robot it was made from (its geometry set as the bag's README
/// states it): calibrate's intervals on the mass, the yaw inertia and the speed loop's gains
/// hold the robot's values (within 3 standard deviations), and the mass is reported as the
/// recording determines it, to kilograms: its commands are ramped by the base's
/// acceleration limits, and 2.8 kg less mass moves the wheel speeds by a hundredth of the
/// encoders' noise. A fitting model whose step changed with the mass reported it as 37.2 ±
/// 0.05 kg (`tests/one_physics.rs`, the reduced base held at a fit's start). A key off
/// by more than 10 % is said to be loosely determined.
#[test]
fn the_example_bags_intervals_hold_the_robot_it_was_made_from() {
    let dir = scratch("example_bag_intervals");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/ros2_example");
    let o = import(&root.join("robot_square"), &dir, &common::EXAMPLE_BAG_ROBOT);
    assert!(o.status.success(), "{}", text(&o));
    let json = dir.join("calibrated.json");
    let o = agvsim(&[
        "calibrate",
        "--scene",
        dir.join("robot_square.scene.toml").to_str().unwrap(),
        "--recording",
        dir.join("robot_square.csv").to_str().unwrap(),
        "--effects",
        "none",
        "--set",
        "wheel.right_rolling_radius_m=0.0792",
        "--set",
        "chassis.track_width_m=0.408",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let robot = [
        ("chassis.mass_kg", 40.0),
        ("chassis.yaw_inertia_kg_m2", 3.035),
        ("base.speed_kp_V_s_rad", 0.6063),
        ("base.speed_ki_V_rad", 4.85),
    ];
    for (key, truth) in robot {
        let k = j["keys"]
            .as_array()
            .unwrap()
            .iter()
            .find(|k| k["key"] == key)
            .unwrap_or_else(|| panic!("{key} not in {}", j["keys"]));
        if k["estimate"] != true {
            continue;
        }
        let (v, sd) = (
            k["calibrated"].as_f64().unwrap(),
            k["std"].as_f64().unwrap(),
        );
        assert!(
            (v - truth).abs() < 3.0 * sd,
            "{key}: {v} ± {sd} for the robot's {truth}"
        );
        // Within 10 % of the robot, or said to be loosely determined (issue 55).
        assert!(
            (v - truth).abs() < 0.1 * truth || k["loosely_determined"] == true,
            "{key}: {v} ± {sd} for the robot's {truth}, not said to be loosely determined"
        );
        if key == "chassis.mass_kg" {
            assert!(sd > 1.0, "the mass reported to {sd} kg");
        }
    }
}

/// A robot imported with nothing but its bag gets a drive of its own size, said on the
/// console: the thesis machine's motor and gear sized for it (its top speed at the wheel,
/// 24 V / 0.063 V s/rad / 23.41 x 0.075 m = 1.22 m/s, and both motors at stall pushing
/// 2.29 times the weight), which `check` finds plausible; a gear given keeps that top
/// speed through the motor instead.
#[test]
fn a_robot_imported_without_its_drive_gets_one_sized_for_it_and_said() {
    let dir = scratch("sized_drive");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/ros2_example");
    for (out, extra) in [("bare", &[][..]), ("geared", &["--gear-ratio", "20"][..])] {
        let o = import(&root.join("robot_square"), &dir.join(out), extra);
        let t = text(&o);
        assert!(o.status.success(), "{t}");
        assert!(
            t.contains("sized as the thesis machine's for it: a top speed of 1.22 m/s at the wheel, both motors at stall pushing 2.29 times its weight"),
            "{t}"
        );
        // The example robot's wheels are 0.08 m: 23.41 x 0.08 / 0.075 = 24.97.
        assert_eq!(
            t.contains("guessed    gear ratio 25, sized for the thesis machine's top speed of 1.22 m/s on the 0.08 m wheel"),
            extra.is_empty(),
            "{t}"
        );
        let scene = dir.join(out).join("robot_square.scene.toml");
        let o = agvsim(&["check", scene.to_str().unwrap()]);
        let c = text(&o);
        assert!(o.status.success(), "{c}");
        assert!(
            c.contains("top speed 1.2 m/s") && c.contains("no plausibility warnings"),
            "{c}"
        );
    }
}
