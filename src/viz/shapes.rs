//! The shapes the vehicle views draw, in view coordinates (f32, z up): floor points, the
//! wire lifted over the path, rectangles, the tyres' force and slip arrows, and segments
//! clipped to a box.

use super::{FORCE_ARROW_M, FORCE_ARROW_REF_N, SLIP_ARROW_M, WIRE_ABOVE_PATH_M};

/// A floor point at z = 0.
pub(super) fn w(p: [f64; 2]) -> [f32; 3] {
    [p[0] as f32, p[1] as f32, 0.0]
}

/// A floor point lifted to draw above the path (the wire).
pub(super) fn above_path(p: [f64; 2]) -> [f32; 3] {
    [p[0] as f32, p[1] as f32, WIRE_ABOVE_PATH_M]
}

/// A closed rectangle on the floor: centre, half extents along its own x and y, and its
/// rotation, rad (vehicle parts use 0 in the vehicle frame; obstacles their angle).
pub(super) fn rectangle(c: [f64; 2], half: [f64; 2], angle_rad: f64) -> Vec<[f32; 3]> {
    let (s, co) = angle_rad.sin_cos();
    [
        [-1.0, -1.0],
        [1.0, -1.0],
        [1.0, 1.0],
        [-1.0, 1.0],
        [-1.0, -1.0],
    ]
    .iter()
    .map(|k: &[f64; 2]| {
        let (x, y) = (k[0] * half[0], k[1] * half[1]);
        w([c[0] + co * x - s * y, c[1] + s * x + co * y])
    })
    .collect()
}

/// An arrow along `v` whose length grows with the square root of its size: `length_m` at
/// a size of `reference`. Short quantities stay visible and large ones on screen.
fn sqrt_arrow(v: [f64; 2], length_m: f64, reference: f64) -> [f32; 3] {
    let size = v[0].hypot(v[1]);
    if size == 0.0 || !size.is_finite() {
        return [0.0; 3];
    }
    let scale = length_m * (size / reference).sqrt() / size;
    [(scale * v[0]) as f32, (scale * v[1]) as f32, 0.0]
}

/// The force arrow of a tyre, vehicle frame, m: along the force, [`FORCE_ARROW_M`] times
/// the square root of its size over [`FORCE_ARROW_REF_N`] long.
pub(super) fn force_arrow(f_n: [f64; 2]) -> [f32; 3] {
    sqrt_arrow(f_n, FORCE_ARROW_M, FORCE_ARROW_REF_N)
}

/// The slip arrow of a tyre, vehicle frame, m: along the slip vector (ratio forward,
/// angle sideways), [`SLIP_ARROW_M`] times the square root of its size long.
pub(super) fn slip_arrow(ratio: f64, angle_rad: f64) -> [f32; 3] {
    sqrt_arrow([ratio, angle_rad], SLIP_ARROW_M, 1.0)
}

/// The part of a segment inside an axis-aligned box (Liang-Barsky), if any.
pub(super) fn clip_segment(
    a: [f64; 2],
    b: [f64; 2],
    lo: [f64; 2],
    hi: [f64; 2],
) -> Option<([f64; 2], [f64; 2])> {
    let d = [b[0] - a[0], b[1] - a[1]];
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for k in 0..2 {
        for (p, q) in [(-d[k], a[k] - lo[k]), (d[k], hi[k] - a[k])] {
            if p == 0.0 {
                if q < 0.0 {
                    return None;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
            }
        }
    }
    (t0 <= t1).then(|| {
        (
            [a[0] + t0 * d[0], a[1] + t0 * d[1]],
            [a[0] + t1 * d[0], a[1] + t1 * d[1]],
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn length(v: [f32; 3]) -> f64 {
        f64::from(v[0]).hypot(f64::from(v[1]))
    }

    #[test]
    fn force_arrows_grow_with_the_square_root_of_the_force() {
        // A tyre at its grip limit (400 N) draws 1 m; steady rolling's 4 N still 0.1 m.
        assert!((length(force_arrow([400.0, 0.0])) - 1.0).abs() < 1e-6);
        assert!((length(force_arrow([0.0, -4.0])) - 0.1).abs() < 1e-6);
        // Along the force.
        let a = force_arrow([30.0, -40.0]);
        assert!((f64::from(a[1]) / f64::from(a[0]) + 4.0 / 3.0).abs() < 1e-6);
        assert_eq!(force_arrow([0.0, 0.0]), [0.0; 3]);
    }

    #[test]
    fn slip_arrows_grow_with_the_square_root_of_the_slip() {
        assert!((length(slip_arrow(0.01, 0.0)) - 0.1).abs() < 1e-6);
        assert!((length(slip_arrow(0.0, 1.0)) - 1.0).abs() < 1e-6);
    }
}
