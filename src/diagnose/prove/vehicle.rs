//! The proof's whole-vehicle cases on the floor (full fidelity: rapier chassis, tyres,
//! castors): the clean vehicle, wheel slip and castor drag, each recorded with open-loop
//! voltages, encoders and a pose tracker, and diagnosed against a nominal vehicle rig.

use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use rand_pcg::Pcg64;

use super::{current_sense, nominal_rig, sampling, simulation_source, ProveError};
use crate::experiment::EncoderSpeed;
use crate::ident::effects::Effect;
use crate::model::chassis::ChassisParams;
use crate::model::wheel::WheelParams;
use crate::record::channels as chan;
use crate::rig::blocks::Instruments;
use crate::rig::Rig;
use crate::scene::Scene;
use crate::sim::{Actuation, Sim};
use std::fmt::Write as _;

/// A whole-vehicle proof case on the floor (full fidelity: rapier chassis, tyres, castors).
pub(super) struct VehicleSpec {
    pub(super) name: &'static str,
    pub(super) effect: Option<Effect>,
    pub(super) overrides: Vec<String>,
}

/// The vehicle cases: clean, wheel slip on a slippery floor, castor drag.
pub(super) fn vehicle_specs() -> Vec<VehicleSpec> {
    // Physics the vocabulary names only where the case says so: a stiff gear mesh without
    // play, no brush friction, the centre of mass on the drive axle (the rig format has no
    // key for an offset), castors that swivel and roll freely.
    let base: Vec<String> = [
        "sim.fidelity=full",
        "gearbox.backlash_rad=0",
        "gearbox.tooth_stiffness_Nm_rad=100000",
        "motor.coulomb_Nm=0",
        "chassis.cg_x_m=0",
        "payload.cg_x_m=0",
        "castors.swivel_friction_Nm=0",
        "castors.rolling_resistance=0",
        "tyre.compound=high_grip",
        "wire.points_m=[[-50.0, 0.0], [50.0, 0.0]]",
    ]
    .map(String::from)
    .to_vec();
    let with = |extra: &[&str]| {
        let mut v = base.clone();
        v.extend(extra.iter().map(|s| s.to_string()));
        v
    };
    vec![
        VehicleSpec {
            name: "vehicle_clean",
            effect: None,
            overrides: base.clone(),
        },
        VehicleSpec {
            name: "vehicle_wheel_slip",
            effect: Some(Effect::WheelSlip),
            // A slippery floor for the drive tyres: grip 0.15 at the peak.
            overrides: with(&["tyre.compound=hard_polyurethane", "tyre.peak_mu=0.15"]),
        },
        VehicleSpec {
            name: "vehicle_castor_drag",
            effect: Some(Effect::CastorDrag),
            overrides: with(&["castors.rolling_resistance=0.05"]),
        },
    ]
}

/// A floor recording with open-loop voltages: smoothed random forward (2.5-8 V) and turn
/// (+-2 V) levels held 0.3-1 s, encoders (1024 counts) at `rate_hz`, a pose tracker (2 mm, 0.005 rad) on every
/// fourth row.
pub(super) fn record_vehicle(
    scene: &Scene,
    duration_s: f64,
    rate_hz: f64,
    rng: &mut Pcg64,
) -> Result<String, ProveError> {
    let mut sim = Sim::new(scene).map_err(ProveError::from)?;
    let (per, interval, n) = sampling(&sim, rate_hz, duration_s);
    let mut csv = crate::record::header(
        crate::rig::RigKind::Vehicle,
        &[
            (
                "description",
                "agvsim proof case, vehicle on the floor, open-loop random voltages, tracker on every fourth row".into(),
            ),
            ("sample_time_s", format!("{interval}")),
            ("source", simulation_source(&sim)),
        ],
        &[
            chan::T_S,
            chan::LEFT_VOLTAGE_V,
            chan::RIGHT_VOLTAGE_V,
            chan::X_M,
            chan::Y_M,
            chan::HEADING_RAD,
            chan::LEFT_MOTOR_SPEED_RAD_S,
            chan::RIGHT_MOTOR_SPEED_RAD_S,
            chan::LEFT_CURRENT_A,
            chan::RIGHT_CURRENT_A,
        ],
    );
    let (mut target, mut level, mut hold) = ([0.0f64; 2], [0.0f64; 2], 0usize);
    let mut encoders = [0, 1].map(|s| EncoderSpeed::new(sim.drivetrains()[s].motor.angle_rad));
    let smoothing = (-interval / 0.15).exp();
    for k in 0..=n {
        if hold == 0 {
            // Both wheels always forward: a castor that flips round on a reversal scrubs
            // sideways at full friction for a moment, a force far beyond its rolling drag
            // that would swamp the drag the case is about.
            let fwd = rng.random_range(2.5..=8.0);
            let turn = rng.random_range(-2.0..=2.0);
            target = [fwd - turn, fwd + turn];
            hold = rng
                .random_range((0.3 / interval) as usize..=(1.0 / interval) as usize)
                .max(1);
        }
        hold -= 1;
        for s in 0..2 {
            level[s] = smoothing * level[s] + (1.0 - smoothing) * target[s];
        }
        let mut speed = [0.0; 2];
        for (s, d) in sim.drivetrains().iter().enumerate() {
            speed[s] = encoders[s].read(d.motor.angle_rad, interval);
        }
        let pose = sim.pose();
        let tracker = if k % 4 == 0 {
            let mut noise = || -> f64 { StandardNormal.sample(rng) };
            format!(
                "{:.5},{:.5},{:.5}",
                pose.x_m + 0.002 * noise(),
                pose.y_m + 0.002 * noise(),
                pose.heading_rad + 0.005 * noise()
            )
        } else {
            ",,".into()
        };
        let mut current = [0.0; 2];
        for (s, d) in sim.drivetrains().iter().enumerate() {
            current[s] = current_sense(d.motor.current_a, rng);
        }
        let _ = writeln!(
            csv,
            "{:.6},{:.4},{:.4},{tracker},{:.4},{:.4},{:.2},{:.2}",
            k as f64 * interval,
            level[0],
            level[1],
            speed[0],
            speed[1],
            current[0],
            current[1]
        );
        sim.set_actuation(Actuation::Voltage(level));
        for _ in 0..per {
            sim.step().map_err(ProveError::from)?;
        }
    }
    Ok(csv)
}

/// The vehicle rig an experimenter would write: the scene's values 5-25 % off (wheel radius
/// and track 1-3 %), and no word of the effect.
pub(super) fn nominal_vehicle_rig(scene: &Scene, rng: &mut Pcg64) -> Result<Rig, ProveError> {
    let params = crate::sim::SimParams::from_scene(scene).map_err(ProveError::from)?;
    let mut rig = nominal_rig(scene, &mut Pcg64::seed_from_u64(rng.random()));
    let mut off = |x: f64, lo: f64, hi: f64| {
        let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
        x * (1.0 + sign * rng.random_range(lo..hi))
    };
    rig.rig = crate::rig::RigKind::Vehicle;
    let c = &params.chassis;
    let load_fraction = params.loads.drive_n.iter().sum::<f64>() / params.weight_n();
    rig.set(ChassisParams::mass_kg.key(), off(c.mass_kg, 0.05, 0.25));
    rig.set(
        ChassisParams::yaw_inertia_kg_m2.key(),
        off(c.yaw_inertia_kg_m2, 0.05, 0.25),
    );
    rig.set(
        ChassisParams::track_width_m.key(),
        off(c.track_width_m, 0.01, 0.03),
    );
    rig.set(ChassisParams::drive_load_fraction.key(), load_fraction);
    rig.set(
        WheelParams::radius_m.key(),
        off(scene.wheel.radius_m, 0.01, 0.03),
    );
    rig.set(Instruments::current_noise_a.key(), 0.2);
    rig.set(Instruments::tracker_position_noise_m.key(), 0.002);
    rig.set(Instruments::tracker_heading_noise_rad.key(), 0.005);
    rig.set(Instruments::tracker_rate_hz.key(), rate_hz_of_tracker());
    Ok(rig)
}

fn rate_hz_of_tracker() -> f64 {
    VEHICLE_RATE_HZ / 4.0
}

/// Encoder rate of the vehicle proof, Hz.
pub(super) const VEHICLE_RATE_HZ: f64 = 200.0;

/// The truth of a vehicle case's effect parameter, from the scene.
pub(super) fn vehicle_truth(scene: &Scene, effect: Option<Effect>) -> Result<f64, ProveError> {
    let params = crate::sim::SimParams::from_scene(scene).map_err(ProveError::from)?;
    Ok(match effect {
        Some(Effect::WheelSlip) => params.drive_tyre(params.floor.default).peak_mu,
        Some(Effect::CastorDrag) => {
            params.castors.rolling_resistance * params.loads.castor_n.iter().sum::<f64>()
        }
        _ => 0.0,
    })
}
