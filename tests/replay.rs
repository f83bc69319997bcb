//! `agvsim replay`: the simulator driven by a recording's inputs reproduces its own
//! recordings, and a machine that differs in its physics fits them worse.

mod common;
use common::tmp;

use std::path::Path;

use agvsim::record::Recording;
use agvsim::replay::{replay, Drive};
use agvsim::run::{run_scene, RunOptions};
use agvsim::scene::Scene;

fn lab(set: &[&str]) -> Scene {
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    Scene::load(Path::new("scenes/lab_offset_120mm.toml"), &set).unwrap()
}

/// A 12 s lab run of the full level under its firmware, recorded every 10 ms.
fn lab_recording(dir: &Path) -> Recording {
    let out = run_scene(
        &lab(&["sim.duration_s=12"]),
        &RunOptions {
            out_dir: dir.to_owned(),
            name: "lab".into(),
            manoeuvre: None,
        },
        None,
    )
    .unwrap();
    Recording::load(&out.recording).unwrap()
}

/// The same machine replaying its own run's voltages: the only difference is that the
/// replay holds each 10 ms voltage sample where the run's DCMC varied it within the
/// interval, so motor speeds and the pose agree to within a few percent; each change of
/// physics (heavier chassis, no gear play, another tyre) fits clearly worse.
#[test]
fn the_simulator_replays_its_own_recording_and_tells_other_physics_apart() {
    let rec = lab_recording(&tmp("own"));
    let same = replay(&lab(&[]), &rec).unwrap();
    assert_eq!(same.drive, Drive::Voltages);
    for name in [
        "left_motor_speed_rad_s",
        "right_motor_speed_rad_s",
        "x_m",
        "heading_rad",
    ] {
        let fit = same.output(name).unwrap().fit_pct;
        println!("same machine: {name} fit {fit:.1} %");
        assert!(fit > 95.0, "{name}: {fit}");
    }
    assert!(same.not_compared.contains(&"demand_fwd_pct".to_string()));
    for change in [
        "chassis.mass_kg=300",
        "gearbox.backlash_rad=0",
        "tyre.compound=soft_rubber",
    ] {
        let other = replay(&lab(&[change]), &rec).unwrap();
        println!(
            "{change}: mean fit {:.1} % against {:.1} %",
            other.mean_fit_pct(),
            same.mean_fit_pct()
        );
        assert!(
            other.mean_fit_pct() < same.mean_fit_pct() - 10.0,
            "{change}"
        );
    }
}

/// Without the voltage columns the demands drive the DCMC, and the voltages become
/// outputs to compare.
#[test]
fn demands_drive_the_dcmc_when_there_are_no_voltages() {
    let dir = tmp("demands");
    let rec = lab_recording(&dir);
    let text = std::fs::read_to_string(&rec.path).unwrap();
    let keep = |line: &str| {
        let cells: Vec<&str> = line.split(',').collect();
        // Drop columns 3 and 4 (left_/right_voltage_V) of every data line.
        cells
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != 3 && *i != 4)
            .map(|(_, c)| *c)
            .collect::<Vec<_>>()
            .join(",")
    };
    let header_idx = text.lines().position(|l| l.starts_with("t_s")).unwrap();
    assert!(text
        .lines()
        .nth(header_idx)
        .unwrap()
        .contains("left_voltage_V,right_voltage_V"));
    let edited: String = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i < header_idx {
                l.to_string()
            } else {
                keep(l)
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let path = dir.join("demands_only.csv");
    std::fs::write(&path, edited).unwrap();
    let r = replay(&lab(&[]), &Recording::load(&path).unwrap()).unwrap();
    assert_eq!(r.drive, Drive::Demands);
    let fit = r.output("left_motor_speed_rad_s").unwrap().fit_pct;
    println!("demand-driven replay: left motor speed fit {fit:.1} %");
    assert!(fit > 95.0, "{fit}");
}

/// A recording with nothing to drive the simulator with, or a single row, is refused
/// with the file and what was expected.
#[test]
fn recordings_a_replay_cannot_use_are_refused_clearly() {
    let dir = tmp("bad");
    let no_inputs = dir.join("no_inputs.csv");
    std::fs::write(
        &no_inputs,
        "# agvsim-recording: 1\n# rig: vehicle\nt_s,x_m,y_m\n0,0,0\n0.01,0.001,0\n",
    )
    .unwrap();
    let err = replay(&lab(&[]), &Recording::load(&no_inputs).unwrap())
        .unwrap_err()
        .to_string();
    println!("{err}");
    assert!(
        err.contains("no_inputs.csv") && err.contains("left_voltage_V and right_voltage_V"),
        "{err}"
    );
    let one_row = dir.join("one_row.csv");
    std::fs::write(
        &one_row,
        "# agvsim-recording: 1\n# rig: drive_axis\nt_s,voltage_V,motor_speed_rad_s\n0,1,0\n",
    )
    .unwrap();
    let err = replay(&lab(&[]), &Recording::load(&one_row).unwrap())
        .unwrap_err()
        .to_string();
    assert!(err.contains("too few samples"), "{err}");
    // A corrupt time column (found by tests/fuzz.rs) used to run the simulator for ever:
    // the reader refuses a time past 1e12 s, and a recording holding one all the same
    // (made in memory) is refused by the replay's own guard.
    let endless = dir.join("endless.csv");
    std::fs::write(
        &endless,
        "# agvsim-recording: 1\n# rig: drive_axis\nt_s,voltage_V,motor_speed_rad_s\n0,1,0\n99999999999999999999,1,0\n",
    )
    .unwrap();
    let refused = Recording::load(&endless).unwrap_err().to_string();
    assert!(
        refused.contains("endless.csv:5") && refused.contains("beyond any time"),
        "{refused}"
    );
    std::fs::write(
        &endless,
        "# agvsim-recording: 1\n# rig: drive_axis\nt_s,voltage_V,motor_speed_rad_s\n0,1,0\n1,1,0\n",
    )
    .unwrap();
    let mut held = Recording::load(&endless).unwrap();
    held.t_s[1] = 1e20;
    let err = replay(&lab(&[]), &held).unwrap_err().to_string();
    println!("{err}");
    assert!(
        err.contains("simulator steps") && err.contains("time column"),
        "{err}"
    );
}
