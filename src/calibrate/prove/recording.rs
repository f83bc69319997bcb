//! A case recorded: the excitation's rows (random demands, a voltage multisine, SysId's
//! ramps and steps, random velocity commands) replayed on the machine, the outputs with
//! seeded measurement noise.

use super::noise::SensorNoise;
use super::*;
use crate::record::channels as chan;

/// The rows of an excitation: times and one value per input column.
pub(super) fn excitation_rows(
    kind: Kind,
    excitation: Excitation,
    rng: &mut Pcg64,
) -> (Vec<&'static str>, f64, Vec<Vec<f64>>) {
    let tau = std::f64::consts::TAU;
    let phases: Vec<f64> = (0..8).map(|_| rng.random_range(0.0..tau)).collect();
    let sines = |t: f64, offset: usize, peak: f64| -> f64 {
        let parts = [(0.3, 1.0), (0.7, 0.8), (1.9, 0.6), (4.3, 0.4)];
        let sum: f64 = parts
            .iter()
            .enumerate()
            .map(|(i, (f, a))| a * (tau * f * t + phases[offset + i]).sin())
            .sum();
        peak * sum / 2.8
    };
    match (kind, excitation) {
        (Kind::AxisVoltage, Excitation::SysId) => {
            (vec![chan::VOLTAGE_V], SYSID_DT_S, sysid_voltages())
        }
        (Kind::AxisVoltage, _) => (
            vec![chan::VOLTAGE_V],
            0.005,
            (0..1600)
                .map(|k| vec![sines(k as f64 * 0.005, 0, peak_voltage(excitation))])
                .collect(),
        ),
        (Kind::AxisDemand, _) => (
            vec![chan::DEMAND_PCT],
            0.005,
            (0..1600)
                .map(|k| {
                    let t = k as f64 * 0.005;
                    // Zero until the DCMC's enable delay has passed.
                    vec![if t < 0.6 {
                        0.0
                    } else {
                        sines(t, 0, peak_demand(kind))
                    }]
                })
                .collect(),
        ),
        (Kind::PairDemand, _) => {
            let (mut level, mut hold) = ([0.0, 0.0], 0usize);
            let peak = peak_demand(kind);
            let rows = (0..600)
                .map(|k| {
                    if k >= 24 {
                        if hold == 0 {
                            level = [
                                rng.random_range(-peak..=peak),
                                rng.random_range(-0.5 * peak..=0.5 * peak),
                            ];
                            hold = rng.random_range(4..=16);
                        }
                        hold -= 1;
                    }
                    level.to_vec()
                })
                .collect();
            (
                vec![chan::DEMAND_FWD_PCT, chan::DEMAND_TURN_PCT],
                0.025,
                rows,
            )
        }
        (Kind::VehicleVoltage, _) => (
            vec![chan::LEFT_VOLTAGE_V, chan::RIGHT_VOLTAGE_V],
            0.005,
            (0..1600)
                .map(|k| {
                    let t = k as f64 * 0.005;
                    let p = peak_voltage(excitation);
                    vec![sines(t, 0, p), sines(t, 4, p)]
                })
                .collect(),
        ),
        (Kind::BaseVelocity | Kind::BaseRig, _) => {
            let (mut v, mut w) = (0.0, 0.0);
            let rows = (0..1000)
                .map(|k| {
                    if k >= 50 && k % 100 == 50 {
                        v = rng.random_range(-0.6..0.8);
                        w = rng.random_range(-1.0..1.0);
                    }
                    vec![v, w]
                })
                .collect();
            (
                vec![chan::CMD_LINEAR_M_S, chan::CMD_ANGULAR_RAD_S],
                0.01,
                rows,
            )
        }
    }
}

/// The SysId test's sample interval, s.
pub(super) const SYSID_DT_S: f64 = 0.005;

/// SysId's voltages: quasistatic 1.2 V/s each way for 5 s, then a 12 V step each way for
/// 2 s, a second at rest before each.
pub(super) fn sysid_voltages() -> Vec<Vec<f64>> {
    let dt = SYSID_DT_S;
    let mut rows = vec![];
    let mut push = |len: f64, f: &dyn Fn(f64) -> f64| {
        let n = (len / dt).round() as usize;
        for k in 0..n {
            rows.push(vec![f(k as f64 * dt)]);
        }
    };
    push(1.0, &|_| 0.0);
    push(5.0, &|s| 1.2 * s);
    push(1.0, &|_| 0.0);
    push(5.0, &|s| -1.2 * s);
    push(1.0, &|_| 0.0);
    push(2.0, &|_| 12.0);
    push(1.0, &|_| 0.0);
    push(2.0, &|_| -12.0);
    rows
}

/// The outputs a kind's rig measures.
pub(super) fn outputs_of(kind: Kind) -> &'static [&'static str] {
    match kind {
        Kind::AxisVoltage | Kind::AxisDemand => &[chan::MOTOR_SPEED_RAD_S, chan::CURRENT_A],
        Kind::PairDemand => &[chan::LEFT_MOTOR_SPEED_RAD_S, chan::RIGHT_MOTOR_SPEED_RAD_S],
        Kind::VehicleVoltage => &[
            chan::X_M,
            chan::Y_M,
            chan::HEADING_RAD,
            chan::LEFT_MOTOR_SPEED_RAD_S,
            chan::RIGHT_MOTOR_SPEED_RAD_S,
        ],
        Kind::BaseVelocity | Kind::BaseRig => &[
            chan::X_M,
            chan::Y_M,
            chan::HEADING_RAD,
            chan::LEFT_WHEEL_SPEED_M_S,
            chan::RIGHT_WHEEL_SPEED_M_S,
            chan::YAW_RATE_RAD_S,
        ],
    }
}

pub(super) fn rig_of(kind: Kind) -> RigKind {
    match kind {
        Kind::AxisVoltage | Kind::AxisDemand => RigKind::DriveAxis,
        Kind::PairDemand => RigKind::DrivePair,
        _ => RigKind::Vehicle,
    }
}

/// The machine's recording of the excitation: the inputs replayed on it, each output with
/// seeded noise of the case's kind ([`SensorNoise`]; white, or coloured as its sensor's) of
/// a standard deviation of a tracker's 2 mm and 5 mrad on the pose, 1 % of the output's
/// spread on the others (a sensor ranged to its signal).
pub fn record(case: &Case, machine: &Scene, seed: u64) -> Result<Recording, CalibrateError> {
    let (text, path) = record_text(case, machine, seed)?;
    Recording::parse(&text, &path).map_err(|e| CalibrateError::Data(e.to_string()))
}

/// [`record`]'s recording as text in the exchange format, and its name.
pub fn record_text(
    case: &Case,
    machine: &Scene,
    seed: u64,
) -> Result<(String, std::path::PathBuf), CalibrateError> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let (inputs, dt, rows) = excitation_rows(case.kind, case.excitation, &mut rng);
    let outputs = outputs_of(case.kind);
    let mut columns = vec![chan::T_S];
    columns.extend(&inputs);
    columns.extend(outputs);
    let mut text = crate::record::header(
        rig_of(case.kind),
        &[(
            "description",
            format!("calibration proof case {}", case.name),
        )],
        &columns,
    );
    for (k, u) in rows.iter().enumerate() {
        let mut cells = vec![format!("{}", k as f64 * dt)];
        cells.extend(u.iter().map(|v| format!("{v}")));
        cells.extend(outputs.iter().map(|_| "0".to_string()));
        let _ = writeln!(text, "{}", cells.join(","));
    }
    let path = Path::new(&case.name).with_extension("csv");
    let inputs_rec =
        Recording::parse(&text, &path).map_err(|e| CalibrateError::Data(e.to_string()))?;
    let r = replay(machine, &inputs_rec)?;
    let mut noisy = crate::record::header(
        rig_of(case.kind),
        &[(
            "description",
            format!("calibration proof case {}", case.name),
        )],
        &columns,
    );
    // Each output's simulated column, found once (not per sample).
    let truth: Vec<&[f64]> = outputs
        .iter()
        .map(|n| {
            r.output(n).map(|o| o.simulated.as_slice()).ok_or_else(|| {
                CalibrateError::Data(format!("the machine's replay produced no `{n}`"))
            })
        })
        .collect::<Result<_, _>>()?;
    let sd: Vec<f64> = outputs
        .iter()
        .zip(&truth)
        .map(|(n, y)| match *n {
            chan::X_M | chan::Y_M => 0.002,
            chan::HEADING_RAD => 0.005,
            _ => {
                let m = y.iter().sum::<f64>() / y.len() as f64;
                0.01 * (y.iter().map(|v| (v - m).powi(2)).sum::<f64>() / y.len() as f64).sqrt()
            }
        })
        .collect();
    let measured: Vec<Vec<f64>> = match case.noise {
        // Drawn sample by sample across the outputs, as the proof always drew them.
        SensorNoise::White => {
            let mut m: Vec<Vec<f64>> = vec![Vec::with_capacity(rows.len()); outputs.len()];
            for k in 0..rows.len() {
                for ((y, s), col) in truth.iter().zip(&sd).zip(&mut m) {
                    let e: f64 = StandardNormal.sample(&mut rng);
                    col.push(y[k] + s * e);
                }
            }
            m
        }
        SensorNoise::Sensors => outputs
            .iter()
            .zip(&truth)
            .zip(&sd)
            .map(|((n, y), s)| super::noise::by_its_sensor(n, y, *s, dt, &mut rng))
            .collect(),
    };
    for (k, u) in rows.iter().enumerate() {
        let mut cells = vec![format!("{}", k as f64 * dt)];
        cells.extend(u.iter().map(|v| format!("{v}")));
        cells.extend(measured.iter().map(|col| format!("{}", col[k])));
        let _ = writeln!(noisy, "{}", cells.join(","));
    }
    Ok((noisy, path))
}

pub(super) fn peak_voltage(excitation: Excitation) -> f64 {
    match excitation {
        Excitation::SysId => 12.0,
        _ => 14.0,
    }
}

pub(super) fn peak_demand(kind: Kind) -> f64 {
    match kind {
        Kind::PairDemand => 60.0,
        _ => 70.0,
    }
}
