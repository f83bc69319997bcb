//! The reduced base's defect: what the simulator's replay of a recording adds to the reduced
//! base's at one set of keys, carried as an additive correction of the reduced base's
//! predictions (space mapping's zeroth-order output correction, Bandler et al. 2004).
//!
//! The reduced base leaves out the castors' swing and the tooth mesh's sub-steps; on a
//! recording they leave a residual the fit would otherwise close by bending the mass or a
//! loop gain. With the defect at the keys the fit starts from added, the corrected reduced
//! base equals the simulator there and follows the reduced base's sensitivities around it:
//! the fit moves the keys only for what the simulator would also see, at the reduced base's
//! cost per evaluation. The defect is in the fitted outputs' units, row by row.
//!
//! [`super::faithful`] decides on what a velocity recording's calibration is fitted: the
//! reduced base as it is, the reduced base carrying its defect, or the simulator.

use std::sync::Arc;

/// The simulator's prediction minus the reduced base's, one vector of rows per fitted
/// output (in the dataset's output order), in the outputs' units.
#[derive(Debug, Clone, PartialEq)]
pub struct Defect(Arc<Vec<Vec<f64>>>);

impl Defect {
    /// The defect between a simulator's and a reduced base's predictions of the same rows;
    /// a row either leaves empty (a pose outside its windows) has none.
    pub fn between(simulator: &[Vec<f64>], reduced: &[Vec<f64>]) -> Defect {
        let rows = simulator
            .iter()
            .zip(reduced)
            .map(|(s, r)| {
                s.iter()
                    .zip(r)
                    .map(|(a, b)| if (a - b).is_finite() { a - b } else { 0.0 })
                    .collect()
            })
            .collect();
        Defect(Arc::new(rows))
    }

    /// Adds the defect to a reduced base's prediction `y` of the same outputs over the
    /// same rows or a first part of them (the rows a race explores).
    pub fn correct(&self, y: &mut [Vec<f64>]) {
        for (out, d) in y.iter_mut().zip(self.0.iter()) {
            for (v, dv) in out.iter_mut().zip(d) {
                *v += dv;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_corrected_reduced_base_equals_the_simulator_where_the_defect_was_taken() {
        let sim = vec![vec![1.0, 2.0, 3.5], vec![0.1, f64::NAN, 0.3]];
        let reduced = vec![vec![0.9, 2.2, 3.5], vec![0.0, f64::NAN, 0.4]];
        let d = Defect::between(&sim, &reduced);
        let mut y = reduced.clone();
        d.correct(&mut y);
        assert!((y[0][0] - 1.0).abs() < 1e-12 && (y[0][1] - 2.0).abs() < 1e-12);
        assert!((y[1][2] - 0.3).abs() < 1e-12);
        // An empty cell stays empty; the defect there is none.
        assert!(y[1][1].is_nan());
        // A first part of the rows takes the defect's first part.
        let mut part = vec![vec![0.9], vec![0.0]];
        d.correct(&mut part);
        assert!((part[0][0] - 1.0).abs() < 1e-12 && (part[1][0] - 0.1).abs() < 1e-12);
    }
}
