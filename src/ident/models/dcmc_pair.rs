//! The thesis's DCMC identification structures: two lifted drive axes behind the motor
//! controller, forward and turn demand in, left and right motor speeds out (states the
//! motor speeds), in continuous time.
//!
//! - Case 1 (`gain`): the DCMC is a gain matrix, each motor a first-order lag:
//!   `dw/dt = A w + B d`, A diagonal, B full (2 x 2).
//! - Case 2-I (`p`): a proportional speed loop around each motor:
//!   `dw_i/dt = k_i (sum_j s_ij d_j - w_i)`; the same structure as case 1 (A = -k,
//!   B_ij = k_i s_ij), hence the same fit.
//! - Case 2-II (`pi`): a PI speed loop adds an integrator per side:
//!   `dw_i/dt = a_i w_i + sum_j b_ij d_j + e_i z_i`, `dz_i/dt = sum_j s_ij d_j - w_i`.

use std::path::Path;

use nalgebra::DMatrix;

use crate::ident::data::Dataset;
use crate::ident::model::{GreyBox, OutputKind, ParamSpec};
use crate::rig::{Rig, RigError};

/// Which thesis structure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Case {
    /// Case 1.
    Gain,
    /// Case 2-I.
    P,
    /// Case 2-II.
    Pi,
}

impl Case {
    pub fn label(self) -> &'static str {
        match self {
            Case::Gain => "case 1 (gain)",
            Case::P => "case 2-I (proportional speed loop)",
            Case::Pi => "case 2-II (PI speed loop)",
        }
    }
}

const SIDES: [&str; 2] = ["left", "right"];
const DEMANDS: [&str; 2] = ["fwd", "turn"];

#[derive(Debug, Clone)]
pub struct DcmcPair {
    pub case: Case,
    specs: Vec<ParamSpec>,
    pub encoder: bool,
}

/// First-order motor seen from its terminal voltage: dw/dt = -alpha w + beta V.
struct MotorLag {
    alpha: f64,
    beta: f64,
}

impl DcmcPair {
    pub fn from_rig(rig: &Rig, path: &Path, case: Case) -> Result<DcmcPair, RigError> {
        let why = "the DCMC pair model takes its starting values from the motor";
        let need = |k: &str| rig.require(k, path, why);
        let (r, k) = (
            need("motor.resistance_ohm")?,
            need("motor.torque_constant_Nm_A")?,
        );
        let n = rig.get("gearbox.ratio").unwrap_or(1.0);
        let j = need("motor.rotor_inertia_kg_m2")?
            + rig.get("wheel.inertia_kg_m2").unwrap_or(0.0) / (n * n);
        let b = rig.get("motor.viscous_Nm_s_rad").unwrap_or(0.0);
        let m = MotorLag {
            alpha: (b + k * k / r) / j,
            beta: k / (r * j),
        };
        let gf = rig.get("controller.gain_V_pct").unwrap_or(0.24);
        let gt = rig.get("controller.turn_gain_V_pct").unwrap_or(gf);
        // Left = forward - turn, right = forward + turn (the DCMC's mix).
        let mix = [[1.0, -1.0], [1.0, 1.0]];
        let (a_nom, b_nom, e_nom, s_nom) = match rig.text("controller.kind").unwrap_or("gain") {
            "gain" => {
                let bm = |i: usize, jj: usize| m.beta * [gf, gt][jj] * mix[i][jj];
                let a = -m.alpha;
                let bb = [[bm(0, 0), bm(0, 1)], [bm(1, 0), bm(1, 1)]];
                let s = bb.map(|row| row.map(|v| v / m.alpha));
                (a, bb, 1e-3 * m.alpha * m.alpha, s)
            }
            "p" | "pi" => {
                let sp = rig.get("controller.speed_per_pct_rad_s").unwrap_or(3.5);
                let kp = rig.get("controller.kp_V_s_rad").unwrap_or(0.5);
                let ki = rig.get("controller.ki_V_rad").unwrap_or(0.0);
                let s = [0, 1].map(|i| [0, 1].map(|jj| sp * [1.0, gt / gf][jj] * mix[i][jj]));
                let a = -(m.alpha + m.beta * kp);
                let bb = s.map(|row| row.map(|v| m.beta * kp * v));
                (a, bb, (m.beta * ki).max(1e-3 * m.alpha * m.alpha), s)
            }
            other => {
                return Err(RigError::Invalid {
                    file: path.to_owned(),
                    message: format!(
                        "controller.kind = \"{other}\": expected \"gain\", \"p\" or \"pi\""
                    ),
                })
            }
        };
        let signed = |name: String, v: f64| {
            ParamSpec::new(&name, v, -1e6 * v.abs().max(1e-9), 1e6 * v.abs().max(1e-9))
        };
        let rate = |name: String, v: f64| ParamSpec::new(&name, v, -1e5, -1e-6);
        let mut specs = Vec::new();
        match case {
            Case::Gain | Case::Pi => {
                for (i, side) in SIDES.iter().enumerate() {
                    specs.push(rate(format!("a_{side}_1_s"), a_nom));
                    let _ = i;
                }
                for (i, side) in SIDES.iter().enumerate() {
                    for (jj, d) in DEMANDS.iter().enumerate() {
                        specs.push(signed(format!("b_{side}_{d}_rad_s2_pct"), b_nom[i][jj]));
                    }
                }
            }
            Case::P => {
                for side in SIDES {
                    specs.push(ParamSpec::positive(&format!("k_{side}_1_s"), -a_nom));
                }
                for (i, side) in SIDES.iter().enumerate() {
                    for (jj, d) in DEMANDS.iter().enumerate() {
                        specs.push(signed(format!("s_{side}_{d}_rad_s_pct"), s_nom[i][jj]));
                    }
                }
            }
        }
        if case == Case::Pi {
            for side in SIDES {
                specs.push(ParamSpec::new(
                    &format!("e_{side}_1_s2"),
                    e_nom,
                    1e-4 * e_nom,
                    1e4 * e_nom,
                ));
            }
            for (i, side) in SIDES.iter().enumerate() {
                for (jj, d) in DEMANDS.iter().enumerate() {
                    specs.push(signed(format!("s_{side}_{d}_rad_s_pct"), s_nom[i][jj]));
                }
            }
        }
        Ok(DcmcPair {
            case,
            specs,
            encoder: rig.get("sensors.motor_encoder_counts_per_rev").is_some(),
        })
    }

    /// Number of states of the identified state-space model (speeds, plus integrators).
    pub fn order(&self) -> usize {
        if self.case == Case::Pi {
            4
        } else {
            2
        }
    }

    /// The continuous-time (A, B) of the model at parameters p.
    pub fn state_space(&self, p: &[f64]) -> (DMatrix<f64>, DMatrix<f64>) {
        let nx = self.order();
        let mut a = DMatrix::zeros(nx, nx);
        let mut b = DMatrix::zeros(nx, 2);
        match self.case {
            Case::Gain | Case::Pi => {
                for i in 0..2 {
                    a[(i, i)] = p[i];
                    for j in 0..2 {
                        b[(i, j)] = p[2 + 2 * i + j];
                    }
                }
                if self.case == Case::Pi {
                    for i in 0..2 {
                        a[(i, 2 + i)] = p[6 + i];
                        a[(2 + i, i)] = -1.0;
                        for j in 0..2 {
                            b[(2 + i, j)] = p[8 + 2 * i + j];
                        }
                    }
                }
            }
            Case::P => {
                for i in 0..2 {
                    a[(i, i)] = -p[i];
                    for j in 0..2 {
                        b[(i, j)] = p[i] * p[2 + 2 * i + j];
                    }
                }
            }
        }
        (a, b)
    }
}

impl GreyBox for DcmcPair {
    fn name(&self) -> String {
        format!("DCMC and two lifted motors, {}", self.case.label())
    }

    fn params(&self) -> &[ParamSpec] {
        &self.specs
    }

    fn default_free(&self, _outputs: &[String]) -> Vec<usize> {
        (0..self.specs.len()).collect()
    }

    fn input_names(&self) -> Vec<String> {
        vec!["demand_fwd_pct".into(), "demand_turn_pct".into()]
    }

    fn output_names(&self) -> Vec<String> {
        vec![
            "left_motor_speed_rad_s".into(),
            "right_motor_speed_rad_s".into(),
        ]
    }

    /// Speeds (left, right), angles (left, right), then the integrators in case 2-II.
    fn n_states(&self) -> usize {
        4 + if self.case == Case::Pi { 2 } else { 0 }
    }

    fn initial_state(&self, _p: &[f64], _data: &Dataset) -> Vec<f64> {
        vec![0.0; self.n_states()]
    }

    fn max_step_s(&self, p: &[f64]) -> f64 {
        let (a, _) = self.state_space(p);
        let fastest = a.iter().map(|v| v.abs()).fold(1e-9, f64::max);
        0.3 / fastest
    }

    fn derivatives(&self, p: &[f64], x: &[f64], u: &[f64], _held: &[f64], dx: &mut [f64]) {
        match self.case {
            Case::Gain => {
                for i in 0..2 {
                    dx[i] = p[i] * x[i] + p[2 + 2 * i] * u[0] + p[3 + 2 * i] * u[1];
                }
            }
            Case::P => {
                for i in 0..2 {
                    let set = p[2 + 2 * i] * u[0] + p[3 + 2 * i] * u[1];
                    dx[i] = p[i] * (set - x[i]);
                }
            }
            Case::Pi => {
                for i in 0..2 {
                    dx[i] = p[i] * x[i]
                        + p[2 + 2 * i] * u[0]
                        + p[3 + 2 * i] * u[1]
                        + p[6 + i] * x[4 + i];
                    dx[4 + i] = p[8 + 2 * i] * u[0] + p[9 + 2 * i] * u[1] - x[i];
                }
            }
        }
        dx[2] = x[0];
        dx[3] = x[1];
    }

    fn output_kind(&self, name: &str) -> OutputKind {
        let side = usize::from(name.starts_with("right"));
        if self.encoder {
            OutputKind::IntervalRate(2 + side)
        } else {
            OutputKind::Instant
        }
    }

    fn output(&self, _p: &[f64], name: &str, x: &[f64], _u: &[f64], _held: &[f64]) -> f64 {
        x[usize::from(name.starts_with("right"))]
    }
}
