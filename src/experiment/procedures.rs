//! How each experiment is run on the simulated machine and sampled into its recording's
//! rows (the module's list says what each is).

use super::{
    lifted_scene, steps_per, DemandPattern, EncoderSpeed, ExperimentError, ExperimentOptions,
    ENCODER_COUNTS,
};
use crate::model::motor::{MotorParams, MotorState, Terminal};
use crate::model::Bounded;
use crate::model::GRAVITY_M_S2;
use crate::record::channels as chan;
use crate::record::header;
use crate::record::Recording;
use crate::scene::Scene;
use crate::sim::{Actuation, Sim};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use rand_pcg::Pcg64;
use std::fmt::Write as _;
use std::path::Path;

/// `lifted-random-demand`: the CSV and its row count.
pub(super) fn lifted_random_demand(
    scene: &Scene,
    opts: &ExperimentOptions,
    interval: f64,
    rng: &mut Pcg64,
) -> Result<(String, usize), ExperimentError> {
    let scene = lifted_scene(scene);
    let mut sim = Sim::new(&scene)?;
    let per = steps_per(interval, sim.params().sim.dt_s)?;
    let n = (opts.duration_s / interval).round() as usize;
    // Zero demand for the DCMC's enable delay, so that the unit does not fault.
    let quiet = ((scene.dcmc.enable_delay_s + 0.1) / interval).ceil() as usize;
    let peak = opts.peak_demand_pct;
    let mut demand = [0.0, 0.0];
    let mut hold_left = 0usize;
    let mut csv = header(
        crate::rig::RigKind::DrivePair,
        &[
            ("description", format!("wheels lifted, {:?} forward and turn demands into the DCMC, motor encoders ({} counts/rev)", opts.pattern, ENCODER_COUNTS).to_lowercase()),
            ("sample_time_s", format!("{interval}")),
            ("source", format!("agvsim {} simulation, fidelity {}", env!("CARGO_PKG_VERSION"), sim.params().sim.fidelity.name())),
            ("experiment", "lifted-random-demand".into()),
            ("seed", format!("{}", scene.sim.seed)),
        ],
        &[chan::T_S, chan::DEMAND_FWD_PCT, chan::DEMAND_TURN_PCT, chan::LEFT_MOTOR_SPEED_RAD_S, chan::RIGHT_MOTOR_SPEED_RAD_S],
    );
    let mut encoders = [0, 1].map(|i| EncoderSpeed::new(sim.drivetrains()[i].motor.angle_rad));
    for k in 0..=n {
        let t = k as f64 * interval;
        // Demand applied from this row to the next (zero-order hold).
        if k >= quiet {
            match opts.pattern {
                DemandPattern::Pulses => {
                    if hold_left == 0 {
                        demand = [
                            rng.random_range(-peak..=peak),
                            rng.random_range(-0.5 * peak..=0.5 * peak),
                        ];
                        hold_left = rng.random_range(opts.hold_samples.0..=opts.hold_samples.1);
                    }
                    hold_left -= 1;
                }
                DemandPattern::Walk => {
                    for (i, d) in demand.iter_mut().enumerate() {
                        let lim = peak * [1.0, 0.5][i];
                        let step: f64 = StandardNormal.sample(rng);
                        *d = (*d + 0.1 * lim * step).bounded(-lim, lim);
                    }
                }
            }
        }
        let mut speed = [0.0; 2];
        for i in 0..2 {
            let read = encoders[i].read(sim.drivetrains()[i].motor.angle_rad, interval);
            if k > 0 {
                let noise: f64 = StandardNormal.sample(rng);
                speed[i] = read + opts.speed_noise_rad_s * noise;
            }
        }
        let _ = writeln!(
            csv,
            "{t:.6},{:.4},{:.4},{:.5},{:.5}",
            demand[0], demand[1], speed[0], speed[1]
        );
        if k == n {
            break;
        }
        sim.set_actuation(Actuation::Demand {
            forward_pct: demand[0],
            turn_pct: demand[1],
        });
        for _ in 0..per {
            sim.step()?;
        }
    }
    Ok((csv, n + 1))
}

/// `falling-weight`: the CSV and its row count.
pub(super) fn falling_weight(
    scene: &Scene,
    opts: &ExperimentOptions,
    interval: f64,
    rng: &mut Pcg64,
) -> (String, usize) {
    let motor = scene.motor;
    let (m, r) = (opts.weight_mass_kg, opts.pulley_radius_m);
    // While the cord is taut the weight's inertia rides on the rotor.
    let loaded = MotorParams {
        rotor_inertia_kg_m2: motor.rotor_inertia_kg_m2 + m * r * r,
        ..motor
    };
    let weight_torque = m * GRAVITY_M_S2 * r;
    let h = 1e-4;
    let per = ((interval / h).round() as u64).max(1);
    let mut s = MotorState::default();
    let mut csv = header(
        crate::rig::RigKind::DriveAxis,
        &[
            (
                "description",
                format!(
                    "falling weight: {m} kg on a {r} m pulley, {} m drop, motor open-circuited",
                    opts.drop_m
                ),
            ),
            ("sample_time_s", format!("{}", per as f64 * h)),
            (
                "source",
                format!("agvsim {} motor model", env!("CARGO_PKG_VERSION")),
            ),
            ("experiment", "falling-weight".into()),
        ],
        &[chan::T_S, chan::MOTOR_SPEED_RAD_S, "back_emf_V"],
    );
    let mut encoder = EncoderSpeed::new(s.angle_rad);
    let mut rows = 0;
    let mut at_rest_since = None;
    let max_rows = (60.0 / (per as f64 * h)) as usize;
    for k in 0..max_rows {
        let t = k as f64 * per as f64 * h;
        let speed = encoder.read(s.angle_rad, per as f64 * h);
        let n: f64 = StandardNormal.sample(rng);
        let emf = motor.back_emf_v(s.speed_rad_s) + opts.voltage_noise_v * n;
        let _ = writeln!(csv, "{t:.6},{speed:.5},{emf:.5}");
        rows += 1;
        let falling = s.angle_rad * r < opts.drop_m;
        if !falling && s.speed_rad_s == 0.0 {
            let since = *at_rest_since.get_or_insert(t);
            if t - since > 0.2 {
                break;
            }
        }
        for _ in 0..per {
            if s.angle_rad * r < opts.drop_m {
                loaded.step(&mut s, Terminal::Open, -weight_torque, h);
            } else {
                motor.step(&mut s, Terminal::Open, 0.0, h);
            }
        }
    }
    (csv, rows)
}

/// `coast-down`: the CSV and its row count.
pub(super) fn coast_down(
    scene: &Scene,
    opts: &ExperimentOptions,
    interval: f64,
    rng: &mut Pcg64,
) -> Result<(String, usize), ExperimentError> {
    let scene = lifted_scene(scene);
    let mut sim = Sim::new(&scene)?;
    let per = steps_per(interval, sim.params().sim.dt_s)?;
    let full = scene.battery.drive_limit_v;
    sim.set_actuation(Actuation::Voltage([full, full]));
    // Run up until the speed has settled (five mechanical time constants, at least 2 s).
    let m = scene.motor;
    let j = m.rotor_inertia_kg_m2 + scene.wheel.inertia_kg_m2 / scene.gearbox.ratio.powi(2);
    let tau = m.mechanical_time_constant_s(j);
    sim.run_for((5.0 * tau).max(2.0), |_| {})?;
    sim.set_actuation(Actuation::Open);
    let mut csv = header(
        crate::rig::RigKind::DriveAxis,
        &[
            (
                "description",
                format!("coast-down: left wheel lifted, run up at {full} V, power cut at t = 0"),
            ),
            ("sample_time_s", format!("{interval}")),
            (
                "source",
                format!(
                    "agvsim {} simulation, fidelity {}",
                    env!("CARGO_PKG_VERSION"),
                    sim.params().sim.fidelity.name()
                ),
            ),
            ("experiment", "coast-down".into()),
        ],
        &[chan::T_S, chan::MOTOR_SPEED_RAD_S],
    );
    let mut encoder = EncoderSpeed::new(sim.drivetrains()[0].motor.angle_rad);
    let mut rows = 0;
    let mut at_rest_since = None;
    for k in 0..(60.0 / interval) as usize {
        let t = k as f64 * interval;
        let w = sim.drivetrains()[0].motor.speed_rad_s;
        // The first row has no previous read: the run-up's settled speed.
        let speed = if k == 0 {
            w
        } else {
            encoder.read(sim.drivetrains()[0].motor.angle_rad, interval)
        };
        let n: f64 = StandardNormal.sample(rng);
        let _ = writeln!(csv, "{t:.6},{:.5}", speed + opts.speed_noise_rad_s * n);
        rows += 1;
        if w == 0.0 {
            let since = *at_rest_since.get_or_insert(t);
            if t - since > 0.2 {
                break;
            }
        }
        for _ in 0..per {
            sim.step()?;
        }
    }
    Ok((csv, rows))
}

/// Pen dashes from a floor-run recording: `t_s, x_m, y_m` of each dash start, with the
/// pen's play as a uniform error.
pub(super) fn pen_trace(
    recording: &Path,
    interval: f64,
    play_m: f64,
    rng: &mut Pcg64,
) -> Result<(String, usize), ExperimentError> {
    let rec = Recording::load(recording).map_err(|e| ExperimentError::Setup(e.to_string()))?;
    let col = |n: &str| -> Result<Vec<f64>, ExperimentError> {
        rec.require_complete(n)
            .map_err(|e| ExperimentError::Setup(e.to_string()))
    };
    let (x, y) = (col(chan::X_M)?, col(chan::Y_M)?);
    let mut out = String::from("# agvsim-pen-trace: 1\n# description: pen dash starts (drive-axle midpoint), with pen play\nt_s,x_m,y_m\n");
    let mut n = 0;
    let mut next = 0.0;
    for k in 0..rec.t_s.len() {
        if rec.t_s[k] + 1e-9 >= next {
            let jitter = |rng: &mut Pcg64| play_m * (rng.random::<f64>() - 0.5);
            let _ = writeln!(
                out,
                "{:.4},{:.5},{:.5}",
                rec.t_s[k],
                x[k] + jitter(rng),
                y[k] + jitter(rng)
            );
            n += 1;
            next += interval;
        }
    }
    Ok((out, n))
}
