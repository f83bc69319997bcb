//! The linearised plant in forms other tools load: a MAT-file (`load` in MATLAB, then
//! `ss(A, B, C, D, Ts)`; `scipy.io.loadmat`, then `scipy.signal.dlti`) and JSON. The
//! matrices are discrete-time over one step `Ts`; each state, input and output is named,
//! its unit being the suffix of its name.

use serde_json::json;

use super::{Linearisation, STATE_NAMES};
use crate::matfile::Writer;

/// Input names (their units are their suffixes).
pub const INPUT_NAMES: [&str; 2] = ["left_voltage_V", "right_voltage_V"];
/// Output names: the steering coil pair's readings.
pub const OUTPUT_NAMES: [&str; 2] = ["sensor_left_adc", "sensor_right_adc"];

fn rows(m: &nalgebra::DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect())
        .collect()
}

fn row_major(m: &nalgebra::DMatrix<f64>) -> Vec<f64> {
    rows(m).concat()
}

/// A description of the operating point, in words.
fn operating_point(l: &Linearisation) -> String {
    format!(
        "straight on the wire at {:.4} m/s ({:.3} V on both motors), level {}, {} coil pair",
        l.speed_m_s,
        l.voltage_v,
        l.level.name(),
        l.sensors
    )
}

/// The JSON form.
pub fn to_json(l: &Linearisation) -> serde_json::Value {
    let named = |names: &[&str]| -> Vec<serde_json::Value> {
        names
            .iter()
            .map(|n| json!({"name": n, "unit": crate::numtext::unit_of_name(n)}))
            .collect()
    };
    let d = nalgebra::DMatrix::<f64>::zeros(l.c.nrows(), l.b.ncols());
    json!({
        "description": "agvsim linearize: discrete-time x[k+1] = A x[k] + B u[k], y[k] = C x[k] + D u[k]; the poles agvsim prints are those of its zero-order-hold continuous equivalent (MATLAB d2c(sys), SciPy: logm of [[A, B], [0, I]] / Ts), ln(z)/Ts of each pole z of A",
        "operating_point": operating_point(l),
        "Ts_s": l.dt_s,
        "A": rows(&l.a),
        "B": rows(&l.b),
        "C": rows(&l.c),
        "D": rows(&d),
        "states": named(&STATE_NAMES),
        "inputs": named(&INPUT_NAMES),
        "outputs": named(&OUTPUT_NAMES),
    })
}

/// The MAT-file form: A, B, C, D, Ts, the names and units as cell rows, and a note.
pub fn to_mat(l: &Linearisation) -> Vec<u8> {
    let units = |names: &[&str]| {
        names
            .iter()
            .map(|n| crate::numtext::unit_of_name(n))
            .collect::<Vec<_>>()
    };
    let (nx, nu, ny) = (l.a.nrows(), l.b.ncols(), l.c.nrows());
    let mut w = Writer::new("written by agvsim linearize");
    w.matrix("A", nx, nx, &row_major(&l.a))
        .matrix("B", nx, nu, &row_major(&l.b))
        .matrix("C", ny, nx, &row_major(&l.c))
        .matrix("D", ny, nu, &vec![0.0; ny * nu])
        .matrix("Ts", 1, 1, &[l.dt_s])
        .texts("state_names", &STATE_NAMES)
        .texts("state_units", &units(&STATE_NAMES))
        .texts("input_names", &INPUT_NAMES)
        .texts("input_units", &units(&INPUT_NAMES))
        .texts("output_names", &OUTPUT_NAMES)
        .texts("output_units", &units(&OUTPUT_NAMES))
        .text(
            "description",
            &format!(
                "discrete-time over Ts: sys = ss(A, B, C, D, Ts); agvsim prints the poles of d2c(sys) (zero-order hold), log(z)/Ts of each pole z of A; operating point {}",
                operating_point(l)
            ),
        );
    w.finish()
}
