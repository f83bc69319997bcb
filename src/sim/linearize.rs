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

/// Typical sizes of the states, for scaling before rank decisions.
const STATE_SCALE: [f64; 11] = [
    1.0, 0.1, 0.1, 1.0, 1.0, 10.0, 10.0, 100.0, 100.0, 0.01, 0.01,
];
const VOLTAGE_SCALE_V: f64 = 10.0;
const READING_SCALE_ADC: f64 = 100.0;

/// Relative size below which a new Krylov direction counts as already spanned.
const RANK_TOLERANCE: f64 = 1e-7;

/// Errors of a linearisation.
#[derive(Debug, thiserror::Error)]
pub enum LinearizeError {
    #[error(transparent)]
    Sim(#[from] SimError),
    #[error("{0}")]
    Unsupported(String),
}

/// The linearised plant about its operating point.
#[derive(Debug, Clone)]
pub struct Linearisation {
    pub level: Fidelity,
    /// Steady forward speed at the operating point, m/s (negative reversing).
    pub speed_m_s: f64,
    /// Terminal voltage of both motors there, V.
    pub voltage_v: f64,
    /// Which coil pair is the output: "front" or "rear".
    pub sensors: &'static str,
    pub dt_s: f64,
    /// Discrete-time matrices over one step: x+ = A x + B u, y = C x (u: left and right
    /// voltage, V; y: left and right coil reading, counts).
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub c: DMatrix<f64>,
}

/// What the linearisation shows.
#[derive(Debug, Clone)]
pub struct Reach {
    pub states: usize,
    pub controllable_rank: usize,
    pub observable_rank: usize,
    /// Per state: the share (0-1) of it outside the controllable subspace.
    pub uncontrollable_share: Vec<f64>,
    /// Per state: the share (0-1) of it the coil readings cannot see.
    pub unobservable_share: Vec<f64>,
    /// Continuous-time poles (eigenvalues of (A - I)/dt), 1/s, as (re, im).
    pub poles: Vec<(f64, f64)>,
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

/// Linearises the scene's plant about straight running on its wire at the speed its
/// firmware drives (reversing if `controller.reverse`). The `full` level (rapier chassis)
/// is linearised as its no-slip counterpart `complex` (tyres that do not slip).
pub fn linearise(scene: &Scene) -> Result<Linearisation, LinearizeError> {
    let mut params = SimParams::from_scene(scene)?;
    let level = match params.fidelity {
        Fidelity::Full => {
            let mut s = scene.clone();
            s.sim.fidelity = Fidelity::Complex;
            params = SimParams::from_scene(&s)?;
            Fidelity::Complex
        }
        l => l,
    };
    if params.wheels_lifted {
        return Err(LinearizeError::Unsupported(
            "the scene has the wheels lifted: there is no vehicle motion to linearise".into(),
        ));
    }
    // On the wire: the start projected onto the wire, heading along it.
    let near = params.wire.offset([params.start.x_m, params.start.y_m]);
    let reverse = params.firmware.reverse;
    params.start = Pose {
        x_m: near.nearest_m[0],
        y_m: near.nearest_m[1],
        heading_rad: near.direction_rad,
    };
    params.noise_adc = 0.0;
    // The firmware's forward voltage: mean terminal voltage over the last second of a
    // 4 s run on the wire.
    let mut sim = Sim::from_params(params.clone())?;
    let dt = params.dt_s;
    let steps = (4.0 / dt).round() as usize;
    let mut v_sum = 0.0;
    let mut v_n = 0usize;
    for k in 0..steps {
        sim.step()?;
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
    // Straight running at that voltage, to steady state (teeth in contact).
    let mut sim = Sim::from_params(params.clone())?;
    sim.set_actuation(Actuation::Voltage([v0, v0]));
    for _ in 0..(4.0 / dt).round() as usize {
        sim.step()?;
    }
    let x0 = sim.plant_vector();
    let coils = match (reverse, params.rear_coils_m) {
        (true, Some(r)) => r,
        _ => params.coils_m,
    };
    let sensors = if reverse && params.rear_coils_m.is_some() {
        "rear"
    } else {
        "front"
    };
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
        let fp = step_from(&mut sim, &xp, [v0, v0]);
        let fm = step_from(&mut sim, &xm, [v0, v0]);
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
        let fp = step_from(&mut sim, &x0, up);
        let fm = step_from(&mut sim, &x0, um);
        b.set_column(k, &((fp - fm) / (2.0 * d)));
    }
    Ok(Linearisation {
        level,
        speed_m_s: x0[3],
        voltage_v: v0,
        sensors,
        dt_s: dt,
        a,
        b,
        c,
    })
}

/// Orthonormal basis of the block Krylov subspace span{G, F G, F^2 G, ...}.
fn krylov_basis(f: &DMatrix<f64>, g: &DMatrix<f64>) -> DMatrix<f64> {
    let n = f.nrows();
    let f_norm = f.norm().max(1e-300);
    let mut basis: Vec<DVector<f64>> = vec![];
    let mut block: Vec<DVector<f64>> = g.column_iter().map(|c| c.into_owned()).collect();
    let g_norm = g.norm().max(1e-300);
    let mut scale = g_norm;
    for _ in 0..n {
        let mut added = vec![];
        for mut v in block {
            // Twice Gram-Schmidt against everything kept so far.
            for _ in 0..2 {
                for q in basis.iter().chain(added.iter()) {
                    let p = q.dot(&v);
                    v -= q * p;
                }
            }
            let norm = v.norm();
            if norm > RANK_TOLERANCE * scale {
                added.push(v / norm);
            }
        }
        if added.is_empty() {
            break;
        }
        block = added.iter().map(|q| f * q).collect();
        basis.extend(added);
        scale = f_norm;
        if basis.len() >= n {
            break;
        }
    }
    if basis.is_empty() {
        DMatrix::zeros(n, 0)
    } else {
        DMatrix::from_columns(&basis)
    }
}

/// Per coordinate, the squared norm of its unit vector outside the span of `q`.
fn outside_share(q: &DMatrix<f64>) -> Vec<f64> {
    (0..q.nrows())
        .map(|j| {
            let inside: f64 = (0..q.ncols()).map(|k| q[(j, k)].powi(2)).sum();
            (1.0 - inside).clamp(0.0, 1.0)
        })
        .collect()
}

/// Controllability from the voltages and observability from the coil readings.
pub fn analyse(l: &Linearisation) -> Reach {
    let n = l.a.nrows();
    let s = DMatrix::from_diagonal(&DVector::from_row_slice(&STATE_SCALE));
    let s_inv = DMatrix::from_diagonal(&DVector::from_iterator(
        n,
        STATE_SCALE.iter().map(|x| 1.0 / x),
    ));
    let f = (&l.a - DMatrix::identity(n, n)) / l.dt_s;
    let f_scaled = &s_inv * &f * &s;
    let b_scaled = &s_inv * &l.b * (VOLTAGE_SCALE_V / l.dt_s);
    let c_scaled = &l.c * &s / READING_SCALE_ADC;
    let ctrb = krylov_basis(&f_scaled, &b_scaled);
    let obsv = krylov_basis(&f_scaled.transpose(), &c_scaled.transpose());
    let poles = f
        .clone()
        .complex_eigenvalues()
        .iter()
        .map(|z| (z.re, z.im))
        .collect();
    Reach {
        states: n,
        controllable_rank: ctrb.ncols(),
        observable_rank: obsv.ncols(),
        uncontrollable_share: outside_share(&ctrb),
        unobservable_share: outside_share(&obsv),
        poles,
    }
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
    let mut poles = r.poles.clone();
    poles.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let _ = writeln!(
        s,
        "\npoles (1/s)      {}",
        poles
            .iter()
            .map(|(re, im)| if im.abs() < 1e-9 * re.abs().max(1.0) {
                format!("{re:.3}")
            } else {
                format!("{re:.2}{im:+.2}i")
            })
            .collect::<Vec<_>>()
            .join(", ")
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn krylov_rank_of_a_decoupled_pair_counts_only_the_driven_chain() {
        // Two integrator chains, the input drives only the first: rank 2 of 4.
        let f = DMatrix::from_row_slice(
            4,
            4,
            &[
                0., 1., 0., 0., 0., 0., 0., 0., 0., 0., 0., 1., 0., 0., 0., 0.,
            ],
        );
        let g = DMatrix::from_row_slice(4, 1, &[0., 1., 0., 0.]);
        let q = krylov_basis(&f, &g);
        assert_eq!(q.ncols(), 2);
        let out = outside_share(&q);
        assert!(out[0] < 1e-12 && out[1] < 1e-12 && out[2] > 1.0 - 1e-12);
    }
}
