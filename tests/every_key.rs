//! No value of any scene key panics `run` or `linearize`, and a run that is not refused
//! up front either finishes with finite outputs or stops with an error that says it
//! diverged: every numeric key of the key table with non-finite, negative, zero, tiny and
//! huge values (through the library, as `--set` gives them).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use agvsim::scene::{keys, Scene};
use agvsim::sim::Sim;

const VALUES: &[&str] = &["nan", "inf", "-inf", "-1", "0", "1e-300", "1e15", "1e308"];

/// A short run of the scene: `Ok` with every snapshot finite, or the simulator's error.
fn short_run(scene: &Scene) -> Result<(), String> {
    let mut sim = Sim::new(scene).map_err(|e| e.to_string())?;
    // 0.05 s: long enough for the drive to be commanded and the tyres loaded.
    for _ in 0..50 {
        sim.step().map_err(|e| e.to_string())?;
    }
    let s = sim.snapshot();
    let mut values = vec![
        s.pose.x_m,
        s.pose.y_m,
        s.pose.heading_rad,
        s.lateral_error_m,
    ];
    for d in &s.sides {
        values.extend([
            d.voltage_v,
            d.current_a,
            d.motor_speed_rad_s,
            d.wheel_speed_rad_s,
        ]);
    }
    let finite = values.iter().all(|v| v.is_finite());
    if finite {
        Ok(())
    } else {
        Err(format!("a run ended with non-finite outputs: {s:?}"))
    }
}

#[test]
fn no_value_of_any_key_panics_run_or_linearize_or_leaves_nan() {
    let text = std::fs::read_to_string("scenes/lab_offset_120mm.toml").unwrap();
    let path = Path::new("scenes/lab_offset_120mm.toml");
    let mut ran = 0;
    let mut refused = 0;
    for (k, _) in keys::table().numbers() {
        for v in VALUES {
            let arg = format!("{}={v}", k.key);
            let scene =
                match Scene::from_toml(&text, path, &[arg.clone(), "sim.duration_s=0.05".into()]) {
                    Ok(s) => s,
                    Err(e) => {
                        // Refused up front, naming the key's --set.
                        let msg = e.to_string();
                        assert!(msg.contains("expected"), "{arg}: {msg}");
                        refused += 1;
                        continue;
                    }
                };
            let outcome = catch_unwind(AssertUnwindSafe(|| short_run(&scene)));
            match outcome {
                Err(_) => panic!("{arg}: the run panicked"),
                Ok(Err(e)) => assert!(
                    e.contains("diverged")
                        || e.contains("cannot set up")
                        || e.contains("sub-steps"),
                    "{arg}: {e}"
                ),
                Ok(Ok(())) => {}
            }
            let lin = catch_unwind(AssertUnwindSafe(|| {
                agvsim::sim::linearize::linearise(&scene)
                    .map(|l| agvsim::sim::linearize::analyse(&l))
            }));
            assert!(lin.is_ok(), "{arg}: linearize panicked");
            ran += 1;
        }
    }
    assert!(ran > 100 && refused > 300, "{ran} run, {refused} refused");
}
