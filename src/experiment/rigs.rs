//! The rig files the experiments write: the scene's values as the experimenter's beliefs,
//! optionally off by a seeded random error. Each rig key is read from the scene key it
//! names ([`crate::rig::keys`]).

use rand::Rng;
use rand_pcg::Pcg64;

use super::{ExperimentOptions, ENCODER_COUNTS};
use crate::model::dcmc::DcmcKind;
use crate::rig::{Rig, RigKind};
use crate::scene::Scene;

/// The motor's rig keys.
const MOTOR: [&str; 6] = [
    "motor.resistance_ohm",
    "motor.inductance_H",
    "motor.torque_constant_Nm_A",
    "motor.rotor_inertia_kg_m2",
    "motor.viscous_Nm_s_rad",
    "motor.coulomb_Nm",
];

/// A rig of `kind` stating the scene's value of each rig key in `keys`.
fn from_scene(kind: RigKind, scene: &Scene, keys: &[&str]) -> Rig {
    let mut rig = Rig::new(kind);
    let table = crate::scene::keys::table();
    for key in keys {
        let value = crate::rig::keys::find(key)
            .and_then(|k| k.scene_key)
            .and_then(|scene_key| table.find(scene_key))
            .and_then(|k| k.get(scene));
        if let Some(v) = value {
            rig.set(key, v);
        }
    }
    rig
}

/// A lifted drive axis: motor, gearbox, wheel, supply and the motor encoder.
pub(super) fn axis_rig(scene: &Scene) -> Rig {
    let mut keys = MOTOR.to_vec();
    keys.extend([
        "gearbox.ratio",
        "wheel.radius_m",
        "wheel.inertia_kg_m2",
        "supply.voltage_V",
    ]);
    with_encoder(from_scene(RigKind::DriveAxis, scene, &keys))
}

fn with_encoder(mut rig: Rig) -> Rig {
    rig.set("sensors.motor_encoder_counts_per_rev", ENCODER_COUNTS);
    rig
}

/// The DCMC as the contract's rigs describe it: its gains, and its speed loop for `p` and
/// `pi` (the contract knows the gain structure; its speed loop is the effect
/// `speed_feedback` a diagnosis finds).
fn with_controller(mut rig: Rig, scene: &Scene) -> Rig {
    let d = &scene.dcmc;
    let kind = match d.kind {
        DcmcKind::Gain | DcmcKind::GainPi => "gain",
        DcmcKind::P => "p",
        DcmcKind::Pi => "pi",
    };
    rig.set_text("controller.kind", kind);
    rig.set("controller.gain_V_pct", d.forward_gain_v_pct);
    rig.set("controller.turn_gain_V_pct", d.turn_gain_v_pct);
    if matches!(d.kind, DcmcKind::P | DcmcKind::Pi) {
        rig.set("controller.speed_per_pct_rad_s", d.speed_per_pct_rad_s);
        rig.set("controller.kp_V_s_rad", d.kp_v_s_rad);
    }
    if d.kind == DcmcKind::Pi {
        rig.set("controller.ki_V_rad", d.ki_v_rad);
    }
    rig
}

/// Two lifted drive axes behind the DCMC.
pub(super) fn pair_rig(scene: &Scene) -> Rig {
    let mut rig = with_controller(axis_rig(scene), scene);
    rig.rig = RigKind::DrivePair;
    rig
}

/// The motor off the vehicle under a falling weight.
pub(super) fn falling_weight_rig(scene: &Scene, opts: &ExperimentOptions) -> Rig {
    let mut rig = with_encoder(from_scene(RigKind::DriveAxis, scene, &MOTOR));
    rig.set("falling_weight.mass_kg", opts.weight_mass_kg);
    rig.set("falling_weight.pulley_radius_m", opts.pulley_radius_m);
    rig.set("falling_weight.drop_m", opts.drop_m);
    rig
}

/// The whole vehicle: the axis's keys, the DCMC and the chassis with its payload.
pub(super) fn vehicle_rig(scene: &Scene) -> Rig {
    let mut rig = with_controller(axis_rig(scene), scene);
    rig.rig = RigKind::Vehicle;
    let c = &scene.chassis;
    rig.set("chassis.mass_kg", c.mass_kg + scene.payload.mass_kg);
    rig.set("chassis.yaw_inertia_kg_m2", c.yaw_inertia_kg_m2);
    rig.set("chassis.track_width_m", c.track_width_m);
    rig.set("chassis.drive_load_fraction", c.drive_load_fraction);
    rig
}

/// Keys that are measured, not believed: gear ratio, wheel radius, track, the supply and
/// the test set-up (weight, pulley, drop, encoder).
fn measured(key: &str) -> bool {
    matches!(
        key,
        "gearbox.ratio"
            | "wheel.radius_m"
            | "supply.voltage_V"
            | "chassis.track_width_m"
            | "chassis.drive_load_fraction"
    ) || key.starts_with("falling_weight.")
        || key.starts_with("sensors.")
}

/// Multiplies each uncertain value by a factor uniform in [1 - e, 1 + e], in the rig's
/// key order.
pub(super) fn perturb(rig: Rig, e: f64, rng: &mut Pcg64) -> Rig {
    if e <= 0.0 {
        return rig;
    }
    let mut rig = rig;
    rig.map_numbers(|key, x| {
        if measured(key) {
            x
        } else {
            x * (1.0 + e * rng.random_range(-1.0..=1.0))
        }
    });
    rig
}
