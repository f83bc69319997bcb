//! The continuous-time system a discrete-time one samples: the zero-order-hold inverse
//! (MATLAB's `d2c`, SciPy's inverse of `cont2discrete(..., method="zoh")`).
//!
//! Held inputs over a step `Ts` give `[A_d B_d; 0 I] = expm([A_c B_c; 0 0] Ts)`, so
//! `[A_c B_c; 0 0] = logm([A_d B_d; 0 I]) / Ts`. The poles of `A_c` are then `ln(z)/Ts` for
//! each pole `z` of `A_d`, what a user converting the exported matrices gets; the first
//! order `(A_d - I)/Ts` is not (a pole at `z = 0.686` over 1 ms is -314 1/s by it and
//! -377 1/s exactly).

use nalgebra::DMatrix;

/// The principal matrix logarithm of `m` (no eigenvalue on the closed negative real axis),
/// by inverse scaling and squaring: square roots (Denman-Beavers) until `m` is within 0.05
/// of the identity, then the series `log(I + X) = X - X^2/2 + X^3/3 - ...`, scaled back by
/// `2^k`. `None` when a square root does not converge (a singular or unsuited matrix).
pub fn matrix_log(m: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let n = m.nrows();
    let eye = DMatrix::<f64>::identity(n, n);
    let mut y = m.clone();
    let mut roots = 0u32;
    while (&y - &eye).norm() > 0.05 {
        y = sqrt_denman_beavers(&y)?;
        roots += 1;
        if roots > 60 {
            return None;
        }
    }
    let x = &y - &eye;
    let mut power = x.clone();
    let mut log = x.clone();
    for k in 2..200 {
        power = &power * &x;
        let term = &power / k as f64;
        if k % 2 == 0 {
            log -= &term;
        } else {
            log += &term;
        }
        if term.norm() < 1e-18 * (1.0 + log.norm()) {
            break;
        }
    }
    Some(log * 2f64.powi(roots as i32))
}

/// The principal square root by the Denman-Beavers iteration.
fn sqrt_denman_beavers(m: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let n = m.nrows();
    let mut y = m.clone();
    let mut z = DMatrix::<f64>::identity(n, n);
    for _ in 0..100 {
        let y_inv = y.clone().try_inverse()?;
        let z_inv = z.clone().try_inverse()?;
        let next_y = (&y + &z_inv) * 0.5;
        let next_z = (&z + &y_inv) * 0.5;
        let change = (&next_y - &y).norm();
        y = next_y;
        z = next_z;
        if !y.iter().all(|v| v.is_finite()) {
            return None;
        }
        if change <= 1e-15 * y.norm() {
            return Some(y);
        }
    }
    None
}

/// The continuous-time `(A_c, B_c)` whose zero-order-hold sampling over `ts_s` is
/// `(a_d, b_d)`, 1/s and per second; `None` when the logarithm does not exist.
pub fn zoh_to_continuous(
    a_d: &DMatrix<f64>,
    b_d: &DMatrix<f64>,
    ts_s: f64,
) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
    let (n, m) = (a_d.nrows(), b_d.ncols());
    let mut aug = DMatrix::<f64>::identity(n + m, n + m);
    aug.view_mut((0, 0), (n, n)).copy_from(a_d);
    aug.view_mut((0, n), (n, m)).copy_from(b_d);
    let log = matrix_log(&aug)? / ts_s;
    Some((
        log.view((0, 0), (n, n)).into_owned(),
        log.view((0, n), (n, m)).into_owned(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sampling_then_inverting_gives_the_continuous_system_back() {
        // A lightly damped pair, a fast real pole and an integrator, two inputs.
        let a_c = DMatrix::from_row_slice(
            4,
            4,
            &[
                -3.0, 180.0, 0.0, 0.0, //
                -180.0, -3.0, 1.0, 0.0, //
                0.0, 0.0, -377.0, 0.0, //
                1.0, 0.0, 0.0, 0.0,
            ],
        );
        let b_c = DMatrix::from_row_slice(4, 2, &[1.0, 0.0, 0.0, 2.0, 50.0, -50.0, 0.0, 0.0]);
        let ts = 0.001;
        // Sample with the exponential of the augmented matrix (nalgebra's Pade `exp`).
        let mut aug = DMatrix::<f64>::zeros(6, 6);
        aug.view_mut((0, 0), (4, 4)).copy_from(&a_c);
        aug.view_mut((0, 4), (4, 2)).copy_from(&b_c);
        let sampled = (aug * ts).exp();
        let a_d = sampled.view((0, 0), (4, 4)).into_owned();
        let b_d = sampled.view((0, 4), (4, 2)).into_owned();
        let (a, b) = zoh_to_continuous(&a_d, &b_d, ts).expect("a logarithm");
        assert!((&a - &a_c).norm() < 1e-7 * a_c.norm(), "{a}");
        assert!((&b - &b_c).norm() < 1e-7 * b_c.norm(), "{b}");
        // The fast pole is ln(z)/Ts, not (z - 1)/Ts.
        let z = (-377.0f64 * ts).exp();
        assert!((z.ln() / ts + 377.0).abs() < 1e-9);
        assert!(((z - 1.0) / ts + 314.0).abs() < 1.0);
    }
}
