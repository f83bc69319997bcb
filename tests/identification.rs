//! Identification (issue 3): virtual experiments on the simulated AGV, then grey-box fits
//! whose answers are known from the scene.

mod common;
use common::tmp;

use std::path::{Path, PathBuf};

use agvsim::experiment::{run_experiment, ExperimentKind, ExperimentOptions};
use agvsim::ident::{identify, Identification, IdentifyOptions, ModelChoice};
use agvsim::record::Recording;
use agvsim::rig::Rig;
use agvsim::scene::Scene;

fn experiment(
    kind: ExperimentKind,
    scene: &Scene,
    dir: &Path,
    name: &str,
    seed: u64,
    rig_error: f64,
) -> (Rig, PathBuf, Recording) {
    let out = run_experiment(
        kind,
        scene,
        &ExperimentOptions {
            out_dir: dir.to_owned(),
            name: Some(name.into()),
            seed: Some(seed),
            rig_error,
            ..ExperimentOptions::default()
        },
    )
    .unwrap();
    (
        Rig::load(&out.rig).unwrap(),
        out.rig.clone(),
        Recording::load(&out.recording).unwrap(),
    )
}

fn ident(
    rig: &Rig,
    rig_path: &Path,
    rec: &Recording,
    model: Option<ModelChoice>,
) -> Identification {
    identify(
        rig,
        rig_path,
        rec,
        None,
        &IdentifyOptions {
            model,
            ..IdentifyOptions::default()
        },
    )
    .unwrap()
}

/// The thesis's case-1 A and B from the scene's physics: each lifted motor is
/// J dw/dt = K (V - K w)/R - b w with V = g_f fwd -/+ g_t turn (left/right), J the rotor
/// plus the wheel reflected through the gear ratio.
fn true_gain_model(s: &Scene) -> Vec<(&'static str, f64)> {
    let m = &s.motor;
    let j = m.rotor_inertia_kg_m2 + s.wheel.inertia_kg_m2 / s.gearbox.ratio.powi(2);
    let k = m.torque_constant_nm_a;
    let a = -(m.viscous_nm_s_rad + k * k / m.resistance_ohm) / j;
    let beta = k / (m.resistance_ohm * j);
    let (gf, gt) = (s.dcmc.forward_gain_v_pct, s.dcmc.turn_gain_v_pct);
    vec![
        ("a_left_1_s", a),
        ("a_right_1_s", a),
        ("b_left_fwd_rad_s2_pct", beta * gf),
        ("b_left_turn_rad_s2_pct", -beta * gt),
        ("b_right_fwd_rad_s2_pct", beta * gf),
        ("b_right_turn_rad_s2_pct", beta * gt),
    ]
}

/// Acceptance 1: from rig beliefs up to 20 % off, identification recovers the scene's A and
/// B within 5 %, and the 1-sigma intervals cover the truth at about their nominal 68 %.
#[test]
fn lifted_random_demand_recovers_the_scene_and_its_intervals_are_honest() {
    let scene = Scene::load(Path::new("scenes/lifted_identification.toml"), &[]).unwrap();
    let truth = true_gain_model(&scene);
    let dir = tmp("coverage");
    let (mut inside, mut total) = (0, 0);
    let mut worst_rel: f64 = 0.0;
    for seed in 0..20u64 {
        let (rig, rig_path, rec) = experiment(
            ExperimentKind::LiftedRandomDemand,
            &scene,
            &dir,
            &format!("s{seed}"),
            seed,
            0.2,
        );
        let id = ident(&rig, &rig_path, &rec, Some(ModelChoice::Gain));
        for (name, t) in &truth {
            let v = id.value(name).unwrap();
            let s = id.std(name).expect("determined");
            worst_rel = worst_rel.max(((v - t) / t).abs());
            total += 1;
            if (v - t).abs() <= s {
                inside += 1;
            }
        }
    }
    let coverage = inside as f64 / total as f64;
    println!(
        "lifted random demand, 20 seeds x 6 parameters: worst relative error {:.3} %, 1-sigma coverage {:.1} % ({inside}/{total})",
        100.0 * worst_rel,
        100.0 * coverage
    );
    assert!(worst_rel < 0.05, "worst relative error {worst_rel}");
    // Nominal 68.3 %; 120 intervals (correlated within a seed) give a spread of several
    // percent, and the acceptance band of honest coverage is 55-85 %.
    assert!((0.55..=0.85).contains(&coverage), "coverage {coverage}");
}

/// Acceptance 2: the thesis's finding on a simulated lifted-wheel run. Cases 1 and 2-I are
/// one structure in two parameterisations, so their fits and their A, B (with standard
/// deviations) agree; case 2-II adds integrator parameters the data barely determine.
#[test]
fn thesis_cases_one_and_two_i_agree_and_two_ii_is_poorly_determined() {
    let scene = Scene::load(Path::new("scenes/lifted_identification.toml"), &[]).unwrap();
    let dir = tmp("cases");
    let (rig, rig_path, rec) = experiment(
        ExperimentKind::LiftedRandomDemand,
        &scene,
        &dir,
        "cases",
        7,
        0.2,
    );
    let gain = ident(&rig, &rig_path, &rec, Some(ModelChoice::Gain));
    let p = ident(&rig, &rig_path, &rec, Some(ModelChoice::P));
    let pi = ident(&rig, &rig_path, &rec, Some(ModelChoice::Pi));
    println!("{}", agvsim::ident::report::render(&gain));
    println!(
        "case 2-I:\n{}",
        agvsim::ident::report::state_space_table(p.state_space.as_ref().unwrap())
    );
    println!(
        "case 2-II:\n{}",
        agvsim::ident::report::state_space_table(pi.state_space.as_ref().unwrap())
    );
    println!(
        "loss: case 1 {:.6e}, case 2-I {:.6e}, case 2-II {:.6e}; FPE {:.6e} / {:.6e} / {:.6e}",
        gain.estimation.loss, p.estimation.loss, pi.estimation.loss, gain.fpe, p.fpe, pi.fpe
    );
    // Same structure: the same minimum, to the solver's precision.
    let rel = (gain.estimation.loss - p.estimation.loss).abs() / gain.estimation.loss;
    assert!(rel < 1e-6, "case 1 and 2-I losses differ by {rel}");
    let (g, q) = (
        gain.state_space.as_ref().unwrap(),
        p.state_space.as_ref().unwrap(),
    );
    for r in 0..2 {
        for c in 0..2 {
            let (a, b) = (g.b[r][c], q.b[r][c]);
            assert!((a - b).abs() <= 1e-5 * a.abs(), "B[{r}][{c}] {a} vs {b}");
            let (sa, sb) = (g.b_std[r][c].unwrap(), q.b_std[r][c].unwrap());
            assert!((sa - sb).abs() <= 0.02 * sa, "std B[{r}][{c}] {sa} vs {sb}");
        }
    }
    let rel_std = |id: &Identification| {
        id.params
            .iter()
            .filter(|p| p.free)
            .map(|p| p.std.map_or(f64::INFINITY, |s| s / p.value.abs()))
            .fold(0.0, f64::max)
    };
    let (worst_gain, worst_pi) = (rel_std(&gain), rel_std(&pi));
    println!(
        "largest relative std: case 1 {:.3} %, case 2-II {:.1} %",
        100.0 * worst_gain,
        100.0 * worst_pi
    );
    assert!(worst_pi > 10.0 * worst_gain);
    // The extra parameters buy no prediction: FPE does not improve on case 1's.
    assert!(pi.fpe > gain.fpe);
}

/// Acceptance 3: the falling-weight test yields rotor inertia, Coulomb friction and Kv; the
/// coast-down, with that inertia, yields the damping; each within 5 % of the scene, from
/// beliefs up to 20 % off. The lab scene runs at full fidelity (backlash included).
#[test]
fn falling_weight_and_coast_down_recover_the_motor() {
    let scene = Scene::load(Path::new("scenes/lab_offset_120mm.toml"), &[]).unwrap();
    let m = &scene.motor;
    let dir = tmp("bench-tests");
    let (rig, rig_path, rec) =
        experiment(ExperimentKind::FallingWeight, &scene, &dir, "fw", 3, 0.2);
    let fw = ident(&rig, &rig_path, &rec, None);
    let check = |what: &str, got: f64, truth: f64| {
        let e = (got - truth) / truth;
        println!(
            "{what}: {got:.6e} against {truth:.6e} ({:+.2} %)",
            100.0 * e
        );
        assert!(e.abs() < 0.05, "{what}");
    };
    check(
        "falling weight: rotor inertia",
        fw.value("motor.rotor_inertia_kg_m2").unwrap(),
        m.rotor_inertia_kg_m2,
    );
    check(
        "falling weight: Coulomb friction",
        fw.value("motor.coulomb_Nm").unwrap(),
        m.coulomb_nm,
    );
    check(
        "falling weight: Kv",
        fw.value("motor.torque_constant_Nm_A").unwrap(),
        m.torque_constant_nm_a,
    );

    // Coast-down: the rig knows the wheel's inertia and takes the rotor's from the falling
    // weight; its friction beliefs are off by +30 % and -30 %.
    let (mut rig, _, rec) = experiment(ExperimentKind::CoastDown, &scene, &dir, "cd", 4, 0.0);
    rig.set(
        "motor.rotor_inertia_kg_m2",
        fw.value("motor.rotor_inertia_kg_m2").unwrap(),
    );
    rig.set("motor.viscous_Nm_s_rad", 1.3 * m.viscous_nm_s_rad);
    rig.set("motor.coulomb_Nm", 0.7 * m.coulomb_nm);
    let cd_rig = dir.join("cd_from_fw.rig.toml");
    std::fs::write(&cd_rig, rig.to_toml()).unwrap();
    let cd = ident(&rig, &cd_rig, &rec, None);
    check(
        "coast-down: viscous damping",
        cd.value("motor.viscous_Nm_s_rad").unwrap(),
        m.viscous_nm_s_rad,
    );
}

/// Acceptance 4: the real EMPS record, nominal rig (rigid mass, viscous friction) in the
/// known closed loop. It runs to completion; the structure lacks Coulomb friction and the
/// offset, so the viscous term must absorb the friction and the residuals stay coloured.
#[test]
fn emps_nominal_structure_runs_in_closed_loop_and_shows_its_gap() {
    let base = Path::new("../shared/data/real/emps");
    let rig_path = base.join("data_emps.rig.toml");
    let rig = Rig::load(&rig_path).unwrap();
    let rec = Recording::load(&base.join("data_emps.csv")).unwrap();
    let id = ident(&rig, &rig_path, &rec, None);
    print!("{}", agvsim::ident::report::render(&id));
    let mass = id.value("load.mass_kg").unwrap();
    let fv = id.value("load.viscous_N_s_m").unwrap();
    // Published inverse-model values (Janot et al. 2019): M = 95.11 kg, Fv = 203.5 N s/m,
    // Fc = 20.39 N. Mass is set by the accelerations, which friction hardly touches.
    assert!((mass - 95.11).abs() / 95.11 < 0.15, "mass {mass}");
    // At the trajectory's speeds (~0.1 m/s) a 20 N Coulomb force looks like ~200 N s/m more
    // viscous friction: the nominal structure must overestimate Fv.
    assert!(fv > 203.5 * 1.3, "viscous {fv}");
    let cmd = id.estimation.fit_pct["command_V"];
    assert!(cmd > 50.0 && cmd < 95.0, "command fit {cmd}");
    assert!(id.estimation.fit_pct["position_m"] > 99.0);
    assert!(
        !id.estimation
            .checks
            .iter()
            .find(|c| c.output == "command_V")
            .unwrap()
            .whiteness
            .passes
    );
}

/// Issue 14: the default machine is the thesis's as identified. The lab scene's lifted-wheel
/// experiment driven like the thesis's (25 ms samples, levels up to 90 % held 0.5-1.5 s),
/// identified with the thesis's case-1 structure and averaged over four seeds (one run's
/// fit scatters by about 10 %: the structure lacks the machine's fast turn path), gives
/// time constants within 15 % of the thesis's 0.65 s (left) and 0.58 s (right) and
/// turn/forward column ratios within 10 % of its 0.717 and 0.723 (section 5.2.1). The
/// tolerances are the issue's; the thesis's own standard deviations are 2-4 %.
#[test]
fn default_machine_identifies_as_the_thesis_dcmc() {
    use agvsim::study::thesis_dcmc::{identify_lifted, identify_lifted_mean, MATCH_SEEDS};
    let scene = Scene::load(Path::new("scenes/lab_offset_120mm.toml"), &[]).unwrap();
    let dir = tmp("thesis-dcmc");
    for seed in MATCH_SEEDS {
        let (m, _) = identify_lifted(&scene, &dir, seed, None).unwrap();
        println!(
            "seed {seed}: time constants {:.3?} s, turn/forward {:.3?}",
            m.time_constants_s(),
            m.column_ratios()
        );
    }
    println!("mean of seeds {MATCH_SEEDS:?}:");
    check_against_thesis(&identify_lifted_mean(&scene, &dir).unwrap());
}

fn check_against_thesis(m: &agvsim::study::thesis_dcmc::PairModel) {
    use agvsim::study::thesis_dcmc::CASE1;
    let (tau, ratio) = (m.time_constants_s(), m.column_ratios());
    let (tau_t, ratio_t) = (CASE1.time_constants_s(), CASE1.column_ratios());
    let b_t = CASE1.b_agvsim();
    println!("            thesis (agvsim signs)      agvsim default machine");
    for i in 0..2 {
        println!(
            "A{i}{i}        {:9.4} +- {:.4}      {:9.4}",
            CASE1.a_1_s[i],
            CASE1.a_std_1_s[i],
            m.a[(i, i)]
        );
    }
    for i in 0..2 {
        for j in 0..2 {
            println!(
                "B{i}{j}        {:9.4} +- {:.4}      {:9.4}",
                b_t[i][j],
                CASE1.b_std[i][j],
                m.b[(i, j)]
            );
        }
    }
    for i in 0..2 {
        println!(
            "side {i}: time constant {:.3} s (thesis {:.3}), turn/forward {:.3} (thesis {:.3})",
            tau[i], tau_t[i], ratio[i], ratio_t[i]
        );
        assert!((tau[i] / tau_t[i] - 1.0).abs() < 0.15, "time constant {i}");
        assert!(
            (ratio[i] / ratio_t[i] - 1.0).abs() < 0.10,
            "column ratio {i}"
        );
    }
}

/// Issue 14: the reference recording shipped in `data/thesis_case1/` is what its generator
/// makes (byte for byte), and agvsim's case-1 identification of it gives back the thesis's
/// A and B within the noise: each within three of the thesis's standard deviations at the
/// thesis's loss (the reference's own record is as informative as the thesis's).
#[test]
fn thesis_reference_recording_is_reproducible_and_identifies_as_the_thesis() {
    use agvsim::study::thesis_dcmc::{identify_lifted, reference_recording, ReferenceSpec, CASE1};
    let path = Path::new("data/thesis_case1/case1_reference.csv");
    let shipped = std::fs::read_to_string(path).unwrap();
    assert!(
        shipped == reference_recording(&ReferenceSpec::default()),
        "{} differs from its generator (agvsim study thesis-dcmc writes it)",
        path.display()
    );
    let scene = Scene::load(Path::new("scenes/lab_offset_120mm.toml"), &[]).unwrap();
    let (_, r) = identify_lifted(&scene, &tmp("thesis-ref"), 1, Some(path)).unwrap();
    let r = r.unwrap();
    let b_t = CASE1.b_agvsim();
    for i in 0..2 {
        let a = r.a[(i, i)];
        println!(
            "A{i}{i} {a:.4} (thesis {:.4} +- {:.4})",
            CASE1.a_1_s[i], CASE1.a_std_1_s[i]
        );
        assert!((a - CASE1.a_1_s[i]).abs() < 3.0 * CASE1.a_std_1_s[i].max(0.03 * a.abs()));
        for j in 0..2 {
            let b = r.b[(i, j)];
            println!(
                "B{i}{j} {b:.4} (thesis {:.4} +- {:.4})",
                b_t[i][j], CASE1.b_std[i][j]
            );
            assert!((b - b_t[i][j]).abs() < 3.0 * CASE1.b_std[i][j].max(0.03 * b.abs()));
        }
    }
}

/// Adds to every encoder-speed column of a recording file a coloured noise: a first-order
/// autoregression `e_k = phi e_(k-1) + sqrt(1 - phi^2) sd w_k` (w white, unit normal) with
/// a correlation time of `rows` samples. Writes the result beside it and loads it.
fn with_coloured_noise(path: &Path, sd: f64, rows: f64, seed: u64) -> Recording {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    let text = std::fs::read_to_string(path).unwrap();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let phi = (-1.0 / rows).exp();
    let mut header: Option<Vec<bool>> = None;
    let mut state: Vec<f64> = Vec::new();
    let mut out = String::new();
    for line in text.lines() {
        if line.starts_with('#') || line.trim().is_empty() {
            out.push_str(line);
        } else if header.is_none() {
            let noisy: Vec<bool> = line
                .split(',')
                .map(|c| c.ends_with("_speed_rad_s"))
                .collect();
            state = vec![0.0; noisy.len()];
            header = Some(noisy);
            out.push_str(line);
        } else {
            let noisy = header.as_ref().unwrap();
            let cells: Vec<String> = line
                .split(',')
                .enumerate()
                .map(|(j, c)| match (noisy[j], c.parse::<f64>()) {
                    (true, Ok(v)) => {
                        let w: f64 = StandardNormal.sample(&mut rng);
                        state[j] = phi * state[j] + (1.0 - phi * phi).sqrt() * sd * w;
                        format!("{}", v + state[j])
                    }
                    _ => c.to_string(),
                })
                .collect();
            out.push_str(&cells.join(","));
        }
        out.push('\n');
    }
    let noisy_path = path.with_extension("coloured.csv");
    std::fs::write(&noisy_path, out).unwrap();
    Recording::load(&noisy_path).unwrap()
}

/// Issue 29: standard deviations that hold when the residual is not white. The same
/// lifted runs as above, their encoder noise replaced by a coloured one (correlation time
/// ten samples, as slow disturbances and model mismatch leave on a real record). A record
/// of such a residual holds far fewer independent samples than rows, so an interval that
/// counts every row as independent is too narrow; the block-sandwich covariance over the
/// residual's correlation time must still cover the truth at about 68 %.
#[test]
fn intervals_cover_the_truth_when_the_residual_is_coloured() {
    let scene = Scene::load(Path::new("scenes/lifted_identification.toml"), &[]).unwrap();
    let truth = true_gain_model(&scene);
    let dir = tmp("coloured");
    let (mut inside, mut total) = (0, 0);
    let mut widths = Vec::new();
    for seed in 0..20u64 {
        let out = run_experiment(
            ExperimentKind::LiftedRandomDemand,
            &scene,
            &ExperimentOptions {
                out_dir: dir.clone(),
                name: Some(format!("c{seed}")),
                seed: Some(seed),
                rig_error: 0.2,
                speed_noise_rad_s: 0.0,
                ..ExperimentOptions::default()
            },
        )
        .unwrap();
        let rig = Rig::load(&out.rig).unwrap();
        let rec = with_coloured_noise(&out.recording, 1.0, 10.0, 1000 + seed);
        let id = ident(&rig, &out.rig, &rec, Some(ModelChoice::Gain));
        for (name, t) in &truth {
            let v = id.value(name).unwrap();
            let s = id.std(name).expect("determined");
            widths.push((v - t).abs() / s);
            total += 1;
            if (v - t).abs() <= s {
                inside += 1;
            }
        }
    }
    let coverage = inside as f64 / total as f64;
    widths.sort_by(f64::total_cmp);
    println!(
        "coloured noise (10-sample correlation), 20 seeds x 6 parameters: 1-sigma coverage {:.1} % ({inside}/{total}), median |error|/sigma {:.2}",
        100.0 * coverage,
        widths[widths.len() / 2]
    );
    // Nominal 68.3 % (median |error|/sigma 0.67); the same band as for white noise.
    assert!((0.55..=0.85).contains(&coverage), "coverage {coverage}");
}
