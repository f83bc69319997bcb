//! The buried guide wire: a polyline or closed loop on the floor (parry2d), its magnetic
//! field at the pick-up coils, and the signed lateral offset of a point from it.

use parry2d_f64::math::Vector;
use parry2d_f64::query::PointQuery;
use parry2d_f64::shape::Polyline;

/// What `wire.points_m` takes.
fn wire_points() -> String {
    format!(
        "at least 2 distinct `[x, y]` points (3 when closed), within {:e} m of the origin",
        MAX_FLOOR_M
    )
}

/// Largest coordinate on the floor, m: far beyond any plant, small enough that squared
/// distances and the field's arithmetic stay exact to well below a millimetre.
pub const MAX_FLOOR_M: f64 = 1.0e5;

crate::declare_params! {
    /// The buried guide wire: a polyline or a closed loop, world frame (scene section
    /// `[wire]`).
    #[derive(Debug, Clone, PartialEq)]
    pub struct WireParams in "wire" {
        /// Vertices, world frame.
        #[serde(deserialize_with = "crate::param::points_2d")]
        points_m: Vec<[f64; 2]> = vec![[-2.0, 0.0], [40.0, 0.0]], "m", other(wire_points);
        /// Joins the last point to the first.
        closed: bool = false, "", other(crate::param::true_or_false);
    }
}

/// A guide wire, world frame, carrying current in the order of its points.
#[derive(Clone)]
pub struct Wire {
    points: Vec<[f64; 2]>,
    closed: bool,
    shape: Polyline,
}

impl std::fmt::Debug for Wire {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Wire")
            .field("points", &self.points)
            .field("closed", &self.closed)
            .finish()
    }
}

/// Where a point is relative to the wire.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WireOffset {
    /// Signed distance, m: positive when the point is to the left of the wire's direction.
    pub lateral_m: f64,
    /// Direction of the nearest wire segment, rad.
    pub direction_rad: f64,
    /// Nearest point on the wire, m.
    pub nearest_m: [f64; 2],
}

impl Wire {
    /// Needs at least two distinct points (three for a loop); the scene validator checks.
    pub fn new(points: Vec<[f64; 2]>, closed: bool) -> Wire {
        let verts: Vec<Vector> = points.iter().map(|p| Vector::new(p[0], p[1])).collect();
        let n = verts.len() as u32;
        let mut idx: Vec<[u32; 2]> = (0..n.saturating_sub(1)).map(|i| [i, i + 1]).collect();
        if closed {
            idx.push([n - 1, 0]);
        }
        Wire {
            shape: Polyline::new(verts, Some(idx)),
            points,
            closed,
        }
    }

    /// The wire's vertices, m.
    pub fn points(&self) -> &[[f64; 2]] {
        &self.points
    }

    /// Whether the last vertex joins the first.
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// The wire's segments, in current order.
    pub fn segments(&self) -> impl Iterator<Item = ([f64; 2], [f64; 2])> + '_ {
        let n = self.points.len();
        let count = if self.closed { n } else { n - 1 };
        (0..count).map(move |i| (self.points[i], self.points[(i + 1) % n]))
    }

    /// Signed lateral offset of a floor point from the nearest segment.
    pub fn offset(&self, p: [f64; 2]) -> WireOffset {
        let (proj, _) = self
            .shape
            .project_local_point_and_get_feature(Vector::new(p[0], p[1]));
        let seg = self
            .shape
            .segment(proj.subshape.min(self.shape.num_segments() as u32 - 1));
        let dir = [seg.b.x - seg.a.x, seg.b.y - seg.a.y];
        let rel = [p[0] - proj.point.x, p[1] - proj.point.y];
        let dist = rel[0].hypot(rel[1]);
        let cross = dir[0] * rel[1] - dir[1] * rel[0];
        WireOffset {
            lateral_m: if cross >= 0.0 { dist } else { -dist },
            direction_rad: dir[1].atan2(dir[0]),
            nearest_m: [proj.point.x, proj.point.y],
        }
    }

    /// Whether a floor point lies beyond the far end of an open wire: its nearest wire
    /// point is the last vertex and it sits ahead of it along the last segment (a loop has
    /// no end). Past the end the lateral offset measures distance to the end point, not a
    /// tracking error.
    pub fn past_end(&self, p: [f64; 2]) -> bool {
        if self.closed || self.points.len() < 2 {
            return false;
        }
        let n = self.points.len();
        let (a, b) = (self.points[n - 2], self.points[n - 1]);
        let along = (p[0] - b[0]) * (b[0] - a[0]) + (p[1] - b[1]) * (b[1] - a[1]);
        let nearest = self.offset(p).nearest_m;
        along > 0.0 && (nearest[0] - b[0]).hypot(nearest[1] - b[1]) < 1e-9
    }

    /// Horizontal magnetic field at a point `height_m` above the floor (Biot-Savart, each
    /// segment a finite straight conductor), scaled so that an infinite straight wire
    /// directly below gives magnitude 1. Returns the world-frame horizontal vector.
    pub fn horizontal_field(&self, p: [f64; 2], height_m: f64) -> [f64; 2] {
        let mut b = [0.0, 0.0];
        for (a, c) in self.segments() {
            let f = segment_horizontal_field(a, c, p, height_m);
            b[0] += f[0];
            b[1] += f[1];
        }
        b
    }
}

/// Horizontal field of one straight segment from `a` to `b` on the floor at a point `p`
/// raised `h` above it, scaled so an infinite wire directly below gives magnitude 1.
/// Magnitude `(1/(4 pi d)) (sin t2 - sin t1)` (d: distance from the wire's line) times the
/// horizontal share `h/d`, pointing along `-n` (n: in-plane normal left of the current).
pub fn segment_horizontal_field(a: [f64; 2], b: [f64; 2], p: [f64; 2], h: f64) -> [f64; 2] {
    let u = [b[0] - a[0], b[1] - a[1]];
    let len = u[0].hypot(u[1]);
    if len == 0.0 {
        return [0.0, 0.0];
    }
    let u = [u[0] / len, u[1] / len];
    let n = [-u[1], u[0]];
    let ap = [p[0] - a[0], p[1] - a[1]];
    let along = ap[0] * u[0] + ap[1] * u[1];
    let lateral = ap[0] * n[0] + ap[1] * n[1];
    let d2 = lateral * lateral + h * h;
    let d = d2.sqrt();
    // Along-wire coordinates of the segment ends measured from the foot of p.
    let s1 = -along;
    let s2 = len - along;
    let span = s2 / (s2 * s2 + d2).sqrt() - s1 / (s1 * s1 + d2).sqrt();
    // Scale: infinite wire (span = 2) directly below (d = h) must give 1.
    let mag = span / (4.0 * std::f64::consts::PI * d) * (h / d) * (2.0 * std::f64::consts::PI * h);
    [-mag * n[0], -mag * n[1]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_points_ahead_of_an_open_wires_last_vertex_are_past_its_end() {
        let w = Wire::new(vec![[0.0, 0.0], [5.0, 0.0], [5.0, 5.0]], false);
        assert!(w.past_end([5.0, 5.5]));
        assert!(w.past_end([5.2, 6.0]));
        assert!(!w.past_end([5.1, 4.0]), "beside the last leg");
        assert!(
            !w.past_end([-1.0, 0.0]),
            "before the start is not past the end"
        );
        let loop_ = Wire::new(vec![[0.0, 0.0], [5.0, 0.0], [5.0, 5.0]], true);
        assert!(!loop_.past_end([5.0, 6.0]));
    }

    #[test]
    fn lateral_offset_is_signed_left_positive() {
        let w = Wire::new(vec![[0.0, 0.0], [10.0, 0.0]], false);
        assert!((w.offset([3.0, 0.12]).lateral_m - 0.12).abs() < 1e-12);
        assert!((w.offset([3.0, -0.05]).lateral_m + 0.05).abs() < 1e-12);
    }

    #[test]
    fn long_wire_field_follows_the_infinite_wire_law() {
        let w = Wire::new(vec![[-100.0, 0.0], [100.0, 0.0]], false);
        let h = 0.038;
        for y in [0.0, 0.02, 0.05, 0.1] {
            let b = w.horizontal_field([0.0, y], h);
            let expect = h * h / (h * h + y * y);
            assert!(
                (b[1].abs() - expect).abs() < 1e-6,
                "y={y}: {b:?} vs {expect}"
            );
            assert!(b[0].abs() < 1e-9);
        }
    }
}
