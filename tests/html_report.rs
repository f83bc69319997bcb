//! `--html FILE.html` of calibrate, diagnose and identify: one self-contained file (no
//! script, nothing fetched) whose numbers are the command's own (its JSON's), with the
//! plots inline and the command that made it.

mod common;
use common::tmp;

use std::path::Path;
use std::process::Command;

fn agvsim(args: &[&str]) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_agvsim"))
        .args(args)
        .output()
        .expect("agvsim runs");
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "agvsim {args:?}: {}{text}",
        String::from_utf8_lossy(&o.stderr)
    );
    text
}

fn dev(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/dev")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

/// Self-contained: one document, no script, nothing loaded from elsewhere (the only URL
/// is the SVG namespace), every figure inline.
fn assert_self_contained(html: &str, figures: usize) {
    assert!(html.starts_with("<!DOCTYPE html>") && html.trim_end().ends_with("</html>"));
    assert!(!html.contains("<script") && !html.contains("<link") && !html.contains("<img"));
    let urls = html.replace("http://www.w3.org/2000/svg", "");
    assert!(
        !urls.contains("http://") && !urls.contains("https://"),
        "a URL in the report"
    );
    assert_eq!(html.matches("<figure>").count(), figures, "figures");
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn a_calibration_report_has_its_keys_effects_fits_changes_and_command() {
    let dir = tmp("calibrate");
    let machine = dir.join("machine");
    agvsim(&[
        "replay",
        "--scene",
        "scenes/lab_offset_120mm.toml",
        "--recording",
        "data/calibrate_example/multisine_inputs.csv",
        "--out",
        machine.to_str().unwrap(),
        "--set",
        "gearbox.backlash_rad=0",
        "--set",
        "motor.coulomb_Nm=0.05",
    ]);
    let rec = machine.join("multisine_inputs.replay.csv");
    let (html, j) = (dir.join("report.html"), dir.join("c.json"));
    agvsim(&[
        "calibrate",
        "--scene",
        "scenes/lab_offset_120mm.toml",
        "--set",
        "gearbox.backlash_rad=0",
        "--set",
        "motor.coulomb_Nm=0",
        "--recording",
        rec.to_str().unwrap(),
        "--effects",
        "coulomb_friction,battery_sag",
        "--json",
        j.to_str().unwrap(),
        "--html",
        html.to_str().unwrap(),
    ]);
    let page = std::fs::read_to_string(&html).unwrap();
    let j = json(&j);
    // A figure per fitted output.
    assert_self_contained(&page, j["replay_fit"].as_object().unwrap().len());
    for section in [
        "The recording",
        "Fitted keys",
        "Effects tried",
        "Replay fit per output",
        "What the calibrated scene changes",
        "The report as printed",
        "The command",
    ] {
        assert!(page.contains(&format!("<h2>{section}</h2>")), "{section}");
    }
    // The effect accepted and the one refused, with their verdicts.
    assert!(
        page.contains("<td>coulomb_friction</td>") && page.contains("accepted: added to the scene")
    );
    assert!(page.contains("<td>battery_sag</td>"));
    // The change of the scene the JSON states: Coulomb friction from 0 to 0.05 N m.
    let found = j["effects"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["name"] == "coulomb_friction")
        .unwrap();
    assert!((found["value"].as_f64().unwrap() - 0.05).abs() < 1e-3);
    assert!(
        page.contains("<td class=\"num\">0 N m</td><td class=\"num\">0.05 N m</td><td>fitted</td>"),
        "changes"
    );
    // The fits, as the JSON has them.
    let cur = &j["replay_fit"]["current_A"];
    for f in ["original_pct", "calibrated_pct"] {
        assert!(
            page.contains(&format!("{:.1} %", cur[f].as_f64().unwrap())),
            "{f}"
        );
    }
    assert!(page.contains("agvsim calibrate --scene scenes/lab_offset_120mm.toml"));
}

#[test]
fn diagnosis_and_identification_reports_carry_their_findings_and_parameters() {
    let dir = tmp("diagnose");
    let (html, j) = (dir.join("d.html"), dir.join("d.json"));
    agvsim(&[
        "diagnose",
        "--rig",
        &dev("dev_axis_03.rig.toml"),
        "--recording",
        &dev("dev_axis_03.csv"),
        "--json",
        j.to_str().unwrap(),
        "--html",
        html.to_str().unwrap(),
    ]);
    let page = std::fs::read_to_string(&html).unwrap();
    let j = json(&j);
    // Compare and residual per output, and the regimes.
    let outputs = j["final"]["fit_pct_per_output"].as_object().unwrap().len();
    assert_self_contained(&page, 2 * outputs + 1);
    let first = &j["effects"][0];
    assert!(
        page.contains(&format!("{} — ", first["name"].as_str().unwrap())),
        "finding"
    );
    assert!(page.contains("Evidence: "));
    assert!(page.contains(&format!(
        "{:.1} %",
        j["baseline"]["fit_pct"].as_f64().unwrap()
    )));

    let (html, j) = (dir.join("i.html"), dir.join("i.json"));
    agvsim(&[
        "identify",
        "--rig",
        &dev("dev_axis_01.rig.toml"),
        "--recording",
        &dev("dev_axis_01.csv"),
        "--json",
        j.to_str().unwrap(),
        "--html",
        html.to_str().unwrap(),
    ]);
    let page = std::fs::read_to_string(&html).unwrap();
    let j = json(&j);
    let outputs = j["estimation"]["fit_pct"].as_object().unwrap().len();
    // A fit and a residual-check figure per output.
    assert_self_contained(&page, 2 * outputs);
    for p in j["params"].as_array().unwrap() {
        assert!(page.contains(&format!("<td>{}</td>", p["name"].as_str().unwrap())));
    }
}

/// A mobile robot's calibration report shows its path from above (measured, original,
/// calibrated: one more figure than the fitted outputs) and its wheel geometry as a table
/// whose UMBmark figures and controller multipliers are the JSON's.
#[test]
fn a_mobile_robot_report_has_its_path_from_above_and_its_wheel_geometry() {
    let dir = tmp("mobile");
    let d = dir.to_str().unwrap();
    let import = [
        "import",
        "ros2",
        "data/ros2_example/robot_square",
        "--out",
        d,
    ];
    agvsim(&[&import[..], &common::EXAMPLE_BAG_ROBOT[..]].concat());
    let (html_path, json_path) = (dir.join("report.html"), dir.join("cal.json"));
    agvsim(&[
        "calibrate",
        "--scene",
        dir.join("robot_square.scene.toml").to_str().unwrap(),
        "--recording",
        dir.join("robot_square.csv").to_str().unwrap(),
        "--effects",
        "wheel_geometry",
        "--html",
        html_path.to_str().unwrap(),
        "--json",
        json_path.to_str().unwrap(),
    ]);
    let html = std::fs::read_to_string(&html_path).unwrap();
    let j = json(&json_path);
    let outputs = j["replay_fit"].as_object().map_or(0, |o| o.len());
    assert!(outputs >= 3, "{}", j["replay_fit"]);
    assert_self_contained(&html, outputs + 1);
    assert!(html.contains("seen from above, to scale"), "no path figure");
    assert!(html.contains("Wheel geometry"));
    let g = &j["wheel_geometry"];
    for v in [
        &g["umbmark_ed"],
        &g["umbmark_eb"],
        &g["diff_drive_controller"]["wheel_separation_multiplier"],
    ] {
        let shown = agvsim::numtext::sig(v.as_f64().unwrap(), 6);
        assert!(
            html.contains(&format!(">{shown}<")),
            "{shown} not in the table"
        );
    }
}
