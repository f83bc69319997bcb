//! What each fidelity level switches on: one simulator, whose levels differ only in these
//! switches. Declared with the scene (its `sim.fidelity` names the level), read by the
//! simulator and by the scene's own checks.

use super::schema::Fidelity;

/// Which parts of the model a fidelity level switches on. One simulator; the levels only
/// differ in these switches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Features {
    /// Feedback is the linearised sensor difference of the true lateral offset.
    pub ideal_feedback: bool,
    /// The firmware samples on its timer period with a computation delay.
    pub sample_and_hold: bool,
    /// 8-bit ADC rounding and integer arithmetic in the P-D law.
    pub quantisation: bool,
    /// Gear backlash (otherwise the play is zero and only the tooth spring remains).
    pub backlash: bool,
    /// PWM outputs through the 100 Hz filter.
    pub pwm_filter: bool,
    /// Rapier chassis with tyres (slip) and castor bodies; otherwise the no-slip chassis.
    pub tyres_and_castors: bool,
    /// The DCMC's faults (enable delay, combined demand, low battery), which the thesis's
    /// Simulink levels did not model.
    pub dcmc_faults: bool,
}

impl Features {
    /// The switches of a level.
    pub fn of(f: Fidelity) -> Features {
        match f {
            Fidelity::Linear => Features {
                ideal_feedback: true,
                sample_and_hold: false,
                quantisation: false,
                backlash: false,
                pwm_filter: false,
                tyres_and_castors: false,
                dcmc_faults: false,
            },
            Fidelity::Nonlinear => Features {
                ideal_feedback: false,
                sample_and_hold: true,
                quantisation: false,
                backlash: false,
                pwm_filter: true,
                tyres_and_castors: false,
                dcmc_faults: false,
            },
            Fidelity::Complex => Features {
                ideal_feedback: false,
                sample_and_hold: true,
                quantisation: true,
                backlash: true,
                pwm_filter: true,
                tyres_and_castors: false,
                dcmc_faults: false,
            },
            Fidelity::Full => Features {
                ideal_feedback: false,
                sample_and_hold: true,
                quantisation: true,
                backlash: true,
                pwm_filter: true,
                tyres_and_castors: true,
                dcmc_faults: true,
            },
        }
    }
}
