//! A speed loop's law: the voltage a controller requests from a speed set-point and the
//! measured speed, with feed-forward, proportional and integral action. The DCMC block
//! (`p`, `pi`, `gain_pi`) and the fitting models' speed-feedback block both call it.

/// The gains of a speed loop (the DCMC's `p`, `pi` and `gain_pi`, and the fitting models'
/// speed-feedback block).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpeedLoopGains {
    /// Feed-forward of the set-point, V s/rad: the voltage per rad/s of set speed a unit
    /// calibrated to its motor applies before any error acts (the motor's back-EMF
    /// constant for such a unit; 0: none, the thesis's case-2 structures).
    pub feedforward_v_s_rad: f64,
    /// Proportional gain on the speed error, V s/rad.
    pub kp_v_s_rad: f64,
    /// Integral gain (`pi`), V/rad; 0 for `p`.
    pub ki_v_rad: f64,
}

impl SpeedLoopGains {
    /// The loop of a unit calibrated to its motor (`gain_pi`, the contract's
    /// `speed_feedback`): the gain structure's voltage fed forward through the motor's
    /// back-EMF constant (V s/rad), integral action (V/rad), no proportional term.
    #[inline]
    pub fn calibrated_to_motor(back_emf_v_s_rad: f64, ki_v_rad: f64) -> SpeedLoopGains {
        SpeedLoopGains {
            feedforward_v_s_rad: back_emf_v_s_rad,
            kp_v_s_rad: 0.0,
            ki_v_rad,
        }
    }

    /// The set-point (rad/s) such a unit makes of its gain structure's voltage (V): the
    /// speed that voltage gives the unloaded motor.
    #[inline]
    pub fn calibrated_setpoint_rad_s(&self, voltage_v: f64) -> f64 {
        voltage_v / self.feedforward_v_s_rad
    }

    /// One side's voltage request, V: `ff w_set + kp (w_set - w) + ki z`, with `z` the
    /// integral of the speed error `w_set - w` (rad). The simulator's DCMC and the fitting
    /// models' speed-feedback block both call this law; each integrates `z` its own way.
    #[inline]
    pub fn voltage_v(&self, setpoint_rad_s: f64, speed_rad_s: f64, integral_rad: f64) -> f64 {
        self.feedforward_v_s_rad * setpoint_rad_s
            + self.kp_v_s_rad * (setpoint_rad_s - speed_rad_s)
            + self.ki_v_rad * integral_rad
    }
}
