//! The 80C552 firmware: a timer interrupt samples the ADC (sample and hold), computes the
//! fixed-point P-D law on the sensor difference, and after a computation delay writes the
//! PWM registers, clipped to the DCMC's accepted duty range. `pwm` holds the 100 Hz
//! filter that turns duty into analogue demand. The Open Day program (PLAYTIME.C) is a
//! small state machine around the same law. `swing_away` is the reversing strategy the
//! thesis describes but did not build.

pub mod pwm;
pub mod swing_away;

use crate::model::Bounded;
use swing_away::{SwingAwayDesign, SwingAwayInput, SwingAwayParams, SwingAwayState};

/// What the firmware does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, serde::Serialize, Default)]
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
    /// No firmware: a velocity-commanded base (a ROS robot), its base controller and
    /// drivers' speed loops (`[base]`) driven by the scene's manoeuvre (`[manoeuvre]`).
    Velocity,
}

impl crate::param::Value for ControllerKind {}
impl crate::param::Value for SwingAwayDesign {}

/// What `controller.kind` takes.
fn controller_kinds() -> String {
    "`pd`, `open_day`, `open_loop`, `swing_away` (needs `reverse = true`), `velocity` (a velocity-commanded base driving `[manoeuvre]`)".into()
}

/// What `controller.swing_away` takes.
fn swing_away_table() -> String {
    "`[controller.swing_away]`: the keys below".into()
}

crate::declare_params! {
    /// The 80C552 firmware: fixed-point P-D law, timer period, PWM outputs and filter
    /// (scene section `[controller]`).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct ControllerParams in "controller" {
        /// What the firmware does: `pd` (the lab runs), `open_day` (PLAYTIME.C),
        /// `open_loop` (constant demands) or `swing_away` (reversing).
        kind: ControllerKind = ControllerKind::Pd, "", other(controller_kinds);
        /// Proportional gain numerator (firmware: -1).
        kp_num: i32 = -1, "", Integer;
        /// Proportional gain denominator (firmware: 20).
        kp_den: i32 = 20, "", NonZeroInteger;
        /// Derivative gain numerator (firmware: 1).
        kd_num: i32 = 1, "", Integer;
        /// Derivative gain denominator (firmware: 8).
        kd_den: i32 = 8, "", NonZeroInteger;
        /// Multiplies the proportional gain; 1.0 is the firmware's Kp = kp_num/kp_den.
        /// This is the "proportional gain" of the thesis's simulation sweeps (0.1-6.0).
        gain_scale: f64 = 1.0, "", NonNegative;
        /// Control period (CNTRLPERIOD 0x10 on timer 2: 4096 ticks of 7.63 us = 31.25 ms).
        period_s: f64 = 0.03125, "s", Positive;
        /// Delay from sampling the ADC to writing the PWM registers (*assumed*).
        compute_delay_s: f64 = 0.004, "s", NonNegative;
        /// Forward demand as PWM counts above 127 (lab runs: ForwardVelocity 100).
        forward_counts: i32 = 100, "counts", Integer;
        /// Reversing: drive backwards and steer on the rear coil pair if there is one.
        reverse: bool = false, "", other(crate::param::true_or_false);
        /// Set-point of the sensor difference.
        reference_counts: i32 = 0, "counts", Integer;
        /// Lowest PWM duty the DCMC accepts, counts of 255 (127 = stop).
        duty_min: i32 = 20, "counts", closed_open(0.0, 127.0);
        /// Highest PWM duty the DCMC accepts, counts of 255.
        duty_max: i32 = 236, "counts", open_closed(127.0, 255.0);
        /// PWM low-pass filter corner (-3 dB).
        pwm_filter_hz: f64 = 100.0, "Hz", Positive;
        /// Keep the P-D law's fraction of a count and dither the 8-bit PWM registers
        /// (each interrupt's rounding residue carried to the next), so the filtered
        /// demand averages the fractional command; `false`: the C as printed, each term
        /// truncated to whole counts. *Assumed* `true` for the thesis machine: the
        /// printed arithmetic would never turn it from the floor runs' start, yet it did.
        pwm_dither: bool = true, "", other(crate::param::true_or_false);
        /// The firmware waits this long after enabling the DCMC before it drives (Delay(60)).
        start_delay_s: f64 = 1.0, "s", NonNegative;
        /// Open loop: constant forward demand.
        open_loop_forward_pct: f64 = 0.0, "pct", Finite;
        /// Open loop: constant turn demand.
        open_loop_turn_pct: f64 = 0.0, "pct", Finite;
        /// Open day: crawl speed (CRAWLSPEED 0x20).
        crawl_counts: i32 = 0x20, "counts", Integer;
        /// Open day: spin speed (TURNSPEED 0x20).
        spin_counts: i32 = 0x20, "counts", Integer;
        /// Open day: a reading above this ends the spin (COOEE 0x60).
        found_adc: i32 = 0x60, "counts", Integer;
        /// Open day: re-centring ends within this sensor difference (CLOSETOHOME 0x30).
        centred_counts: i32 = 0x30, "counts", Integer;
        /// Open day: denominator of the stronger re-centring gain (Kpt = -1/4).
        centring_kp_den: i32 = 4, "", NonZeroInteger;
        /// Stop (bumper interrupt) on contact with an obstacle.
        bumper: bool = true, "", other(crate::param::true_or_false);
        /// The swing-away reversing strategy's design (kind `swing_away`).
        swing_away: SwingAwayDesign = SwingAwayDesign::default(), "", other(swing_away_table);
    }
}

/// PWM duty that means "stop" (half of 255).
pub const HALF_DUTY: i32 = 127;

/// The firmware as it runs on its machine: its settings, and what the fidelity level and
/// the rest of the vehicle decide of it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Firmware {
    /// The firmware's settings.
    pub controller: ControllerParams,
    /// Sampling period, s; `None`: a continuous controller (evaluated every physics step).
    pub period_s: Option<f64>,
    /// Delay from sampling to writing the PWM registers, s (0 for a continuous controller).
    pub compute_delay_s: f64,
    /// Integer arithmetic as on the 8-bit micro (C division truncates toward zero).
    pub integer_math: bool,
    /// The wire counts as lost when both readings are below this, counts.
    pub lost_threshold_adc: f64,
    /// The swing-away reversing strategy (controller kind `swing_away` only).
    pub swing_away: Option<SwingAwayParams>,
}

/// The Open Day program's phases.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Phase {
    /// Waiting out the start delay after enabling the DCMC.
    #[default]
    Starting,
    /// Following the wire.
    Follow,
    /// Wire lost: stopped, spinning towards where it was last seen.
    Spin,
    /// Wire found: re-centring with a stronger gain, no forward speed.
    Centre,
    /// Bumper hit: demands at stop, DCMC disabled.
    Stopped,
}

impl Phase {
    /// The phase's name, for plots and summaries.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Starting => "starting",
            Phase::Follow => "follow",
            Phase::Spin => "spin",
            Phase::Centre => "centre",
            Phase::Stopped => "stopped",
        }
    }
}

/// What the firmware remembers.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FirmwareState {
    /// `X[0]`, `X[1]`: this and the previous sensor difference, counts.
    pub x_hist: [f64; 2],
    /// Sample index of the next interrupt.
    pub next_sample: u64,
    /// Duty values computed but not yet written (applies at the given time).
    pub pending: Option<(f64, [i32; 2])>,
    /// PWM registers (forward, turn), counts.
    pub duty: [i32; 2],
    /// Demands before the duty quantisation (forward, turn), counts, for plots.
    pub command_counts: [f64; 2],
    /// The Open Day program's phase.
    pub phase: Phase,
    /// The wire was last seen on the right (S0 < S1).
    pub last_seen_right: bool,
    /// The firmware holds the DCMC's enable line active.
    pub drive_enabled: bool,
    /// Both readings were below the lost threshold at the last interrupt.
    pub lost_wire: bool,
    /// The larger of the two readings at the last interrupt, counts.
    pub peak_reading_adc: f64,
    /// The swing-away strategy's estimate of where the wire is.
    pub swing_away: SwingAwayState,
    /// Rounding residue of the PWM registers (forward, turn) carried to the next
    /// interrupt when dithering, counts.
    pub dither_residue: [f64; 2],
}

/// What the firmware reads at an interrupt.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FirmwareInput {
    /// Time, s.
    pub t_s: f64,
    /// ADC readings (S0 left, S1 right), counts.
    pub sensors_adc: [f64; 2],
    /// Sensor difference from ideal position feedback (linear level), counts; used
    /// instead of the readings when present.
    pub ideal_difference: Option<f64>,
    /// The bumper's switch is open (contact).
    pub bumper: bool,
    /// Drive wheels' rim speeds (left, right), m/s: odometry, read only by the swing-away
    /// strategy.
    pub wheel_speed_m_s: [f64; 2],
}

impl Firmware {
    /// Starting state: DCMC enabled at t = 0, drives after the start delay.
    pub fn initial_state(&self) -> FirmwareState {
        FirmwareState {
            duty: [HALF_DUTY, HALF_DUTY],
            drive_enabled: true,
            phase: Phase::Starting,
            ..FirmwareState::default()
        }
    }

    /// Whether an interrupt falls due at `t_s` (one every period; every step when
    /// continuous).
    fn interrupt_due(&self, s: &FirmwareState, t_s: f64) -> bool {
        match self.period_s {
            None => true,
            Some(p) => t_s + 1e-9 >= s.next_sample as f64 * p,
        }
    }

    /// `num * e / den` as the firmware computes it (integer: truncation toward zero).
    fn gain_times(&self, num: i32, den: i32, scale: f64, e: f64) -> f64 {
        let v = num as f64 * scale * e / den as f64;
        if self.integer_math && !self.controller.pwm_dither {
            v.trunc()
        } else {
            v
        }
    }

    /// `Ut = Kp (R - X[1]) + Kd (X[0] - X[1])`.
    fn pd_turn(&self, s: &FirmwareState, kp_den: i32) -> f64 {
        let p = self.gain_times(
            self.controller.kp_num,
            kp_den,
            self.controller.gain_scale,
            self.controller.reference_counts as f64 - s.x_hist[1],
        );
        let d = self.gain_times(
            self.controller.kd_num,
            self.controller.kd_den,
            1.0,
            s.x_hist[0] - s.x_hist[1],
        );
        p + d
    }

    /// `Drive(Forward, Turn)`: offsets from half duty, rounded to whole counts (with the
    /// carried residue when dithering) and clipped to the accepted range.
    fn duties(&self, s: &mut FirmwareState, forward: f64, turn: f64) -> [i32; 2] {
        let mut duty = [0; 2];
        for (i, v) in [forward, turn].into_iter().enumerate() {
            let wanted = HALF_DUTY as f64
                + v
                + if self.controller.pwm_dither {
                    s.dither_residue[i]
                } else {
                    0.0
                };
            let written = wanted.round().bounded(
                self.controller.duty_min as f64,
                self.controller.duty_max as f64,
            );
            // A clipped register carries nothing over (no wind-up against the limit).
            s.dither_residue[i] = if self.controller.pwm_dither && written == wanted.round() {
                wanted - written
            } else {
                0.0
            };
            duty[i] = written as i32;
        }
        duty
    }

    /// Runs the firmware at a physics step: an interrupt if one is due, and the delayed
    /// write of the PWM registers. Returns the registers now in force.
    pub fn step(&self, s: &mut FirmwareState, u: &FirmwareInput) -> [i32; 2] {
        if let Some((at, duty)) = s.pending {
            if u.t_s + 1e-9 >= at {
                s.duty = duty;
                s.pending = None;
            }
        }
        if self.controller.bumper && u.bumper && s.phase != Phase::Stopped {
            // The bumper interrupt: both channels to half duty, DCMC disabled, at once.
            s.phase = Phase::Stopped;
            s.duty = [HALF_DUTY, HALF_DUTY];
            s.pending = None;
            s.drive_enabled = false;
        }
        if !self.interrupt_due(s, u.t_s) {
            return s.duty;
        }
        s.next_sample += 1;
        if s.phase == Phase::Stopped {
            return s.duty;
        }
        // GetXpos: the difference of the two readings and the lost-wire test.
        let [s0, s1] = u.sensors_adc;
        s.peak_reading_adc = s0.max(s1);
        s.lost_wire = s.peak_reading_adc < self.lost_threshold_adc;
        if s0 != s1 && !s.lost_wire {
            s.last_seen_right = s0 < s1;
        }
        let x = u.ideal_difference.unwrap_or(s0 - s1);
        s.x_hist = [x, s.x_hist[0]];
        let command = self.command(s, u);
        s.command_counts = command;
        let duty = self.duties(s, command[0], command[1]);
        if self.compute_delay_s > 0.0 {
            s.pending = Some((u.t_s + self.compute_delay_s, duty));
        } else {
            s.duty = duty;
        }
        s.duty
    }

    /// The (forward, turn) demand in counts for this interrupt, advancing the Open Day
    /// phases.
    fn command(&self, s: &mut FirmwareState, u: &FirmwareInput) -> [f64; 2] {
        let t_s = u.t_s;
        if s.phase == Phase::Starting {
            if t_s + 1e-9 < self.controller.start_delay_s {
                return [0.0, 0.0];
            }
            s.phase = Phase::Follow;
        }
        let sign = if self.controller.reverse { -1.0 } else { 1.0 };
        match self.controller.kind {
            // The run drives the base's velocity commands; the firmware asks nothing.
            ControllerKind::Velocity => [0.0, 0.0],
            ControllerKind::OpenLoop => [
                self.controller.open_loop_forward_pct * crate::firmware::pwm::COUNTS_PER_PCT,
                self.controller.open_loop_turn_pct * crate::firmware::pwm::COUNTS_PER_PCT,
            ],
            ControllerKind::Pd => [
                sign * self.controller.forward_counts as f64,
                sign * self.pd_turn(s, self.controller.kp_den),
            ],
            ControllerKind::SwingAway => {
                let turn = self.swing_away.map_or(0.0, |p| {
                    p.step(
                        &mut s.swing_away,
                        &SwingAwayInput {
                            readings_adc: u.sensors_adc,
                            wire_seen: !s.lost_wire,
                            wheel_speed_m_s: u.wheel_speed_m_s,
                            t_s,
                        },
                    )
                });
                [sign * self.controller.forward_counts as f64, turn]
            }
            ControllerKind::OpenDay => match s.phase {
                Phase::Follow => {
                    if s.lost_wire {
                        s.phase = Phase::Spin;
                        self.spin(s)
                    } else {
                        [
                            self.controller.crawl_counts as f64,
                            self.pd_turn(s, self.controller.kp_den),
                        ]
                    }
                }
                Phase::Spin => {
                    // Spin until either reading exceeds COOEE, then re-centre.
                    if s.peak_reading_adc > self.controller.found_adc as f64 {
                        s.phase = Phase::Centre;
                        [0.0, self.pd_turn(s, self.controller.centring_kp_den)]
                    } else {
                        self.spin(s)
                    }
                }
                Phase::Centre => {
                    if s.x_hist[0].abs() < self.controller.centred_counts as f64 {
                        s.phase = Phase::Follow;
                        [
                            self.controller.crawl_counts as f64,
                            self.pd_turn(s, self.controller.kp_den),
                        ]
                    } else {
                        [0.0, self.pd_turn(s, self.controller.centring_kp_den)]
                    }
                }
                Phase::Starting | Phase::Stopped => [0.0, 0.0],
            },
        }
    }

    /// Spin on the spot towards the side the wire was last seen (positive turn = left).
    fn spin(&self, s: &FirmwareState) -> [f64; 2] {
        let turn = if s.last_seen_right {
            -self.controller.spin_counts
        } else {
            self.controller.spin_counts
        };
        [0.0, turn as f64]
    }
}
