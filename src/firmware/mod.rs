//! The 80C552 firmware: a timer interrupt samples the ADC (sample and hold), computes the
//! fixed-point P-D law on the sensor difference, and after a computation delay writes the
//! PWM registers, clipped to the DCMC's accepted duty range. `pwm` holds the 100 Hz
//! filter that turns duty into analogue demand. The Open Day program (PLAYTIME.C) is a
//! small state machine around the same law. `swing_away` is the reversing strategy the
//! thesis describes but did not build.

pub mod pwm;
pub mod swing_away;

use swing_away::{SwingAwayInput, SwingAwayParams, SwingAwayState};

use crate::scene::ControllerKind;

/// PWM duty that means "stop" (half of 255).
pub const HALF_DUTY: i32 = 127;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FirmwareParams {
    pub kind: ControllerKind,
    pub kp_num: i32,
    pub kp_den: i32,
    pub kd_num: i32,
    pub kd_den: i32,
    pub gain_scale: f64,
    /// Sampling period, s; `None`: a continuous controller (evaluated every physics step).
    pub period_s: Option<f64>,
    pub compute_delay_s: f64,
    /// Integer arithmetic as on the 8-bit micro (C division truncates toward zero).
    pub integer_math: bool,
    /// Keep the law's fraction and dither the PWM registers by error feedback (the
    /// rounding residue of each interrupt carried to the next) instead of truncating.
    pub pwm_dither: bool,
    pub forward_counts: i32,
    pub reverse: bool,
    pub reference_counts: i32,
    pub duty_min: i32,
    pub duty_max: i32,
    pub start_delay_s: f64,
    pub open_loop_forward_pct: f64,
    pub open_loop_turn_pct: f64,
    pub crawl_counts: i32,
    pub spin_counts: i32,
    pub found_adc: i32,
    pub centred_counts: i32,
    pub centring_kp_den: i32,
    pub lost_threshold_adc: f64,
    pub bumper: bool,
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
    /// X[0], X[1]: this and the previous sensor difference, counts.
    pub x_hist: [f64; 2],
    /// Sample index of the next interrupt.
    pub next_sample: u64,
    /// Duty values computed but not yet written (applies at the given time).
    pub pending: Option<(f64, [i32; 2])>,
    /// PWM registers (forward, turn), counts.
    pub duty: [i32; 2],
    /// Demands before the duty quantisation (forward, turn), counts, for plots.
    pub command_counts: [f64; 2],
    pub phase: Phase,
    /// The wire was last seen on the right (S0 < S1).
    pub last_seen_right: bool,
    pub drive_enabled: bool,
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
    pub t_s: f64,
    /// ADC readings (S0 left, S1 right), counts.
    pub sensors_adc: [f64; 2],
    /// Sensor difference from ideal position feedback (linear level), counts; used
    /// instead of the readings when present.
    pub ideal_difference: Option<f64>,
    pub bumper: bool,
    /// Drive wheels' rim speeds (left, right), m/s: odometry, read only by the swing-away
    /// strategy.
    pub wheel_speed_m_s: [f64; 2],
}

impl FirmwareParams {
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
        if self.integer_math && !self.pwm_dither {
            v.trunc()
        } else {
            v
        }
    }

    /// `Ut = Kp (R - X[1]) + Kd (X[0] - X[1])`.
    fn pd_turn(&self, s: &FirmwareState, kp_den: i32) -> f64 {
        let p = self.gain_times(
            self.kp_num,
            kp_den,
            self.gain_scale,
            self.reference_counts as f64 - s.x_hist[1],
        );
        let d = self.gain_times(self.kd_num, self.kd_den, 1.0, s.x_hist[0] - s.x_hist[1]);
        p + d
    }

    /// `Drive(Forward, Turn)`: offsets from half duty, rounded to whole counts (with the
    /// carried residue when dithering) and clipped to the accepted range.
    fn duties(&self, s: &mut FirmwareState, forward: f64, turn: f64) -> [i32; 2] {
        let mut duty = [0; 2];
        for (i, v) in [forward, turn].into_iter().enumerate() {
            let wanted = HALF_DUTY as f64
                + v
                + if self.pwm_dither {
                    s.dither_residue[i]
                } else {
                    0.0
                };
            let written = wanted
                .round()
                .clamp(self.duty_min as f64, self.duty_max as f64);
            // A clipped register carries nothing over (no wind-up against the limit).
            s.dither_residue[i] = if self.pwm_dither && written == wanted.round() {
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
        if self.bumper && u.bumper && s.phase != Phase::Stopped {
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
            if t_s + 1e-9 < self.start_delay_s {
                return [0.0, 0.0];
            }
            s.phase = Phase::Follow;
        }
        let sign = if self.reverse { -1.0 } else { 1.0 };
        match self.kind {
            ControllerKind::OpenLoop => [
                self.open_loop_forward_pct * crate::firmware::pwm::COUNTS_PER_PCT,
                self.open_loop_turn_pct * crate::firmware::pwm::COUNTS_PER_PCT,
            ],
            ControllerKind::Pd => [
                sign * self.forward_counts as f64,
                sign * self.pd_turn(s, self.kp_den),
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
                [sign * self.forward_counts as f64, turn]
            }
            ControllerKind::OpenDay => match s.phase {
                Phase::Follow => {
                    if s.lost_wire {
                        s.phase = Phase::Spin;
                        self.spin(s)
                    } else {
                        [self.crawl_counts as f64, self.pd_turn(s, self.kp_den)]
                    }
                }
                Phase::Spin => {
                    // Spin until either reading exceeds COOEE, then re-centre.
                    if s.peak_reading_adc > self.found_adc as f64 {
                        s.phase = Phase::Centre;
                        [0.0, self.pd_turn(s, self.centring_kp_den)]
                    } else {
                        self.spin(s)
                    }
                }
                Phase::Centre => {
                    if s.x_hist[0].abs() < self.centred_counts as f64 {
                        s.phase = Phase::Follow;
                        [self.crawl_counts as f64, self.pd_turn(s, self.kp_den)]
                    } else {
                        [0.0, self.pd_turn(s, self.centring_kp_den)]
                    }
                }
                Phase::Starting | Phase::Stopped => [0.0, 0.0],
            },
        }
    }

    /// Spin on the spot towards the side the wire was last seen (positive turn = left).
    fn spin(&self, s: &FirmwareState) -> [f64; 2] {
        let turn = if s.last_seen_right {
            -self.spin_counts
        } else {
            self.spin_counts
        };
        [0.0, turn as f64]
    }
}
