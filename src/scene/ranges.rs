//! Every scene key in one table: its allowed values, read by the validation and printed
//! as the README's scene reference (`agvsim keys`), so the two cannot drift. A test
//! checks that every key of the schema has a row and that the README holds this
//! table's text.

use super::{presets, Invalid, Scene};

/// What a numeric key allows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Allowed {
    /// Finite and above zero.
    Positive,
    /// Finite, zero or more.
    NonNegative,
    /// Finite and below zero.
    Negative,
    /// Any finite number.
    Finite,
    /// Strictly between 0 and 1.
    OpenFraction,
    /// Within `[lo, hi]`, each end open or closed.
    Interval {
        lo: f64,
        lo_open: bool,
        hi: f64,
        hi_open: bool,
    },
    /// Any integer (the type is checked when the file is read).
    Integer,
    /// An integer other than zero (a denominator).
    NonZeroInteger,
}

impl Allowed {
    /// The rule as the reference prints it.
    pub fn text(&self) -> String {
        match *self {
            Allowed::Positive => "> 0".into(),
            Allowed::Negative => "< 0".into(),
            Allowed::NonNegative => ">= 0".into(),
            Allowed::Finite => "finite".into(),
            Allowed::OpenFraction => "(0, 1)".into(),
            Allowed::Interval {
                lo,
                lo_open,
                hi,
                hi_open,
            } => format!(
                "{}{}, {}{}",
                if lo_open { "(" } else { "[" },
                bound(lo),
                bound(hi),
                if hi_open { ")" } else { "]" }
            ),
            Allowed::Integer => "integer".into(),
            Allowed::NonZeroInteger => "integer, not 0".into(),
        }
    }

    /// What the error message says was expected.
    fn expected(&self) -> String {
        match self {
            Allowed::Positive => "a finite number greater than zero".into(),
            Allowed::Negative => "a finite number below zero".into(),
            Allowed::NonNegative => "a finite number, zero or more".into(),
            Allowed::Finite => "a finite number".into(),
            Allowed::OpenFraction => "a fraction strictly between 0 and 1".into(),
            Allowed::Interval { .. } => format!("a number in {}", self.text()),
            Allowed::Integer => "an integer".into(),
            Allowed::NonZeroInteger => "a non-zero integer".into(),
        }
    }

    pub fn admits(&self, v: f64) -> bool {
        v.is_finite()
            && match *self {
                Allowed::Positive => v > 0.0,
                Allowed::Negative => v < 0.0,
                Allowed::NonNegative => v >= 0.0,
                Allowed::Finite | Allowed::Integer => true,
                Allowed::OpenFraction => v > 0.0 && v < 1.0,
                Allowed::Interval {
                    lo,
                    lo_open,
                    hi,
                    hi_open,
                } => {
                    (if lo_open { v > lo } else { v >= lo })
                        && (if hi_open { v < hi } else { v <= hi })
                }
                Allowed::NonZeroInteger => v != 0.0,
            }
    }
}

/// An interval's end as the reference prints it.
fn bound(v: f64) -> String {
    if v == std::f64::consts::FRAC_PI_2 {
        "pi/2".into()
    } else {
        format!("{v}")
    }
}

/// One numeric key: its dotted name (units in the name), rule, and where its value is
/// (`None`: an optional key left out).
pub struct NumericKey {
    pub key: &'static str,
    pub allowed: Allowed,
    pub get: fn(&Scene) -> Option<f64>,
}

/// One key that is not a number: its dotted name and what it takes.
pub struct OtherKey {
    pub key: &'static str,
    pub takes: fn() -> String,
}

use Allowed::*;

macro_rules! numeric {
    ($( $key:literal $allowed:expr => |$s:ident| $get:expr ;)*) => {
        &[$( NumericKey { key: $key, allowed: $allowed, get: |$s: &Scene| $get } ),*]
    };
}

const fn closed(lo: f64, hi: f64) -> Allowed {
    Interval {
        lo,
        lo_open: false,
        hi,
        hi_open: false,
    }
}

const fn open_closed(lo: f64, hi: f64) -> Allowed {
    Interval {
        lo,
        lo_open: true,
        hi,
        hi_open: false,
    }
}

const fn closed_open(lo: f64, hi: f64) -> Allowed {
    Interval {
        lo,
        lo_open: false,
        hi,
        hi_open: true,
    }
}

/// Every numeric scene key, in the schema's order.
pub const NUMERIC: &[NumericKey] = numeric! {
    "sim.duration_s" Positive => |s| Some(s.sim.duration_s);
    "sim.dt_s" open_closed(0.0, 0.01) => |s| Some(s.sim.dt_s);
    "sim.seed" Integer => |s| Some(s.sim.seed as f64);
    "sim.record_interval_s" Positive => |s| Some(s.sim.record_interval_s);
    "sim.max_steps" Positive => |s| Some(s.sim.max_steps as f64);
    "chassis.mass_kg" Positive => |s| Some(s.chassis.mass_kg);
    "chassis.yaw_inertia_kg_m2" Positive => |s| Some(s.chassis.yaw_inertia_kg_m2);
    "chassis.track_width_m" Positive => |s| Some(s.chassis.track_width_m);
    "chassis.cg_x_m" Finite => |s| Some(s.chassis.cg_x_m);
    "chassis.cg_y_m" Finite => |s| Some(s.chassis.cg_y_m);
    "chassis.drive_load_fraction" OpenFraction => |s| Some(s.chassis.drive_load_fraction);
    "chassis.front_m" Positive => |s| Some(s.chassis.front_m);
    "chassis.rear_m" Positive => |s| Some(s.chassis.rear_m);
    "chassis.width_m" Positive => |s| Some(s.chassis.width_m);
    "payload.mass_kg" NonNegative => |s| Some(s.payload.mass_kg);
    "payload.cg_x_m" Finite => |s| Some(s.payload.cg_x_m);
    "payload.cg_y_m" Finite => |s| Some(s.payload.cg_y_m);
    "payload.yaw_inertia_kg_m2" NonNegative => |s| Some(s.payload.yaw_inertia_kg_m2);
    "castors.front_x_m" Positive => |s| Some(s.castors.front_x_m);
    "castors.rear_x_m" Negative => |s| Some(s.castors.rear_x_m);
    "castors.half_spacing_m" Positive => |s| Some(s.castors.half_spacing_m);
    "castors.trail_m" Positive => |s| Some(s.castors.trail_m);
    "castors.mass_kg" Positive => |s| Some(s.castors.mass_kg);
    "castors.swivel_friction_Nm" NonNegative => |s| Some(s.castors.swivel_friction_Nm);
    "castors.rolling_resistance" NonNegative => |s| Some(s.castors.rolling_resistance);
    "castors.initial_angle_rad" Finite => |s| Some(s.castors.initial_angle_rad);
    "castors.lumped_linear_drag_N_s_m" NonNegative => |s| Some(s.castors.lumped_linear_drag_N_s_m);
    "castors.lumped_angular_drag_Nm_s_rad" NonNegative => |s| Some(s.castors.lumped_angular_drag_Nm_s_rad);
    "motor.resistance_ohm" Positive => |s| Some(s.motor.resistance_ohm);
    "motor.inductance_H" Positive => |s| Some(s.motor.inductance_H);
    "motor.torque_constant_Nm_A" Positive => |s| Some(s.motor.torque_constant_Nm_A);
    "motor.rotor_inertia_kg_m2" Positive => |s| Some(s.motor.rotor_inertia_kg_m2);
    "motor.viscous_Nm_s_rad" NonNegative => |s| Some(s.motor.viscous_Nm_s_rad);
    "motor.coulomb_Nm" NonNegative => |s| Some(s.motor.coulomb_Nm);
    "motor.viscous_ratio" Positive => |s| Some(s.motor.viscous_ratio);
    "motor.offset_Nm" Finite => |s| Some(s.motor.offset_Nm);
    "gearbox.ratio" Positive => |s| Some(s.gearbox.ratio);
    "gearbox.backlash_rad" closed_open(0.0, 1.0) => |s| Some(s.gearbox.backlash_rad);
    "gearbox.tooth_stiffness_Nm_rad" Positive => |s| Some(s.gearbox.tooth_stiffness_Nm_rad);
    "gearbox.tooth_damping_Nm_s_rad" NonNegative => |s| Some(s.gearbox.tooth_damping_Nm_s_rad);
    "wheel.radius_m" Positive => |s| Some(s.wheel.radius_m);
    "wheel.inertia_kg_m2" Positive => |s| Some(s.wheel.inertia_kg_m2);
    "wheel.viscous_Nm_s_rad" NonNegative => |s| Some(s.wheel.viscous_Nm_s_rad);
    "tyre.peak_mu" Positive => |s| s.tyre.peak_mu;
    "tyre.sliding_ratio" open_closed(0.0, 1.0) => |s| s.tyre.sliding_ratio;
    "tyre.long_stiffness_per_N" Positive => |s| s.tyre.long_stiffness_per_N;
    "tyre.lat_stiffness_per_N" Positive => |s| s.tyre.lat_stiffness_per_N;
    "tyre.relaxation_length_m" Positive => |s| s.tyre.relaxation_length_m;
    "battery.open_circuit_V" Positive => |s| Some(s.battery.open_circuit_V);
    "battery.internal_resistance_ohm" NonNegative => |s| Some(s.battery.internal_resistance_ohm);
    "battery.drive_limit_V" Positive => |s| Some(s.battery.drive_limit_V);
    "battery.low_voltage_fault_V" NonNegative => |s| Some(s.battery.low_voltage_fault_V);
    "battery.bridge_rated_V" NonNegative => |s| Some(s.battery.bridge_rated_V);
    "dcmc.forward_gain_V_pct" Finite => |s| Some(s.dcmc.forward_gain_V_pct);
    "dcmc.turn_gain_V_pct" Finite => |s| Some(s.dcmc.turn_gain_V_pct);
    "dcmc.speed_per_pct_rad_s" Positive => |s| Some(s.dcmc.speed_per_pct_rad_s);
    "dcmc.kp_V_s_rad" NonNegative => |s| Some(s.dcmc.kp_V_s_rad);
    "dcmc.ki_V_rad" NonNegative => |s| Some(s.dcmc.ki_V_rad);
    "dcmc.enable_delay_s" NonNegative => |s| Some(s.dcmc.enable_delay_s);
    "dcmc.combined_fault_pct" Positive => |s| Some(s.dcmc.combined_fault_pct);
    "dcmc.brake_gain_V_s_rad" NonNegative => |s| Some(s.dcmc.brake_gain_V_s_rad);
    "dcmc.current_limit_A" Positive => |s| Some(s.dcmc.current_limit_A);
    "dcmc.ramp_left_pct_s" NonNegative => |s| Some(s.dcmc.ramp_left_pct_s);
    "dcmc.ramp_right_pct_s" NonNegative => |s| Some(s.dcmc.ramp_right_pct_s);
    "dcmc.turn_ramp_pct_s" NonNegative => |s| Some(s.dcmc.turn_ramp_pct_s);
    "dcmc.response_time_left_s" NonNegative => |s| Some(s.dcmc.response_time_left_s);
    "dcmc.response_time_right_s" NonNegative => |s| Some(s.dcmc.response_time_right_s);
    "dcmc.turn_response_time_s" NonNegative => |s| Some(s.dcmc.turn_response_time_s);
    "dcmc.command_delay_s" NonNegative => |s| Some(s.dcmc.command_delay_s);
    "sensors.x_m" Finite => |s| Some(s.sensors.x_m);
    "sensors.half_spacing_m" Positive => |s| Some(s.sensors.half_spacing_m);
    "sensors.height_m" Positive => |s| Some(s.sensors.height_m);
    "sensors.full_scale_adc" Positive => |s| Some(s.sensors.full_scale_adc);
    "sensors.noise_adc" NonNegative => |s| Some(s.sensors.noise_adc);
    "sensors.lost_threshold_adc" NonNegative => |s| Some(s.sensors.lost_threshold_adc);
    "sensors.rear_x_m" Finite => |s| s.sensors.rear_x_m;
    "controller.kp_num" Integer => |s| Some(s.controller.kp_num as f64);
    "controller.kp_den" NonZeroInteger => |s| Some(s.controller.kp_den as f64);
    "controller.kd_num" Integer => |s| Some(s.controller.kd_num as f64);
    "controller.kd_den" NonZeroInteger => |s| Some(s.controller.kd_den as f64);
    "controller.gain_scale" NonNegative => |s| Some(s.controller.gain_scale);
    "controller.period_s" Positive => |s| Some(s.controller.period_s);
    "controller.compute_delay_s" NonNegative => |s| Some(s.controller.compute_delay_s);
    "controller.forward_counts" Integer => |s| Some(s.controller.forward_counts as f64);
    "controller.reference_counts" Integer => |s| Some(s.controller.reference_counts as f64);
    "controller.duty_min" closed_open(0.0, 127.0) => |s| Some(s.controller.duty_min as f64);
    "controller.duty_max" open_closed(127.0, 255.0) => |s| Some(s.controller.duty_max as f64);
    "controller.pwm_filter_hz" Positive => |s| Some(s.controller.pwm_filter_hz);
    "controller.start_delay_s" NonNegative => |s| Some(s.controller.start_delay_s);
    "controller.open_loop_forward_pct" Finite => |s| Some(s.controller.open_loop_forward_pct);
    "controller.open_loop_turn_pct" Finite => |s| Some(s.controller.open_loop_turn_pct);
    "controller.crawl_counts" Integer => |s| Some(s.controller.crawl_counts as f64);
    "controller.spin_counts" Integer => |s| Some(s.controller.spin_counts as f64);
    "controller.found_adc" Integer => |s| Some(s.controller.found_adc as f64);
    "controller.centred_counts" Integer => |s| Some(s.controller.centred_counts as f64);
    "controller.centring_kp_den" NonZeroInteger => |s| Some(s.controller.centring_kp_den as f64);
    "controller.swing_away.axle_gain_per_s" Positive => |s| Some(s.controller.swing_away.axle_gain_per_s);
    "controller.swing_away.heading_gain_per_s" Positive => |s| Some(s.controller.swing_away.heading_gain_per_s);
    "controller.swing_away.max_heading_rad" Interval { lo: 0.0, lo_open: true, hi: std::f64::consts::FRAC_PI_2, hi_open: true } => |s| Some(s.controller.swing_away.max_heading_rad);
    "controller.swing_away.correction" closed(0.0, 1.0) => |s| Some(s.controller.swing_away.correction);
    "controller.swing_away.straight_start_s" NonNegative => |s| Some(s.controller.swing_away.straight_start_s);
    "start.x_m" Finite => |s| Some(s.start.x_m);
    "start.y_m" Finite => |s| Some(s.start.y_m);
    "start.heading_rad" Finite => |s| Some(s.start.heading_rad);
};

fn text(s: &str) -> String {
    s.to_string()
}

/// Every scene key that is not a single number, with what it takes (checked where the
/// file is read, or by the consistency rules in `validate.rs`).
pub const OTHER: &[OtherKey] = &[
    OtherKey {
        key: "description",
        takes: || text("text"),
    },
    OtherKey {
        key: "sim.fidelity",
        takes: || text("`linear`, `nonlinear`, `complex`, `full`"),
    },
    OtherKey {
        key: "sim.wheels_lifted",
        takes: || text("true, false"),
    },
    OtherKey {
        key: "castors.compound",
        takes: || format!("one of {}", presets::compound_names()),
    },
    OtherKey {
        key: "tyre.compound",
        takes: || format!("one of {}", presets::compound_names()),
    },
    OtherKey {
        key: "floor.surface",
        takes: || format!("one of {}", presets::surface_names()),
    },
    OtherKey {
        key: "floor.regions",
        takes: || {
            text("`[[floor.regions]]` tables of `surface` and `polygon_m`: at least 3 finite `[x, y]` corners of a convex polygon, m")
        },
    },
    OtherKey {
        key: "dcmc.kind",
        takes: || text("`gain`, `p`, `pi`, `gain_pi`"),
    },
    OtherKey {
        key: "dcmc.turn_priority",
        takes: || text("true, false"),
    },
    OtherKey {
        key: "sensors.law",
        takes: || text("`measured`, `physical`"),
    },
    OtherKey {
        key: "controller.kind",
        takes: || text("`pd`, `open_day`, `open_loop`, `swing_away` (needs `reverse = true`)"),
    },
    OtherKey {
        key: "controller.reverse",
        takes: || text("true, false"),
    },
    OtherKey {
        key: "controller.pwm_dither",
        takes: || text("true, false"),
    },
    OtherKey {
        key: "controller.bumper",
        takes: || text("true, false"),
    },
    OtherKey {
        key: "wire.points_m",
        takes: || {
            format!(
                "at least 2 distinct `[x, y]` points (3 when closed), within {:e} m of the origin",
                super::validate::MAX_FLOOR_M
            )
        },
    },
    OtherKey {
        key: "wire.closed",
        takes: || text("true, false"),
    },
    OtherKey {
        key: "obstacles",
        takes: || {
            text("`[[obstacles]]` tables of `center_m` `[x, y]`, exactly one of `half_extents_m` `[hx, hy]` (> 0) or `radius_m` (> 0), and `angle_rad`")
        },
    },
    OtherKey {
        key: "expect",
        takes: || {
            text("`[expect]`: what a run of the scene shows (`settles`, `rms_error_mm`, `limit_cycle`, `limit_cycle_mm`, `loses_wire`, `on_wire_at_end`, `wire_losses`, `reaches_wire_end`, `bumper_stop`, `sliding_pct`, `distance_m`; ranges as `[lo, hi]`), checked by `run` and the tests")
        },
    },
];

/// Checks every numeric key present against its rule.
pub fn check(scene: &Scene) -> Result<(), Invalid> {
    for k in NUMERIC {
        if let Some(v) = (k.get)(scene) {
            if !k.allowed.admits(v) {
                return Err(Invalid {
                    key: k.key.to_string(),
                    value: v.to_string(),
                    expected: k.allowed.expected(),
                });
            }
        }
    }
    Ok(())
}

/// The scene reference in Markdown: one table per section, each key with its allowed
/// values and default (the thesis machine).
pub fn markdown() -> String {
    let defaults = Scene::default();
    let mut rows: Vec<(String, String, String)> = NUMERIC
        .iter()
        .map(|k| {
            let default = (k.get)(&defaults).map_or("(unset)".into(), |v| format!("{v}"));
            (k.key.to_string(), k.allowed.text(), default)
        })
        .collect();
    let tree = toml::Value::try_from(&defaults).unwrap_or(toml::Value::Boolean(false));
    rows.extend(OTHER.iter().map(|k| {
        let default = k
            .key
            .split('.')
            .try_fold(&tree, |v, part| v.get(part))
            .map_or(String::new(), |v| match v {
                toml::Value::String(t) if t.is_empty() => "(empty)".into(),
                toml::Value::String(t) => format!("`{t}`"),
                toml::Value::Boolean(b) => b.to_string(),
                toml::Value::Array(a) if k.key == "wire.points_m" => format!("{} points", a.len()),
                toml::Value::Array(a) if a.is_empty() => "none".into(),
                _ => String::new(),
            });
        (k.key.to_string(), (k.takes)(), default)
    }));
    // The schema's order; a key of a section not listed sorts last.
    const SECTIONS: [&str; 19] = [
        "description",
        "sim",
        "chassis",
        "payload",
        "castors",
        "motor",
        "gearbox",
        "wheel",
        "tyre",
        "floor",
        "battery",
        "dcmc",
        "sensors",
        "controller",
        "controller.swing_away",
        "wire",
        "start",
        "obstacles",
        "expect",
    ];
    let rank = |key: &str| {
        let section = key.rsplit_once('.').map_or(key, |(s, _)| s);
        SECTIONS
            .iter()
            .position(|s| *s == section)
            .unwrap_or(SECTIONS.len())
    };
    rows.sort_by_key(|(k, _, _)| rank(k));
    let mut out = String::from("| key | allowed | default |\n| --- | --- | --- |\n");
    for (k, allowed, default) in rows {
        out.push_str(&format!("| `{k}` | {allowed} | {default} |\n"));
    }
    out
}
