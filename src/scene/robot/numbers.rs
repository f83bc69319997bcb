//! The builder's numbers completed from a starting scene: each given, sized from the robot
//! ([`super::sizing`]) or the starting scene's; the derivations' inputs.

use super::sizing::{sized_mass_kg, DriveProportions};
use super::thesis;
use super::{MotorDatasheet, RobotSpec};
use crate::scene::Scene;

/// The builder's numbers, completed from a starting scene.
#[derive(Debug, Clone)]
pub(super) struct Numbers {
    pub(super) mass_kg: f64,
    /// Whether the mass was given (else sized from the outline: [`sized_mass_kg`]).
    pub(super) mass_given: bool,
    /// The starting scene's body outline (length, width; m) and mass, kg.
    pub(super) base_outline_m: [f64; 2],
    pub(super) base_mass_kg: f64,
    pub(super) track_m: f64,
    pub(super) wheel_radius_m: f64,
    pub(super) battery_v: f64,
    pub(super) rated_v: f64,
    pub(super) torque_constant_nm_a: f64,
    pub(super) resistance_ohm: f64,
    pub(super) ratio: f64,
    /// Whether the motor's datasheet and the gear ratio were given.
    pub(super) motor_given: bool,
    pub(super) ratio_given: bool,
    /// The starting scene's drive proportions, where the motor or gear (not given) was
    /// sized for this robot by them.
    pub(super) drive_sized: Option<DriveProportions>,
    pub(super) backlash_rad: f64,
    pub(super) length_m: f64,
    pub(super) width_m: f64,
    pub(super) castors: bool,
}

impl RobotSpec {
    /// The numbers, each given or taken from the starting scene.
    pub(super) fn numbers(&self, base: &Scene) -> (Numbers, Vec<String>) {
        let mut notes = Vec::new();
        let track_m = self.track_m.unwrap_or(base.chassis.track_width_m);
        let base_length = base.chassis.front_m + base.chassis.rear_m;
        let (length_m, width_m) = match (self.track_m, self.length_m, self.width_m) {
            (_, Some(l), Some(w)) => (l, w),
            (Some(t), l, w) => (
                l.unwrap_or(thesis::LENGTH_PER_TRACK * t),
                w.unwrap_or(t + thesis::WIDTH_OVER_TRACK_M),
            ),
            (None, l, w) => (l.unwrap_or(base_length), w.unwrap_or(base.chassis.width_m)),
        };
        // Not given, the mass is sized from the body's outline as the starting scene's
        // ([`sized_mass_kg`]), not carried over from a machine of another size.
        let base_outline = [base_length, base.chassis.width_m];
        let mass_kg = self.mass_kg.unwrap_or_else(|| {
            sized_mass_kg(base.chassis.mass_kg, base_outline, [length_m, width_m])
        });
        let wheel_radius_m = self.wheel_radius_m.unwrap_or(base.wheel.radius_m);
        let battery_v = self.battery_v.unwrap_or(base.battery.open_circuit_v);
        let drive = self.drive(base, mass_kg, wheel_radius_m, battery_v, &mut notes);
        let n = Numbers {
            mass_kg,
            mass_given: self.mass_kg.is_some(),
            base_outline_m: base_outline,
            base_mass_kg: base.chassis.mass_kg,
            track_m,
            wheel_radius_m,
            battery_v,
            rated_v: drive.rated_v,
            torque_constant_nm_a: drive.k_nm_a,
            resistance_ohm: drive.resistance_ohm,
            ratio: drive.ratio,
            motor_given: self.motor.is_some(),
            ratio_given: self.gear_ratio.is_some(),
            drive_sized: drive.sized_by,
            backlash_rad: self.backlash_rad.unwrap_or(if self.gear_ratio.is_some() {
                0.0
            } else {
                base.gearbox.backlash_rad
            }),
            length_m,
            width_m,
            castors: self
                .castors
                .unwrap_or(base.chassis.drive_load_fraction < 1.0),
        };
        (n, notes)
    }

    /// The motor (rated voltage, torque constant, resistance) and gear ratio: each given,
    /// sized for the robot ([`RobotSpec::size_drive`]) or the starting scene's.
    fn drive(
        &self,
        base: &Scene,
        mass_kg: f64,
        wheel_radius_m: f64,
        battery_v: f64,
        notes: &mut Vec<String>,
    ) -> Drive {
        let sized_by = self
            .size_drive
            .then(|| DriveProportions::of(base))
            .filter(|_| self.motor.is_none() || self.gear_ratio.is_none());
        let datasheet = self.motor.as_ref().map(|m| m.motor(notes));
        let (mut rated_v, mut k_nm_a, mut resistance_ohm) = datasheet.unwrap_or((
            base.battery.open_circuit_v,
            base.motor.torque_constant_nm_a,
            base.motor.resistance_ohm,
        ));
        // A motor sized (not given) runs on the robot's battery.
        let motor_sized = sized_by.filter(|_| datasheet.is_none());
        if motor_sized.is_some() {
            rated_v = battery_v;
        }
        // A gear not given is sized for the motor's torque constant: the datasheet's, or
        // the starting motor's where the motor is sized too.
        let ratio = self.gear_ratio.unwrap_or_else(|| {
            sized_by.map_or(base.gearbox.ratio, |p| {
                p.ratio(rated_v, k_nm_a, wheel_radius_m)
            })
        });
        // A motor not given is sized for the gear.
        if let Some(p) = motor_sized {
            k_nm_a = p.torque_constant_nm_a(rated_v, ratio, wheel_radius_m);
            resistance_ohm = p.resistance_ohm(rated_v, mass_kg);
        }
        Drive {
            rated_v,
            k_nm_a,
            resistance_ohm,
            ratio,
            sized_by,
        }
    }
}

/// A robot's motor and gear as the builder takes them ([`RobotSpec::drive`]).
struct Drive {
    /// The voltage the motor's numbers are rated at, V.
    rated_v: f64,
    /// Torque (back-EMF) constant, N m/A.
    k_nm_a: f64,
    /// Winding resistance, ohm.
    resistance_ohm: f64,
    /// Motor turns per wheel turn.
    ratio: f64,
    /// The proportions the motor or gear was sized by, where one was.
    sized_by: Option<DriveProportions>,
}

impl MotorDatasheet {
    /// The rated voltage, torque constant (N m/A) and resistance (ohm) of the datasheet
    /// point, with a note where its stall torque and stall current disagree.
    fn motor(&self, notes: &mut Vec<String>) -> (f64, f64, f64) {
        let no_load_rad_s = self.no_load_rpm * std::f64::consts::TAU / 60.0;
        let k = self.rated_v / no_load_rad_s;
        let stall_a = self
            .stall_current_a
            .unwrap_or_else(|| self.stall_torque_nm.unwrap_or(0.0) / k);
        if let (Some(i), Some(t)) = (self.stall_current_a, self.stall_torque_nm) {
            notes.push(format!(
                "the datasheet's stall torque {t} N m against {:.3} N m from its no-load speed and stall current ({:+.0} %): the difference is the motor's own friction and no-load current",
                k * i,
                100.0 * (t / (k * i) - 1.0)
            ));
        }
        (self.rated_v, k, self.rated_v / stall_a)
    }
}
