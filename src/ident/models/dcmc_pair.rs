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

use crate::model::motor::MotorParams;
use crate::model::wheel::WheelParams;
use crate::record::channels as chan;
use crate::rig::blocks::Instruments;
use crate::rig::keys::alias;
use std::path::Path;
use std::sync::OnceLock;

use nalgebra::DMatrix;

use crate::ident::data::Dataset;
use crate::ident::model::{Binding, Dynamics, GreyBox, OutputKind, ParamSpec};
use crate::model::motor::electrical_damping_nm_s_rad;
use crate::param::KeyTable;
use crate::rig::{Rig, RigError};

crate::declare_params! {
    /// One side of the thesis's structures (sections `left` and `right`): the motor
    /// speed's rate, the demands' gains, the speed loop's integrator and set-points.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct DcmcSide {
        /// Case 1 and 2-II: the speed's own rate (A's diagonal; negative).
        a_1_s: f64 = 0.0, "1/s", Finite;
        /// Case 2-I: the speed loop's rate (positive).
        k_1_s: f64 = 0.0, "1/s", Finite;
        /// Case 1 and 2-II: the acceleration per percent of forward demand (B).
        b_fwd_rad_s2_pct: f64 = 0.0, "rad/s^2 per pct", Finite;
        /// Case 1 and 2-II: the acceleration per percent of turn demand (B).
        b_turn_rad_s2_pct: f64 = 0.0, "rad/s^2 per pct", Finite;
        /// Case 2-II: the integrator's gain into the speed.
        e_1_s2: f64 = 0.0, "1/s^2", Finite;
        /// Case 2-I and 2-II: the speed set-point per percent of forward demand.
        s_fwd_rad_s_pct: f64 = 0.0, "rad/s per pct", Finite;
        /// Case 2-I and 2-II: the speed set-point per percent of turn demand.
        s_turn_rad_s_pct: f64 = 0.0, "rad/s per pct", Finite;
    }
}

/// Both sides' values: what the structures' parameters set, by key.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DcmcPairParams {
    /// Left, right.
    pub sides: [DcmcSide; 2],
}

impl DcmcSide {
    /// The gains of both demands (forward, turn).
    fn b(&self) -> [f64; 2] {
        [self.b_fwd_rad_s2_pct, self.b_turn_rad_s2_pct]
    }

    /// The set-points of both demands (forward, turn).
    fn s(&self) -> [f64; 2] {
        [self.s_fwd_rad_s_pct, self.s_turn_rad_s_pct]
    }
}

fn pair_keys() -> &'static KeyTable<DcmcPairParams> {
    static TABLE: OnceLock<KeyTable<DcmcPairParams>> = OnceLock::new();
    TABLE.get_or_init(|| {
        KeyTable::<DcmcPairParams>::new()
            .section("left", |p| &p.sides[0], |p| &mut p.sides[0])
            .section("right", |p| &p.sides[1], |p| &mut p.sides[1])
    })
}

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
    /// The case as the thesis numbers it.
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

/// The thesis's DCMC structures on two lifted drives (forward and turn demand in, left and right motor speed out).
#[derive(Debug, Clone)]
pub struct DcmcPair {
    /// Which structure.
    pub case: Case,
    specs: Vec<ParamSpec>,
    binding: Binding<DcmcPairParams>,
    /// The speeds are encoders' (count differences over the sample interval).
    pub encoder: bool,
}

/// First-order motor seen from its terminal voltage: dw/dt = -alpha w + beta V.
struct MotorLag {
    alpha: f64,
    beta: f64,
}

impl MotorLag {
    /// The lag of a rig's motor with its wheel's inertia behind the gears.
    fn from_rig(rig: &Rig, path: &Path) -> Result<MotorLag, RigError> {
        let why = "the DCMC pair model takes its starting values from the motor";
        let need = |k: &str| rig.require(k, path, why);
        let (r, k) = (
            need(MotorParams::resistance_ohm.key())?,
            need(MotorParams::torque_constant_nm_a.key())?,
        );
        let n = rig.gear_ratio(path)?;
        let j = need(MotorParams::rotor_inertia_kg_m2.key())?
            + rig.get(WheelParams::inertia_kg_m2.key()).unwrap_or(0.0) / (n * n);
        let b = rig.get(MotorParams::viscous_nm_s_rad.key()).unwrap_or(0.0);
        Ok(MotorLag {
            alpha: (b + electrical_damping_nm_s_rad(k, r)) / j,
            beta: k / (r * j),
        })
    }
}

/// The structures' starting values from the rig's controller and motor: the speed's
/// rate, the demands' gains, the integrator's gain and the set-points per percent.
struct Nominal {
    a: f64,
    b: [[f64; 2]; 2],
    e: f64,
    s: [[f64; 2]; 2],
}

impl Nominal {
    fn of(rig: &Rig, path: &Path, m: &MotorLag) -> Result<Nominal, RigError> {
        let gf = rig.get(alias::CONTROLLER_GAIN_V_PCT.key()).unwrap_or(0.24);
        let gt = rig
            .get(alias::CONTROLLER_TURN_GAIN_V_PCT.key())
            .unwrap_or(gf);
        // Left = forward - turn, right = forward + turn (the DCMC's mix).
        let mix = [[1.0, -1.0], [1.0, 1.0]];
        let (a, b, e, s) = match rig.text(alias::CONTROLLER_KIND.key()).unwrap_or("gain") {
            "gain" => {
                let bm = |i: usize, jj: usize| m.beta * [gf, gt][jj] * mix[i][jj];
                let a = -m.alpha;
                let bb = [[bm(0, 0), bm(0, 1)], [bm(1, 0), bm(1, 1)]];
                let s = bb.map(|row| row.map(|v| v / m.alpha));
                (a, bb, 1e-3 * m.alpha * m.alpha, s)
            }
            "p" | "pi" => {
                let sp = rig
                    .get(alias::CONTROLLER_SPEED_PER_PCT_RAD_S.key())
                    .unwrap_or(3.5);
                let kp = rig.get(alias::CONTROLLER_KP_V_S_RAD.key()).unwrap_or(0.5);
                let ki = rig.get(alias::CONTROLLER_KI_V_RAD.key()).unwrap_or(0.0);
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
        Ok(Nominal { a, b, e, s })
    }

    /// The structure's parameters, named as the thesis names them.
    fn specs(&self, case: Case) -> Vec<ParamSpec> {
        let (a_nom, b_nom, e_nom, s_nom) = (self.a, self.b, self.e, self.s);
        // The thesis's names (`b_left_fwd_rad_s2_pct`), each setting its side's key
        // (`left.b_fwd_rad_s2_pct`).
        let key = |name: &str, side: &str| {
            format!("{side}.{}", name.replacen(&format!("_{side}"), "", 1))
        };
        let signed = |name: String, side: &str, v: f64| {
            ParamSpec::new(&name, v, -1e6 * v.abs().max(1e-9), 1e6 * v.abs().max(1e-9))
                .setting(&key(&name, side))
        };
        let rate = |name: String, side: &str, v: f64| {
            ParamSpec::new(&name, v, -1e5, -1e-6).setting(&key(&name, side))
        };
        let mut specs = Vec::new();
        match case {
            Case::Gain | Case::Pi => {
                for side in SIDES {
                    specs.push(rate(format!("a_{side}_1_s"), side, a_nom));
                }
                for (i, side) in SIDES.iter().enumerate() {
                    for (jj, d) in DEMANDS.iter().enumerate() {
                        specs.push(signed(
                            format!("b_{side}_{d}_rad_s2_pct"),
                            side,
                            b_nom[i][jj],
                        ));
                    }
                }
            }
            Case::P => {
                for side in SIDES {
                    let name = format!("k_{side}_1_s");
                    specs.push(ParamSpec::positive(&name, -a_nom).setting(&key(&name, side)));
                }
                for (i, side) in SIDES.iter().enumerate() {
                    for (jj, d) in DEMANDS.iter().enumerate() {
                        specs.push(signed(
                            format!("s_{side}_{d}_rad_s_pct"),
                            side,
                            s_nom[i][jj],
                        ));
                    }
                }
            }
        }
        if case == Case::Pi {
            for side in SIDES {
                let name = format!("e_{side}_1_s2");
                specs.push(
                    ParamSpec::new(&name, e_nom, 1e-4 * e_nom, 1e4 * e_nom)
                        .setting(&key(&name, side)),
                );
            }
            for (i, side) in SIDES.iter().enumerate() {
                for (jj, d) in DEMANDS.iter().enumerate() {
                    specs.push(signed(
                        format!("s_{side}_{d}_rad_s_pct"),
                        side,
                        s_nom[i][jj],
                    ));
                }
            }
        }
        specs
    }
}

impl DcmcPair {
    /// The structure a rig describes, starting from the motor's first-order lag.
    pub fn from_rig(rig: &Rig, path: &Path, case: Case) -> Result<DcmcPair, RigError> {
        let motor = MotorLag::from_rig(rig, path)?;
        let specs = Nominal::of(rig, path, &motor)?.specs(case);
        Ok(DcmcPair {
            case,
            binding: Binding::new(pair_keys(), &specs),
            specs,
            encoder: rig
                .get(Instruments::motor_encoder_counts_per_rev.key())
                .is_some(),
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

    /// Both sides' values at the parameters `p`.
    pub fn sides(&self, p: &[f64]) -> DcmcPairParams {
        self.binding.apply(&DcmcPairParams::default(), p)
    }

    /// The continuous-time (A, B) of the model at parameters p.
    pub fn state_space(&self, p: &[f64]) -> (DMatrix<f64>, DMatrix<f64>) {
        self.state_space_of(&self.sides(p))
    }

    /// The continuous-time (A, B) of both sides' values.
    fn state_space_of(&self, v: &DcmcPairParams) -> (DMatrix<f64>, DMatrix<f64>) {
        let nx = self.order();
        let mut a = DMatrix::zeros(nx, nx);
        let mut b = DMatrix::zeros(nx, 2);
        for (i, side) in v.sides.iter().enumerate() {
            match self.case {
                Case::Gain | Case::Pi => {
                    a[(i, i)] = side.a_1_s;
                    for (j, bij) in side.b().into_iter().enumerate() {
                        b[(i, j)] = bij;
                    }
                    if self.case == Case::Pi {
                        a[(i, 2 + i)] = side.e_1_s2;
                        a[(2 + i, i)] = -1.0;
                        for (j, sij) in side.s().into_iter().enumerate() {
                            b[(2 + i, j)] = sij;
                        }
                    }
                }
                Case::P => {
                    a[(i, i)] = -side.k_1_s;
                    for (j, sij) in side.s().into_iter().enumerate() {
                        b[(i, j)] = side.k_1_s * sij;
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

    fn params_mut(&mut self) -> &mut [ParamSpec] {
        &mut self.specs
    }

    fn default_free(&self, _outputs: &[String]) -> Vec<usize> {
        (0..self.specs.len()).collect()
    }

    fn input_names(&self) -> Vec<String> {
        vec![chan::DEMAND_FWD_PCT.into(), chan::DEMAND_TURN_PCT.into()]
    }

    fn output_names(&self) -> Vec<String> {
        vec![
            chan::LEFT_MOTOR_SPEED_RAD_S.into(),
            chan::RIGHT_MOTOR_SPEED_RAD_S.into(),
        ]
    }
}

impl Dynamics for DcmcPair {
    type Blocks = DcmcPairParams;
    /// The side whose motor speed the column is: 0 left, 1 right.
    type Output = usize;

    fn blocks(&self, p: &[f64]) -> DcmcPairParams {
        self.sides(p)
    }

    /// Speeds (left, right), angles (left, right), then the integrators in case 2-II.
    fn n_states(&self) -> usize {
        4 + if self.case == Case::Pi { 2 } else { 0 }
    }

    fn initial_state(&self, _v: &DcmcPairParams, _data: &Dataset) -> Vec<f64> {
        vec![0.0; self.n_states()]
    }

    fn max_step_s(&self, v: &DcmcPairParams) -> f64 {
        let (a, _) = self.state_space_of(v);
        let fastest = a.iter().map(|v| v.abs()).fold(1e-9, f64::max);
        0.3 / fastest
    }

    fn derivatives(&self, v: &DcmcPairParams, x: &[f64], u: &[f64], _held: &[f64], dx: &mut [f64]) {
        for (i, side) in v.sides.iter().enumerate() {
            match self.case {
                Case::Gain => {
                    dx[i] = side.a_1_s * x[i]
                        + side.b_fwd_rad_s2_pct * u[0]
                        + side.b_turn_rad_s2_pct * u[1];
                }
                Case::P => {
                    let set = side.s_fwd_rad_s_pct * u[0] + side.s_turn_rad_s_pct * u[1];
                    dx[i] = side.k_1_s * (set - x[i]);
                }
                Case::Pi => {
                    dx[i] = side.a_1_s * x[i]
                        + side.b_fwd_rad_s2_pct * u[0]
                        + side.b_turn_rad_s2_pct * u[1]
                        + side.e_1_s2 * x[4 + i];
                    dx[4 + i] = side.s_fwd_rad_s_pct * u[0] + side.s_turn_rad_s_pct * u[1] - x[i];
                }
            }
        }
        dx[2] = x[0];
        dx[3] = x[1];
    }

    fn output_of(&self, name: &str) -> usize {
        usize::from(name.starts_with("right"))
    }

    fn output_kind(&self, side: usize) -> OutputKind {
        if self.encoder {
            OutputKind::IntervalRate(2 + side)
        } else {
            OutputKind::Instant
        }
    }

    fn output(
        &self,
        _v: &DcmcPairParams,
        side: usize,
        x: &[f64],
        _u: &[f64],
        _held: &[f64],
    ) -> f64 {
        x[side]
    }
}
