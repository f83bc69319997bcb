//! Battery: two 12 V lead-acid cells in series with internal resistance, the H-bridge's
//! voltage ceiling under load, and the DCMC's low-voltage threshold.

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BatteryParams {
    pub open_circuit_v: f64,
    pub internal_resistance_ohm: f64,
    /// Highest motor voltage the bridges deliver, V.
    pub drive_limit_v: f64,
    pub low_voltage_fault_v: f64,
}

impl BatteryParams {
    /// Terminal voltage while delivering `current_a` (negative: charging by regeneration), V.
    pub fn terminal_voltage_v(&self, current_a: f64) -> f64 {
        self.open_circuit_v - self.internal_resistance_ohm * current_a
    }

    /// Highest voltage a motor can be given at a terminal voltage, V.
    pub fn available_drive_v(&self, terminal_v: f64) -> f64 {
        self.drive_limit_v.min(terminal_v).max(0.0)
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

    pub fn below_fault(&self, terminal_v: f64) -> bool {
        terminal_v < self.low_voltage_fault_v
    }
}
