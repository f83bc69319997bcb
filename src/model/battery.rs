//! Battery: two 12 V lead-acid cells in series with internal resistance, the H-bridge's
//! voltage ceiling under load, and the DCMC's low-voltage threshold.

use super::Bounded;

crate::declare_params! {
    /// The battery and the H-bridges' limits (scene section `[battery]`): two 12 V
    /// lead-acid batteries in series on the thesis machine.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct BatteryParams in "battery" {
        /// Open-circuit voltage.
        open_circuit_v as "open_circuit_V": f64 = 24.0, "V", Positive;
        /// Internal resistance (*assumed*).
        internal_resistance_ohm: f64 = 0.02, "ohm", NonNegative;
        /// Highest voltage the H-bridges deliver to a motor under load (23.5 V measured).
        drive_limit_v as "drive_limit_V": f64 = 23.5, "V", Positive;
        /// The DCMC faults when the battery's terminal voltage falls below this.
        low_voltage_fault_v as "low_voltage_fault_V": f64 = 22.0, "V", NonNegative;
        /// For motor-voltage commands (a recording's `voltage_V`): the supply voltage the
        /// bridges assume when they set their PWM duty. 0 (default): compensated bridges,
        /// which deliver the command while the battery can. Above 0: duty = command / this
        /// (clipped to 1), times the battery's terminal voltage, so its sag under current
        /// scales every command (the contract's `battery_sag`).
        bridge_rated_v as "bridge_rated_V": f64 = 0.0, "V", NonNegative;
    }
}

impl BatteryParams {
    /// Terminal voltage while delivering `current_a` (negative: charging by regeneration), V.
    #[inline]
    pub fn terminal_voltage_v(&self, current_a: f64) -> f64 {
        self.open_circuit_v - self.internal_resistance_ohm * current_a
    }

    /// Highest voltage a motor can be given at a terminal voltage, V.
    #[inline]
    pub fn available_drive_v(&self, terminal_v: f64) -> f64 {
        self.drive_limit_v.min(terminal_v).max(0.0)
    }

    /// PWM duty (-1..1) an uncompensated bridge sets for a voltage command: the command over
    /// its rated supply. `None` for a compensated bridge (`bridge_rated_v` 0).
    #[inline]
    pub fn duty_for_command(&self, command_v: f64) -> Option<f64> {
        (self.bridge_rated_v > 0.0).then(|| (command_v / self.bridge_rated_v).bounded(-1.0, 1.0))
    }

    /// Voltage a bridge applies to a motor for a voltage command at a battery terminal
    /// voltage, V. A compensated bridge delivers the command while the supply can, so the
    /// battery's sag shows only once the command exceeds what is left. An uncompensated one
    /// sets its duty against its rated supply and applies the duty times the terminal
    /// voltage, so the sag scales every command. Either is clipped to what can be given.
    #[inline]
    pub fn bridge_output_v(&self, command_v: f64, terminal_v: f64) -> f64 {
        let available = self.available_drive_v(terminal_v);
        let applied = match self.duty_for_command(command_v) {
            Some(duty) => duty * terminal_v,
            None => command_v,
        };
        applied.bounded(-available, available)
    }

    /// Voltages that bridges sharing this battery apply for their commands (V), feeding
    /// motors that draw `currents_a`: each sets its duty from its command (a compensated
    /// bridge counted at full duty), the battery delivers the sum of duty times current,
    /// and each applies its command through [`Self::bridge_output_v`] at the terminal
    /// voltage that leaves.
    #[inline]
    pub fn bridges_output_v<const N: usize>(
        &self,
        commands_v: [f64; N],
        currents_a: [f64; N],
    ) -> [f64; N] {
        let battery_current_a: f64 = commands_v
            .iter()
            .zip(&currents_a)
            .map(|(&v, &i)| self.duty_for_command(v).unwrap_or(1.0) * i)
            .sum();
        let terminal_v = self.terminal_voltage_v(battery_current_a);
        commands_v.map(|v| self.bridge_output_v(v, terminal_v))
    }

    /// Battery current for the motors' electrical power (ideal bridges: power balance), A.
    pub fn current_for_power_a(&self, motor_power_w: f64) -> f64 {
        // Solve P = (Voc - R i) i for the smaller root (the physical one).
        let (v, r) = (self.open_circuit_v, self.internal_resistance_ohm);
        if r <= 0.0 {
            return motor_power_w / v;
        }
        let disc = v * v - 4.0 * r * motor_power_w;
        if disc <= 0.0 {
            v / (2.0 * r) // beyond maximum power transfer: the battery collapses
        } else {
            (v - disc.sqrt()) / (2.0 * r)
        }
    }

    /// Whether a terminal voltage is below the DCMC's low-voltage threshold.
    pub fn below_fault(&self, terminal_v: f64) -> bool {
        terminal_v < self.low_voltage_fault_v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn battery(rated_v: f64) -> BatteryParams {
        BatteryParams {
            open_circuit_v: 24.0,
            internal_resistance_ohm: 0.1,
            drive_limit_v: 23.5,
            low_voltage_fault_v: 20.0,
            bridge_rated_v: rated_v,
        }
    }

    #[test]
    fn an_uncompensated_bridge_passes_the_sag_on_and_a_compensated_one_does_not() {
        // 20 A from the battery: 2 V of sag on 24 V.
        let terminal = battery(0.0).terminal_voltage_v(20.0);
        assert!((terminal - 22.0).abs() < 1e-12);
        // A 12 V command: the compensated bridge delivers it, the uncompensated one half of
        // the sagging terminal voltage.
        assert!((battery(0.0).bridge_output_v(12.0, terminal) - 12.0).abs() < 1e-12);
        assert!((battery(24.0).bridge_output_v(12.0, terminal) - 11.0).abs() < 1e-12);
        // Both are clipped by the drive limit and what the terminal gives.
        assert!((battery(0.0).bridge_output_v(-30.0, 24.0) + 23.5).abs() < 1e-12);
        assert!((battery(24.0).bridge_output_v(30.0, terminal) - 22.0).abs() < 1e-12);
    }
}
