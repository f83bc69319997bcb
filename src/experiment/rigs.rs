//! The rig files the experiments write: the scene's values as the experimenter's beliefs,
//! optionally off by a seeded random error.

use rand::Rng;
use rand_pcg::Pcg64;

use super::{ExperimentOptions, ENCODER_COUNTS};
use crate::rig::{
    ChassisRig, ControllerRig, FallingWeightRig, GearboxRig, MotorRig, Rig, SensorsRig, SupplyRig,
    WheelRig,
};
use crate::scene::{DcmcKind, Scene};

fn motor_rig(scene: &Scene) -> MotorRig {
    let m = &scene.motor;
    MotorRig {
        resistance_ohm: Some(m.resistance_ohm),
        inductance_H: Some(m.inductance_H),
        torque_constant_Nm_A: Some(m.torque_constant_Nm_A),
        rotor_inertia_kg_m2: Some(m.rotor_inertia_kg_m2),
        viscous_Nm_s_rad: Some(m.viscous_Nm_s_rad),
        coulomb_Nm: Some(m.coulomb_Nm),
    }
}

fn encoder() -> Option<SensorsRig> {
    Some(SensorsRig {
        motor_encoder_counts_per_rev: Some(ENCODER_COUNTS),
        ..SensorsRig::default()
    })
}

pub(super) fn axis_rig(scene: &Scene) -> Rig {
    Rig {
        rig: "drive_axis".into(),
        motor: Some(motor_rig(scene)),
        gearbox: Some(GearboxRig {
            ratio: Some(scene.gearbox.ratio),
        }),
        wheel: Some(WheelRig {
            radius_m: Some(scene.wheel.radius_m),
            inertia_kg_m2: Some(scene.wheel.inertia_kg_m2),
        }),
        supply: Some(SupplyRig {
            voltage_V: Some(scene.battery.open_circuit_V),
        }),
        sensors: encoder(),
        ..Rig::default()
    }
}

fn controller_rig(scene: &Scene) -> ControllerRig {
    let d = &scene.dcmc;
    ControllerRig {
        kind: Some(
            match d.kind {
                // The contract's rigs know the gain structure; its speed loop is the
                // effect `speed_feedback` a diagnosis finds.
                DcmcKind::Gain | DcmcKind::GainPi => "gain",
                DcmcKind::P => "p",
                DcmcKind::Pi => "pi",
            }
            .into(),
        ),
        gain_V_pct: Some(d.forward_gain_V_pct),
        turn_gain_V_pct: Some(d.turn_gain_V_pct),
        speed_per_pct_rad_s: matches!(d.kind, DcmcKind::P | DcmcKind::Pi)
            .then_some(d.speed_per_pct_rad_s),
        kp_V_s_rad: matches!(d.kind, DcmcKind::P | DcmcKind::Pi).then_some(d.kp_V_s_rad),
        ki_V_rad: (d.kind == DcmcKind::Pi).then_some(d.ki_V_rad),
    }
}

pub(super) fn pair_rig(scene: &Scene) -> Rig {
    Rig {
        rig: "drive_pair".into(),
        controller: Some(controller_rig(scene)),
        ..axis_rig(scene)
    }
}

pub(super) fn falling_weight_rig(scene: &Scene, opts: &ExperimentOptions) -> Rig {
    Rig {
        rig: "drive_axis".into(),
        motor: Some(motor_rig(scene)),
        falling_weight: Some(FallingWeightRig {
            mass_kg: Some(opts.weight_mass_kg),
            pulley_radius_m: Some(opts.pulley_radius_m),
            drop_m: Some(opts.drop_m),
        }),
        sensors: encoder(),
        ..Rig::default()
    }
}

pub(super) fn vehicle_rig(scene: &Scene) -> Rig {
    let c = &scene.chassis;
    Rig {
        rig: "vehicle".into(),
        controller: Some(controller_rig(scene)),
        chassis: Some(ChassisRig {
            mass_kg: Some(c.mass_kg + scene.payload.mass_kg),
            yaw_inertia_kg_m2: Some(c.yaw_inertia_kg_m2),
            track_width_m: Some(c.track_width_m),
            drive_load_fraction: Some(c.drive_load_fraction),
        }),
        ..axis_rig(scene)
    }
}

/// Multiplies each uncertain value by a factor uniform in [1 - e, 1 + e]. Gear ratio,
/// wheel radius, track and the test set-up (weight, pulley, drop) are measured, not believed.
pub(super) fn perturb(rig: Rig, e: f64, rng: &mut Pcg64) -> Rig {
    if e <= 0.0 {
        return rig;
    }
    let mut f = |v: &mut Option<f64>| {
        if let Some(x) = v {
            *x *= 1.0 + e * rng.random_range(-1.0..=1.0);
        }
    };
    let mut rig = rig;
    if let Some(m) = rig.motor.as_mut() {
        f(&mut m.resistance_ohm);
        f(&mut m.inductance_H);
        f(&mut m.torque_constant_Nm_A);
        f(&mut m.rotor_inertia_kg_m2);
        f(&mut m.viscous_Nm_s_rad);
        f(&mut m.coulomb_Nm);
    }
    if let Some(w) = rig.wheel.as_mut() {
        f(&mut w.inertia_kg_m2);
    }
    if let Some(c) = rig.controller.as_mut() {
        f(&mut c.gain_V_pct);
        f(&mut c.turn_gain_V_pct);
        f(&mut c.speed_per_pct_rad_s);
        f(&mut c.kp_V_s_rad);
        f(&mut c.ki_V_rad);
    }
    if let Some(c) = rig.chassis.as_mut() {
        f(&mut c.mass_kg);
        f(&mut c.yaw_inertia_kg_m2);
    }
    rig
}
