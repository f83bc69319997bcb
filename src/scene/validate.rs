//! Checks on a parsed scene: each key against its rule in [`super::ranges`], then the
//! rules that tie keys together. Each failure names the key, the value and what was
//! expected.

use super::{Invalid, Scene};
use crate::firmware::ControllerKind;
use crate::firmware::ControllerParams;
use crate::model::battery::BatteryParams;
use crate::model::castor::CastorParams;
use crate::model::manoeuvre::ManoeuvreParams;
use crate::model::tyre::TyreChoice;
use crate::model::tyre_presets as presets;
use crate::scene::schema::SimSettings;
use crate::sensing::wire::WireParams;
use crate::sensing::wire::MAX_FLOOR_M;
use crate::world::FloorParams;

fn bad(key: &str, value: impl std::fmt::Display, expected: &str) -> Invalid {
    Invalid {
        key: key.to_string(),
        value: value.to_string(),
        expected: expected.to_string(),
    }
}

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

impl Scene {
    /// Every key against its rule in the table ([`super::keys`]), then the rules that
    /// tie keys together.
    pub fn validate(&self) -> Result<(), Invalid> {
        self.expect.validate()?;
        super::keys::check(self)?;
        self.check_timing()?;
        self.check_loads()?;
        self.check_choices()?;
        self.check_floor()?;
        self.check_controller()?;
        self.check_wire()?;
        self.check_obstacles()?;
        self.check_uncertainties()
    }

    /// Each `[uncertainty_pct]` entry names a numeric scene key and a percentage above zero.
    fn check_uncertainties(&self) -> Result<(), Invalid> {
        let table = super::keys::table();
        for (key, &pct) in &self.uncertainty_pct {
            let name = format!("uncertainty_pct.\"{key}\"");
            if table.find(key).and_then(|k| k.allowed()).is_none() {
                return Err(Invalid {
                    key: name,
                    value: format!("{pct}"),
                    expected: "a numeric scene key (quoted, e.g. \"chassis.mass_kg\" = 10; `agvsim keys` lists them)".into(),
                });
            }
            if !(pct.is_finite() && pct > 0.0) {
                return Err(bad(
                    &name,
                    pct,
                    "a percentage greater than zero: one standard deviation of the belief",
                ));
            }
        }
        Ok(())
    }

    fn check_timing(&self) -> Result<(), Invalid> {
        let s = &self.sim;
        let steps = s.duration_s / s.dt_s;
        if steps > s.max_steps as f64 {
            return Err(bad(
                SimSettings::duration_s.key(),
                format!("{} s", crate::param::plain_number(s.duration_s)),
                &format!(
                    "a run of at most sim.max_steps = {} physics steps; at sim.dt_s = {} s this one would take {steps:.3e}: shorten it, or raise sim.max_steps (e.g. --set sim.max_steps={}) if it is meant",
                    s.max_steps,
                    s.dt_s,
                    crate::param::plain_number(steps.ceil())
                ),
            ));
        }
        if s.duration_s < s.record_interval_s {
            // A run shorter than one recorded interval writes one row: nothing to see.
            return Err(bad(
                SimSettings::duration_s.key(),
                format!("{} s", s.duration_s),
                &format!(
                    "a run at least one recording interval long (sim.record_interval_s = {} s)",
                    s.record_interval_s
                ),
            ));
        }
        if s.record_interval_s < s.dt_s {
            return Err(bad(
                SimSettings::record_interval_s.key(),
                s.record_interval_s,
                "an interval no shorter than sim.dt_s",
            ));
        }
        let b = &self.battery;
        if b.low_voltage_fault_v >= b.open_circuit_v {
            return Err(bad(
                BatteryParams::low_voltage_fault_v.key(),
                format!("{} V", b.low_voltage_fault_v),
                &format!(
                    "a fault threshold below battery.open_circuit_V = {} V, or the unit faults \
                     before it drives; the thesis machine faults at 22 of 24 V (92 %), here about \
                     {:.1} V (--set battery.low_voltage_fault_V={:.1})",
                    b.open_circuit_v,
                    0.92 * b.open_circuit_v,
                    0.92 * b.open_circuit_v
                ),
            ));
        }
        Ok(())
    }

    /// Where the castors must carry the part of the weight the drive wheels do not, their
    /// share must fall inside their rectangle or some castor would need negative load.
    fn check_loads(&self) -> Result<(), Invalid> {
        let (c, k) = (&self.chassis, &self.castors);
        let (_, cgx, cgy) = self.total_mass_and_cg();
        if c.drive_load_fraction == 1.0 {
            // Every load on the drive axle: the CG must be over it for the loads to balance.
            if cgx.abs() > 1e-9 {
                return Err(bad(
                    "chassis.cg_x_m / payload.cg_x_m",
                    format!("{cgx:.3} m (combined CG)"),
                    "a centre of gravity over the drive axle (0 m) when chassis.drive_load_fraction = 1 puts every load on the drive wheels",
                ));
            }
        } else {
            let cx = cgx / (1.0 - c.drive_load_fraction);
            if cgy.abs() >= k.half_spacing_m {
                return Err(bad(
                    "chassis.cg_y_m / payload.cg_y_m",
                    format!("{cgy:.3} m (combined CG)"),
                    &format!(
                        "a centre of gravity within the castors' spacing (|y| < castors.half_spacing_m = {} m)",
                        k.half_spacing_m
                    ),
                ));
            }
            if !(cx > k.rear_x_m && cx < k.front_x_m) {
                return Err(bad(
                    "chassis.cg_x_m / payload.cg_x_m",
                    format!("{cgx:.3} m (combined CG)"),
                    "a centre of gravity that the drive wheels and castors can carry with positive loads",
                ));
            }
        }
        if cgy.abs() >= c.track_width_m / 2.0 {
            return Err(bad(
                "chassis.cg_y_m / payload.cg_y_m",
                format!("{cgy:.3} m (combined CG)"),
                "a centre of gravity between the drive wheels",
            ));
        }
        Ok(())
    }

    fn check_choices(&self) -> Result<(), Invalid> {
        for (key, name) in [
            (CastorParams::compound.key(), &self.castors.compound),
            (TyreChoice::compound.key(), &self.tyre.compound),
        ] {
            if presets::compound(name).is_none() {
                return Err(bad(
                    key,
                    format!("{name:?}"),
                    &format!("one of {}", presets::compound_names()),
                ));
            }
        }
        let m = &self.manoeuvre;
        if !["square", "circle", "commands"].contains(&m.kind.as_str()) {
            return Err(bad(
                ManoeuvreParams::kind.key(),
                format!("{:?}", m.kind),
                "one of \"square\", \"circle\", \"commands\"",
            ));
        }
        if m.kind == "commands" && m.commands.trim().is_empty() {
            return Err(bad(
                ManoeuvreParams::commands.key(),
                "\"\"",
                "the commands CSV's path (t_s, cmd_linear_m_s, cmd_angular_rad_s) for manoeuvre.kind = \"commands\"",
            ));
        }
        Ok(())
    }

    fn check_floor(&self) -> Result<(), Invalid> {
        if presets::surface(&self.floor.surface).is_none() {
            return Err(bad(
                FloorParams::surface.key(),
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
        Ok(())
    }

    fn check_controller(&self) -> Result<(), Invalid> {
        let k = &self.controller;
        if k.compute_delay_s >= k.period_s {
            return Err(bad(
                ControllerParams::compute_delay_s.key(),
                k.compute_delay_s,
                "a delay shorter than controller.period_s",
            ));
        }
        if k.kind == ControllerKind::SwingAway && !k.reverse {
            return Err(bad(
                ControllerParams::kind.key(),
                "swing_away",
                "a reversing run: swing_away is a reversing strategy, so set controller.reverse = true",
            ));
        }
        Ok(())
    }

    fn check_wire(&self) -> Result<(), Invalid> {
        let w = &self.wire;
        if w.points_m.len() < 2 {
            return Err(bad(
                WireParams::points_m.key(),
                format!("{} point(s)", w.points_m.len()),
                "at least 2 [x, y] points (3 for a closed loop)",
            ));
        }
        if w.closed && w.points_m.len() < 3 {
            return Err(bad(
                WireParams::points_m.key(),
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
        Ok(())
    }

    fn check_obstacles(&self) -> Result<(), Invalid> {
        for (i, o) in self.obstacles.iter().enumerate() {
            let key = format!("obstacles[{i}]");
            if !o.center_m.iter().all(|v| v.is_finite()) {
                return Err(bad(
                    &format!("{key}.center_m"),
                    format!("{:?}", o.center_m),
                    "finite coordinates",
                ));
            }
            if !o.angle_rad.is_finite() {
                return Err(bad(
                    &format!("{key}.angle_rad"),
                    o.angle_rad,
                    "a finite angle, rad",
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
                (None, Some(r)) => {
                    if !(r.is_finite() && r > 0.0) {
                        return Err(bad(
                            &format!("{key}.radius_m"),
                            r,
                            "a finite number greater than zero",
                        ));
                    }
                }
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
