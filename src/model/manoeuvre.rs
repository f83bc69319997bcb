//! The manoeuvre a velocity-commanded base drives in `agvsim run` (`controller.kind =
//! "velocity"`): a `/cmd_vel` stream as a robot's navigation or a test script would send
//! it. The built-in tests are UMBmark's square (straight sides, a quarter turn on the spot
//! at each corner) and a circle; `commands` replays a commands CSV (`t_s`,
//! `cmd_linear_m_s`, `cmd_angular_rad_s`, each held to the next row), which the run reads
//! (the block holds only its path).

use std::f64::consts::{FRAC_PI_2, TAU};

/// What `manoeuvre.kind` takes.
fn manoeuvre_kinds() -> String {
    "`square`, `circle` or `commands` (with `manoeuvre.commands`)".into()
}

/// What `manoeuvre.commands` takes.
fn commands_file() -> String {
    "a CSV path (relative to the scene's folder) with t_s, cmd_linear_m_s, cmd_angular_rad_s".into()
}

crate::declare_params! {
    /// The manoeuvre of a velocity-commanded base (scene section `[manoeuvre]`).
    #[derive(Debug, Clone, PartialEq)]
    pub struct ManoeuvreParams in "manoeuvre" {
        /// `square` (UMBmark's: each side straight, then a quarter turn on the spot),
        /// `circle`, or `commands` (a commands CSV).
        kind: String = "square".into(), "", other(manoeuvre_kinds);
        /// Forward speed on the straights and the circle.
        speed_m_s: f64 = 0.3, "m/s", Positive;
        /// Yaw rate of a turn on the spot.
        turn_rate_rad_s: f64 = 0.5, "rad/s", Positive;
        /// Side of the square.
        side_m: f64 = 1.0, "m", Positive;
        /// Radius of the circle.
        radius_m: f64 = 1.0, "m", Positive;
        /// Times round.
        laps: u64 = 1, "", Positive;
        /// Clockwise (turning right) instead of counter-clockwise.
        clockwise: bool = false, "", other(crate::param::true_or_false);
        /// Rest before the manoeuvre starts and after it ends.
        rest_s: f64 = 1.0, "s", NonNegative;
        /// The commands CSV for `kind = "commands"`.
        commands: String = String::new(), "", other(commands_file);
    }
}

/// A manoeuvre ready to drive: the command at each time.
#[derive(Debug, Clone, PartialEq)]
pub enum Manoeuvre {
    /// The built-in square or circle.
    Shape(ManoeuvreParams),
    /// Commands read from a file: (time, forward speed, yaw rate), time increasing.
    Commands(Vec<(f64, f64, f64)>),
}

impl ManoeuvreParams {
    /// Whether every key has its default (the section is then left out of a scene's text).
    pub fn is_default(&self) -> bool {
        *self == ManoeuvreParams::default()
    }

    /// Time one side of the square takes (straight, then the quarter turn), s.
    fn side_s(&self) -> (f64, f64) {
        (
            self.side_m / self.speed_m_s,
            FRAC_PI_2 / self.turn_rate_rad_s,
        )
    }

    /// The shape's own length (its rests included), s.
    pub fn duration_s(&self) -> f64 {
        let laps = self.laps.max(1) as f64;
        let moving = match self.kind.as_str() {
            "circle" => laps * TAU * self.radius_m / self.speed_m_s,
            _ => {
                let (straight, turn) = self.side_s();
                laps * 4.0 * (straight + turn)
            }
        };
        moving + 2.0 * self.rest_s
    }

    /// The command at time `t_s` of the shape: forward speed, m/s, and yaw rate, rad/s.
    pub fn command_at(&self, t_s: f64) -> (f64, f64) {
        let t = t_s - self.rest_s;
        let sign = if self.clockwise { -1.0 } else { 1.0 };
        if t < 0.0 || t >= self.duration_s() - 2.0 * self.rest_s {
            return (0.0, 0.0);
        }
        match self.kind.as_str() {
            "circle" => (self.speed_m_s, sign * self.speed_m_s / self.radius_m),
            _ => {
                let (straight, turn) = self.side_s();
                if t % (straight + turn) < straight {
                    (self.speed_m_s, 0.0)
                } else {
                    (0.0, sign * self.turn_rate_rad_s)
                }
            }
        }
    }
}

impl Manoeuvre {
    /// The command at `t_s`: the shape's, or the last file row at or before it (zero
    /// before the first and held after the last).
    pub fn command_at(&self, t_s: f64) -> (f64, f64) {
        match self {
            Manoeuvre::Shape(p) => p.command_at(t_s),
            Manoeuvre::Commands(rows) => {
                let i = rows.partition_point(|r| r.0 <= t_s);
                if i == 0 {
                    (0.0, 0.0)
                } else {
                    (rows[i - 1].1, rows[i - 1].2)
                }
            }
        }
    }

    /// How long it lasts, s (a file's: its last row's time).
    pub fn duration_s(&self) -> f64 {
        match self {
            Manoeuvre::Shape(p) => p.duration_s(),
            Manoeuvre::Commands(rows) => rows.last().map_or(0.0, |r| r.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The square's commands, integrated as a robot that follows them exactly would, come
    /// back to the start: four sides of its length at its speed, four quarter turns.
    #[test]
    fn a_square_driven_exactly_closes_on_its_start() {
        let p = ManoeuvreParams {
            side_m: 0.75,
            speed_m_s: 0.25,
            ..ManoeuvreParams::default()
        };
        let dt = 1e-3;
        let (mut x, mut y, mut h) = (0.0, 0.0, 0.0_f64);
        let n = (p.duration_s() / dt).round() as usize;
        let mut turned = 0.0;
        for k in 0..n {
            let (v, w) = p.command_at(k as f64 * dt);
            x += v * h.cos() * dt;
            y += v * h.sin() * dt;
            h += w * dt;
            turned += w * dt;
        }
        assert!((turned - TAU).abs() < 0.01, "{turned}");
        assert!(x.hypot(y) < 0.01, "({x}, {y})");
        assert_eq!(p.command_at(p.duration_s() + 1.0), (0.0, 0.0));
    }

    #[test]
    fn commands_hold_from_their_row() {
        let m = Manoeuvre::Commands(vec![(1.0, 0.5, 0.0), (2.0, 0.0, 1.0)]);
        assert_eq!(m.command_at(0.5), (0.0, 0.0));
        assert_eq!(m.command_at(1.5), (0.5, 0.0));
        assert_eq!(m.command_at(9.0), (0.0, 1.0));
        assert_eq!(m.duration_s(), 2.0);
    }
}
