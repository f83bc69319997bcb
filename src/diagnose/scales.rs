//! Scales of a record (largest actuation, speed, sample interval, effort, time constant,
//! weight) that set candidate effects' starting values and bounds.

use crate::ident::data::Dataset;
use crate::ident::Structure;
use crate::record::channels as chan;

/// Scales of a record that set effect starting values and bounds.
pub(crate) struct Scales {
    /// Largest actuation voltage (or force command), V.
    pub v_max: f64,
    /// Largest measured speed of the drive: the motor shaft's, rad/s (a rotary axis, a
    /// vehicle), or the load's, m/s (a linear axis). A vehicle measured by its wheels'
    /// rim speeds or a tracker (m/s) has it through the gear ratio and the wheel radius:
    /// the friction laws' smoothing speed is a share of it, and a rim speed taken for a
    /// motor speed made Coulomb friction's law a hundred times too stiff to fit.
    pub speed_max: f64,
    /// Typical sample interval, s.
    pub dt: f64,
    /// Stall torque K V / R (rotary), N m, or largest force (linear), N.
    pub effort: f64,
    /// Mechanical time constant, s.
    pub tau: f64,
    /// Vehicle weight, N (vehicle only).
    pub weight_n: f64,
}

pub(crate) fn scales(structure: &Structure, p: &[f64], data: &Dataset, speed: &[f64]) -> Scales {
    let speed_max = speed.iter().map(|v| v.abs()).fold(0.0, f64::max).max(1e-9);
    let mut dts: Vec<f64> = data.t_s.windows(2).map(|w| w[1] - w[0]).collect();
    dts.sort_by(f64::total_cmp);
    let dt = dts.get(dts.len() / 2).copied().unwrap_or(1e-3);
    let u_max = data
        .inputs
        .first()
        .map(|u| u.iter().map(|v| v.abs()).fold(0.0, f64::max))
        .unwrap_or(1.0);
    match structure {
        Structure::Rotary(m) if let Some(c) = m.torque_command() => {
            let a = m.declared(p);
            let command = largest_command(data, u_max);
            Scales {
                v_max: command,
                speed_max,
                dt,
                effort: (c.per_volt_nm_v * command).max(1e-9),
                tau: m.inertia_at_motor(&a) / a.motor.viscous_nm_s_rad,
                weight_n: 0.0,
            }
        }
        Structure::Rotary(m) => {
            let a = m.declared(p);
            let v_max = m.voltage(&a, u_max).abs().max(1e-6);
            Scales {
                v_max,
                speed_max,
                dt,
                effort: a.motor.stall_torque_nm(v_max),
                tau: m.mechanical_time_constant_s(&a),
                weight_n: 0.0,
            }
        }
        Structure::Linear(m) => {
            let load = m.declared(p).load;
            let cmd = largest_command(data, u_max);
            Scales {
                v_max: cmd,
                speed_max,
                dt,
                effort: (m.force_per_volt * cmd).max(1e-6),
                tau: load.mass_kg / load.viscous_n_s_m,
                weight_n: 0.0,
            }
        }
        Structure::Vehicle(m) => {
            let a = m.declared(p);
            let motor_measured = data.output_index(chan::LEFT_MOTOR_SPEED_RAD_S).is_some()
                && data.output_index(chan::RIGHT_MOTOR_SPEED_RAD_S).is_some();
            let speed_max = if motor_measured {
                speed_max
            } else {
                speed_max * m.ratio / a.wheel.radius_m
            };
            let v_max = data
                .inputs
                .iter()
                .flat_map(|u| u.iter().map(|v| v.abs()))
                .fold(0.0, f64::max)
                .max(1e-6);
            Scales {
                v_max,
                speed_max,
                dt,
                effort: a.motor.stall_torque_nm(v_max),
                tau: m.mechanical_time_constant_s(&a),
                weight_n: a.chassis.mass_kg * crate::model::GRAVITY_M_S2,
            }
        }
        _ => Scales {
            v_max: 1.0,
            speed_max,
            dt,
            effort: 1.0,
            tau: 1.0,
            weight_n: 0.0,
        },
    }
}

/// Largest recorded drive command (`command_V`), or `otherwise` when it is not recorded.
fn largest_command(data: &Dataset, otherwise: f64) -> f64 {
    data.output_index(chan::COMMAND_V)
        .map(|j| {
            data.outputs[j]
                .iter()
                .flatten()
                .map(|v| v.abs())
                .fold(0.0, f64::max)
        })
        .unwrap_or(otherwise)
}
