//! What a fit knows of its parameters' uncertainty: the covariance from a block sandwich
//! over the residual's correlation time combined with the priors, the standard deviations
//! it gives, and a direction nothing determines.

use super::*;

/// What a fit knows of its free parameters' uncertainty.
pub(super) struct Uncertainty {
    pub(super) std: Vec<Option<f64>>,
    pub(super) data_std: Vec<Option<f64>>,
    pub(super) prior_std: Vec<Option<f64>>,
    pub(super) covariance: DMatrix<f64>,
    pub(super) correlation_rows: usize,
    pub(super) weakest: Option<Vec<f64>>,
}

impl Uncertainty {
    /// Not computed (an intermediate fit).
    pub(super) fn unknown(d: usize) -> Uncertainty {
        Uncertainty {
            std: vec![None; d],
            data_std: vec![None; d],
            prior_std: vec![None; d],
            covariance: DMatrix::zeros(d, d),
            correlation_rows: 1,
            weakest: None,
        }
    }
}

/// The unit eigenvector of a symmetric information matrix with the smallest eigenvalue,
/// where that eigenvalue lies below [`UNDETERMINED_SHARE`] of the largest (a direction
/// nothing determines); `None` where every direction is determined.
pub(super) fn weakest_direction(m: &DMatrix<f64>) -> Option<Vec<f64>> {
    let sym = (m + m.transpose()) * 0.5;
    let eig = sym.symmetric_eigen();
    let largest = eig.eigenvalues.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let (k, &lambda) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    (lambda <= UNDETERMINED_SHARE * largest || lambda <= 0.0)
        .then(|| eig.eigenvectors.column(k).iter().copied().collect())
}

/// Fewest blocks the covariance's sandwich is estimated from: the residual's correlation
/// time sets a block's length, but never so long that fewer blocks than this remain (a
/// score variance from a handful of blocks is itself too uncertain to use).
pub const MIN_COVARIANCE_BLOCKS: usize = 20;

/// Singular values below this share of the largest are directions the data do not
/// determine.
pub(super) const UNDETERMINED_SHARE: f64 = 1e-9;

/// Covariance of the free parameters, for records whose residuals are neither white nor
/// from the true model:
///
/// - **the record's part** is a block sandwich, `A+ B A+`, with `A = J'J` the weighted
///   Gauss-Newton information and `B = G/(G-1) sum_b s_b s_b'` the spread of the scores
///   `s_b = J_b' r_b` of `G` blocks of consecutive samples (within each test), each block
///   as long as the residual stays correlated ([`correlation_rows`]). A correlated residual
///   is worth fewer samples than it has, and a mismatched model's residual is not its
///   noise: the blocks' scores see both, where `sigma^2 (J'J)^-1` assumes white noise from
///   the true model and on real records came out thousands of times too small;
/// - **the beliefs' part** is each believed parameter's prior information `1/sd^2` in the
///   search coordinate, added to the inverse of the record's part: a direction the record
///   does not determine keeps its prior's width instead of an infinite or invented one.
///
/// Returns the combined standard deviations, the record's alone and the priors', in
/// physical units. Directions that neither determines are reported as such.
pub(super) fn covariance(pb: &Problem, p: &[f64], jac: &DMatrix<f64>, r: &[f64]) -> Uncertainty {
    let d = jac.ncols();
    if d == 0 {
        return Uncertainty::unknown(0);
    }
    let n_data = r.len();
    let jd = jac.rows(0, n_data).into_owned();
    let a = jd.transpose() * &jd;
    let a_pinv = symmetric_pinv(&a);
    let (rows, v_data) = widest_sandwich(pb.data, &jd, r, &a_pinv.0);
    let prior_sd = prior_sd_z(pb.model.param_specs(), &pb.free, &pb.coords, pb.weighting);
    let mut info = symmetric_pinv(&v_data).0;
    for (i, sd) in prior_sd.iter().enumerate() {
        if let Some(sd) = sd {
            info[(i, i)] += 1.0 / (sd * sd);
        }
    }
    let (cov_z, undetermined) = symmetric_pinv(&info);
    let weakest = weakest_direction(&info);
    let scale = pb.dp_dz(p);
    let physical =
        |m: &DMatrix<f64>| DMatrix::from_fn(d, d, |i, j| scale[i] * scale[j] * m[(i, j)]);
    let covariance = physical(&cov_z);
    let v_data_p = physical(&v_data);
    Uncertainty {
        std: (0..d)
            .map(|i| (!undetermined[i]).then(|| covariance[(i, i)].max(0.0).sqrt()))
            .collect(),
        data_std: (0..d)
            .map(|i| (!a_pinv.1[i] && v_data_p[(i, i)] > 0.0).then(|| v_data_p[(i, i)].sqrt()))
            .collect(),
        prior_std: prior_sd
            .iter()
            .enumerate()
            .map(|(i, sd)| sd.map(|sd| sd * scale[i].abs()))
            .collect(),
        covariance,
        correlation_rows: rows,
        weakest,
    }
}

/// The pseudo-inverse of a symmetric positive semi-definite matrix through its
/// eigen-decomposition, and which coordinates lie in a direction it does not determine
/// (an eigenvalue below [`UNDETERMINED_SHARE`] of the largest).
pub(super) fn symmetric_pinv(m: &DMatrix<f64>) -> (DMatrix<f64>, Vec<bool>) {
    let d = m.nrows();
    let sym = (m + m.transpose()) * 0.5;
    let eig = sym.symmetric_eigen();
    let largest = eig.eigenvalues.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let mut inv = DMatrix::zeros(d, d);
    let mut undetermined = vec![false; d];
    for (k, &lambda) in eig.eigenvalues.iter().enumerate() {
        let v = eig.eigenvectors.column(k);
        if lambda > UNDETERMINED_SHARE * largest && lambda > 0.0 {
            inv += v * v.transpose() / lambda;
        } else {
            for i in 0..d {
                if v[i].abs() > 1e-3 {
                    undetermined[i] = true;
                }
            }
        }
    }
    (inv, undetermined)
}

/// The record's part of the covariance, `A+ B_L A+`, at the block length `L` (samples)
/// that makes it widest: `L` doubles from 1 (a white residual) to a twentieth of the record
/// ([`MIN_COVARIANCE_BLOCKS`]), ranked by their inflation over the white residual's,
/// `trace(V_white+ V_L)` (the sum of the variance ratios along the white covariance's
/// principal directions: the same whatever the parameterisation, so two parameterisations
/// of one model get one block length). A real residual mixes white sensor noise with slow
/// mismatch, whose autocorrelation is hidden under the noise's and still moves the
/// parameters; the spread of longer blocks' scores sees it, and where the residual is
/// white, longer blocks only estimate the same spread less precisely.
pub(super) fn widest_sandwich(
    data: &Dataset,
    jac: &DMatrix<f64>,
    r: &[f64],
    a_pinv: &DMatrix<f64>,
) -> (usize, DMatrix<f64>) {
    let longest = (data.len() / MIN_COVARIANCE_BLOCKS).max(1);
    let sandwich = |rows: usize| {
        let b = block_score_spread(data, jac, r, rows);
        a_pinv * b * a_pinv
    };
    let white = sandwich(1);
    let white_inv = symmetric_pinv(&white).0;
    let inflation = |v: &DMatrix<f64>| (&white_inv * v).trace();
    let mut best = (1, inflation(&white), white.clone());
    let mut rows = 2;
    while rows <= longest {
        let v = sandwich(rows);
        let score = inflation(&v);
        if score > best.1 {
            best = (rows, score, v);
        }
        rows *= 2;
    }
    (best.0, best.2)
}

/// `G/(G-1) sum_b s_b s_b'`: the spread of the scores `s_b = J_b' r_b` of blocks of `rows`
/// consecutive samples, each within one test (a test's last block may be shorter), every
/// output's residuals at those samples in the block.
pub(super) fn block_score_spread(
    data: &Dataset,
    jac: &DMatrix<f64>,
    r: &[f64],
    rows: usize,
) -> DMatrix<f64> {
    let d = jac.ncols();
    // The block of each sample: blocks restart at each test.
    let mut block_of = vec![0usize; data.len()];
    let mut next = 0;
    for seg in data.segments() {
        for (i, k) in seg.clone().enumerate() {
            block_of[k] = next + i / rows;
        }
        next += seg.len().div_ceil(rows);
    }
    let mut scores = DMatrix::<f64>::zeros(next.max(1), d);
    let mut at = 0;
    for col in &data.outputs {
        for (k, y) in col.iter().enumerate() {
            if y.is_some() {
                let b = block_of[k];
                for c in 0..d {
                    scores[(b, c)] += jac[(at, c)] * r[at];
                }
                at += 1;
            }
        }
    }
    // Centred: at a fit held by its priors (or on a bound) the record's scores do not sum
    // to zero, and their mean is no spread.
    let g = scores.nrows();
    let mean = scores.row_mean();
    for b in 0..g {
        for c in 0..d {
            scores[(b, c)] -= mean[c];
        }
    }
    let correction = if g > 1 {
        g as f64 / (g - 1) as f64
    } else {
        1.0
    };
    scores.transpose() * &scores * correction
}
