//! Flags several commands share, each declared once (its name, placeholder, help and
//! check) and flattened into every request that takes it, and the value checks clap runs
//! on the command line's numbers. Value parsers return `Result<_, String>`: clap's form.

use std::path::PathBuf;

use crate::ident::effects::{Choice, EffectNameError};
use crate::scene::robot::MotorDatasheet;

/// `--set KEY=VALUE` (repeatable): scene overrides, applied as the scene is loaded.
#[derive(clap::Args, Debug, Clone, Default, PartialEq)]
pub struct Overrides {
    /// Override a scene value, e.g. --set chassis.mass_kg=60 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

impl From<Vec<String>> for Overrides {
    fn from(set: Vec<String>) -> Self {
        Overrides { set }
    }
}

impl std::ops::Deref for Overrides {
    type Target = [String];
    fn deref(&self) -> &[String] {
        &self.set
    }
}

/// `--jobs N`: worker threads.
#[derive(clap::Args, Debug, Clone, Copy, Default, PartialEq)]
pub struct Jobs {
    /// Worker threads [default: one per core]; the results do not depend on it.
    #[arg(long = "jobs", value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub jobs: Option<u32>,
}

impl Jobs {
    /// `n` threads (0: one per core).
    pub fn of(n: usize) -> Jobs {
        Jobs {
            jobs: (n > 0).then(|| n.min(u32::MAX as usize) as u32),
        }
    }

    /// The thread count asked for (0: one per core).
    pub fn count(self) -> usize {
        self.jobs.unwrap_or(0) as usize
    }
}

/// `--effects NAME,...`: the effects a diagnosis or calibration tries.
#[derive(clap::Args, Debug, Clone, PartialEq)]
pub struct Effects {
    /// Comma-separated effects of the contract's vocabulary to try (backlash,
    /// coulomb_friction, friction_asymmetry, offset, voltage_saturation, battery_sag,
    /// transport_delay, speed_feedback, wheel_slip, castor_drag, wheel_geometry,
    /// base_limits): each is
    /// fitted with the machine's keys and kept only where the recording gives evidence for
    /// it. `all`: every effect the recording and the machine's model can show, and (for
    /// `diagnose` of a rotary drive axis) the terms outside the vocabulary, searched after
    /// them (speed_power, periodic_motor_angle, periodic_wheel_angle,
    /// load_dependent_friction, thermal_drift, current_power, time_drift); named effects
    /// leave the terms out; `none`: no effect.
    #[arg(
        long = "effects",
        value_delimiter = ',',
        value_name = "NAME,...",
        default_value = "all"
    )]
    pub effects: Vec<String>,
}

impl Default for Effects {
    fn default() -> Self {
        Effects {
            effects: vec!["all".into()],
        }
    }
}

impl From<Vec<String>> for Effects {
    fn from(effects: Vec<String>) -> Self {
        Effects { effects }
    }
}

impl Effects {
    /// The effects named, checked against the vocabulary: the one place the words are
    /// read.
    pub fn choice(&self) -> Result<Choice, EffectNameError> {
        Choice::parse(&self.effects)
    }
}

/// `--save FILE.rrd`, `--spawn`, `--connect`: where a run goes in Rerun.
#[derive(clap::Args, Debug, Clone, Default, PartialEq)]
pub struct RerunFlags {
    /// Write a Rerun recording to this .rrd file.
    #[arg(long, value_name = "FILE.rrd")]
    pub save: Option<PathBuf>,
    /// Open the Rerun viewer and stream to it.
    #[arg(long, conflicts_with_all = ["save", "connect"])]
    pub spawn: bool,
    /// Stream to a running Rerun viewer.
    #[arg(long, conflicts_with_all = ["save"])]
    pub connect: bool,
}

impl RerunFlags {
    /// Where the flags send the run, if anywhere.
    pub fn target(&self) -> Option<crate::viz::RerunTarget> {
        use crate::viz::RerunTarget;
        match (&self.save, self.spawn, self.connect) {
            (Some(p), _, _) => Some(RerunTarget::Save(p.clone())),
            (None, true, _) => Some(RerunTarget::Spawn),
            (None, false, true) => Some(RerunTarget::Connect),
            _ => None,
        }
    }
}

/// A robot's battery, drive motor (one datasheet point) and gear, as `new` and `import
/// ros2` take them; each in its unit.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct DriveFlags {
    /// Battery (open-circuit) voltage, V.
    #[arg(long = "battery-V", value_parser = positive_number)]
    pub battery_v: Option<f64>,
    /// The motor datasheet's rated voltage, V [default: --battery-V].
    #[arg(long = "motor-rated-V", value_parser = positive_number)]
    pub motor_rated_v: Option<f64>,
    /// The motor's no-load speed at its rated voltage, rpm (at the motor shaft, before the
    /// gear).
    #[arg(long, value_parser = positive_number)]
    pub motor_no_load_rpm: Option<f64>,
    /// The motor's stall current at its rated voltage, A.
    #[arg(long = "motor-stall-current-A", value_parser = positive_number)]
    pub motor_stall_current_a: Option<f64>,
    /// The motor's stall torque at its rated voltage, N m (at the motor shaft); used for
    /// the resistance when the stall current is not given.
    #[arg(long = "motor-stall-torque-Nm", value_parser = positive_number)]
    pub motor_stall_torque_nm: Option<f64>,
    /// Motor turns per wheel turn.
    #[arg(long, value_parser = positive_number)]
    pub gear_ratio: Option<f64>,
    /// Gear play at the wheel, rad [default: 0, none].
    #[arg(long)]
    pub backlash_rad: Option<f64>,
}

impl DriveFlags {
    /// The motor's datasheet point the flags give: `None` when no motor number is given;
    /// an error naming the flags when some are given but not enough for a motor.
    pub fn motor(&self) -> Result<Option<MotorDatasheet>, super::CommandError> {
        let motor_given = self.motor_no_load_rpm.is_some()
            || self.motor_stall_current_a.is_some()
            || self.motor_stall_torque_nm.is_some()
            || self.motor_rated_v.is_some();
        match (motor_given, self.motor_no_load_rpm, self.motor_rated_v.or(self.battery_v)) {
            (false, _, _) => Ok(None),
            (true, Some(rpm), Some(v)) => Ok(Some(MotorDatasheet {
                rated_v: v,
                no_load_rpm: rpm,
                stall_current_a: self.motor_stall_current_a,
                stall_torque_nm: self.motor_stall_torque_nm,
            })),
            (true, _, _) => Err(super::CommandError::Option {
                option: "--motor-*".into(),
                value: String::new(),
                message: "a motor needs --motor-no-load-rpm and --motor-rated-V (or --battery-V), with --motor-stall-current-A or --motor-stall-torque-Nm".into(),
            }),
        }
    }
}

/// Does nothing with a progress line (a request's default until its caller says where
/// progress goes).
pub fn no_progress(_: &str) {}

/// A positive, finite number.
pub fn positive_number(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("`{s}`: expected a positive number")),
    }
}

/// A positive, finite number of seconds.
pub fn positive_seconds(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number of seconds"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("`{s}`: expected a positive number of seconds"))
    }
}

/// A finite number, zero or more.
pub fn non_negative(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("`{s}`: expected a number >= 0")),
    }
}

/// `MIN..MAX` whole samples, 1 <= MIN <= MAX.
pub fn hold_range(s: &str) -> Result<(usize, usize), String> {
    let bad =
        || format!("`{s}`: expected MIN..MAX whole samples with 1 <= MIN <= MAX, e.g. 20..60");
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let (a, b): (usize, usize) = (
        a.trim().parse().map_err(|_| bad())?,
        b.trim().parse().map_err(|_| bad())?,
    );
    if a >= 1 && a <= b {
        Ok((a, b))
    } else {
        Err(bad())
    }
}

/// A demand in percent, 0 < d <= 100.
pub fn demand_pct(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v <= 100.0 => Ok(v),
        _ => Err(format!("`{s}`: expected a demand in percent, 0 < d <= 100")),
    }
}

/// `yes`/`true` or `no`/`false`.
pub fn yes_no(s: &str) -> Result<bool, String> {
    match s {
        "yes" | "true" => Ok(true),
        "no" | "false" => Ok(false),
        _ => Err(format!("`{s}`: expected yes or no")),
    }
}

/// `--seed`: a whole number from 0 to 2^63 - 1 (a scene's TOML holds its seed as a signed
/// 64-bit integer: a larger one would be read back as a float).
pub fn seed(s: &str) -> Result<u64, String> {
    let v: u64 = s
        .trim()
        .parse()
        .map_err(|_| format!("expected a whole number from 0 to {}", i64::MAX))?;
    if v > i64::MAX as u64 {
        return Err(format!(
            "expected a whole number from 0 to {} (a scene's seed is a TOML integer)",
            i64::MAX
        ));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_outside_their_range_are_refused_with_the_text_typed() {
        assert_eq!(positive_number("2.5"), Ok(2.5));
        for bad in ["0", "-1", "inf", "NaN", "x"] {
            assert!(positive_number(bad).unwrap_err().contains(bad), "{bad}");
        }
        assert!(positive_seconds("1e400").is_err());
        assert_eq!(hold_range("20..60"), Ok((20, 60)));
        assert!(hold_range("0..3").is_err() && hold_range("5..4").is_err());
        assert!(demand_pct("100").is_ok() && demand_pct("100.1").is_err());
        assert_eq!(Jobs::of(0).count(), 0);
        assert_eq!(Jobs::of(3).count(), 3);
    }
}
