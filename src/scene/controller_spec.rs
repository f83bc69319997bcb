//! The scene's `[controller]` section: the firmware the AGV runs (the lab's P-D law, the
//! Open Day program, open loop, or the swing-away reversing strategy) and its settings.

use serde::{Deserialize, Serialize};

/// What the firmware does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ControllerKind {
    /// The lab runs: P-D wire following at a constant forward demand.
    #[default]
    Pd,
    /// PLAYTIME.C: follow, lose the wire, stop and spin to find it, re-centre, go on.
    OpenDay,
    /// No controller: constant demands (for identification and property tests).
    OpenLoop,
    /// The thesis's "swing away" reversing strategy on the front pair alone: steer the
    /// drive axle onto a wire assumed straight, by dead reckoning from wheel odometry
    /// (`[controller.swing_away]`; needs `reverse = true`). The thesis describes it but
    /// did not build it.
    SwingAway,
}

/// Design of the swing-away reversing strategy (`[controller.swing_away]`). The defaults
/// are ours (*assumed*): a heading loop several times faster than the axle loop.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SwingAwaySpec {
    /// Rate at which the axle closes on the assumed line, 1/s.
    pub axle_gain_per_s: f64,
    /// Yaw-rate demand per rad of heading error, 1/s.
    pub heading_gain_per_s: f64,
    /// Largest heading demand relative to the line, rad.
    pub max_heading_rad: f64,
    /// Share of the disagreement between sensed and estimated pair offset the estimate
    /// takes at each interrupt, 0..1.
    pub correction: f64,
    /// Reverse straight this long after first seeing the wire (the wheels spin up and
    /// would mislead the odometry) before taking the line estimate and steering, s.
    pub straight_start_s: f64,
}

impl Default for SwingAwaySpec {
    fn default() -> Self {
        SwingAwaySpec {
            axle_gain_per_s: 0.5,
            heading_gain_per_s: 2.5,
            max_heading_rad: 0.35,
            correction: 0.2,
            straight_start_s: 1.0,
        }
    }
}

/// The 80C552 firmware: fixed-point P-D law, timer period, PWM outputs and filter.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct ControllerSpec {
    pub kind: ControllerKind,
    /// Proportional gain numerator (firmware: -1).
    pub kp_num: i32,
    /// Proportional gain denominator (firmware: 20).
    pub kp_den: i32,
    /// Derivative gain numerator (firmware: 1).
    pub kd_num: i32,
    /// Derivative gain denominator (firmware: 8).
    pub kd_den: i32,
    /// Multiplies the proportional gain; 1.0 is the firmware's Kp = kp_num/kp_den. This is
    /// the "proportional gain" of the thesis's simulation sweeps (0.1-6.0).
    pub gain_scale: f64,
    /// Control period, s (CNTRLPERIOD 0x10 on timer 2: 4096 ticks of 7.63 us = 31.25 ms).
    pub period_s: f64,
    /// Delay from sampling the ADC to writing the PWM registers, s (*assumed*).
    pub compute_delay_s: f64,
    /// Forward demand as PWM counts above 127 (lab runs: ForwardVelocity 100).
    pub forward_counts: i32,
    /// Reversing: drive backwards and steer on the rear coil pair if there is one.
    pub reverse: bool,
    /// Set-point of the sensor difference, counts.
    pub reference_counts: i32,
    /// PWM duty limits, counts of 255 (127 = stop).
    pub duty_min: i32,
    pub duty_max: i32,
    /// PWM low-pass filter corner, Hz (-3 dB).
    pub pwm_filter_hz: f64,
    /// Keep the P-D law's fraction of a count and dither the 8-bit PWM registers (each
    /// interrupt's rounding residue is carried to the next), so the filtered demand
    /// averages the fractional command. `false`: the C as printed, each term truncated
    /// to whole counts. *Assumed* `true` for the thesis machine: with the calibrated
    /// coils the sensor difference 120 mm off the wire is 14 counts, and -14/20
    /// truncates to 0, so the printed arithmetic would never turn the vehicle from the
    /// floor runs' start, yet it did (the OCR lost the type of `ControlValue`).
    pub pwm_dither: bool,
    /// The firmware waits this long after enabling the DCMC before it drives, s (Delay(60)).
    pub start_delay_s: f64,
    /// Open loop: constant forward demand, pct.
    pub open_loop_forward_pct: f64,
    /// Open loop: constant turn demand, pct.
    pub open_loop_turn_pct: f64,
    /// Open day: crawl speed, counts (CRAWLSPEED 0x20).
    pub crawl_counts: i32,
    /// Open day: spin speed, counts (TURNSPEED 0x20).
    pub spin_counts: i32,
    /// Open day: a reading above this ends the spin, counts (COOEE 0x60).
    pub found_adc: i32,
    /// Open day: re-centring ends within this sensor difference, counts (CLOSETOHOME 0x30).
    pub centred_counts: i32,
    /// Open day: denominator of the stronger re-centring gain (Kpt = -1/4).
    pub centring_kp_den: i32,
    /// Stop (bumper interrupt) on contact with an obstacle.
    pub bumper: bool,
    /// The swing-away reversing strategy's design (kind `swing_away`).
    pub swing_away: SwingAwaySpec,
}

impl Default for ControllerSpec {
    fn default() -> Self {
        ControllerSpec {
            kind: ControllerKind::Pd,
            kp_num: -1,
            kp_den: 20,
            kd_num: 1,
            kd_den: 8,
            gain_scale: 1.0,
            period_s: 0.03125,
            compute_delay_s: 0.004,
            forward_counts: 100,
            reverse: false,
            reference_counts: 0,
            duty_min: 20,
            duty_max: 236,
            pwm_filter_hz: 100.0,
            pwm_dither: true,
            start_delay_s: 1.0,
            open_loop_forward_pct: 0.0,
            open_loop_turn_pct: 0.0,
            crawl_counts: 0x20,
            spin_counts: 0x20,
            found_adc: 0x60,
            centred_counts: 0x30,
            centring_kp_den: 4,
            bumper: true,
            swing_away: SwingAwaySpec::default(),
        }
    }
}
