//! Dead time between an external command (a recording's motor voltages or demands) and
//! the drive acting on it: the contract's `transport_delay` (a serial link, a controller's
//! scan, a bridge's own loop). The firmware's computation delay is its own
//! (`controller.compute_delay_s`).

use std::collections::VecDeque;

use super::Actuation;

/// Commands waiting out the dead time, and the one acting.
#[derive(Debug, Clone)]
pub struct CommandDelay {
    delay_s: f64,
    /// (arrival time, command), in arrival order.
    pending: VecDeque<(f64, Actuation)>,
    acting: Actuation,
}

/// The same command at zero (what acts before the first one arrives, from rest).
fn zero_of(a: Actuation) -> Actuation {
    match a {
        Actuation::Voltage(_) => Actuation::Voltage([0.0; 2]),
        Actuation::Demand { .. } => Actuation::Demand {
            forward_pct: 0.0,
            turn_pct: 0.0,
        },
        Actuation::Velocity { .. } => Actuation::Velocity {
            linear_m_s: 0.0,
            angular_rad_s: 0.0,
        },
        other => other,
    }
}

/// `f` of `a` and `1 - f` of `b`, where both are the same kind of command; otherwise
/// whichever acts longer.
fn blend(a: Actuation, b: Actuation, f: f64) -> Actuation {
    let mix = |x: f64, y: f64| f * x + (1.0 - f) * y;
    match (a, b) {
        (Actuation::Voltage(x), Actuation::Voltage(y)) => {
            Actuation::Voltage([mix(x[0], y[0]), mix(x[1], y[1])])
        }
        (
            Actuation::Demand {
                forward_pct: f0,
                turn_pct: t0,
            },
            Actuation::Demand {
                forward_pct: f1,
                turn_pct: t1,
            },
        ) => Actuation::Demand {
            forward_pct: mix(f0, f1),
            turn_pct: mix(t0, t1),
        },
        (
            Actuation::Velocity {
                linear_m_s: v0,
                angular_rad_s: w0,
            },
            Actuation::Velocity {
                linear_m_s: v1,
                angular_rad_s: w1,
            },
        ) => Actuation::Velocity {
            linear_m_s: mix(v0, v1),
            angular_rad_s: mix(w0, w1),
        },
        _ if f >= 0.5 => a,
        _ => b,
    }
}

impl CommandDelay {
    /// A dead time of `delay_s` (> 0), with `acting` in force until the first command.
    pub fn new(delay_s: f64, acting: Actuation) -> CommandDelay {
        CommandDelay {
            delay_s,
            pending: VecDeque::new(),
            acting,
        }
    }

    /// A command given at `t_s`: it reaches the drive `delay_s` later. Before the first
    /// external command arrives the drive holds that command at zero (a recording starts
    /// from rest), not the firmware.
    pub fn push(&mut self, t_s: f64, a: Actuation) {
        if self.pending.is_empty() && self.acting == Actuation::Firmware {
            self.acting = zero_of(a);
        }
        self.pending.push_back((t_s + self.delay_s, a));
    }

    /// The command acting over the step `[t_s, t_s + dt_s)`: the one in force, blended
    /// with one arriving within the step in proportion to the time each acts, so that the
    /// response moves smoothly with the delay rather than in whole steps.
    pub fn acting(&mut self, t_s: f64, dt_s: f64) -> Actuation {
        // Arrivals within a billionth of a step of the start count as arrived.
        let due = t_s + 1e-9 * dt_s;
        while let Some(&(arrival, a)) = self.pending.front() {
            if arrival > due {
                break;
            }
            self.acting = a;
            self.pending.pop_front();
        }
        match self.pending.front() {
            Some(&(arrival, next)) if arrival < t_s + dt_s => {
                blend(self.acting, next, (arrival - t_s) / dt_s)
            }
            _ => self.acting,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_command_acts_its_dead_time_later_and_mid_step_arrivals_are_blended() {
        let mut d = CommandDelay::new(0.0025, Actuation::Firmware);
        d.push(0.0, Actuation::Voltage([10.0, -4.0]));
        // Before the command arrives: zero volts, not the firmware.
        assert_eq!(d.acting(0.0, 0.001), Actuation::Voltage([0.0, 0.0]));
        assert_eq!(d.acting(0.001, 0.001), Actuation::Voltage([0.0, 0.0]));
        // It arrives half-way through the third step.
        match d.acting(0.002, 0.001) {
            Actuation::Voltage(v) => {
                assert!(
                    (v[0] - 5.0).abs() < 1e-9 && (v[1] + 2.0).abs() < 1e-9,
                    "{v:?}"
                )
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(d.acting(0.003, 0.001), Actuation::Voltage([10.0, -4.0]));
    }
}
