//! Plausibility: values each inside its key's rule that do not fit the machine's own
//! size and supply (a thesis value left in a scene for another robot, a typo of a
//! factor of ten). They are warnings, not errors: a scene may mean them. Each names the
//! key, its value, what the rest of the scene would lead one to expect, and why.

use super::Scene;
use crate::model::battery::BatteryParams;
use crate::model::chassis::ChassisParams;
use crate::model::dcmc::DcmcKind;
use crate::model::dcmc::DcmcParams;
use crate::model::gearbox::GearboxParams;
use crate::model::motor::MotorParams;
use crate::model::tyre::TyreChoice;
use crate::model::wheel::WheelParams;
use crate::param::plain_number as num;

/// One value that does not fit the rest of the scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Warning {
    /// The dotted key.
    pub key: &'static str,
    /// Its value, with its unit.
    pub value: String,
    /// What the rest of the scene leads one to expect.
    pub expected: String,
    /// Why.
    pub why: String,
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "`{}` = {}: expected {}: {}",
            self.key, self.value, self.expected, self.why
        )
    }
}

/// A uniform slab's yaw inertia about its centre, kg m^2: `m (L^2 + W^2) / 12`.
pub fn slab_yaw_inertia_kg_m2(mass_kg: f64, length_m: f64, width_m: f64) -> f64 {
    mass_kg * (length_m * length_m + width_m * width_m) / 12.0
}

/// The yaw inertia a body may have against the uniform slab of its footprint: from mass
/// gathered near the centre (a third) to mass near the corners (point masses at the
/// corners give three times the slab; two is the plausible end for a real chassis).
const YAW_INERTIA_SPAN: (f64, f64) = (1.0 / 3.0, 2.0);

/// Friction coefficients drive tyres of rubber or polyurethane reach on floors (wet epoxy
/// to dry rough concrete); above is racing rubber or a no-slip idealisation.
const TYRE_MU_SPAN: (f64, f64) = (0.1, 1.3);

/// Sizes a differential-drive vehicle has, from a toy robot to a heavy AGV: outside them a
/// value is most likely in another unit (millimetres, grams, millivolts typed as metres,
/// kilograms, volts). (key, unit, lowest, highest, the unit it looks typed in).
const VEHICLE_SIZES: [(&str, &str, f64, f64, &str); 5] = [
    (ChassisParams::mass_kg.key(), "kg", 0.2, 30_000.0, "grams"),
    (
        ChassisParams::track_width_m.key(),
        "m",
        0.03,
        5.0,
        "millimetres",
    ),
    (WheelParams::radius_m.key(), "m", 0.005, 1.0, "millimetres"),
    (
        BatteryParams::open_circuit_v.key(),
        "V",
        1.0,
        1_000.0,
        "millivolts",
    ),
    (
        GearboxParams::ratio.key(),
        "motor turns per wheel turn",
        0.1,
        1_000.0,
        "another convention",
    ),
];

/// Fastest top speed (the motors' no-load speed at the drive limit, at the wheel) of a
/// wheeled robot or AGV, m/s: industrial AGVs run under 2 m/s, fast mobile robots under 10.
const TOP_SPEED_MAX_M_S: f64 = 20.0;

/// Slowest top speed of a robot that drives itself, m/s: a motor's no-load speed given in
/// rad/s where rpm is asked, or a gearmotor's output speed geared down again, lands below.
const TOP_SPEED_MIN_M_S: f64 = 0.1;

/// Heaviest a vehicle is for its footprint: the mass over `A^1.5` (A the body's outline
/// area, m^2), kg/m^3. A box as tall as its footprint is wide and full of water has 1000;
/// robots are mostly air and lower than wide (the thesis machine 246, a TurtleBot 3 about
/// 260, OptiOdom's robot 90, a 1 t pallet AGV about 550). Twice water is another machine's
/// mass on this body (the thesis machine's 120 kg on a 0.2 m track's body gives 2600).
const MASS_PER_FOOTPRINT_1_5_MAX: f64 = 2000.0;

/// The force the two motors at their current limit (or stall) push at the wheels, over the
/// robot's weight: a drive that cannot push a twentieth of its weight cannot climb a 3
/// degree ramp; tyres grip about once the weight (mu near 1), so a drive twenty times
/// stronger is a motor or gear of another machine (the thesis machine 1.3, a TurtleBot 3
/// about 9, the thesis motor on OptiOdom's 4 kg robot 130).
const DRIVE_PER_WEIGHT_SPAN: (f64, f64) = (0.05, 20.0);

/// Density of water, kg/m^3: the scale the mass-for-outline rule speaks in.
const WATER_KG_M3: f64 = 1000.0;

/// Standard gravity, m/s^2.
const G_M_S2: f64 = 9.81;

/// Every plausibility warning of a scene, in key order.
pub fn warnings(scene: &Scene) -> Vec<Warning> {
    let mut w = Vec::new();
    sizes(scene, &mut w);
    yaw_inertia(scene, &mut w);
    geometry(scene, &mut w);
    configured_geometry(scene, &mut w);
    supply(scene, &mut w);
    dcmc_gains(scene, &mut w);
    tyre_friction(scene, &mut w);
    mass_for_size(scene, &mut w);
    drive_for_weight(scene, &mut w);
    w
}

/// Sizes no wheeled robot has, and a top speed none reaches: a unit slipped.
fn sizes(scene: &Scene, w: &mut Vec<Warning>) {
    let value = |key: &str| crate::scene::keys::number(scene, key).unwrap_or(f64::NAN);
    for (key, unit, lo, hi, typed) in VEHICLE_SIZES {
        let v = value(key);
        if v.is_finite() && !(lo..=hi).contains(&v) {
            w.push(Warning {
                key,
                value: format!("{} {unit}", sig(v)),
                expected: format!(
                    "{} to {} {unit} for a wheeled robot or AGV",
                    sig(lo),
                    sig(hi)
                ),
                why: format!("a value in {typed} where the key takes {unit}?"),
            });
        }
    }
    let top_m_s = scene.top_speed_m_s(drive_v(scene));
    // Too slow or too fast: one warning, the band and the likeliest slip differing.
    let band = if top_m_s.is_finite() && top_m_s > 0.0 && top_m_s < TOP_SPEED_MIN_M_S {
        Some((
            format!("a top speed of at least {} m/s", sig(TOP_SPEED_MIN_M_S)),
            "a no-load speed in rad/s given as rpm, or a gearmotor's output speed with its ratio applied again?",
        ))
    } else if top_m_s.is_finite() && top_m_s > TOP_SPEED_MAX_M_S {
        Some((
            format!("a top speed under {} m/s", sig(TOP_SPEED_MAX_M_S)),
            "a no-load speed given in rad/s as rpm, or a radius or ratio in another unit?",
        ))
    } else {
        None
    };
    if let Some((expected, slip)) = band {
        w.push(Warning {
            key: MotorParams::torque_constant_nm_a.key(),
            value: format!("{} N m/A", sig(scene.motor.torque_constant_nm_a)),
            expected,
            why: format!(
                "the motor's no-load speed at the drive limit ({} V / {} N m/A) through gearbox.ratio = {} to a {} m wheel gives {} m/s; {slip}",
                sig(drive_v(scene)),
                sig(scene.motor.torque_constant_nm_a),
                sig(scene.gearbox.ratio),
                sig(scene.wheel.radius_m),
                sig(top_m_s)
            ),
        });
    }
}

fn yaw_inertia(scene: &Scene, w: &mut Vec<Warning>) {
    let c = &scene.chassis;
    let length_m = c.front_m + c.rear_m;
    let slab = slab_yaw_inertia_kg_m2(c.mass_kg, length_m, c.width_m);
    let (lo, hi) = (YAW_INERTIA_SPAN.0 * slab, YAW_INERTIA_SPAN.1 * slab);
    if !(lo..=hi).contains(&c.yaw_inertia_kg_m2) {
        w.push(Warning {
            key: ChassisParams::yaw_inertia_kg_m2.key(),
            value: format!("{} kg m^2", num(c.yaw_inertia_kg_m2)),
            expected: format!("about {} kg m^2 ({} to {})", sig(slab), sig(lo), sig(hi)),
            why: format!(
                "a uniform {} kg body of {} x {} m (chassis.front_m + rear_m, width_m) has {}; \
                 mass gathered at the centre or the corners moves it by a factor of 3 or 2",
                sig(c.mass_kg),
                sig(length_m),
                sig(c.width_m),
                sig(slab)
            ),
        });
    }
}

fn geometry(scene: &Scene, w: &mut Vec<Warning>) {
    let c = &scene.chassis;
    if c.track_width_m > c.width_m {
        w.push(Warning {
            key: ChassisParams::track_width_m.key(),
            value: format!("{} m", num(c.track_width_m)),
            expected: format!(
                "at most the body's width, chassis.width_m = {} m",
                num(c.width_m)
            ),
            why: "the drive wheels' centres would stand outside the body's outline".into(),
        });
    }
    let length_m = c.front_m + c.rear_m;
    let r = scene.wheel.radius_m;
    if 2.0 * r > length_m.min(c.width_m) {
        w.push(Warning {
            key: WheelParams::radius_m.key(),
            value: format!("{} m", num(r)),
            expected: format!(
                "a wheel smaller than the body (diameter below {} m)",
                sig(length_m.min(c.width_m))
            ),
            why: format!(
                "a {} m wheel on a {} x {} m body",
                sig(2.0 * r),
                sig(length_m),
                sig(c.width_m)
            ),
        });
    }
}

/// Widest ratio of a configured size (the base controller's wheel radius and separation)
/// to the size the wheels have: a controller configured 1.5 times off its wheels drives
/// 50 % off every command, which no robot is tuned to; a factor of 1000 is millimetres.
const CONFIGURED_SIZE_RATIO: f64 = 1.5;

/// Widest ratio of a wheel's rolling radius to its nominal radius: a tyre compressed or
/// worn by a fifth is flat, not rolling on a smaller radius.
const ROLLING_RADIUS_RATIO: f64 = 1.25;

/// The sizes the base controller is configured with, and the wheels' rolling radii, far
/// from the sizes the wheels have (`--set base.wheel_separation_m=1e5`, a controller file
/// in millimetres or of another robot).
fn configured_geometry(scene: &Scene, w: &mut Vec<Warning>) {
    use crate::model::base_controller::BaseParams;
    let r = scene.wheel.radius_m;
    let checks = [
        (
            BaseParams::wheel_separation_m.key(),
            scene.base.wheel_separation_m,
            scene.chassis.track_width_m,
            "the track, chassis.track_width_m",
            CONFIGURED_SIZE_RATIO,
            "the base controller would turn every yaw command into wheel speeds and every wheel speed into odometry that far off: millimetres, or another robot's file?",
        ),
        (
            BaseParams::wheel_radius_m.key(),
            scene.base.wheel_radius_m,
            r,
            "the wheel's radius, wheel.radius_m",
            CONFIGURED_SIZE_RATIO,
            "the base controller would drive every command and count every distance that far off: millimetres, a diameter, or another robot's file?",
        ),
        (
            WheelParams::left_rolling_radius_m.key(),
            scene.wheel.left_rolling_radius_m,
            r,
            "the wheel's radius, wheel.radius_m",
            ROLLING_RADIUS_RATIO,
            "a tyre rolls within a few per cent of its radius",
        ),
        (
            WheelParams::right_rolling_radius_m.key(),
            scene.wheel.right_rolling_radius_m,
            r,
            "the wheel's radius, wheel.radius_m",
            ROLLING_RADIUS_RATIO,
            "a tyre rolls within a few per cent of its radius",
        ),
    ];
    for (key, value, size, what, ratio, why) in checks {
        let Some(v) = value else { continue };
        if !(v >= size / ratio && v <= size * ratio) {
            w.push(Warning {
                key,
                value: format!("{} m", num(v)),
                expected: format!(
                    "{} to {} m, within a factor of {} of {what} ({} m)",
                    sig(size / ratio),
                    sig(size * ratio),
                    sig(ratio),
                    sig(size)
                ),
                why: format!("{} times it: {why}", sig(v / size)),
            });
        }
    }
}

fn supply(scene: &Scene, w: &mut Vec<Warning>) {
    let b = &scene.battery;
    if b.drive_limit_v > b.open_circuit_v {
        w.push(Warning {
            key: BatteryParams::drive_limit_v.key(),
            value: format!("{} V", num(b.drive_limit_v)),
            expected: format!(
                "at most battery.open_circuit_V = {} V (the thesis's bridges deliver 23.5 of 24 V: here about {} V)",
                num(b.open_circuit_v),
                sig(b.open_circuit_v * 23.5 / 24.0)
            ),
            why: "H-bridges cannot deliver more than the battery's voltage".into(),
        });
    }
    // Both motors at the most current they draw (the limit, or stall at the drive
    // voltage) pull the battery down by this; only the full level models the fault.
    let most_a = most_current_a(scene);
    let sag_v = 2.0 * most_a * b.internal_resistance_ohm;
    let lowest_v = b.open_circuit_v - sag_v;
    let faults = crate::scene::Features::of(scene.sim.fidelity).dcmc_faults;
    if faults && b.low_voltage_fault_v > lowest_v && b.low_voltage_fault_v < b.open_circuit_v {
        w.push(Warning {
            key: BatteryParams::low_voltage_fault_v.key(),
            value: format!("{} V", num(b.low_voltage_fault_v)),
            expected: format!("below {} V", sig(lowest_v)),
            why: format!(
                "both motors at {} A (dcmc.current_limit_A, or stall) sag the {} V battery (internal resistance {} ohm) by {} V, so the unit would fault at full current",
                sig(most_a),
                num(b.open_circuit_v),
                num(b.internal_resistance_ohm),
                sig(sag_v)
            ),
        });
    }
}

fn dcmc_gains(scene: &Scene, w: &mut Vec<Warning>) {
    let d = &scene.dcmc;
    let drive_v = drive_v(scene);
    match d.kind {
        DcmcKind::Gain | DcmcKind::GainPi => {
            let full_v = d.forward_gain_v_pct.abs() * 100.0;
            if full_v > 1.05 * drive_v {
                w.push(Warning {
                    key: DcmcParams::forward_gain_v_pct.key(),
                    value: format!("{} V/pct", num(d.forward_gain_v_pct)),
                    expected: format!("at most {} V/pct", sig(drive_v / 100.0)),
                    why: format!(
                        "full demand (100 %) asks {} V of a drive that delivers {} V: every demand above {:.0} % gives the same speed",
                        sig(full_v),
                        sig(drive_v),
                        100.0 * drive_v / full_v
                    ),
                });
            }
        }
        DcmcKind::P | DcmcKind::Pi => {
            let no_load_rad_s = scene.motor.no_load_speed_rad_s(drive_v);
            let full_rad_s = d.speed_per_pct_rad_s * 100.0;
            if full_rad_s > 1.05 * no_load_rad_s {
                w.push(Warning {
                    key: DcmcParams::speed_per_pct_rad_s.key(),
                    value: format!("{} rad/s per pct", num(d.speed_per_pct_rad_s)),
                    expected: format!("at most {} rad/s per pct", sig(no_load_rad_s / 100.0)),
                    why: format!(
                        "full demand asks {} rad/s of a motor whose no-load speed at {} V is {} rad/s (drive limit over motor.torque_constant_Nm_A)",
                        sig(full_rad_s),
                        sig(drive_v),
                        sig(no_load_rad_s)
                    ),
                });
            }
        }
    }
}

fn tyre_friction(scene: &Scene, w: &mut Vec<Warning>) {
    if let Some(mu) = scene.tyre.peak_mu {
        if !(TYRE_MU_SPAN.0..=TYRE_MU_SPAN.1).contains(&mu) {
            w.push(Warning {
                key: TyreChoice::peak_mu.key(),
                value: num(mu),
                expected: format!("{} to {}", TYRE_MU_SPAN.0, TYRE_MU_SPAN.1),
                why: "rubber and polyurethane drive tyres reach about that from wet epoxy to dry concrete; for a tyre that never slips use tyre.compound = \"high_grip\" (an idealised no-slip tyre)".into(),
            });
        }
    }
}

/// A mass no body of this outline carries: the thesis machine's mass left on a small robot.
fn mass_for_size(scene: &Scene, w: &mut Vec<Warning>) {
    let c = &scene.chassis;
    let length_m = c.front_m + c.rear_m;
    // A box as tall as the footprint is wide: its volume, m^3.
    let box_m3 = (length_m * c.width_m).powf(1.5);
    let heaviest_kg = MASS_PER_FOOTPRINT_1_5_MAX * box_m3;
    if c.mass_kg > heaviest_kg {
        w.push(Warning {
            key: ChassisParams::mass_kg.key(),
            value: format!("{} kg", sig(c.mass_kg)),
            expected: format!("at most about {} kg for its outline", sig(heaviest_kg)),
            why: format!(
                "a {} x {} m body (chassis.front_m + rear_m, width_m) full of water as tall as it is wide weighs {} kg; robots are mostly air: another machine's mass?",
                sig(length_m),
                sig(c.width_m),
                sig(WATER_KG_M3 * box_m3)
            ),
        });
    }
}

/// The voltage the bridges deliver a motor, V: their limit, at most the battery's.
fn drive_v(scene: &Scene) -> f64 {
    scene
        .battery
        .drive_limit_v
        .min(scene.battery.open_circuit_v)
}

/// The most current a motor draws, A: the drive's limit, or its stall current at the
/// drive limit if lower.
fn most_current_a(scene: &Scene) -> f64 {
    let stall_a = drive_v(scene) / scene.motor.resistance_ohm;
    scene.dcmc.current_limit_a.min(stall_a)
}

/// The most force the two drive wheels push, N: each motor's torque at its most current
/// through the gear to the wheel.
pub fn drive_force_n(scene: &Scene) -> f64 {
    2.0 * scene.motor.torque_constant_nm_a * most_current_a(scene) * scene.gearbox.ratio
        / scene.wheel.radius_m
}

/// A drive too strong or too weak for the robot's weight: a motor or gear of another
/// machine (an import's guess when the user gave none).
fn drive_for_weight(scene: &Scene, w: &mut Vec<Warning>) {
    let weight_n = scene.chassis.mass_kg * G_M_S2;
    let force_n = drive_force_n(scene);
    let ratio = force_n / weight_n;
    let (lo, hi) = DRIVE_PER_WEIGHT_SPAN;
    if ratio.is_finite() && !(lo..=hi).contains(&ratio) {
        w.push(Warning {
            key: MotorParams::resistance_ohm.key(),
            value: format!("{} ohm", sig(scene.motor.resistance_ohm)),
            expected: format!(
                "a drive pushing {} to {} times the robot's weight",
                sig(lo),
                sig(hi)
            ),
            why: format!(
                "two motors of {} N m/A at {} A (dcmc.current_limit_A, or stall at the drive limit over this resistance) through gearbox.ratio = {} to a {} m wheel push {} N, {} times the {} kg robot's weight; tyres grip about once it: a motor or gear of another machine?",
                sig(scene.motor.torque_constant_nm_a),
                sig(most_current_a(scene)),
                sig(scene.gearbox.ratio),
                sig(scene.wheel.radius_m),
                sig(force_n),
                sig(ratio),
                sig(scene.chassis.mass_kg)
            ),
        });
    }
}

/// A number to 3 significant figures, in plain decimals for everyday magnitudes.
pub fn sig(v: f64) -> String {
    crate::numtext::sig(v, 3)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_thesis_machine_is_plausible() {
        assert_eq!(warnings(&Scene::default()), vec![]);
    }

    #[test]
    fn the_thesis_inertia_on_a_small_light_body_is_caught() {
        let mut s = Scene::default();
        s.chassis.mass_kg = 60.0;
        (s.chassis.front_m, s.chassis.rear_m, s.chassis.width_m) = (0.3, 0.3, 0.5);
        let w = warnings(&s);
        // 60 kg over 0.6 x 0.5 m: 60 (0.36 + 0.25) / 12 = 3.05 kg m^2.
        assert_eq!(w.len(), 1, "{w:?}");
        assert_eq!(w[0].key, "chassis.yaw_inertia_kg_m2");
        assert!(w[0].expected.starts_with("about 3.05 kg m^2"), "{}", w[0]);
    }

    #[test]
    fn a_12_v_battery_under_the_thesis_drive_is_caught_key_by_key() {
        let mut s = Scene::default();
        s.battery.open_circuit_v = 12.0;
        s.battery.low_voltage_fault_v = 11.0;
        let keys: Vec<&str> = warnings(&s).iter().map(|w| w.key).collect();
        // 23.5 V drive on 12 V; 16.2 V at full demand; 2 x 40 A x 0.02 ohm = 1.6 V sag
        // brings 12 V below the 11 V threshold.
        assert_eq!(
            keys,
            [
                "battery.drive_limit_V",
                "battery.low_voltage_fault_V",
                "dcmc.forward_gain_V_pct"
            ]
        );
    }

    #[test]
    fn millimetres_typed_as_metres_are_caught() {
        let mut s = Scene::default();
        // `new --track-m 400 --wheel-radius-m 50`: the body follows the track.
        s.chassis.track_width_m = 400.0;
        s.chassis.width_m = 400.12;
        (s.chassis.front_m, s.chassis.rear_m) = (400.0, 400.0);
        s.wheel.radius_m = 50.0;
        let w = warnings(&s);
        let keys: Vec<&str> = w.iter().map(|w| w.key).collect();
        assert!(
            keys.starts_with(&[
                "chassis.track_width_m",
                "wheel.radius_m",
                "motor.torque_constant_Nm_A"
            ]),
            "{w:?}"
        );
        assert!(w[0].why.contains("millimetres"), "{}", w[0]);
        // 23.5 V / 0.063 N m/A / 23.41 x 50 m = 797 m/s.
        assert!(w[2].why.contains("797 m/s"), "{}", w[2]);
        // Grams typed as kilograms.
        let mut s = Scene::default();
        s.chassis.mass_kg = 60_000.0;
        assert_eq!(warnings(&s)[0].key, "chassis.mass_kg");
    }

    /// A configured separation in millimetres, a radius of 1e-300, a rolling radius of a
    /// thousandth: each named; a configured size 10 % off its wheels passes.
    #[test]
    fn configured_sizes_far_from_the_wheels_are_caught() {
        let mut s = Scene::default();
        s.base.wheel_separation_m = Some(1.1 * s.chassis.track_width_m);
        s.wheel.left_rolling_radius_m = Some(0.98 * s.wheel.radius_m);
        assert!(warnings(&s).is_empty(), "{:?}", warnings(&s));
        s.base.wheel_separation_m = Some(1000.0 * s.chassis.track_width_m);
        s.base.wheel_radius_m = Some(1e-300);
        s.wheel.right_rolling_radius_m = Some(1e-3 * s.wheel.radius_m);
        let keys: Vec<&str> = warnings(&s).iter().map(|w| w.key).collect();
        assert_eq!(
            keys,
            [
                "base.wheel_separation_m",
                "base.wheel_radius_m",
                "wheel.right_rolling_radius_m"
            ]
        );
        assert!(
            warnings(&s)[0].why.contains("1000 times it"),
            "{}",
            warnings(&s)[0]
        );
    }

    #[test]
    fn the_thesis_machine_on_a_small_robot_is_caught() {
        // A 0.2 m track's body as `new` and the import make it: 0.4 x 0.32 m.
        let mut s = Scene::default();
        s.chassis.track_width_m = 0.2;
        (s.chassis.front_m, s.chassis.rear_m, s.chassis.width_m) = (0.2, 0.2, 0.32);
        s.wheel.radius_m = 0.042;
        s.gearbox.ratio = 43.7;
        s.chassis.yaw_inertia_kg_m2 = slab_yaw_inertia_kg_m2(120.0, 0.4, 0.32);
        let w = warnings(&s);
        let keys: Vec<&str> = w.iter().map(|w| w.key).collect();
        // 2000 x (0.4 x 0.32)^1.5 = 91.6 kg at most.
        assert!(keys.contains(&"chassis.mass_kg"), "{w:?}");
        // With the robot's own 4 kg, the mass fits; the thesis motor does not: 40 A x
        // 0.063 N m/A x 43.7 / 0.042 m x 2 = 5244 N against 39.2 N of weight.
        s.chassis.mass_kg = 4.0;
        s.chassis.yaw_inertia_kg_m2 = slab_yaw_inertia_kg_m2(4.0, 0.4, 0.32);
        let w = warnings(&s);
        let keys: Vec<&str> = w.iter().map(|w| w.key).collect();
        assert_eq!(keys, ["motor.resistance_ohm"], "{w:?}");
        assert!(w[0].why.contains("5244 N, 134 times"), "{}", w[0]);
        // A drive sized for it (a 0.6 N m stall gearmotor's worth) is plausible.
        s.motor.torque_constant_nm_a = 0.01;
        s.dcmc.current_limit_a = 2.0;
        assert_eq!(warnings(&s), vec![]);
    }

    #[test]
    fn numbers_print_to_three_figures() {
        assert_eq!(sig(13.8441), "13.8");
        assert_eq!(sig(0.0630001), "0.063");
        assert_eq!(sig(1234.6), "1235");
        assert_eq!(sig(-2.5), "-2.5");
    }
}
