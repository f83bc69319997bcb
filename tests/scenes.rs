//! Every shipped scene states what a run of it shows (`[expect]`), and a run checks it;
//! the run summary never claims more than the run shows.

use std::path::{Path, PathBuf};

use agvsim::run::render_summary;
use agvsim::scene::Scene;
use agvsim::sim::expectation::check;
use agvsim::sweep::run::summarise;

fn shipped_scenes() -> Vec<PathBuf> {
    let mut out = vec![];
    let mut dirs = vec![PathBuf::from("scenes")];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "toml") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

#[test]
fn every_shipped_scene_does_what_its_expect_table_says() {
    let scenes = shipped_scenes();
    assert!(scenes.len() >= 10, "found {} scenes", scenes.len());
    let mut failures = vec![];
    for path in &scenes {
        let scene = Scene::load(path, &[]).unwrap();
        assert!(
            !scene.expect.is_empty(),
            "{}: no [expect] table; every shipped scene states its outcome",
            path.display()
        );
        let s = summarise(&scene).unwrap();
        for c in check(&scene.expect, &s) {
            println!(
                "{:<45} {:<40} {:<8} run: {}",
                path.display(),
                c.claim,
                if c.met { "met" } else { "NOT MET" },
                c.observed
            );
            if !c.met {
                failures.push(format!(
                    "{}: {} (run: {})",
                    path.display(),
                    c.claim,
                    c.observed
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

fn summary_of(path: &str, set: &[&str]) -> String {
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    let scene = Scene::load(Path::new(path), &set).unwrap();
    let s = summarise(&scene).unwrap();
    render_summary(Path::new(path), &scene, &s)
}

/// A run that loses the wire says so, with when and where; its error is not a tracking
/// error after the loss and does not claim to be "after settling".
#[test]
fn the_summary_of_a_run_that_loses_the_wire_says_so() {
    let text = summary_of("scenes/studies/reversing_front_only.toml", &[]);
    println!("{text}");
    assert!(text.contains("wire       lost at"), "{text}");
    assert!(text.contains("until the wire was lost"), "{text}");
    assert!(!text.contains("after settling"), "{text}");
}

/// A run that never settles states its RMS over the whole run, never "after settling";
/// one that settles says "after settling".
#[test]
fn an_unsettled_run_does_not_claim_an_error_after_settling() {
    let text = summary_of("scenes/lab_offset_120mm.toml", &[]);
    println!("{text}");
    assert!(text.contains("settled    no"), "{text}");
    assert!(
        text.contains("(whole run)") && !text.contains("after settling"),
        "{text}"
    );
    assert!(text.contains("limit cycle +/-"), "{text}");
    let settled = summary_of("scenes/lab_offset_120mm.toml", &["gearbox.backlash_rad=0"]);
    println!("{settled}");
    assert!(settled.contains("settled    after") && settled.contains("(after settling)"));
    // docs/scenes.md's claim: without the play it settles within 5 m.
    let no_play = Scene::load(
        Path::new("scenes/lab_offset_120mm.toml"),
        &["gearbox.backlash_rad=0".to_string()],
    )
    .unwrap();
    let d = summarise(&no_play).unwrap().settling_distance_m.unwrap();
    assert!(d < 5.0, "{d}");
}

/// Driving past the end of the wire is reported, and the error is taken only while the
/// wire was under the sensors (the 60 s lab run used to print a 23.5 m peak error).
#[test]
fn running_off_the_end_of_the_wire_is_reported() {
    let text = summary_of("scenes/lab_offset_120mm.toml", &["sim.duration_s=60"]);
    println!("{text}");
    assert!(
        text.contains("wire end   passed the far end of the wire"),
        "{text}"
    );
    let peak_mm: f64 = text
        .split("peak ")
        .nth(1)
        .and_then(|r| r.split(" mm").next())
        .and_then(|v| v.parse().ok())
        .unwrap();
    // The start offset (120 mm) is the largest honest error; beyond it means the metres
    // past the wire's end were counted.
    assert!(peak_mm <= 121.0, "{peak_mm}");
}

/// Lifted wheels track nothing: no "settled after 0.00 m".
#[test]
fn a_lifted_wheel_run_claims_no_tracking() {
    let text = summary_of("scenes/lifted_identification.toml", &["sim.duration_s=1"]);
    println!("{text}");
    assert!(text.contains("tracking   none"), "{text}");
    assert!(!text.contains("settled"), "{text}");
}

/// `--repeat` on a scene with no noise would write identical rows: refused, naming the
/// noise keys; with sensor noise the repeats differ.
#[test]
fn repeats_without_a_noise_source_are_refused() {
    use agvsim::sweep::{parse_vary, SweepOptions};
    let path = Path::new("scenes/lab_offset_120mm.toml");
    let text = std::fs::read_to_string(path).unwrap();
    let vary = || vec![parse_vary("controller.gain_scale=1,2").unwrap()];
    let err = SweepOptions::from_text(path, text.clone(), vec![], vary(), 3)
        .expect_err("refused")
        .to_string();
    println!("{err}");
    assert!(
        err.contains("--repeat 3") && err.contains("sensors.noise_adc"),
        "{err}"
    );
    assert!(SweepOptions::from_text(path, text.clone(), vec![], vary(), 1).is_ok());
    let noisy = vec!["sensors.noise_adc=2".to_string(), "sim.duration_s=2".into()];
    assert!(SweepOptions::from_text(path, text, noisy, vary(), 3).is_ok());
}
