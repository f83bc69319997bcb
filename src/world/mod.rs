//! The vehicle's surroundings: floor surfaces (parry2d regions) and obstacles, and the
//! rapier engine that moves the chassis among them.

pub mod engine;

use parry2d_f64::math::Vector;
use parry2d_f64::query::PointQuery;
use parry2d_f64::shape::ConvexPolygon;

use crate::scene::presets::{self, Surface};
use crate::scene::FloorSpec;

/// Floor: a default surface and convex regions of other surfaces (later ones win).
#[derive(Clone)]
pub struct Floor {
    pub default: &'static Surface,
    pub regions: Vec<(ConvexPolygon, &'static Surface, Vec<[f64; 2]>)>,
}

impl Floor {
    /// Builds the floor of a validated scene (unknown names fall back to the default).
    pub fn from_spec(spec: &FloorSpec) -> Floor {
        let default = presets::surface(&spec.surface).unwrap_or(&presets::SURFACES[0]);
        let regions = spec
            .regions
            .iter()
            .filter_map(|r| {
                let pts: Vec<Vector> = r
                    .polygon_m
                    .iter()
                    .map(|p| Vector::new(p[0], p[1]))
                    .collect();
                let poly = ConvexPolygon::from_convex_hull(&pts)?;
                Some((
                    poly,
                    presets::surface(&r.surface).unwrap_or(default),
                    r.polygon_m.clone(),
                ))
            })
            .collect();
        Floor { default, regions }
    }

    /// The surface at a world point.
    pub fn surface_at(&self, p: [f64; 2]) -> &'static Surface {
        let q = Vector::new(p[0], p[1]);
        for (poly, surface, _) in self.regions.iter().rev() {
            if poly.contains_local_point(q) {
                return surface;
            }
        }
        self.default
    }
}
