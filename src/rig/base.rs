//! A velocity-commanded base (`rig = "base"`) both ways: the scene a base rig describes
//! (what `agvsim diagnose --rig` simulates), and the rig a base scene's robot would be
//! described by (what the calibration's proof writes for an experimenter's beliefs).

use std::path::Path;

use super::{keys, Rig, RigError, RigKind};
use crate::model::base_controller::BaseParams;
use crate::model::chassis::ChassisParams;
use crate::model::gearbox::GearboxParams;
use crate::model::motor::MotorParams;
use crate::model::wheel::WheelParams;
use crate::param::ParamKey;

/// The scene keys a base rig states: the motor, gear and wheels, the supply, the chassis,
/// and the base controller's limits, configured geometry and drivers' loop gains.
const BASE_KEYS: [ParamKey; 21] = [
    MotorParams::resistance_ohm,
    MotorParams::inductance_h,
    MotorParams::torque_constant_nm_a,
    MotorParams::rotor_inertia_kg_m2,
    MotorParams::viscous_nm_s_rad,
    MotorParams::coulomb_nm,
    GearboxParams::ratio,
    WheelParams::radius_m,
    WheelParams::inertia_kg_m2,
    keys::alias::SUPPLY_VOLTAGE_V,
    ChassisParams::mass_kg,
    ChassisParams::yaw_inertia_kg_m2,
    ChassisParams::track_width_m,
    BaseParams::max_linear_m_s,
    BaseParams::max_linear_accel_m_s2,
    BaseParams::max_angular_rad_s,
    BaseParams::max_angular_accel_rad_s2,
    BaseParams::speed_kp_v_s_rad,
    BaseParams::speed_ki_v_rad,
    BaseParams::wheel_radius_m,
    BaseParams::wheel_separation_m,
];

impl Rig {
    /// The `base` rig describing `scene`'s robot: each of [`BASE_KEYS`] at the scene's
    /// value (the chassis's mass with its payload's), as an experimenter who knew the
    /// robot would write it. [`Rig::base_scene`] of it makes the same machine wherever
    /// the base's scene keys decide.
    pub fn of_base_scene(scene: &crate::scene::Scene) -> Rig {
        let mut rig = Rig::from_scene(RigKind::Base, scene, &BASE_KEYS.map(ParamKey::key));
        rig.set(
            ChassisParams::mass_kg.key(),
            scene.chassis.mass_kg + scene.payload.mass_kg,
        );
        rig
    }

    /// The velocity-commanded base a `base` rig describes, as a scene for the simulator:
    /// a robot of its size (`agvsim new`'s derivations from its mass, track, wheel radius,
    /// supply and gear ratio; the thesis machine's where the rig is silent), then every
    /// value the rig states under its scene key (the motor's, the chassis's, the base
    /// controller's limits, configured geometry and its drivers' loop gains), with the
    /// rig's `[uncertainty_pct]`. No gear play and no Coulomb friction unless stated: a rig
    /// is the machine as believed, its effects for the diagnosis to find.
    pub fn base_scene(&self, path: &Path) -> Result<crate::scene::Scene, RigError> {
        use crate::scene::robot::{new_scene, Guidance, RobotSpec};
        let invalid = |message: String| RigError::invalid(path, message);
        let spec = RobotSpec {
            mass_kg: self.get(ChassisParams::mass_kg.key()),
            track_m: self.get(ChassisParams::track_width_m.key()),
            wheel_radius_m: self.get(WheelParams::radius_m.key()),
            battery_v: self.get(keys::alias::SUPPLY_VOLTAGE_V.key()),
            gear_ratio: self.get(GearboxParams::ratio.key()),
            backlash_rad: Some(0.0),
            guidance: Some(Guidance::None),
            configured_geometry: true,
            description: Some(format!(
                "The velocity-commanded base of {}, for the simulator",
                path.display()
            )),
            ..RobotSpec::default()
        };
        // What the rig does not state is the thesis machine's, as `import ros2` takes it.
        let thesis = crate::scene::Scene::default();
        let from = Path::new("the thesis machine (agvsim's defaults)");
        let made = new_scene(&spec, Some((from, &thesis)), "agvsim diagnose --rig")
            .map_err(|e| invalid(format!("the base does not make a scene: {e}")))?;
        let mut sets = vec![format!("{}=0", MotorParams::coulomb_nm.key())];
        sets.extend(self.scene_sets());
        let mut scene = crate::scene::Scene::from_toml(&made.text, path, &sets)
            .map_err(|e| invalid(format!("the base's values do not make a scene: {e}")))?;
        let table = keys::table();
        for (o, pct) in &self.uncertainty_pct {
            if let Some(scene_key) = table[*o].scene_key {
                scene.uncertainty_pct.insert(scene_key.to_string(), *pct);
            }
        }
        scene.validate().map_err(|bad| {
            invalid(format!(
                "{} = {}: expected {}",
                bad.key, bad.value, bad.expected
            ))
        })?;
        Ok(scene)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(t: &str) -> Result<Rig, RigError> {
        Rig::parse(t, Path::new("x.rig.toml"))
    }

    /// A base rig's scene: the robot it states (size, configured geometry, limits, loop
    /// gains, with their uncertainty), no play and no Coulomb friction it did not state.
    #[test]
    fn a_base_rig_makes_the_scene_of_the_robot_it_states() {
        let rig = parse(
            r#"
rig = "base"
[chassis]
mass_kg = 12.0
track_width_m = 0.3
[wheel]
radius_m = 0.05
[base]
wheel_separation_m = 0.3
wheel_radius_m = 0.05
max_angular_rad_s = 1.2
speed_kp_V_s_rad = 0.4
[uncertainty_pct]
"chassis.mass_kg" = 10
"#,
        )
        .unwrap();
        let s = rig.base_scene(Path::new("x.rig.toml")).unwrap();
        assert_eq!(s.chassis.mass_kg, 12.0);
        assert_eq!(s.chassis.track_width_m, 0.3);
        assert_eq!(s.base.max_angular_rad_s, 1.2);
        assert_eq!(s.base.speed_kp_v_s_rad, 0.4);
        assert_eq!(s.gearbox.backlash_rad, 0.0);
        assert_eq!(s.motor.coulomb_nm, 0.0);
        assert_eq!(s.uncertainty_pct.get("chassis.mass_kg"), Some(&10.0));
    }

    /// The rig of a base's scene states what the rig it was made from stated, and reads
    /// back to a scene stating the same: nothing a base rig can say is lost either way.
    #[test]
    fn a_base_scene_s_rig_states_what_made_it() {
        let rig = parse(
            r#"
rig = "base"
[motor]
resistance_ohm = 0.8
torque_constant_Nm_A = 0.05
[gearbox]
ratio = 30.0
[wheel]
radius_m = 0.05
[chassis]
mass_kg = 12.0
yaw_inertia_kg_m2 = 0.4
track_width_m = 0.3
[base]
wheel_separation_m = 0.31
max_angular_rad_s = 1.2
speed_ki_V_rad = 2.5
"#,
        )
        .unwrap();
        let path = Path::new("x.rig.toml");
        let scene = rig.base_scene(path).unwrap();
        let back = Rig::of_base_scene(&scene);
        for (key, value) in rig.numbers() {
            assert_eq!(back.get(&key), Some(value), "{key}");
        }
        // Keys the first rig left to the derivations are stated now, at the scene's values.
        assert_eq!(
            back.get(WheelParams::inertia_kg_m2.key()),
            Some(scene.wheel.inertia_kg_m2)
        );
        // Read back, it states the same again; and from then on the round trip is exact
        // (the first pass left the supply to the thesis machine and the second states it,
        // so the DCMC's demand gains are sized from it then: keys a velocity base does not
        // read).
        let again = back.base_scene(path).unwrap();
        assert_eq!(Rig::of_base_scene(&again).numbers(), back.numbers());
        let twice = Rig::of_base_scene(&again).base_scene(path).unwrap();
        assert_eq!(twice.to_toml(), again.to_toml());
    }
}
