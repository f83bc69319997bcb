//! The bumper: a strip along the front edge of the body (normally-closed microswitch);
//! contact with an obstacle is a parry2d intersection test.

use parry2d_f64::math::{Pose, Vector};
use parry2d_f64::query;
use parry2d_f64::shape::{Ball, Cuboid, SharedShape};

use crate::model::chassis::Pose as BodyPose;

/// A fixed obstacle on the floor as a scene gives it (`[[obstacles]]`); the bumper stops
/// the vehicle on contact.
#[derive(Debug, Clone, serde::Deserialize, serde::Serialize, Default, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ObstacleParams {
    /// Centre, world frame, m.
    pub center_m: [f64; 2],
    /// Rectangle half extents, m (give this or `radius_m`).
    pub half_extents_m: Option<[f64; 2]>,
    /// Circle radius, m.
    pub radius_m: Option<f64>,
    /// Rotation of a rectangle, rad.
    pub angle_rad: f64,
}

/// What `obstacles` takes.
pub fn obstacle_tables() -> String {
    "`[[obstacles]]` tables of `center_m` `[x, y]`, exactly one of `half_extents_m` `[hx, hy]` (> 0) or `radius_m` (> 0), and `angle_rad`".into()
}

/// A fixed obstacle on the floor.
#[derive(Clone)]
pub struct Obstacle {
    /// The obstacle's shape.
    pub shape: SharedShape,
    /// Its pose, world frame.
    pub pose: Pose,
    /// As the scene gives it.
    pub params: ObstacleParams,
}

impl Obstacle {
    /// The obstacle a scene describes.
    pub fn from_params(o: &ObstacleParams) -> Obstacle {
        let shape = match (o.half_extents_m, o.radius_m) {
            (Some(h), _) => SharedShape::new(Cuboid::new(Vector::new(h[0], h[1]))),
            (None, Some(r)) => SharedShape::new(Ball::new(r)),
            (None, None) => SharedShape::new(Ball::new(0.0)),
        };
        Obstacle {
            shape,
            pose: Pose::new(Vector::new(o.center_m[0], o.center_m[1]), o.angle_rad),
            params: o.clone(),
        }
    }
}

/// The bumper strip, body frame.
#[derive(Debug, Clone, Copy)]
pub struct Bumper {
    /// Centre of the strip ahead of the drive axle, m.
    pub x_m: f64,
    /// Half the strip's width, m.
    pub half_width_m: f64,
    /// Half depth of the strip, m (the switch travel).
    pub half_depth_m: f64,
}

impl Bumper {
    /// Whether the bumper touches any obstacle with the body at `pose`.
    pub fn touches(&self, pose: &BodyPose, obstacles: &[Obstacle]) -> bool {
        if obstacles.is_empty() {
            return false;
        }
        let c = pose.to_world([self.x_m, 0.0]);
        let bp = Pose::new(Vector::new(c[0], c[1]), pose.heading_rad);
        let strip = Cuboid::new(Vector::new(self.half_depth_m, self.half_width_m));
        obstacles.iter().any(|o| {
            query::intersection_test(&bp, &strip, &o.pose, o.shape.as_ref())
                .map(|r| r.intersecting)
                .unwrap_or(false)
        })
    }
}
