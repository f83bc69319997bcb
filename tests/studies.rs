//! Sweeps and the shipped studies (issue 5): sweeps give the same bytes whatever the job
//! count or sharding; the studies show the physics their issue asks for.

use std::path::{Path, PathBuf};

use agvsim::study::{self, StudyOptions};
use agvsim::sweep::{self, Shard, SweepOptions};

mod common;

/// A scratch folder's path, not yet made: a sweep or study makes its own.
fn tmp(name: &str) -> PathBuf {
    let d = common::tmp(name);
    std::fs::remove_dir(&d).unwrap();
    d
}

fn no_progress(_: usize, _: usize) {}

/// A 2-D sweep of 50 short full-level runs: gain x payload.
fn fifty_runs(out: PathBuf, jobs: usize, shard: Shard) -> SweepOptions {
    SweepOptions::new(
        Path::new("scenes/studies/tyre_compounds.toml"),
        vec!["sim.duration_s=3".into()],
        vec![
            sweep::parse_vary("controller.gain_scale=1..3:10").unwrap(),
            sweep::parse_vary("payload.mass_kg=0,50,100,150,200").unwrap(),
        ],
        1,
        shard,
        jobs,
        false,
        out,
    )
    .unwrap()
}

#[test]
fn a_sweep_gives_the_same_results_with_one_or_two_jobs_and_when_sharded_and_merged() {
    let one = fifty_runs(tmp("jobs1"), 1, Shard::WHOLE);
    assert_eq!(one.grid.total(), 50);
    let r1 = sweep::run_sweep(&one, &no_progress).unwrap();
    let two = fifty_runs(tmp("jobs2"), 2, Shard::WHOLE);
    let r2 = sweep::run_sweep(&two, &no_progress).unwrap();
    let csv1 = std::fs::read(&r1.results_csv).unwrap();
    let csv2 = std::fs::read(&r2.results_csv).unwrap();
    assert_eq!(csv1.iter().filter(|b| **b == b'\n').count(), 51);
    assert!(csv1 == csv2, "results differ between --jobs 1 and --jobs 2");
    // The runs are real simulations: payload changes the energy drawn.
    let text = String::from_utf8(csv1.clone()).unwrap();
    let energies: Vec<&str> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(16).unwrap())
        .collect();
    assert!(
        energies[0] != energies[4],
        "payload made no difference: {energies:?}"
    );
    assert!(!text.contains("error:"), "a run failed:\n{text}");

    let s1 = fifty_runs(tmp("shard1"), 2, Shard { index: 1, count: 2 });
    let s2 = fifty_runs(tmp("shard2"), 1, Shard { index: 2, count: 2 });
    sweep::run_sweep(&s2, &no_progress).unwrap();
    sweep::run_sweep(&s1, &no_progress).unwrap();
    let merged = tmp("merged");
    // Shards given in either order.
    let (path, _) = sweep::merge(&[s2.out_dir.clone(), s1.out_dir.clone()], &merged).unwrap();
    assert!(
        std::fs::read(path).unwrap() == csv1,
        "merged shards differ from the unsharded sweep"
    );

    // A missing shard, a shard twice, or a shard of another sweep is refused.
    let e = sweep::merge(std::slice::from_ref(&s1.out_dir), &tmp("m2"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("25 of 50 runs are missing"), "{e}");
    let e = sweep::merge(&[s1.out_dir.clone(), s1.out_dir.clone()], &tmp("m3"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("appears twice"), "{e}");
    let other = SweepOptions::new(
        Path::new("scenes/studies/tyre_compounds.toml"),
        vec!["sim.duration_s=2".into()],
        vec![sweep::parse_vary("controller.gain_scale=1,2").unwrap()],
        1,
        Shard { index: 2, count: 2 },
        1,
        false,
        tmp("other"),
    )
    .unwrap();
    sweep::run_sweep(&other, &no_progress).unwrap();
    let e = sweep::merge(&[s1.out_dir.clone(), other.out_dir.clone()], &tmp("m4"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a slice of the same sweep"), "{e}");
}

#[test]
fn a_sweep_refuses_bad_keys_and_values_before_running() {
    let bad = |varies: &[&str]| {
        SweepOptions::new(
            Path::new("scenes/studies/tyre_compounds.toml"),
            vec![],
            varies
                .iter()
                .map(|v| sweep::parse_vary(v).unwrap())
                .collect(),
            1,
            Shard::WHOLE,
            1,
            false,
            tmp("bad"),
        )
        .unwrap_err()
        .to_string()
    };
    let e = bad(&["controller.gain_scael=1,2"]);
    assert!(e.contains("gain_scael"), "{e}");
    let e = bad(&["tyre.compound=hard_polyurethane,marshmallow"]);
    assert!(e.contains("marshmallow"), "{e}");
    let e = bad(&["controller.gain_scale=1,2", "controller.gain_scale=3"]);
    assert!(e.contains("varied twice"), "{e}");
}

fn quick(name: &str) -> StudyOptions {
    StudyOptions {
        out_dir: tmp(name),
        jobs: 0,
        quick: true,
    }
}

#[test]
fn soft_compound_slips_less_and_its_slip_cycles_start_at_a_higher_gain_on_painted_concrete() {
    let (groups, out) = study::tyres::run(&quick("tyres"), &no_progress).unwrap();
    println!("{}", out.summary);
    let on_paint = |c: &str| {
        groups
            .iter()
            .find(|g| g.compound == c && g.surface == "painted_concrete")
            .unwrap()
    };
    let (hard, soft) = (on_paint("hard_polyurethane"), on_paint("soft_rubber"));
    let hard_onset = hard
        .slip_cycle_onset_gain
        .expect("hard tyres never slip-cycle on paint between gains 1 and 3");
    // No onset in the range counts as beyond it.
    let soft_onset = soft.slip_cycle_onset_gain.unwrap_or(f64::INFINITY);
    assert!(
        soft_onset > hard_onset,
        "soft onset {soft_onset} not above hard {hard_onset}"
    );
    // Like for like: the gains at which both kept the wire.
    let both: Vec<f64> = hard
        .runs
        .iter()
        .filter(|h| !h.3 && soft.runs.iter().any(|s| s.0 == h.0 && !s.3))
        .map(|h| h.0)
        .collect();
    assert!(both.len() >= 3, "too few common gains: {both:?}");
    assert!(
        soft.mean_sliding_over(&both) < hard.mean_sliding_over(&both),
        "soft {} vs hard {}",
        soft.mean_sliding_over(&both),
        hard.mean_sliding_over(&both)
    );
    assert!(out.summary.contains("| soft_rubber | painted_concrete |"));
    // One payload (quick): the onset plot shows each compound's onset side by side, not a
    // dot per line on a payload axis; "none" where the gains swept found none.
    let svg = out
        .files
        .iter()
        .find(|f| f.ends_with("slip_cycle_onset.svg"))
        .map(|f| std::fs::read_to_string(f).unwrap())
        .unwrap();
    assert!(svg.contains("payload 0 kg"), "{svg}");
    assert!(
        svg.contains(&format!(">{} <", agvsim::numtext::sig(hard_onset, 3))),
        "{svg}"
    );
    if soft.slip_cycle_onset_gain.is_none() {
        assert!(svg.contains(">none<"), "{svg}");
    }
}

#[test]
fn thesis_figures_show_the_asymptote_growing_backlash_cycles_and_slip_at_the_full_level() {
    let (levels, out) = study::thesis::run(&quick("thesis"), &no_progress).unwrap();
    println!("{}", out.summary);
    let level = |n: &str| levels.iter().find(|l| l.level == n).unwrap();
    let lin = &level("linear").runs;
    let first_drop = lin[0].whole_run_rms_m - lin[1].whole_run_rms_m;
    let last_drop = lin[lin.len() - 2].whole_run_rms_m - lin[lin.len() - 1].whole_run_rms_m;
    assert!(
        first_drop > 0.0 && last_drop < 0.25 * first_drop,
        "no asymptote: {lin:?}"
    );
    let cx = &level("complex").runs;
    assert!(cx.iter().all(|r| r.limit_cycle_m > 0.0), "{cx:?}");
    assert!(
        cx.windows(2)
            .all(|w| w[1].limit_cycle_m > w[0].limit_cycle_m),
        "{cx:?}"
    );
    // Slip is what the full level adds: limit cycles with the tyres on their friction
    // limit part of the time, which the no-slip levels cannot show...
    let full = &level("full").runs;
    assert!(
        full.iter()
            .any(|r| r.limit_cycle_m > 0.0 && r.sliding_fraction > 0.0),
        "no limit cycle with sliding at the full level: {full:?}"
    );
    // ...and at the top gain the slipping vehicle tracks worse than the no-slip model.
    let top = full.last().unwrap();
    let cx_same = cx.iter().find(|r| r.gain == top.gain).unwrap();
    assert!(
        top.whole_run_rms_m > cx_same.whole_run_rms_m,
        "{top:?} vs {cx_same:?}"
    );
    for f in &out.files {
        assert!(f.exists());
    }
}

#[test]
fn reversing_on_the_front_pair_loses_the_wire_where_swing_away_or_a_rear_pair_holds_it_and_swing_away_loses_a_bend(
) {
    let (runs, out) = study::reversing::run(&quick("reversing"), &no_progress).unwrap();
    println!("{}", out.summary);
    let find = |c: &str, w: &str| {
        runs.iter()
            .find(|r| r.configuration == c && r.wire == w)
            .unwrap_or_else(|| panic!("no {c} run on the {w} wire"))
    };
    // Straight wire: the P-D law on the front pair alone is unstable reversing; the
    // swing-away strategy and a rear pair hold the wire, and keep the error within the
    // coils' strong-signal zone (about one coil height, 38 mm) over the second half.
    let front = find("front_only", "straight");
    assert!(front.lost_wire, "{front:?}");
    for c in ["swing_away", "rear_pair"] {
        let r = find(c, "straight");
        assert!(!r.lost_wire, "{r:?}");
        assert!(r.late_rms_m < 0.038, "{r:?}");
    }
    // The bend: the rear pair still follows it, so it can be followed; swing away, whose
    // picture of the wire is the straight line it started on, loses it.
    let rear = find("rear_pair", "bent");
    assert!(!rear.lost_wire && rear.late_rms_m < 0.038, "{rear:?}");
    let swing = find("swing_away", "bent");
    assert!(swing.lost_wire, "{swing:?}");
}

#[test]
fn linearised_plant_is_controllable_and_the_coils_see_only_the_turning_mode() {
    use agvsim::sim::linearize::{analyse, linearise, STATE_NAMES};
    let scene = agvsim::scene::Scene::load(Path::new("scenes/lab_offset_120mm.toml"), &[]).unwrap();
    let l = linearise(&scene).unwrap();
    // The lab speed: about 1 m/s forward.
    assert!(l.speed_m_s > 0.5 && l.speed_m_s < 2.0, "{}", l.speed_m_s);
    let r = analyse(&l);
    // Two voltages reach every state: each side's drivetrain, and through them both the
    // straight-running and the turning motion.
    assert_eq!(r.controllable_rank, STATE_NAMES.len());
    // A straight wire is the same everywhere along it, and the readings of a pair on it
    // depend only on its offset and heading: the position along the wire and the
    // straight-running (common) mode of the drivetrains are invisible, the turning
    // (differential) mode and the offset are seen.
    let unseen: Vec<&str> = STATE_NAMES
        .iter()
        .zip(&r.unobservable_share)
        .filter(|(_, s)| **s > 0.99)
        .map(|(n, _)| *n)
        .collect();
    assert_eq!(
        unseen,
        [
            "x_m",
            "speed_m_s",
            "current_sum_A",
            "motor_speed_sum_rad_s",
            "twist_sum_rad"
        ]
    );
    assert_eq!(r.observable_rank, 6);
    for seen in ["y_m", "heading_rad", "yaw_rate_rad_s", "current_diff_A"] {
        let j = STATE_NAMES.iter().position(|n| *n == seen).unwrap();
        assert!(
            r.unobservable_share[j] < 0.01,
            "{seen}: {}",
            r.unobservable_share[j]
        );
    }
}

#[test]
fn closed_loop_reversing_on_the_front_pair_is_unstable_and_a_rear_pair_stabilises_it() {
    // The thesis's linear result: P-D wire following is stable forwards; reversing on the
    // same two coils is unstable ("backing a trailer knowing only the towbar") whatever the
    // gain; a rear pair makes it stable again. The poles come from the linearised plant
    // closed through the firmware's gains and the DCMC's slopes.
    use agvsim::sim::linearize::{close_loop, linearise};
    let closed = |scene: &str, gain: f64| {
        let scene = agvsim::scene::Scene::load(
            Path::new(scene),
            &[format!("controller.gain_scale={gain}")],
        )
        .unwrap();
        close_loop(&linearise(&scene).unwrap()).expect("the P-D firmware and gain DCMC")
    };
    for gain in [0.5, 1.0, 3.0] {
        let forward = closed("scenes/lab_offset_120mm.toml", gain);
        let front = closed("scenes/studies/reversing_front_only.toml", gain);
        let rear = closed("scenes/studies/reversing_rear_pair.toml", gain);
        assert!(forward.stable(), "forward, gain {gain}: {forward:?}");
        assert!(
            !front.stable(),
            "reversing on the front pair, gain {gain}: {front:?}"
        );
        assert!(
            rear.stable(),
            "reversing on the rear pair, gain {gain}: {rear:?}"
        );
    }
}
