//! `agvsim import csv`: a CSV with other column names and units becomes a contract
//! recording with its conversions stated; bad rows, cells and units are named.

mod common;
use common::tmp;

use std::path::Path;

use agvsim::import::csv_map::{convert, load_map};
use agvsim::record::Recording;

const MAP: &str = r#"
rig = "drive_axis"
description = "bench log"
time = { column = "time_ms", unit = "ms" }
[columns]
voltage_V = { column = "volts" }
motor_speed_rad_s = { column = "vel_rpm", unit = "rpm" }
current_A = { column = "amps_x10", scale = 0.1 }
"#;

fn run(data: &str, map: &str) -> Result<String, String> {
    // A folder per call: the tests run in parallel, and a shared one was removed under
    // another test's feet.
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let n = CALLS.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
    let dir = tmp(&format!("case-{n}"));
    let (d, m) = (dir.join("log.csv"), dir.join("map.toml"));
    std::fs::write(&d, data).unwrap();
    std::fs::write(&m, map).unwrap();
    let map = load_map(&m).map_err(|e| e.to_string())?;
    convert(data, &d, &map, &m).map_err(|e| e.to_string())
}

#[test]
fn columns_are_renamed_and_converted_with_the_conversions_stated() {
    let data = "time_ms,volts,vel_rpm,amps_x10,notes\n0,1.5,0,12,a\n5,2.0,60,,b\n10,2.5,120,25,c\n";
    let text = run(data, MAP).unwrap();
    println!("{text}");
    assert!(text.contains("# conversion: motor_speed_rad_s = vel_rpm rpm -> rad_s"));
    let rec = Recording::parse(&text, Path::new("log.csv")).unwrap();
    assert_eq!(rec.rig.as_str(), "drive_axis");
    assert_eq!(rec.t_s, vec![0.0, 0.005, 0.01]);
    let speed = rec.column("motor_speed_rad_s").unwrap();
    // 60 rpm is one turn per second: 2 pi rad/s.
    assert!((speed[1].unwrap() - std::f64::consts::TAU).abs() < 1e-12);
    let current = rec.column("current_A").unwrap();
    assert_eq!(current[1], None, "an empty cell stays a missing sample");
    assert!((current[2].unwrap() - 2.5).abs() < 1e-12);
}

#[test]
fn bad_rows_cells_and_units_are_named_never_fixed() {
    let ok = "time_ms,volts,vel_rpm,amps_x10\n0,1,0,0\n";
    let err = run(
        "time_ms,volts,vel_rpm,amps_x10\n0,1,0,0\n5,1,0,0\n5,1,0,0\n",
        MAP,
    )
    .unwrap_err();
    println!("{err}");
    assert!(
        err.contains("log.csv:4") && err.contains("not after the previous row"),
        "{err}"
    );
    let err = run("time_ms,volts,vel_rpm,amps_x10\n0,1,0,0\n5,NaN,0,0\n", MAP).unwrap_err();
    println!("{err}");
    assert!(
        err.contains("log.csv:3") && err.contains("`volts`") && err.contains("NaN"),
        "{err}"
    );
    let err = run(ok, &MAP.replace("unit = \"rpm\"", "unit = \"furlongs\"")).unwrap_err();
    println!("{err}");
    assert!(
        err.contains("unit `furlongs`") && err.contains("known: s, ms"),
        "{err}"
    );
    let err = run(ok, &MAP.replace("unit = \"rpm\"", "unit = \"mm\"")).unwrap_err();
    assert!(err.contains("converts to m"), "{err}");
    let err = run(ok, &MAP.replace("vel_rpm\"", "speed\"")).unwrap_err();
    println!("{err}");
    assert!(
        err.contains("column `speed` is not in") && err.contains("vel_rpm"),
        "{err}"
    );
}
