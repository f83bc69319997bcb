//! What a run's metrics report: the summary of a run (its path, tracking, slip and the
//! vehicle's events) and the windows and motions it is stated over. The observer that
//! accumulates it from snapshots is [`super::metrics`].

use super::cycle::{LimitCycle, NoCycle};
use super::Snapshot;

/// Where and when something happened to the vehicle during a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunEvent {
    /// When, s.
    pub t_s: f64,
    /// Distance travelled by then, m.
    pub distance_m: f64,
    /// Axle midpoint then, world frame, m.
    pub at_m: [f64; 2],
}

/// The stretch of the run the RMS and peak lateral errors are taken over.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ErrorWindow {
    /// From settling to the end (the run settled and stayed on the wire).
    AfterSettling,
    /// From the start until the sensors first lost the wire.
    UntilWireLost,
    /// From the start until the axle passed the far end of the wire.
    UntilWireEnd,
    /// The whole run (it never settled, and stayed on the wire).
    #[default]
    WholeRun,
}

impl ErrorWindow {
    /// Words for summaries and tables.
    pub fn describe(self) -> &'static str {
        match self {
            ErrorWindow::AfterSettling => "after settling",
            ErrorWindow::UntilWireLost => "until the wire was lost",
            ErrorWindow::UntilWireEnd => "until the wire's end",
            ErrorWindow::WholeRun => "whole run",
        }
    }

    /// Name in results tables.
    pub fn name(self) -> &'static str {
        match self {
            ErrorWindow::AfterSettling => "after_settling",
            ErrorWindow::UntilWireLost => "until_wire_lost",
            ErrorWindow::UntilWireEnd => "until_wire_end",
            ErrorWindow::WholeRun => "whole_run",
        }
    }
}

/// The stretch of the run the slip figures are taken over: the second half of the time
/// the sensors were on the wire. The first half holds the start from rest, where any wheel
/// spin-up reads as a slip ratio near 1 while the vehicle barely moves; after the wire is
/// lost or ends, the vehicle is no longer tracking, and its slip says nothing of the
/// tracking the figures are about (a run that runs off the wire early would otherwise
/// seem to slip less the harder it was driven).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SlipWindow {
    /// The second half of the run (it stayed on the wire, or had none).
    #[default]
    SecondHalf,
    /// The second half of the time until the sensors first lost the wire.
    SecondHalfUntilWireLost,
    /// The second half of the time until the axle passed the far end of the wire.
    SecondHalfUntilWireEnd,
}

impl SlipWindow {
    /// Words for summaries and tables.
    pub fn describe(self) -> &'static str {
        match self {
            SlipWindow::SecondHalf => "second half of the run",
            SlipWindow::SecondHalfUntilWireLost => {
                "second half of the time until the wire was lost"
            }
            SlipWindow::SecondHalfUntilWireEnd => "second half of the time until the wire's end",
        }
    }

    /// Name in results tables.
    pub fn name(self) -> &'static str {
        match self {
            SlipWindow::SecondHalf => "second_half",
            SlipWindow::SecondHalfUntilWireLost => "second_half_until_wire_lost",
            SlipWindow::SecondHalfUntilWireEnd => "second_half_until_wire_end",
        }
    }
}

/// Below this rim speed a wheel is at or near rest, m/s: a creeping robot's pace.
pub const NEAR_REST_M_S: f64 = 0.02;

/// What the wheels were doing at a sample, by their rim speeds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum WheelMotion {
    /// Turning opposite ways, each faster than [`NEAR_REST_M_S`]: turning on the spot.
    TurningOnTheSpot,
    /// Both at or near rest: starting or stopping.
    #[default]
    NearRest,
    /// Driving along (or curving).
    Driving,
}

impl WheelMotion {
    /// The motion of wheels turning at these rim speeds (left, right), m/s.
    pub fn of(rim_m_s: [f64; 2]) -> WheelMotion {
        let [l, r] = rim_m_s;
        if l.abs() < NEAR_REST_M_S && r.abs() < NEAR_REST_M_S {
            WheelMotion::NearRest
        } else if l * r < 0.0 && l.abs() >= NEAR_REST_M_S && r.abs() >= NEAR_REST_M_S {
            WheelMotion::TurningOnTheSpot
        } else {
            WheelMotion::Driving
        }
    }

    /// As a report says it.
    pub fn words(self) -> &'static str {
        match self {
            WheelMotion::TurningOnTheSpot => "turning on the spot",
            WheelMotion::NearRest => "starting or stopping (both wheels under 0.02 m/s)",
            WheelMotion::Driving => "driving along",
        }
    }
}

/// Where in the motion the tyres slid, as shares of the slip window (they add up to the
/// sliding fraction).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SlidingByMotion {
    /// The wheels turning opposite ways.
    pub turning_on_spot: f64,
    /// Both wheels at or near rest.
    pub near_rest: f64,
    /// Driving along.
    pub moving: f64,
}

/// The summary of a run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunSummary {
    /// Simulated time, s.
    pub duration_s: f64,
    /// The path driven: where it started and ended, and the speeds on it.
    pub motion: Motion,
    /// Distance travelled by the axle midpoint, m.
    pub distance_m: f64,
    /// Distance travelled until the lateral error last left the settled band; `None` if it
    /// never settled (or stayed in the band for less than [`super::metrics::SETTLED_MIN_SHARE`] of the run).
    pub settling_distance_m: Option<f64>,
    /// RMS lateral error over [`RunSummary::error_window`], m.
    pub rms_lateral_error_m: f64,
    /// Peak |lateral error| over [`RunSummary::error_window`], m.
    pub peak_lateral_error_m: f64,
    /// What the RMS and peak are taken over.
    pub error_window: ErrorWindow,
    /// A sustained oscillation over the last [`LIMIT_CYCLE_TAIL_FRACTION`] of the run, or
    /// of the part of it before the wire was lost or ended.
    pub limit_cycle: Option<LimitCycle>,
    /// What the same window shows when it holds no limit cycle (`None` with a cycle, or
    /// with the wheels lifted).
    pub no_cycle: Option<NoCycle>,
    /// Peak |slip ratio| of the drive tyres over [`RunSummary::slip_window`].
    pub peak_abs_slip_ratio: f64,
    /// Time mean of |slip ratio| over both drive tyres, over [`RunSummary::slip_window`].
    pub mean_abs_slip_ratio: f64,
    /// Share of [`RunSummary::slip_window`] in which either drive tyre slid (its force on
    /// the friction limit).
    pub sliding_fraction: f64,
    /// The sliding fraction split by what the body was doing.
    pub sliding_by_motion: SlidingByMotion,
    /// What the wheels were doing where the peak slip ratio was (a ratio of speeds is
    /// large where the contact's speed over the ground is small).
    pub peak_slip_motion: WheelMotion,
    /// What the slip figures cover.
    pub slip_window: SlipWindow,
    /// Energy drawn from the battery, J.
    pub battery_energy_j: f64,
    /// Castor shimmy: RMS swivel rate of the castors over the second half of the run,
    /// rad/s (0 on the levels that lump the castors). Castors that trail quietly behind a
    /// vehicle tracking its wire barely swivel; a shimmying castor flaps at several rad/s.
    pub castor_shimmy_rad_s: f64,
    /// Lateral error at the end of the run, m.
    pub final_lateral_error_m: f64,
    /// The sensors lost the wire at some point.
    pub lost_wire: bool,
    /// When the sensors first lost the wire.
    pub wire_lost: Option<RunEvent>,
    /// How many times the sensors lost the wire (each loss after the wire was seen
    /// again counts anew).
    pub wire_losses: u32,
    /// The sensors were off the wire at the end of the run.
    pub off_wire_at_end: bool,
    /// When the axle first passed the far end of an open wire.
    pub wire_end: Option<RunEvent>,
    /// The wheels were lifted: the chassis did not move, so nothing was tracked.
    pub wheels_lifted: bool,
    /// The DCMC's faults, by name, in the order they happened.
    pub faults: Vec<String>,
    /// The bumper stopped the vehicle.
    pub bumper_stop: bool,
    /// When the bumper first touched an obstacle.
    pub bumper_at: Option<RunEvent>,
}

/// The path a run drove: its start and end, and the speeds on it (what a
/// velocity-commanded base's run is judged by, where there is no wire to follow).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Motion {
    /// Pose of the drive-axle midpoint at the start.
    pub start: crate::model::chassis::Pose,
    /// Pose at the end.
    pub end: crate::model::chassis::Pose,
    /// Largest forward speed either way, m/s.
    pub peak_speed_m_s: f64,
    /// Largest yaw rate either way, rad/s.
    pub peak_yaw_rate_rad_s: f64,
    /// Time the base moved (faster than 1 cm/s or 0.01 rad/s), s.
    pub moving_s: f64,
    /// Distance moved while moving, m (its ratio to `moving_s`: the mean speed).
    pub moving_m: f64,
    started: bool,
}

impl Motion {
    /// The path so far with snapshot `s`, `dt` s after the last.
    pub(super) fn observe(&mut self, s: &Snapshot, dt: f64) {
        if !self.started {
            self.start = s.pose;
            self.started = true;
        }
        self.end = s.pose;
        let v = s.velocity_m_s[0].abs();
        self.peak_speed_m_s = self.peak_speed_m_s.max(v);
        self.peak_yaw_rate_rad_s = self.peak_yaw_rate_rad_s.max(s.yaw_rate_rad_s.abs());
        if dt > 0.0 && (v > 0.01 || s.yaw_rate_rad_s.abs() > 0.01) {
            self.moving_s += dt;
            self.moving_m += v * dt;
        }
    }

    /// Mean forward speed while moving, m/s.
    pub fn mean_speed_m_s(&self) -> f64 {
        if self.moving_s > 0.0 {
            self.moving_m / self.moving_s
        } else {
            0.0
        }
    }
}
