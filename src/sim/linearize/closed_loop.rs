//! The wire-following loop closed around the linearised plant: the firmware's P-D law on
//! the coil difference and the DCMC's local slopes, and the closed loop's poles.

use nalgebra::DMatrix;

use super::{Linearisation, MOTOR_SPEED_DIFF, MOTOR_SPEED_SUM};
use crate::sim::{Sim, SimParams};

/// The wire-following loop about the operating point, continuous-time: the turn demand
/// `u = sign (-Kp X + Kd T dX/dt)` in duty counts from the coil difference `X = left -
/// right` (counts), and the DCMC's terminal voltages `dV = g_turn u + G_speed dw`.
#[derive(Debug, Clone)]
pub struct LoopGains {
    /// Proportional gain, turn counts per count of coil difference (`kp_num gain_scale /
    /// kp_den`; the firmware's -1/20 turns towards the stronger coil).
    pub kp: f64,
    /// Derivative gain per interrupt, turn counts per count of change (`kd_num / kd_den`).
    pub kd: f64,
    /// Interrupt period, s: the derivative acts on the change over one period.
    pub period_s: f64,
    /// -1 reversing (the firmware negates its demands), else +1.
    pub sign: f64,
    /// Terminal voltage per count of turn demand (left, right), V.
    pub volts_per_turn_count: [f64; 2],
    /// Terminal voltage per rad/s of the same side's motor speed (the proportional speed
    /// loop; zero for the gain DCMC), V s/rad.
    pub volts_per_motor_speed: [f64; 2],
    /// Time constant of the DCMC's lag on the turn demand, s; `None` when the turn
    /// passes at once (the forward lags do not act on the loop's small signals).
    pub turn_response_time_s: Option<f64>,
}

/// The closed wire-following loop's poles.
#[derive(Debug, Clone)]
pub struct ClosedLoop {
    /// Continuous-time poles without the position along the wire (a pure integrator the
    /// loop cannot see), 1/s, as (re, im).
    pub poles: Vec<(f64, f64)>,
}

impl ClosedLoop {
    /// Largest real part of the poles, 1/s.
    pub fn rightmost_re(&self) -> f64 {
        self.poles
            .iter()
            .map(|p| p.0)
            .fold(f64::NEG_INFINITY, f64::max)
    }

    /// Every pole in the open left half-plane.
    pub fn stable(&self) -> bool {
        self.rightmost_re() < 0.0
    }
}

/// The P-D law's gains and the DCMC's local slopes at the operating point (`sim` holds it);
/// `None` for other controllers and for the DCMCs with integral action (whose integrators
/// would be states).
pub(super) fn loop_gains(params: &SimParams, sim: &Sim) -> Option<LoopGains> {
    use crate::firmware::pwm::PCT_PER_COUNT;
    use crate::firmware::ControllerKind;
    use crate::model::dcmc::DcmcKind;
    use crate::model::dcmc::{DcmcInput, DcmcState};
    let fw = &params.firmware;
    if fw.controller.kind != ControllerKind::Pd
        || matches!(params.dcmc.params.kind, DcmcKind::Pi | DcmcKind::GainPi)
    {
        return None;
    }
    let sign = if fw.controller.reverse { -1.0 } else { 1.0 };
    let speeds = [
        sim.drive[0].motor.speed_rad_s,
        sim.drive[1].motor.speed_rad_s,
    ];
    let forward_pct = sign * fw.controller.forward_counts as f64 * PCT_PER_COUNT;
    let available_v = params
        .battery
        .available_drive_v(params.battery.open_circuit_v);
    let volts = |turn_counts: f64, w: [f64; 2]| {
        let mut dcmc = params.dcmc;
        dcmc.faults = false;
        // Steady slopes: the response lag is a state of the loop (below), not a gain, and
        // the ramp passes small signals untouched.
        dcmc.params = dcmc.params.without_shaping();
        let mut state = DcmcState {
            enabled_since_s: Some(0.0),
            ..DcmcState::default()
        };
        dcmc.step(
            &mut state,
            &DcmcInput {
                t_s: 1.0e3,
                enabled: true,
                forward_pct,
                turn_pct: turn_counts * PCT_PER_COUNT,
                motor_speed_rad_s: w,
                back_emf_v: w.map(|x| params.drivetrain.motor.back_emf_v(x)),
                low_battery: false,
                available_v,
            },
            params.sim.dt_s,
        )
        .voltage_v
    };
    let du = 0.01;
    let (up, um) = (volts(du, speeds), volts(-du, speeds));
    let dw = 1e-3;
    let mut per_speed = [0.0; 2];
    for k in 0..2 {
        let (mut wp, mut wm) = (speeds, speeds);
        wp[k] += dw;
        wm[k] -= dw;
        per_speed[k] = (volts(0.0, wp)[k] - volts(0.0, wm)[k]) / (2.0 * dw);
    }
    Some(LoopGains {
        kp: fw.controller.kp_num as f64 * fw.controller.gain_scale / fw.controller.kp_den as f64,
        kd: fw.controller.kd_num as f64 / fw.controller.kd_den as f64,
        period_s: fw.period_s.unwrap_or(params.sim.dt_s),
        sign,
        volts_per_turn_count: [(up[0] - um[0]) / (2.0 * du), (up[1] - um[1]) / (2.0 * du)],
        volts_per_motor_speed: per_speed,
        turn_response_time_s: params
            .dcmc
            .params
            .response()
            .map(|r| r.turn_time_constant_s)
            .filter(|t| *t > 0.0),
    })
}

/// Closes the wire-following loop around the linearised plant, continuous-time: the P-D
/// law on the coil difference and the DCMC's slopes. The firmware's sampling, computation
/// delay and the PWM filter are left out; each adds phase lag, so a loop found unstable
/// here has no hope on the machine, while one found stable still has to be confirmed by
/// simulation.
pub fn close_loop(l: &Linearisation) -> Option<ClosedLoop> {
    let g = l.controller.as_ref()?;
    let n = l.a.nrows();
    let (f, b) = l.continuous();
    let cx = l.c.row(0) - l.c.row(1);
    // Turn counts per unit of state: -Kp X + Kd T dX/dt, with dX/dt = C_x f x (the coils
    // do not see the voltages directly).
    let turn = (&cx * (-g.kp) + &cx * &f * (g.kd * g.period_s)) * g.sign;
    // Terminal voltages `v = lagged turn part + speed feedback W x`.
    let mut turn_volts = DMatrix::zeros(2, n);
    let mut speed_feedback = DMatrix::zeros(2, n);
    for side in 0..2 {
        turn_volts.set_row(side, &(&turn * g.volts_per_turn_count[side]));
        // This side's motor speed from the sum and the difference (right - left) states.
        let w = g.volts_per_motor_speed[side];
        let along_diff = if side == 0 { -0.5 } else { 0.5 };
        speed_feedback[(side, MOTOR_SPEED_SUM)] += 0.5 * w;
        speed_feedback[(side, MOTOR_SPEED_DIFF)] += along_diff * w;
    }
    let closed = match g.turn_response_time_s {
        None => &f + &b * (turn_volts + speed_feedback),
        Some(tau) => {
            // Two more states, the lagged turn voltages z: z' = (T x - z) / tau.
            let mut m = DMatrix::zeros(n + 2, n + 2);
            m.view_mut((0, 0), (n, n))
                .copy_from(&(&f + &b * speed_feedback));
            m.view_mut((0, n), (n, 2)).copy_from(&b);
            for side in 0..2 {
                for j in 0..n {
                    m[(n + side, j)] = turn_volts[(side, j)] / tau;
                }
                m[(n + side, n + side)] = -1.0 / tau;
            }
            m
        }
    };
    let n = closed.nrows();
    // Without x (the first state): nothing depends on it, so its mode is a bare integrator.
    let reduced = closed.view((1, 1), (n - 1, n - 1)).into_owned();
    if !reduced.iter().all(|v| v.is_finite()) {
        // An overflowed gain: no poles to find (and the eigenvalue search would not end).
        return None;
    }
    let poles: Vec<(f64, f64)> = reduced
        .complex_eigenvalues()
        .iter()
        .map(|z| (z.re, z.im))
        .collect();
    Some(ClosedLoop { poles })
}
