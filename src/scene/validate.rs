//! Range and consistency checks on a parsed scene. Each failure names the key, the value
//! and what was expected.

use super::{presets, ControllerKind, Invalid, Scene};

fn bad(key: &str, value: impl std::fmt::Display, expected: &str) -> Invalid {
    Invalid {
        key: key.to_string(),
        value: value.to_string(),
        expected: expected.to_string(),
    }
}

fn positive(key: &str, v: f64) -> Result<(), Invalid> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(bad(key, v, "a finite number greater than zero"))
    }
}

/// Largest coordinate on the floor, m: far beyond any plant, small enough that squared
/// distances and the field's arithmetic stay exact to well below a millimetre.
pub const MAX_FLOOR_M: f64 = 1.0e5;

/// The first corner where a polygon's outline turns against its overall direction (a
/// concave or self-crossing outline), if any.
fn concave_corner(poly: &[[f64; 2]]) -> Option<usize> {
    let n = poly.len();
    let turn = |k: usize| {
        let (a, b, c) = (poly[(k + n - 1) % n], poly[k], poly[(k + 1) % n]);
        (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
    };
    let total: f64 = (0..n).map(turn).sum();
    let area2: f64 = (0..n)
        .map(|k| poly[k][0] * poly[(k + 1) % n][1] - poly[(k + 1) % n][0] * poly[k][1])
        .sum();
    let sign = if area2 != 0.0 {
        area2.signum()
    } else {
        total.signum()
    };
    (0..n).find(|&k| turn(k) * sign < -1e-12)
}

fn non_negative(key: &str, v: f64) -> Result<(), Invalid> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(bad(key, v, "a finite number, zero or more"))
    }
}

fn finite(key: &str, v: f64) -> Result<(), Invalid> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(bad(key, v, "a finite number"))
    }
}

fn fraction(key: &str, v: f64) -> Result<(), Invalid> {
    if v.is_finite() && v > 0.0 && v < 1.0 {
        Ok(())
    } else {
        Err(bad(key, v, "a fraction strictly between 0 and 1"))
    }
}

impl Scene {
    pub fn validate(&self) -> Result<(), Invalid> {
        self.expect.validate()?;
        let s = &self.sim;
        positive("sim.duration_s", s.duration_s)?;
        if !(s.dt_s.is_finite() && s.dt_s > 0.0 && s.dt_s <= 0.01) {
            return Err(bad("sim.dt_s", s.dt_s, "a step between 0 and 0.01 s"));
        }
        if !(s.record_interval_s.is_finite() && s.record_interval_s >= s.dt_s) {
            return Err(bad(
                "sim.record_interval_s",
                s.record_interval_s,
                "an interval no shorter than sim.dt_s",
            ));
        }
        let c = &self.chassis;
        positive("chassis.mass_kg", c.mass_kg)?;
        positive("chassis.yaw_inertia_kg_m2", c.yaw_inertia_kg_m2)?;
        positive("chassis.track_width_m", c.track_width_m)?;
        finite("chassis.cg_x_m", c.cg_x_m)?;
        finite("chassis.cg_y_m", c.cg_y_m)?;
        fraction("chassis.drive_load_fraction", c.drive_load_fraction)?;
        positive("chassis.front_m", c.front_m)?;
        positive("chassis.rear_m", c.rear_m)?;
        positive("chassis.width_m", c.width_m)?;
        let p = &self.payload;
        non_negative("payload.mass_kg", p.mass_kg)?;
        finite("payload.cg_x_m", p.cg_x_m)?;
        finite("payload.cg_y_m", p.cg_y_m)?;
        non_negative("payload.yaw_inertia_kg_m2", p.yaw_inertia_kg_m2)?;
        let k = &self.castors;
        finite("castors.front_x_m", k.front_x_m)?;
        finite("castors.rear_x_m", k.rear_x_m)?;
        if !(k.front_x_m > 0.0 && k.rear_x_m < 0.0) {
            return Err(bad(
                "castors.front_x_m / castors.rear_x_m",
                format!("{} / {}", k.front_x_m, k.rear_x_m),
                "front castors ahead of the drive axle (> 0) and rear ones behind it (< 0)",
            ));
        }
        positive("castors.half_spacing_m", k.half_spacing_m)?;
        positive("castors.trail_m", k.trail_m)?;
        positive("castors.mass_kg", k.mass_kg)?;
        non_negative("castors.swivel_friction_Nm", k.swivel_friction_Nm)?;
        non_negative("castors.rolling_resistance", k.rolling_resistance)?;
        finite("castors.initial_angle_rad", k.initial_angle_rad)?;
        non_negative(
            "castors.lumped_linear_drag_N_s_m",
            k.lumped_linear_drag_N_s_m,
        )?;
        non_negative(
            "castors.lumped_angular_drag_Nm_s_rad",
            k.lumped_angular_drag_Nm_s_rad,
        )?;
        if presets::compound(&k.compound).is_none() {
            return Err(bad(
                "castors.compound",
                format!("{:?}", k.compound),
                &format!("one of {}", presets::compound_names()),
            ));
        }
        // Where the castors must carry the part of the weight the drive wheels do not, their
        // share must fall inside their rectangle or some castor would need negative load.
        let (m, cgx, cgy) = self.total_mass_and_cg();
        let _ = m;
        let f = c.drive_load_fraction;
        let cx = cgx / (1.0 - f);
        if !(cx > k.rear_x_m && cx < k.front_x_m) || cgy.abs() >= k.half_spacing_m {
            return Err(bad(
                "chassis.cg_x_m / payload.cg_x_m",
                format!("{cgx:.3} m (combined CG)"),
                "a centre of gravity that the drive wheels and castors can carry with positive loads",
            ));
        }
        if cgy.abs() >= c.track_width_m / 2.0 {
            return Err(bad(
                "chassis.cg_y_m / payload.cg_y_m",
                format!("{cgy:.3} m (combined CG)"),
                "a centre of gravity between the drive wheels",
            ));
        }
        let mo = &self.motor;
        positive("motor.resistance_ohm", mo.resistance_ohm)?;
        positive("motor.inductance_H", mo.inductance_H)?;
        positive("motor.torque_constant_Nm_A", mo.torque_constant_Nm_A)?;
        positive("motor.rotor_inertia_kg_m2", mo.rotor_inertia_kg_m2)?;
        non_negative("motor.viscous_Nm_s_rad", mo.viscous_Nm_s_rad)?;
        non_negative("motor.coulomb_Nm", mo.coulomb_Nm)?;
        let g = &self.gearbox;
        positive("gearbox.ratio", g.ratio)?;
        if !(g.backlash_rad.is_finite() && g.backlash_rad >= 0.0 && g.backlash_rad < 1.0) {
            return Err(bad(
                "gearbox.backlash_rad",
                g.backlash_rad,
                "a play at the wheel from 0 to 1 rad (0 = no backlash)",
            ));
        }
        positive("gearbox.tooth_stiffness_Nm_rad", g.tooth_stiffness_Nm_rad)?;
        non_negative("gearbox.tooth_damping_Nm_s_rad", g.tooth_damping_Nm_s_rad)?;
        positive("wheel.radius_m", self.wheel.radius_m)?;
        positive("wheel.inertia_kg_m2", self.wheel.inertia_kg_m2)?;
        let t = &self.tyre;
        if presets::compound(&t.compound).is_none() {
            return Err(bad(
                "tyre.compound",
                format!("{:?}", t.compound),
                &format!("one of {}", presets::compound_names()),
            ));
        }
        if let Some(v) = t.peak_mu {
            positive("tyre.peak_mu", v)?;
        }
        if let Some(v) = t.sliding_ratio {
            if !(v.is_finite() && v > 0.0 && v <= 1.0) {
                return Err(bad("tyre.sliding_ratio", v, "a fraction in (0, 1]"));
            }
        }
        if let Some(v) = t.long_stiffness_per_N {
            positive("tyre.long_stiffness_per_N", v)?;
        }
        if let Some(v) = t.lat_stiffness_per_N {
            positive("tyre.lat_stiffness_per_N", v)?;
        }
        if let Some(v) = t.relaxation_length_m {
            positive("tyre.relaxation_length_m", v)?;
        }
        if presets::surface(&self.floor.surface).is_none() {
            return Err(bad(
                "floor.surface",
                format!("{:?}", self.floor.surface),
                &format!("one of {}", presets::surface_names()),
            ));
        }
        for (i, r) in self.floor.regions.iter().enumerate() {
            if presets::surface(&r.surface).is_none() {
                return Err(bad(
                    &format!("floor.regions[{i}].surface"),
                    format!("{:?}", r.surface),
                    &format!("one of {}", presets::surface_names()),
                ));
            }
            let area2: f64 = (0..r.polygon_m.len())
                .map(|k| {
                    let (a, b) = (r.polygon_m[k], r.polygon_m[(k + 1) % r.polygon_m.len()]);
                    a[0] * b[1] - b[0] * a[1]
                })
                .sum();
            if r.polygon_m.len() < 3
                || r.polygon_m.iter().flatten().any(|v| !v.is_finite())
                || area2.abs() < 1e-9
            {
                return Err(bad(
                    &format!("floor.regions[{i}].polygon_m"),
                    format!("{} points", r.polygon_m.len()),
                    "at least 3 finite [x, y] corners of a convex polygon",
                ));
            }
            if let Some(k) = concave_corner(&r.polygon_m) {
                return Err(bad(
                    &format!("floor.regions[{i}].polygon_m[{k}]"),
                    format!("{:?}", r.polygon_m[k]),
                    "a corner of a convex polygon (the outline turns the other way here)",
                ));
            }
        }
        let b = &self.battery;
        positive("battery.open_circuit_V", b.open_circuit_V)?;
        non_negative("battery.internal_resistance_ohm", b.internal_resistance_ohm)?;
        positive("battery.drive_limit_V", b.drive_limit_V)?;
        non_negative("battery.low_voltage_fault_V", b.low_voltage_fault_V)?;
        if b.low_voltage_fault_V >= b.open_circuit_V {
            return Err(bad(
                "battery.low_voltage_fault_V",
                b.low_voltage_fault_V,
                "a fault threshold below battery.open_circuit_V",
            ));
        }
        let d = &self.dcmc;
        finite("dcmc.forward_gain_V_pct", d.forward_gain_V_pct)?;
        finite("dcmc.turn_gain_V_pct", d.turn_gain_V_pct)?;
        positive("dcmc.speed_per_pct_rad_s", d.speed_per_pct_rad_s)?;
        non_negative("dcmc.kp_V_s_rad", d.kp_V_s_rad)?;
        non_negative("dcmc.ki_V_rad", d.ki_V_rad)?;
        non_negative("dcmc.enable_delay_s", d.enable_delay_s)?;
        positive("dcmc.combined_fault_pct", d.combined_fault_pct)?;
        non_negative("dcmc.brake_gain_V_s_rad", d.brake_gain_V_s_rad)?;
        positive("dcmc.current_limit_A", d.current_limit_A)?;
        non_negative("dcmc.ramp_left_pct_s", d.ramp_left_pct_s)?;
        non_negative("dcmc.ramp_right_pct_s", d.ramp_right_pct_s)?;
        non_negative("dcmc.turn_ramp_pct_s", d.turn_ramp_pct_s)?;
        non_negative("dcmc.response_time_left_s", d.response_time_left_s)?;
        non_negative("dcmc.response_time_right_s", d.response_time_right_s)?;
        non_negative("dcmc.turn_response_time_s", d.turn_response_time_s)?;
        let se = &self.sensors;
        finite("sensors.x_m", se.x_m)?;
        positive("sensors.half_spacing_m", se.half_spacing_m)?;
        positive("sensors.height_m", se.height_m)?;
        positive("sensors.full_scale_adc", se.full_scale_adc)?;
        non_negative("sensors.noise_adc", se.noise_adc)?;
        non_negative("sensors.lost_threshold_adc", se.lost_threshold_adc)?;
        if let Some(v) = se.rear_x_m {
            finite("sensors.rear_x_m", v)?;
        }
        let k = &self.controller;
        for (key, den) in [
            ("controller.kp_den", k.kp_den),
            ("controller.kd_den", k.kd_den),
            ("controller.centring_kp_den", k.centring_kp_den),
        ] {
            if den == 0 {
                return Err(bad(key, den, "a non-zero denominator"));
            }
        }
        non_negative("controller.gain_scale", k.gain_scale)?;
        positive("controller.period_s", k.period_s)?;
        non_negative("controller.compute_delay_s", k.compute_delay_s)?;
        if k.compute_delay_s >= k.period_s {
            return Err(bad(
                "controller.compute_delay_s",
                k.compute_delay_s,
                "a delay shorter than controller.period_s",
            ));
        }
        if !(0 <= k.duty_min && k.duty_min < 127 && 127 < k.duty_max && k.duty_max <= 255) {
            return Err(bad(
                "controller.duty_min / controller.duty_max",
                format!("{} / {}", k.duty_min, k.duty_max),
                "0 <= duty_min < 127 < duty_max <= 255",
            ));
        }
        positive("controller.pwm_filter_hz", k.pwm_filter_hz)?;
        non_negative("controller.start_delay_s", k.start_delay_s)?;
        finite("controller.open_loop_forward_pct", k.open_loop_forward_pct)?;
        finite("controller.open_loop_turn_pct", k.open_loop_turn_pct)?;
        let sw = &k.swing_away;
        positive("controller.swing_away.axle_gain_per_s", sw.axle_gain_per_s)?;
        positive(
            "controller.swing_away.heading_gain_per_s",
            sw.heading_gain_per_s,
        )?;
        non_negative(
            "controller.swing_away.straight_start_s",
            sw.straight_start_s,
        )?;
        if !(sw.max_heading_rad > 0.0 && sw.max_heading_rad < std::f64::consts::FRAC_PI_2) {
            return Err(bad(
                "controller.swing_away.max_heading_rad",
                sw.max_heading_rad,
                "an angle between 0 and pi/2 rad",
            ));
        }
        if !(0.0..=1.0).contains(&sw.correction) {
            return Err(bad(
                "controller.swing_away.correction",
                sw.correction,
                "a share between 0 and 1",
            ));
        }
        if k.kind == ControllerKind::SwingAway && !k.reverse {
            return Err(bad(
                "controller.kind",
                "swing_away",
                "a reversing run: swing_away is a reversing strategy, so set controller.reverse = true",
            ));
        }
        let w = &self.wire;
        if w.points_m.len() < 2 {
            return Err(bad(
                "wire.points_m",
                format!("{} point(s)", w.points_m.len()),
                "at least 2 [x, y] points (3 for a closed loop)",
            ));
        }
        if w.closed && w.points_m.len() < 3 {
            return Err(bad(
                "wire.points_m",
                "2 points",
                "at least 3 points for a closed loop",
            ));
        }
        for (i, p) in w.points_m.iter().enumerate() {
            if !(p[0].abs() <= MAX_FLOOR_M && p[1].abs() <= MAX_FLOOR_M) {
                return Err(bad(
                    &format!("wire.points_m[{i}]"),
                    format!("{p:?}"),
                    &format!("finite coordinates within {MAX_FLOOR_M:e} m of the origin"),
                ));
            }
        }
        for (i, pair) in w.points_m.windows(2).enumerate() {
            if (pair[0][0] - pair[1][0]).hypot(pair[0][1] - pair[1][1]) < 1e-6 {
                return Err(bad(
                    &format!("wire.points_m[{}]", i + 1),
                    format!("{:?}", pair[1]),
                    "a point distinct from the one before it",
                ));
            }
        }
        finite("start.x_m", self.start.x_m)?;
        finite("start.y_m", self.start.y_m)?;
        finite("start.heading_rad", self.start.heading_rad)?;
        for (i, o) in self.obstacles.iter().enumerate() {
            let key = format!("obstacles[{i}]");
            if !o.center_m.iter().all(|v| v.is_finite()) || !o.angle_rad.is_finite() {
                return Err(bad(
                    &format!("{key}.center_m"),
                    format!("{:?}", o.center_m),
                    "finite coordinates",
                ));
            }
            match (o.half_extents_m, o.radius_m) {
                (Some(h), None) => {
                    if !(h[0] > 0.0 && h[1] > 0.0 && h[0].is_finite() && h[1].is_finite()) {
                        return Err(bad(
                            &format!("{key}.half_extents_m"),
                            format!("{h:?}"),
                            "two positive half extents",
                        ));
                    }
                }
                (None, Some(r)) => positive(&format!("{key}.radius_m"), r)?,
                (given, _) => {
                    return Err(bad(
                        &key,
                        if given.is_some() {
                            "both half_extents_m and radius_m"
                        } else {
                            "neither half_extents_m nor radius_m"
                        },
                        "exactly one of half_extents_m (rectangle) or radius_m (circle)",
                    ))
                }
            }
        }
        Ok(())
    }

    /// Vehicle plus payload: total mass (kg) and CG in the body frame (m).
    pub fn total_mass_and_cg(&self) -> (f64, f64, f64) {
        let c = &self.chassis;
        let p = &self.payload;
        let m = c.mass_kg + p.mass_kg;
        let x = (c.mass_kg * c.cg_x_m + p.mass_kg * p.cg_x_m) / m;
        let y = (c.mass_kg * c.cg_y_m + p.mass_kg * p.cg_y_m) / m;
        (m, x, y)
    }
}
