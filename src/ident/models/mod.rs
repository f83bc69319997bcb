//! The grey-box model structures agvsim identifies.

pub mod coast_down;
pub mod dcmc_pair;
pub mod falling_weight;
pub mod linear_axis;
pub mod rotary_axis;
pub mod vehicle;

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::linear_axis::LinearAxis;
    use super::rotary_axis::{AxisInput, RotaryAxis};
    use super::vehicle::Vehicle;
    use crate::rig::Rig;

    const MOTOR: &str = r#"
[motor]
resistance_ohm = 0.35
inductance_H = 0.0008
torque_constant_Nm_A = 0.063
rotor_inertia_kg_m2 = 2.0e-4
viscous_Nm_s_rad = 1.0e-4
[gearbox]
ratio = 23.41
[wheel]
radius_m = 0.075
inertia_kg_m2 = 0.02
[controller]
kind = "gain"
gain_V_pct = 0.24
[chassis]
mass_kg = 120.0
yaw_inertia_kg_m2 = 14.0
track_width_m = 0.5
drive_load_fraction = 0.6
"#;

    fn rig(kind: &str, more: &str) -> Rig {
        Rig::parse(
            &format!("rig = \"{kind}\"\n{more}"),
            Path::new("t.rig.toml"),
        )
        .unwrap()
    }

    /// Every parameter a model may carry, its own and each effect's, sets a key of its
    /// blocks: no value of a fit is lost for want of a key.
    #[test]
    fn every_parameter_of_every_model_with_every_effect_sets_a_key() {
        let path = Path::new("t.rig.toml");
        for input in [AxisInput::Voltage, AxisInput::Demand] {
            let axis = RotaryAxis::from_rig(&rig("drive_axis", MOTOR), path, input).unwrap();
            assert!(axis.unbound().is_empty(), "{:?}", axis.unbound());
            for e in axis.applicable() {
                let m = axis.with_effect(e, 0.1, 0.0, 1.0, 100.0);
                assert!(m.unbound().is_empty(), "{}: {:?}", e.name(), m.unbound());
            }
        }
        let vehicle = Vehicle::from_rig(&rig("vehicle", MOTOR), path).unwrap();
        for e in vehicle.applicable() {
            let m = vehicle.with_effect(e, 0.1, 0.0, 1.0, 100.0);
            assert!(m.unbound().is_empty(), "{}: {:?}", e.name(), m.unbound());
        }
        let linear = LinearAxis::from_rig(
            &rig(
                "drive_axis",
                "motion = \"linear\"\n[load]\nmass_kg = 80.0\nviscous_N_s_m = 150.0\n[drive]\nforce_per_volt_N_V = 35.0\n",
            ),
            path,
            false,
        )
        .unwrap();
        for e in linear.applicable() {
            let m = linear.with_effect(e, 0.1, 0.0, 1.0, 1.0);
            assert!(m.unbound().is_empty(), "{}: {:?}", e.name(), m.unbound());
        }
    }

    /// A key's value reaches the blocks: doubling the resistance doubles the motor's.
    #[test]
    fn a_parameter_is_read_by_its_key() {
        use crate::ident::model::GreyBox;
        let path = Path::new("t.rig.toml");
        let axis =
            RotaryAxis::from_rig(&rig("drive_axis", MOTOR), path, AxisInput::Voltage).unwrap();
        let mut p = axis.nominal();
        let i = axis.param_index("motor.resistance_ohm").unwrap();
        p[i] *= 2.0;
        assert_eq!(axis.declared(&p).motor.resistance_ohm, 0.7);
        let slip = Vehicle::from_rig(&rig("vehicle", MOTOR), path)
            .unwrap()
            .with_effect(
                crate::ident::effects::Effect::WheelSlip,
                0.3,
                0.05,
                4.0,
                100.0,
            );
        let p = slip.nominal();
        assert_eq!(slip.declared(&p).tyre.peak_mu, 0.3);
    }
}
