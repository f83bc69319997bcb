//! Numerical linearisation of the no-slip plant (both drivetrains and the chassis) about
//! straight running on the wire, and what its coil pair can see: controllability from the
//! two motor voltages and observability from the two coil readings, as the thesis's
//! linearised analysis.
//!
//! The plant is stepped by the simulator's own code ([`Sim`]'s drivetrain and chassis
//! sub-steps) over one step `dt` from perturbed states; central differences give the
//! discrete-time matrices. Ranks come from block Krylov subspaces built with
//! re-orthogonalisation on `(A_d - I)/dt` in scaled coordinates (the powers of a raw
//! Kalman matrix would lose the fast electrical modes to rounding).

use nalgebra::{DMatrix, DVector};

use super::{Actuation, Body, Sim, SimError, SimParams};
use crate::model::chassis::Pose;
use crate::model::motor::Terminal;
use crate::scene::{Fidelity, Scene};

mod closed_loop;
mod d2c;
pub mod export;
mod reach;

pub use closed_loop::{close_loop, ClosedLoop, LoopGains};
pub use reach::{analyse, Reach};

/// The plant state, in this order. Side quantities are in common (`_sum`: left + right)
/// and differential (`_diff`: right - left) form, which separates straight running from
/// turning. `twist` is gear output angle minus wheel angle.
pub const STATE_NAMES: [&str; 11] = [
    "x_m",
    "y_m",
    "heading_rad",
    "speed_m_s",
    "yaw_rate_rad_s",
    "current_sum_A",
    "current_diff_A",
    "motor_speed_sum_rad_s",
    "motor_speed_diff_rad_s",
    "twist_sum_rad",
    "twist_diff_rad",
];

/// Indices of the motor-speed states in [`STATE_NAMES`].
const MOTOR_SPEED_SUM: usize = 7;
const MOTOR_SPEED_DIFF: usize = 8;

/// Typical sizes of the states, for scaling before rank decisions.
const STATE_SCALE: [f64; 11] = [
    1.0, 0.1, 0.1, 1.0, 1.0, 10.0, 10.0, 100.0, 100.0, 0.01, 0.01,
];
const VOLTAGE_SCALE_V: f64 = 10.0;
const READING_SCALE_ADC: f64 = 100.0;

/// Errors of a linearisation.
#[derive(Debug, thiserror::Error)]
pub enum LinearizeError {
    /// The simulator cannot set the scene up.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The scene's controller or level has no linearisation here (the reason).
    #[error("{0}")]
    Unsupported(String),
}

/// The linearised plant about its operating point.
#[derive(Debug, Clone)]
pub struct Linearisation {
    /// The level linearised.
    pub level: Fidelity,
    /// Steady forward speed at the operating point, m/s (negative reversing).
    pub speed_m_s: f64,
    /// Terminal voltage of both motors there, V.
    pub voltage_v: f64,
    /// Which coil pair is the output: "front" or "rear".
    pub sensors: &'static str,
    /// Sample interval of the discrete-time model, s.
    pub dt_s: f64,
    /// Discrete-time matrices over one step: x+ = A x + B u, y = C x (u: left and right
    /// voltage, V; y: left and right coil reading, counts).
    pub a: DMatrix<f64>,
    /// Input matrix (motor voltages).
    pub b: DMatrix<f64>,
    /// Output matrix (the coil pair's difference).
    pub c: DMatrix<f64>,
    /// The firmware's P-D law and the DCMC about the operating point, when the scene runs
    /// the P-D law through the gain or proportional-speed DCMC.
    pub controller: Option<LoopGains>,
}

impl Sim {
    fn plant_vector(&self) -> DVector<f64> {
        let Body::NoSlip(s) = &self.body else {
            return DVector::zeros(11);
        };
        let dtp = &self.params.drivetrain;
        let side = |f: &dyn Fn(usize) -> f64| (f(0) + f(1), f(1) - f(0));
        let (i_s, i_d) = side(&|k| self.drive[k].motor.current_a);
        let (w_s, w_d) = side(&|k| self.drive[k].motor.speed_rad_s);
        let (t_s, t_d) = side(&|k| dtp.twist(&self.drive[k]).0);
        DVector::from_vec(vec![
            s.pose.x_m,
            s.pose.y_m,
            s.pose.heading_rad,
            s.speed_m_s,
            s.yaw_rate_rad_s,
            i_s,
            i_d,
            w_s,
            w_d,
            t_s,
            t_d,
        ])
    }

    fn set_plant_vector(&mut self, x: &DVector<f64>) {
        let n = self.params.drivetrain.gearbox.ratio;
        let Body::NoSlip(s) = &mut self.body else {
            return;
        };
        s.pose = Pose {
            x_m: x[0],
            y_m: x[1],
            heading_rad: x[2],
        };
        s.speed_m_s = x[3];
        s.yaw_rate_rad_s = x[4];
        let wheels = self.params.noslip.wheel_speeds_rad_s(s);
        for k in 0..2 {
            let sign = if k == 0 { -1.0 } else { 1.0 };
            let d = &mut self.drive[k];
            d.motor.current_a = 0.5 * (x[5] + sign * x[6]);
            d.motor.speed_rad_s = 0.5 * (x[7] + sign * x[8]);
            d.wheel_angle_rad = 0.0;
            d.motor.angle_rad = n * 0.5 * (x[9] + sign * x[10]);
            d.wheel_speed_rad_s = wheels[k];
        }
    }

    /// Noise-free, unquantised readings of a coil pair at the current pose, counts, as
    /// over an infinite straight wire along the nearest segment: the thesis's analysis,
    /// and free of the wire ends' faint field, which would otherwise make the position
    /// along the wire "observable" at a level no ADC could resolve.
    fn coil_analogue(&self, coils: [[f64; 2]; 2]) -> DVector<f64> {
        let pose = self.pose();
        DVector::from_iterator(
            2,
            coils.iter().map(|c| {
                let off = self.params.wire.offset(pose.to_world(*c));
                self.params.coil.straight_wire_reading(off.lateral_m)
                    * (pose.heading_rad - off.direction_rad).cos().abs()
            }),
        )
    }
}

impl Linearisation {
    /// The continuous-time state and input matrices the discrete model samples (its
    /// zero-order-hold inverse, MATLAB's `d2c`: [`d2c::zoh_to_continuous`]), 1/s and per
    /// second; the first-order `((A - I)/dt, B/dt)` where no logarithm exists.
    pub fn continuous(&self) -> (DMatrix<f64>, DMatrix<f64>) {
        d2c::zoh_to_continuous(&self.a, &self.b, self.dt_s).unwrap_or_else(|| {
            let n = self.a.nrows();
            (
                (&self.a - DMatrix::identity(n, n)) / self.dt_s,
                &self.b / self.dt_s,
            )
        })
    }
}

/// Linearises the scene's plant about straight running on its wire at the speed its
/// firmware drives (reversing if `controller.reverse`). The `full` level (rapier chassis)
/// is linearised as its no-slip counterpart `complex` (tyres that do not slip).
pub fn linearise(scene: &Scene) -> Result<Linearisation, LinearizeError> {
    let (params, level) = on_the_wire(scene)?;
    let reverse = params.firmware.controller.reverse;
    let dt = params.sim.dt_s;
    let v0 = forward_voltage(&params, scene)?;
    // Straight running at that voltage, to steady state (teeth in contact).
    let mut sim = Sim::from_params(params.clone())?;
    sim.set_actuation(Actuation::Voltage([v0, v0]));
    for _ in 0..(4.0 / dt).round() as usize {
        sim.step().map_err(|e| e.naming_suspects(scene))?;
    }
    let x0 = sim.plant_vector();
    let coils = match (reverse, params.rear_coils_m()) {
        (true, Some(r)) => r,
        _ => params.coils_m(),
    };
    let sensors = if reverse && params.rear_coils_m().is_some() {
        "rear"
    } else {
        "front"
    };
    let (a, b, c) = jacobians(&mut sim, &x0, v0, coils);
    all_finite(scene, &a, &b, &c, v0)?;
    let controller = closed_loop::loop_gains(&params, &sim);
    finite_gains(controller.as_ref())?;
    Ok(Linearisation {
        level,
        speed_m_s: x0[3],
        voltage_v: v0,
        sensors,
        dt_s: dt,
        a,
        b,
        c,
        controller,
    })
}

/// The run's parameters at the operating point: the full level as its no-slip
/// counterpart, the start on the wire heading along it, no sensor noise.
fn on_the_wire(scene: &Scene) -> Result<(SimParams, Fidelity), LinearizeError> {
    let mut params = SimParams::from_scene(scene)?;
    let level = match params.sim.fidelity {
        Fidelity::Full => {
            let mut s = scene.clone();
            s.sim.fidelity = Fidelity::Complex;
            params = SimParams::from_scene(&s)?;
            Fidelity::Complex
        }
        l => l,
    };
    if params.sim.wheels_lifted {
        return Err(LinearizeError::Unsupported(
            "the scene has the wheels lifted: there is no vehicle motion to linearise".into(),
        ));
    }
    // On the wire: the start projected onto the wire, heading along it.
    let near = params.wire.offset([params.start.x_m, params.start.y_m]);
    params.start = Pose {
        x_m: near.nearest_m[0],
        y_m: near.nearest_m[1],
        heading_rad: near.direction_rad,
    };
    params.sensors.noise_adc = 0.0;
    Ok((params, level))
}

/// The firmware's forward voltage: the mean terminal voltage over the last second of a
/// 4 s run on the wire (none is refused: no operating point).
fn forward_voltage(params: &SimParams, scene: &Scene) -> Result<f64, LinearizeError> {
    let mut sim = Sim::from_params(params.clone())?;
    let dt = params.sim.dt_s;
    let steps = (4.0 / dt).round() as usize;
    let mut v_sum = 0.0;
    let mut v_n = 0usize;
    for k in 0..steps {
        sim.step().map_err(|e| e.naming_suspects(scene))?;
        if k >= steps - (1.0 / dt).round() as usize {
            v_sum += 0.5 * (sim.last.motor_v[0] + sim.last.motor_v[1]);
            v_n += 1;
        }
    }
    let v0 = v_sum / v_n.max(1) as f64;
    if v0.abs() < 1e-3 {
        return Err(LinearizeError::Unsupported(
            "the firmware does not drive the vehicle (no forward demand): no operating point"
                .into(),
        ));
    }
    Ok(v0)
}

/// A, B and C by central differences about the state `x0` at the voltage `v0`: one
/// physics step from each perturbed state or voltage, the coils' analogue readings of
/// each perturbed state.
fn jacobians(
    sim: &mut Sim,
    x0: &DVector<f64>,
    v0: f64,
    coils: [[f64; 2]; 2],
) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let dt = sim.params().sim.dt_s;
    let step_from = |sim: &mut Sim, x: &DVector<f64>, u: [f64; 2]| -> DVector<f64> {
        sim.set_plant_vector(x);
        sim.advance_drivetrains_and_body([Terminal::Voltage(u[0]), Terminal::Voltage(u[1])], dt);
        sim.plant_vector()
    };
    let n = STATE_NAMES.len();
    let mut a = DMatrix::zeros(n, n);
    let mut c = DMatrix::zeros(2, n);
    for j in 0..n {
        let d = 1e-6 * STATE_SCALE[j];
        let mut xp = x0.clone();
        xp[j] += d;
        let mut xm = x0.clone();
        xm[j] -= d;
        let fp = step_from(sim, &xp, [v0, v0]);
        let fm = step_from(sim, &xm, [v0, v0]);
        a.set_column(j, &((fp - fm) / (2.0 * d)));
        sim.set_plant_vector(&xp);
        let yp = sim.coil_analogue(coils);
        sim.set_plant_vector(&xm);
        let ym = sim.coil_analogue(coils);
        c.set_column(j, &((yp - ym) / (2.0 * d)));
    }
    let mut b = DMatrix::zeros(n, 2);
    for k in 0..2 {
        let d = 1e-6 * VOLTAGE_SCALE_V;
        let (mut up, mut um) = ([v0, v0], [v0, v0]);
        up[k] += d;
        um[k] -= d;
        let fp = step_from(sim, x0, up);
        let fm = step_from(sim, x0, um);
        b.set_column(k, &((fp - fm) / (2.0 * d)));
    }
    (a, b, c)
}

/// A runaway operating point or a derivative that overflowed is refused: the eigenvalue
/// analysis of a non-finite matrix would never end.
fn all_finite(
    scene: &Scene,
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    c: &DMatrix<f64>,
    v0: f64,
) -> Result<(), LinearizeError> {
    if !(a
        .iter()
        .chain(b.iter())
        .chain(c.iter())
        .all(|v| v.is_finite())
        && v0.is_finite())
    {
        // A runaway operating point or a derivative that overflowed: the eigenvalue
        // analysis of a non-finite matrix would never end.
        let far = crate::scene::keys::furthest_from_default(scene, 3);
        return Err(LinearizeError::Unsupported(format!(
            "the linearisation is not finite (the operating point or a derivative overflowed){}",
            if far.is_empty() {
                String::new()
            } else {
                format!(
                    "; the values furthest from the thesis machine's are the likely cause: {}",
                    far.join(", ")
                )
            }
        )));
    }
    Ok(())
}

/// The loop's gains must be numbers.
fn finite_gains(controller: Option<&closed_loop::LoopGains>) -> Result<(), LinearizeError> {
    if let Some(g) = controller {
        let gains = [
            g.kp,
            g.kd,
            g.volts_per_turn_count[0],
            g.volts_per_turn_count[1],
            g.volts_per_motor_speed[0],
            g.volts_per_motor_speed[1],
        ];
        if !gains.iter().all(|v| v.is_finite()) {
            return Err(LinearizeError::Unsupported(format!(
                "the loop's gains are not finite (Kp {}, Kd {}): check controller.gain_scale and the kp/kd keys",
                crate::param::plain_number(g.kp),
                crate::param::plain_number(g.kd)
            )));
        }
    }
    Ok(())
}

/// The report `agvsim linearize` prints.
pub fn render(l: &Linearisation, r: &Reach) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "operating point  straight on the wire at {:.3} m/s ({:.2} V on both motors), level {}, steering on the {} coil pair",
        l.speed_m_s,
        l.voltage_v,
        l.level.name(),
        l.sensors
    );
    let _ = writeln!(
        s,
        "states           {} (sum: left + right, diff: right - left; twist: gear output minus wheel angle)",
        STATE_NAMES.join(", ")
    );
    let _ = writeln!(
        s,
        "inputs           left_voltage_V, right_voltage_V; outputs: left and right coil readings (counts)"
    );
    let _ = writeln!(
        s,
        "controllable     rank {} of {}",
        r.controllable_rank, r.states
    );
    let _ = writeln!(
        s,
        "observable       rank {} of {} from the two coil readings",
        r.observable_rank, r.states
    );
    let _ = writeln!(
        s,
        "\n{:<24} {:>16} {:>16}",
        "state", "uncontrollable", "unseen by coils"
    );
    for (j, name) in STATE_NAMES.iter().enumerate() {
        let _ = writeln!(
            s,
            "{:<24} {:>15.0}% {:>15.0}%",
            name,
            100.0 * r.uncontrollable_share[j],
            100.0 * r.unobservable_share[j]
        );
    }
    let unseen: Vec<&str> = STATE_NAMES
        .iter()
        .zip(&r.unobservable_share)
        .filter(|(_, x)| **x > 0.99)
        .map(|(n, _)| *n)
        .collect();
    if !unseen.is_empty() {
        let _ = writeln!(
            s,
            "\nThe coils cannot see: {}. On a straight wire the readings depend only on the \
             pair's offset and heading, so the position along the wire and everything that \
             moves both sides alike (the straight-running mode) leave no trace in them.",
            unseen.join(", ")
        );
    }
    let _ = writeln!(s, "\npoles (1/s)      {}", pole_list(&r.poles));
    let _ = writeln!(
        s,
        "                 continuous time: the discrete model's zero-order-hold equivalent over {} ms (MATLAB's d2c), ln(z)/Ts of each discrete pole z",
        1000.0 * l.dt_s
    );
    closed_loop_lines(&mut s, l);
    s
}

/// The report's closed-loop lines: the P-D law's poles and stability, or why the loop
/// is not analysed.
fn closed_loop_lines(s: &mut String, l: &Linearisation) {
    use std::fmt::Write;
    match (&l.controller, close_loop(l)) {
        (Some(g), Some(cl)) => {
            let _ = writeln!(
                s,
                "\nclosed loop      P-D on the coil difference (Kp {:.4}, Kd {:.4} per {:.0} ms interrupt{}), \
                 {:.3}/{:.3} V per turn count; sampling, delay and PWM filter left out",
                g.kp,
                g.kd,
                1000.0 * g.period_s,
                if g.sign < 0.0 { ", demands negated reversing" } else { "" },
                g.volts_per_turn_count[0],
                g.volts_per_turn_count[1],
            );
            let _ = writeln!(s, "closed poles     {}", pole_list(&cl.poles));
            let _ = writeln!(
                s,
                "stability        {} (rightmost pole {:+.3} 1/s){}",
                if cl.stable() { "stable" } else { "UNSTABLE" },
                cl.rightmost_re(),
                if cl.stable() {
                    ": without the left-out lags, which cost phase margin; the simulation has \
                     the last word"
                } else {
                    ": unstable even without the left-out lags, which only cost phase margin"
                }
            );
        }
        _ => {
            let _ = writeln!(
                s,
                "\nclosed loop      not analysed: only the P-D firmware through the gain or \
                 proportional-speed DCMC is"
            );
        }
    }
}

/// Poles sorted by real part, as text.
fn pole_list(poles: &[(f64, f64)]) -> String {
    let mut poles = poles.to_vec();
    poles.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    poles
        .iter()
        .map(|(re, im)| {
            if im.abs() < 1e-9 * re.abs().max(1.0) {
                format!("{re:.3}")
            } else {
                format!("{re:.2}{im:+.2}i")
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}
