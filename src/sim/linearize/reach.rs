//! Controllability from the motor voltages and observability from the coil readings of a
//! linearised plant: ranks of block Krylov subspaces and the share of each state outside
//! them.

use nalgebra::{DMatrix, DVector};

use super::{Linearisation, READING_SCALE_ADC, STATE_SCALE, VOLTAGE_SCALE_V};

/// Relative size below which a new Krylov direction counts as already spanned.
const RANK_TOLERANCE: f64 = 1e-7;

/// What the linearisation shows.
#[derive(Debug, Clone)]
pub struct Reach {
    /// Number of states.
    pub states: usize,
    /// Rank of controllability from the motor voltages.
    pub controllable_rank: usize,
    /// Rank of observability from the coil pair.
    pub observable_rank: usize,
    /// Per state: the share (0-1) of it outside the controllable subspace.
    pub uncontrollable_share: Vec<f64>,
    /// Per state: the share (0-1) of it the coil readings cannot see.
    pub unobservable_share: Vec<f64>,
    /// Continuous-time poles (of the zero-order-hold equivalent, `ln(z)/dt` of each
    /// discrete pole `z`), 1/s, as (re, im).
    pub poles: Vec<(f64, f64)>,
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
    let (f, b) = l.continuous();
    let f_scaled = &s_inv * &f * &s;
    let b_scaled = &s_inv * &b * VOLTAGE_SCALE_V;
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
