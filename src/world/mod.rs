//! The vehicle's surroundings: floor surfaces (parry2d regions) and obstacles, and the
//! rapier engine that moves the chassis among them.

pub mod engine;

use parry2d_f64::math::Vector;
use parry2d_f64::query::PointQuery;
use parry2d_f64::shape::ConvexPolygon;

use crate::model::tyre_presets::{self as presets, Surface};

/// What `floor.surface` takes.
fn surface_choice() -> String {
    format!("one of {}", presets::surface_names())
}

/// What `floor.regions` takes.
fn region_tables() -> String {
    "`[[floor.regions]]` tables of `surface` and `polygon_m`: at least 3 finite `[x, y]` corners of a convex polygon, m".into()
}

crate::declare_params! {
    /// The floor (scene section `[floor]`): a default surface and optional regions of
    /// other surfaces.
    #[derive(Debug, Clone, PartialEq)]
    pub struct FloorParams in "floor" {
        /// The default surface: `painted_concrete`, `bare_concrete` or `epoxy_wet` (see
        /// `agvsim presets`).
        surface: String = "painted_concrete".into(), "", other(surface_choice);
        /// Convex regions of other surfaces; later regions win where they overlap.
        regions: Vec<FloorRegion> = Vec::new(), "", other(region_tables);
    }
}

/// A convex polygon of another surface; later regions win where they overlap.
#[derive(Debug, Clone, serde::Deserialize, serde::Serialize, Default, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FloorRegion {
    /// The region's surface.
    pub surface: String,
    /// Corners of a convex polygon, world frame, m.
    #[serde(deserialize_with = "crate::param::points_2d")]
    pub polygon_m: Vec<[f64; 2]>,
}

/// Floor: a default surface and convex regions of other surfaces (later ones win).
#[derive(Clone)]
pub struct Floor {
    /// The surface outside every region.
    pub default: &'static Surface,
    /// Each region: its polygon, its surface and its corners, m.
    pub regions: Vec<(ConvexPolygon, &'static Surface, Vec<[f64; 2]>)>,
}

impl Floor {
    /// Builds the floor of a validated scene (unknown names fall back to the default).
    pub fn from_params(spec: &FloorParams) -> Floor {
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
