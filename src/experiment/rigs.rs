//! The rig files the experiments write: the scene's values as the experimenter's beliefs,
//! optionally off by a seeded random error. Each rig key is read from the scene key it
//! names ([`crate::rig::keys`]).

use crate::model::chassis::ChassisParams;
use crate::model::gearbox::GearboxParams;
use crate::model::motor::MotorParams;
use crate::model::wheel::WheelParams;
use crate::rig::blocks::FallingWeight;
use crate::rig::blocks::Instruments;
use crate::rig::keys::alias;
use rand::Rng;
use rand_pcg::Pcg64;

use super::{ExperimentOptions, ENCODER_COUNTS};
use crate::model::dcmc::DcmcKind;
use crate::rig::{Rig, RigKind};
use crate::scene::Scene;

/// The motor's rig keys.
const MOTOR: [&str; 6] = [
    MotorParams::resistance_ohm.key(),
    MotorParams::inductance_h.key(),
    MotorParams::torque_constant_nm_a.key(),
    MotorParams::rotor_inertia_kg_m2.key(),
    MotorParams::viscous_nm_s_rad.key(),
    MotorParams::coulomb_nm.key(),
];

/// A lifted drive axis: motor, gearbox, wheel, supply and the motor encoder.
pub(super) fn axis_rig(scene: &Scene) -> Rig {
    let mut keys = MOTOR.to_vec();
    keys.extend([
        GearboxParams::ratio.key(),
        WheelParams::radius_m.key(),
        WheelParams::inertia_kg_m2.key(),
        alias::SUPPLY_VOLTAGE_V.key(),
    ]);
    with_encoder(Rig::from_scene(RigKind::DriveAxis, scene, &keys))
}

fn with_encoder(mut rig: Rig) -> Rig {
    rig.set(
        Instruments::motor_encoder_counts_per_rev.key(),
        ENCODER_COUNTS,
    );
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
    rig.set_text(alias::CONTROLLER_KIND.key(), kind);
    rig.set(alias::CONTROLLER_GAIN_V_PCT.key(), d.forward_gain_v_pct);
    rig.set(alias::CONTROLLER_TURN_GAIN_V_PCT.key(), d.turn_gain_v_pct);
    if matches!(d.kind, DcmcKind::P | DcmcKind::Pi) {
        rig.set(
            alias::CONTROLLER_SPEED_PER_PCT_RAD_S.key(),
            d.speed_per_pct_rad_s,
        );
        rig.set(alias::CONTROLLER_KP_V_S_RAD.key(), d.kp_v_s_rad);
    }
    if d.kind == DcmcKind::Pi {
        rig.set(alias::CONTROLLER_KI_V_RAD.key(), d.ki_v_rad);
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
    let mut rig = with_encoder(Rig::from_scene(RigKind::DriveAxis, scene, &MOTOR));
    rig.set(FallingWeight::mass_kg.key(), opts.weight_mass_kg);
    rig.set(FallingWeight::pulley_radius_m.key(), opts.pulley_radius_m);
    rig.set(FallingWeight::drop_m.key(), opts.drop_m);
    rig
}

/// The whole vehicle: the axis's keys, the DCMC and the chassis with its payload.
pub(super) fn vehicle_rig(scene: &Scene) -> Rig {
    let mut rig = with_controller(axis_rig(scene), scene);
    rig.rig = RigKind::Vehicle;
    let c = &scene.chassis;
    rig.set(
        ChassisParams::mass_kg.key(),
        c.mass_kg + scene.payload.mass_kg,
    );
    rig.set(ChassisParams::yaw_inertia_kg_m2.key(), c.yaw_inertia_kg_m2);
    rig.set(ChassisParams::track_width_m.key(), c.track_width_m);
    rig.set(
        ChassisParams::drive_load_fraction.key(),
        c.drive_load_fraction,
    );
    rig
}

/// Keys that are measured, not believed: gear ratio, wheel radius, track, the supply and
/// the test set-up (weight, pulley, drop, encoder).
fn measured(key: &str) -> bool {
    [
        GearboxParams::ratio,
        WheelParams::radius_m,
        alias::SUPPLY_VOLTAGE_V,
        ChassisParams::track_width_m,
        ChassisParams::drive_load_fraction,
    ]
    .iter()
    .any(|k| k.key() == key)
        || key.starts_with("falling_weight.")
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
