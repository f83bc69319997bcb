//! Diagnosis (issue 4): the nominal model is fitted first, then each effect of
//! the vocabulary is tried; only a significant one is reported.

use std::path::Path;

use agvsim::diagnose::{diagnose, DiagnoseOptions};
use agvsim::ident::effects::Effect;
use agvsim::record::Recording;
use agvsim::rig::Rig;

fn run(dir: &str, name: &str) -> agvsim::diagnose::Diagnosis {
    run_with(dir, name, DiagnoseOptions::default())
}

fn run_with(dir: &str, name: &str, opts: DiagnoseOptions) -> agvsim::diagnose::Diagnosis {
    let base = Path::new(dir);
    let rig_path = base.join(format!("{name}.rig.toml"));
    let rig = Rig::load(&rig_path).unwrap();
    let rec = Recording::load(&base.join(format!("{name}.csv"))).unwrap();
    diagnose(&rig, &rig_path, &rec, None, &opts).unwrap()
}

/// Whole-vehicle recordings (independent simulator): wheel slip concealed in the tracker
/// and encoder noise is found with its friction coefficient within 15 % (key: peak_mu =
/// 0.554356), and a clean vehicle gives nothing. The candidates are limited to the two
/// floor effects to keep the test short; the full diagnosis tries all seven.
#[test]
fn vehicle_wheel_slip_is_found_and_a_clean_vehicle_gives_nothing() {
    static STAGES: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    fn count_stage(_: &str) {
        STAGES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }
    let only = || DiagnoseOptions {
        effects: agvsim::ident::effects::Choice::Named(vec![Effect::WheelSlip, Effect::CastorDrag]),
        progress: Some(count_stage),
        ..Default::default()
    };
    let d = run_with("../shared/data/dev", "dev_vehicle_01", only());
    // Progress: the baseline, then per round its start and each of its two candidates.
    let stages = STAGES.load(std::sync::atomic::Ordering::Relaxed);
    assert!(stages >= 4, "{stages} progress lines");
    println!("{}", agvsim::diagnose::report::render(&d));
    let f = d.findings.first().expect("an effect");
    assert_eq!(f.effect, Effect::WheelSlip);
    assert!((f.value - 0.554356).abs() / 0.554356 < 0.15, "{}", f.value);
    assert!(d.final_fit_pct > d.baseline_fit_pct);
    let clean = run_with("../shared/data/dev", "dev_vehicle_03", only());
    println!("{}", agvsim::diagnose::report::render(&clean));
    assert!(clean.findings.is_empty());
}

/// A recording with nothing missing yields no effect: every candidate's gain stays below
/// the significance test. A recording with Coulomb friction concealed at about the noise
/// level yields that effect, its torque within 15 %, and a better fit. (Answers from the
/// development set's keys: none; coulomb_torque_Nm = 0.021105.)
#[test]
fn clean_record_gives_nothing_and_concealed_coulomb_friction_is_found() {
    let clean = run("../shared/data/dev", "dev_axis_11");
    println!("{}", agvsim::diagnose::report::render(&clean));
    assert!(clean.findings.is_empty());
    let c = run("../shared/data/dev", "dev_axis_03");
    println!("{}", agvsim::diagnose::report::render(&c));
    let f = c.findings.first().expect("an effect");
    assert_eq!(f.effect.name(), "coulomb_friction");
    assert!((f.value - 0.021105).abs() / 0.021105 < 0.15, "{}", f.value);
    assert!(c.final_fit_pct > c.baseline_fit_pct);
}

/// EMPS: the nominal rig (mass and viscous friction) leaves out Coulomb friction; the
/// diagnosis must find it within 10 % of the published 20.39 N (Janot et al. 2019).
#[test]
fn emps_coulomb_friction_matches_the_published_value() {
    let d = run("../shared/data/real/emps", "data_emps");
    println!("{}", agvsim::diagnose::report::render(&d));
    let f = d.findings.first().expect("an effect");
    assert_eq!(f.effect.name(), "coulomb_friction");
    assert!((f.value - 20.3935).abs() / 20.3935 < 0.10, "{}", f.value);
    assert!(d.final_fit_pct > d.baseline_fit_pct + 2.0);
}

/// Acceptance 1 (small version): agvsim's own recordings with a concealed effect, against
/// rigs 5-25 % off that omit it. Clean: nothing found. Coulomb friction and the bridges'
/// voltage limit: found within 15 %.
#[test]
fn quick_proof_on_concealed_effects_from_the_simulator() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("prove");
    let cases = agvsim::diagnose::prove::prove(&dir, true, 1, &[]).unwrap();
    for c in &cases {
        println!(
            "{}: truth {:?} {} found {:?} (fit {:.2} -> {:.2} %)",
            c.name,
            c.effect.map(|e| e.name()),
            c.truth,
            c.found,
            c.baseline_fit_pct,
            c.final_fit_pct
        );
    }
    assert_eq!(cases.len(), 3);
    for c in &cases {
        assert!(c.passed, "{}: {:?}", c.name, c.found);
    }
}

/// Speed without a change of answer: on a clean record the backlash candidate (a rough
/// parameter) stops at its screen, which removes almost nothing; where backlash is present
/// (dev_axis_01, key 0.041388 rad) the screen passes, the full search runs and finds it
/// within 15 %. The diagnosis is the same, byte for byte, on one worker thread and on two.
#[test]
fn absent_rough_effects_stop_at_their_screen_and_any_job_count_gives_the_same_diagnosis() {
    let on = |jobs: usize, name: &str| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(jobs)
            .build()
            .unwrap()
            .install(|| run("../shared/data/dev", name))
    };
    let clean = on(1, "dev_axis_11");
    let backlash = |d: &agvsim::diagnose::Diagnosis| {
        d.rounds[0]
            .iter()
            .find(|c| c.name == "backlash")
            .cloned()
            .expect("backlash tried")
    };
    let b = backlash(&clean);
    println!("clean: {b:?}");
    assert!(b.screened_only && !b.significant);
    assert!(b.rss_reduction_pct < 100.0 * agvsim::diagnose::MIN_RSS_REDUCTION / 3.0);
    let two = on(2, "dev_axis_11");
    assert_eq!(
        clean.contract_json().to_string(),
        two.contract_json().to_string()
    );
    let present = on(2, "dev_axis_01");
    let b = backlash(&present);
    println!("present: {b:?}");
    assert!(!b.screened_only && b.significant);
    let f = present.findings.first().expect("an effect");
    assert_eq!(f.effect.name(), "backlash");
    assert!((f.value - 0.041388).abs() / 0.041388 < 0.15, "{}", f.value);
}
