//! The second reliability campaign's classes, one test each: a value that used to panic
//! now stops with an error that says the run diverged and names the likely key; a run
//! asked for days stops before it starts; inputs the replay changes are said; a second
//! writer of an output folder is refused and a stopped run leaves no file under its
//! final name; and evidence given twice is refused.

mod common;
use common::{hold_lock, text, tmp};

use std::path::Path;
use std::process::{Command, Stdio};

fn agvsim() -> Command {
    Command::new(env!("CARGO_BIN_EXE_agvsim"))
}

/// Panic class: an infinite DCMC gain used to panic in the DCMC's limiter.
#[test]
fn a_gain_that_runs_the_drive_away_stops_with_an_error_naming_it() {
    let dir = tmp("gain");
    let o = agvsim()
        .args([
            "run",
            "scenes/lab_offset_120mm.toml",
            "--set",
            "dcmc.forward_gain_V_pct=1e308",
            "--duration",
            "2",
            "--out",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(
        t.contains("diverged") && t.contains("dcmc.forward_gain_V_pct = 1e308"),
        "{t}"
    );
    assert!(!t.contains("panicked"), "{t}");
    // Nothing left that looks like a recording.
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".csv") || n.ends_with(".partial"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

/// Hang class: an experiment asked for a billion seconds is refused before it starts.
#[test]
fn an_experiment_beyond_the_step_budget_is_refused_up_front() {
    let dir = tmp("budget");
    let t0 = std::time::Instant::now();
    let o = agvsim()
        .args([
            "experiment",
            "lifted-random-demand",
            "scenes/lifted_identification.toml",
            "--duration",
            "1e9",
            "--out",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    let t = text(&o);
    assert_ne!(o.status.code(), Some(0), "{t}");
    assert!(
        t.contains("--duration 1e9") && t.contains("sim.max_steps"),
        "{t}"
    );
    // Refused, not worked on: well under the seconds a billion-second run would take.
    assert!(t0.elapsed().as_secs() < 20);
}

/// Silent class: a replay that clips inputs or faults the DCMC says so.
#[test]
fn a_replay_says_when_it_clipped_inputs_or_the_dcmc_faulted() {
    let dir = tmp("replay");
    // Voltages up to 14 V on a 12 V scene.
    let o = agvsim()
        .args([
            "replay",
            "--scene",
            "scenes/lab_offset_120mm.toml",
            "--recording",
            "data/calibrate_example/multisine_inputs.csv",
            "--set",
            "battery.open_circuit_V=12",
            "--set",
            "battery.drive_limit_V=11.75",
            "--set",
            "battery.low_voltage_fault_V=11",
            "--out",
        ])
        .arg(dir.join("clip"))
        .output()
        .unwrap();
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("exceed the scene's drive (battery.drive_limit_V = 11.75 V"),
        "{t}"
    );
    // A demand that starts 0.1 s into the recording, within the unit's enable delay.
    let rec = dir.join("late_demand.csv");
    let mut csv = String::from("# agvsim-recording: 1\n# rig: vehicle\nt_s,demand_fwd_pct,demand_turn_pct,left_motor_speed_rad_s\n");
    for k in 0..200 {
        let t = k as f64 * 0.01;
        csv.push_str(&format!("{t:.2},{},0,\n", if t >= 0.1 { 40 } else { 0 }));
    }
    std::fs::write(&rec, csv).unwrap();
    let o = agvsim()
        .args([
            "replay",
            "--scene",
            "scenes/lab_offset_120mm.toml",
            "--recording",
        ])
        .arg(&rec)
        .arg("--out")
        .arg(dir.join("late"))
        .output()
        .unwrap();
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("the DCMC faulted (enable_delay) at t = 0.1")
            && t.contains("dcmc.enable_delay_s"),
        "{t}"
    );
}

/// Lost-output class: a folder another live agvsim writes is refused, naming it; a run
/// stopped while saving its Rerun file leaves no `.rrd` under the final name.
#[test]
fn outputs_belong_to_one_process_and_a_stopped_run_claims_no_file() {
    let dir = tmp("lock");
    // Another writer holding the folder's lock as the kernel keeps it (util-linux
    // `flock`, an independent taker), with its owner's line in the file.
    let lock = dir.join(".agvsim.lock");
    std::fs::write(&lock, "process 4242 on another-host\n").unwrap();
    let mut other = hold_lock(&lock);
    let o = agvsim()
        .args([
            "run",
            "scenes/lab_offset_120mm.toml",
            "--duration",
            "0.5",
            "--out",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains("another agvsim (process 4242 on another-host) is writing there"),
        "{t}"
    );
    other.kill().unwrap();
    other.wait().unwrap();
    // The writer gone, the kernel has released its lock: the file it left names a
    // process that may run (another container's id) but holds no lock, and the run goes
    // ahead, leaving no lock.
    let o = agvsim()
        .args([
            "run",
            "scenes/lab_offset_120mm.toml",
            "--duration",
            "0.5",
            "--out",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert!(!dir.join(".agvsim.lock").exists());

    let rrd = dir.join("stopped.rrd");
    let mut run = agvsim()
        .args([
            "run",
            "scenes/lab_offset_120mm.toml",
            "--duration",
            "600",
            "--set",
            "sim.max_steps=1000000000",
            "--out",
        ])
        .arg(dir.join("long"))
        .arg("--save")
        .arg(&rrd)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let partial = dir.join("stopped.rrd.partial");
    let t0 = std::time::Instant::now();
    while !partial.exists() && t0.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    run.kill().unwrap();
    run.wait().unwrap();
    assert!(partial.exists(), "the run saved nowhere");
    assert!(
        !rrd.exists(),
        "a stopped run left a file under the final name"
    );
}

/// Silent class: the same test twice would halve its variance for nothing.
#[test]
fn evidence_given_twice_is_refused() {
    let rec = "../shared/data/dev/dev_axis_11.csv";
    let rig = "../shared/data/dev/dev_axis_11.rig.toml";
    let o = agvsim()
        .args([
            "diagnose",
            "--rig",
            rig,
            "--recording",
            rec,
            "--recording",
            rec,
        ])
        .output()
        .unwrap();
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(t.contains("given twice"), "{t}");
    let o = agvsim()
        .args([
            "identify",
            "--rig",
            rig,
            "--recording",
            rec,
            "--free",
            "motor.resistance_ohm,motor.resistance_ohm",
        ])
        .output()
        .unwrap();
    let t = text(&o);
    assert_ne!(o.status.code(), Some(0), "{t}");
    assert!(t.contains("`motor.resistance_ohm` is given twice"), "{t}");
    assert!(Path::new(rec).exists());
}

/// Memory class: a recording beyond the size cap is refused at once, not read whole.
#[test]
fn a_recording_beyond_the_size_cap_is_refused_before_it_is_read() {
    let dir = tmp("big");
    let big = dir.join("big.csv");
    let f = std::fs::File::create(&big).unwrap();
    // Sparse: 101 MB of nothing on disk.
    f.set_len(101 << 20).unwrap();
    let o = agvsim()
        .args([
            "diagnose",
            "--rig",
            "../shared/data/dev/dev_axis_11.rig.toml",
            "--recording",
        ])
        .arg(&big)
        .output()
        .unwrap();
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains("101 MB: recordings of at most 100 MB are read"),
        "{t}"
    );
}

/// Silent class: a header's sample time that the time column contradicts is refused.
#[test]
fn a_sample_time_the_time_column_contradicts_is_refused() {
    let dir = tmp("dt");
    let rec = dir.join("ms.csv");
    let mut csv = String::from("# agvsim-recording: 1\n# rig: drive_axis\n# sample_time_s: 0.001\nt_s,voltage_V,motor_speed_rad_s\n");
    for k in 0..50 {
        csv.push_str(&format!("{},{},\n", k as f64 * 0.01, 1.0));
    }
    std::fs::write(&rec, csv).unwrap();
    let e = agvsim::record::Recording::load(&rec)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("`sample_time_s: 0.001` but the time column's median interval is 0.01 s"),
        "{e}"
    );
}
