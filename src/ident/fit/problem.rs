//! The fit's problem in its search coordinates: the free parameters on a log or a
//! normalised linear scale, the residuals a point gives, and their Jacobians.

use super::{residuals, Dataset, ParamSpec, Predictor, Weighting, COVARIANCE_FD_STEP};
use nalgebra::DMatrix;
use rayon::prelude::*;

/// How closely two derivatives of a rough cost over steps four times apart must agree
/// (norm of their difference over the wider one's) for the narrower to be taken.
const ROUGH_AGREEMENT: f64 = 0.3;
/// Widenings of a rough parameter's covariance step at most (to 64 times the first).
const ROUGH_WIDENINGS: usize = 3;

/// How a free parameter is searched.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Coord {
    /// The parameter's logarithm.
    Log,
    /// The parameter over `scale`, its nominal magnitude.
    Linear { scale: f64 },
}

impl Coord {
    /// A parameter's value in this coordinate.
    fn of(self, value: f64) -> f64 {
        match self {
            Coord::Log => value.ln(),
            Coord::Linear { scale } => value / scale,
        }
    }

    /// What a finite-difference step in this coordinate is a share of: nothing on a log
    /// scale (a step there is already a share of the value, whatever its units: scaled by
    /// `|ln p|`, a 40 kg mass was differenced over 3.7 % where a 0.6 V s/rad gain was over
    /// 1 %), the coordinate's own size, at least 1, on a linear one.
    fn step_scale(self, z: f64) -> f64 {
        match self {
            Coord::Log => 1.0,
            Coord::Linear { .. } => z.abs().max(1.0),
        }
    }

    /// The parameter's value at coordinate `z`.
    fn value(self, z: f64) -> f64 {
        match self {
            Coord::Log => z.exp(),
            Coord::Linear { scale } => z * scale,
        }
    }
}

/// A fit's problem: the model and data, the parameter vector the free ones are set in
/// (`base`), the free parameters' places and search coordinates, the weighting.
pub(super) struct Problem<'a> {
    pub(super) model: &'a dyn Predictor,
    pub(super) data: &'a Dataset,
    pub(super) base: Vec<f64>,
    pub(super) free: Vec<usize>,
    pub(super) coords: Vec<Coord>,
    pub(super) weighting: &'a Weighting,
}

impl Problem<'_> {
    pub(super) fn to_z(&self, p: &[f64]) -> Vec<f64> {
        self.free
            .iter()
            .zip(&self.coords)
            .map(|(&i, c)| c.of(p[i]))
            .collect()
    }

    pub(super) fn to_p(&self, z: &[f64]) -> Vec<f64> {
        let specs = self.model.param_specs();
        let mut p = self.base.clone();
        for ((&i, c), zi) in self.free.iter().zip(&self.coords).zip(z) {
            p[i] = c.value(*zi).clamp(specs[i].lo, specs[i].hi);
        }
        p
    }

    /// Bounds of the search coordinates.
    pub(super) fn z_bounds(&self) -> (Vec<f64>, Vec<f64>) {
        let specs = self.model.param_specs();
        let bound = |at: fn(&ParamSpec) -> f64| -> Vec<f64> {
            self.free
                .iter()
                .zip(&self.coords)
                .map(|(&i, c)| c.of(at(&specs[i])))
                .collect()
        };
        (bound(|s| s.lo), bound(|s| s.hi))
    }

    /// dp/dz for each free parameter at p.
    pub(super) fn dp_dz(&self, p: &[f64]) -> Vec<f64> {
        self.free
            .iter()
            .zip(&self.coords)
            .map(|(&i, c)| match c {
                Coord::Log => p[i],
                Coord::Linear { scale } => *scale,
            })
            .collect()
    }

    pub(super) fn residuals(&self, z: &[f64]) -> Option<Vec<f64>> {
        self.simulated(z).map(|(r, _)| r)
    }

    /// The weighted residuals at `z` (the record's, then the beliefs' when they are
    /// weighed) and the outputs they come from.
    pub(super) fn simulated(&self, z: &[f64]) -> Option<(Vec<f64>, Vec<Vec<f64>>)> {
        let p = self.to_p(z);
        crate::ident::activity::count_evaluation();
        let y = self.model.predict(&p, self.data).ok()?;
        let mut r = residuals(self.data, &y, &self.weighting.outputs);
        if self.weighting.prior > 0.0 {
            let w = self.weighting.prior.sqrt();
            r.extend(
                self.weighting
                    .belief_deviations(self.model.param_specs(), &p)
                    .map(|d| w * d),
            );
        }
        r.iter().all(|v| v.is_finite()).then_some((r, y))
    }

    pub(super) fn jacobian(&self, z: &[f64], r0: &[f64]) -> DMatrix<f64> {
        let cols: Vec<Vec<f64>> = (0..z.len())
            .into_par_iter()
            .map(|c| {
                let step = self.model.param_specs()[self.free[c]].fd_step;
                let h = step * z[c].abs().max(1.0);
                let mut zc = z.to_vec();
                zc[c] += h;
                let (h, r) = match self.residuals(&zc) {
                    Some(r) => (h, r),
                    None => {
                        // At a bound or a divergence edge, difference backwards.
                        zc[c] = z[c] - h;
                        match self.residuals(&zc) {
                            Some(r) => (-h, r),
                            None => return vec![0.0; r0.len()],
                        }
                    }
                };
                r.iter().zip(r0).map(|(a, b)| (a - b) / h).collect()
            })
            .collect();
        DMatrix::from_fn(r0.len(), z.len(), |i, j| cols[j][i])
    }

    /// The Jacobian by central differences of at least [`COVARIANCE_FD_STEP`] in the search
    /// coordinate (one-sided where a side does not simulate): for the covariance, which
    /// needs the outputs' sensitivity on the scale of the parameters' uncertainty. A law
    /// switched at events or smoothed over a small speed (friction's breakaway, a play)
    /// moves the outputs in steps far below that scale, and a forward difference of 1e-6
    /// measures the steps: on a real record it made the Coulomb friction's standard
    /// deviation a millionth of its value.
    pub(super) fn jacobian_central(&self, z: &[f64], r0: &[f64]) -> DMatrix<f64> {
        let cols: Vec<Vec<f64>> = (0..z.len())
            .into_par_iter()
            .map(|c| {
                let spec = &self.model.param_specs()[self.free[c]];
                let step = spec.fd_step.max(COVARIANCE_FD_STEP);
                let h = step * self.coords[c].step_scale(z[c]);
                let column = |h: f64| self.central_column(z, r0, c, h);
                if !spec.rough {
                    return column(h);
                }
                // The smallest step whose derivative the next, four times wider, confirms
                // within [`ROUGH_AGREEMENT`]; the widest tried where none does.
                let mut here = column(h);
                let mut h = h;
                for _ in 0..ROUGH_WIDENINGS {
                    let wider = column(4.0 * h);
                    let diff: f64 = here
                        .iter()
                        .zip(&wider)
                        .map(|(a, b)| (a - b) * (a - b))
                        .sum::<f64>()
                        .sqrt();
                    let size: f64 = wider.iter().map(|b| b * b).sum::<f64>().sqrt();
                    if diff <= ROUGH_AGREEMENT * size {
                        break;
                    }
                    here = wider;
                    h *= 4.0;
                }
                here
            })
            .collect();
        DMatrix::from_fn(r0.len(), z.len(), |i, j| cols[j][i])
    }

    /// Column `c` of the Jacobian by a central difference of `h` (one-sided where a side
    /// does not simulate; zero where neither does).
    pub(super) fn central_column(&self, z: &[f64], r0: &[f64], c: usize, h: f64) -> Vec<f64> {
        let at = |dz: f64| {
            let mut zc = z.to_vec();
            zc[c] += dz;
            self.residuals(&zc)
        };
        // The two sides at once: a covariance's columns are fewer than the workers' slots
        // would take (five keys on two cores leave one idle for a column's time).
        match rayon::join(|| at(h), || at(-h)) {
            (Some(a), Some(b)) => a.iter().zip(&b).map(|(a, b)| (a - b) / (2.0 * h)).collect(),
            (Some(a), None) => a.iter().zip(r0).map(|(a, b)| (a - b) / h).collect(),
            (None, Some(b)) => r0.iter().zip(&b).map(|(a, b)| (a - b) / h).collect(),
            (None, None) => vec![0.0; r0.len()],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ident::model::Diverged;

    /// A first-order lag's step response, `1 - exp(-t / tau)`, its time constant searched
    /// on a log scale as the calibration searches a scene's keys (rough, differenced over
    /// 1 %).
    struct Lag(Vec<ParamSpec>);

    impl Predictor for Lag {
        fn param_specs(&self) -> &[ParamSpec] {
            &self.0
        }
        fn predict(&self, p: &[f64], data: &Dataset) -> Result<Vec<Vec<f64>>, Diverged> {
            Ok(vec![data
                .t_s
                .iter()
                .map(|t| 1.0 - (-t / p[0]).exp())
                .collect()])
        }
    }

    /// The covariance's derivative with respect to a key on a log scale is the same
    /// whatever the key's units: the lag's response over three time constants, with the
    /// constant 40 s or 0.4 s (time in the same units), gives the same column. Differenced
    /// over a share of `|ln tau|` of the key, the 40 s lag was differenced over 3.7 % and
    /// the 0.4 s one over 1 %; a mass of 40 kg was so differenced, widened to 59 %, and
    /// printed a deviation 2.6 times narrower than its scatter over seeds.
    #[test]
    fn a_log_scaled_keys_derivative_does_not_depend_on_its_units() {
        let column = |tau: f64| {
            let model = Lag(vec![ParamSpec {
                rough: true,
                ..ParamSpec::positive("tau", tau).with_fd_step(1e-2)
            }]);
            let data = Dataset {
                name: "lag".into(),
                t_s: (0..300).map(|k| k as f64 * 0.01 * tau).collect(),
                input_names: vec![],
                inputs: vec![],
                output_names: vec!["y".into()],
                outputs: vec![(0..300)
                    .map(|k| Some(1.0 - (-(k as f64) * 0.01).exp()))
                    .collect()],
                segment_starts: vec![0],
            };
            let weighting = Weighting::outputs_only(vec![1.0]);
            let pb = Problem {
                model: &model,
                data: &data,
                base: vec![tau],
                free: vec![0],
                coords: vec![Coord::Log],
                weighting: &weighting,
            };
            let z = pb.to_z(&[tau]);
            let r0 = pb.residuals(&z).unwrap();
            pb.jacobian_central(&z, &r0)
        };
        let (slow, fast) = (column(40.0), column(0.4));
        let gap = (&slow - &fast).norm() / fast.norm();
        assert!(gap < 1e-9, "the columns differ by {gap} of their size");
    }
}
