#![allow(non_snake_case)]
//! Named tyre compounds and floor surfaces, and how they combine into tyre parameters.
//!
//! Where the numbers come from (order-of-magnitude engineering values, not measurements of
//! the thesis AGV, which gives none):
//! - Peak friction: rubber on dry concrete 0.6-0.85 and polyurethane on concrete about
//!   0.5 are the usual handbook ranges (e.g. the Engineering ToolBox friction tables; AGV
//!   wheel makers quote 0.5-0.7 for 90-95 Shore A polyurethane on clean concrete). Paint
//!   and sealer make a floor smoother and dustier: we take 0.75x of bare concrete, in line
//!   with slip-resistance ratings of painted versus broom-finished concrete. The thesis
//!   observed the hard tyres slipping on its painted lab floor at high gain.
//! - Sliding friction is 75-85 % of the peak for rubber (the Stribeck drop in tyre
//!   brush models); hard polyurethane drops further (it glazes).
//! - Slip stiffness per newton of load: passenger-car tyres sit near 15-20 per unit slip;
//!   a thin hard polyurethane tread on a hub is much stiffer (about 30), a soft rubber
//!   tread softer (about 12). Cornering stiffness per newton is of the same order.
//! - Relaxation length: about the contact-patch half-length; hard small wheels 5-10 mm,
//!   soft tyres 15-25 mm.
//!
//! These are defaults to reason with; a scene can override any of them in `[tyre]`.

/// A tyre compound: what the tread brings regardless of the floor.
#[derive(Debug, Clone, Copy)]
pub struct Compound {
    /// Its name in a scene.
    pub name: &'static str,
    /// Peak friction on bare (broom-finished, dry) concrete.
    pub peak_mu_on_bare_concrete: f64,
    /// Sliding friction as a fraction of the peak.
    pub sliding_ratio: f64,
    /// Longitudinal slip stiffness per newton of normal load (per unit slip).
    pub long_stiffness_per_N: f64,
    /// Cornering stiffness per newton of normal load (per rad).
    pub lat_stiffness_per_N: f64,
    /// Relaxation length, m.
    pub relaxation_length_m: f64,
    /// What it is.
    pub note: &'static str,
}

/// A floor surface: scales the compound's friction.
#[derive(Debug, Clone, Copy)]
pub struct Surface {
    /// Its name in a scene.
    pub name: &'static str,
    /// Friction relative to bare concrete.
    pub friction_factor: f64,
    /// What it is.
    pub note: &'static str,
}

/// The tyre compounds a scene can name.
pub const COMPOUNDS: [Compound; 3] = [
    Compound {
        name: "hard_polyurethane",
        peak_mu_on_bare_concrete: 0.55,
        sliding_ratio: 0.7,
        long_stiffness_per_N: 30.0,
        lat_stiffness_per_N: 25.0,
        relaxation_length_m: 0.008,
        note: "the thesis AGV's tyres: 90-95 Shore A tread on a hub",
    },
    Compound {
        name: "soft_rubber",
        peak_mu_on_bare_concrete: 0.85,
        sliding_ratio: 0.8,
        long_stiffness_per_N: 12.0,
        lat_stiffness_per_N: 10.0,
        relaxation_length_m: 0.02,
        note: "the thesis's recommendation: a softer compound",
    },
    Compound {
        name: "high_grip",
        peak_mu_on_bare_concrete: 5.0,
        sliding_ratio: 0.95,
        long_stiffness_per_N: 200.0,
        lat_stiffness_per_N: 200.0,
        relaxation_length_m: 0.05,
        note: "an idealised no-slip tyre for checks against kinematics",
    },
];

/// The floor surfaces a scene can name.
pub const SURFACES: [Surface; 3] = [
    Surface {
        name: "painted_concrete",
        friction_factor: 0.75,
        note: "the thesis's laboratory floor",
    },
    Surface {
        name: "bare_concrete",
        friction_factor: 1.0,
        note: "broom-finished, dry",
    },
    Surface {
        name: "epoxy_wet",
        friction_factor: 0.45,
        note: "sealed floor with a water film",
    },
];

/// A compound by name.
pub fn compound(name: &str) -> Option<&'static Compound> {
    COMPOUNDS.iter().find(|c| c.name == name)
}

/// A surface by name.
pub fn surface(name: &str) -> Option<&'static Surface> {
    SURFACES.iter().find(|s| s.name == name)
}

/// Names, for error messages.
pub fn compound_names() -> String {
    COMPOUNDS
        .iter()
        .map(|c| c.name)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Surface names, for error messages.
pub fn surface_names() -> String {
    SURFACES
        .iter()
        .map(|s| s.name)
        .collect::<Vec<_>>()
        .join(", ")
}
