//! The pick-up coils and their 8-bit ADC. A tuned coil with a horizontal axis across the
//! vehicle reads the field component along its axis: proportional to 1/distance and to
//! the cosine of the angle between axis and field, so zero with the axis along the wire.
//!
//! Two laws map that field to a reading ([`CoilLaw`]): the physical one (reading
//! proportional to the field component, `full_scale h^2 / (h^2 + y^2)` off a straight
//! wire), and the thesis's coils as measured ([`ResponseCurve`]), whose far tail falls off
//! much faster than `1/r` (10 counts at 90 mm where the physical law gives about 38).

use super::response::ResponseCurve;

/// Which law turns the field at a coil into its reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, serde::Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum SensorLaw {
    /// The thesis's coils as measured: the calibration table (`AGVPOS.C`) as one coil's
    /// response against distance, interpolated monotonically, zero beyond 164 mm.
    #[default]
    Measured,
    /// Reading proportional to the Biot-Savart field component along the coil's axis
    /// (`full_scale_adc h^2 / (h^2 + y^2)` off a straight wire): for other machines.
    Physical,
}

impl crate::param::Value for SensorLaw {}

/// What `sensors.law` takes.
fn sensor_laws() -> String {
    "`measured`, `physical`".into()
}

crate::declare_params! {
    /// The two guide-wire pick-up coils and their ADC, body frame (scene section
    /// `[sensors]`).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct SensorParams in "sensors" {
        /// Coil pair ahead of the drive axle (*assumed*).
        x_m: f64 = 0.45, "m", Finite;
        /// Half the spacing between the coils (37 mm: where the thesis's calibration
        /// table puts them, see `sensing::response`).
        half_spacing_m: f64 = 0.037, "m", Positive;
        /// Height of the coils above the wire (about 38 mm).
        height_m: f64 = 0.038, "m", Positive;
        /// `measured` (the thesis's calibration table) or `physical` (Biot-Savart).
        law: SensorLaw = SensorLaw::Measured, "", other(sensor_laws);
        /// Reading directly over a straight wire (the `physical` law's scale).
        full_scale_adc: f64 = 250.0, "counts", Positive;
        /// RMS noise added before quantisation.
        noise_adc: f64 = 0.0, "counts", NonNegative;
        /// The wire counts as lost when both readings are below this.
        lost_threshold_adc: f64 = 4.0, "counts", NonNegative;
        /// A second, rear coil pair for reversing (body frame x).
        rear_x_m: Option<f64> = None, "m", Finite, unset "no rear pair";
    }
}

impl SensorParams {
    /// The pair's sensing law.
    pub fn coil(&self) -> CoilParams {
        CoilParams {
            height_m: self.height_m,
            full_scale_adc: self.full_scale_adc,
            law: match self.law {
                SensorLaw::Physical => CoilLaw::Physical,
                SensorLaw::Measured => CoilLaw::Measured(ResponseCurve::thesis()),
            },
        }
    }
}

/// How a coil's reading follows the field at it.
// The measured curve is about 1 KB of knots held inline so that the sensing parameters
// stay `Copy` (the firmware's and the simulator's parameters are); it is read by
// reference every step and copied only when parameters are built.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CoilLaw {
    /// Reading proportional to the field component along the coil's axis (Biot-Savart).
    Physical,
    /// The measured response: the field component is turned into the distance at which a
    /// straight wire would give it (physical law, the coil's height), and the curve gives
    /// the reading at that distance. On a straight wire with the axis across it this is the
    /// curve itself; turned, or over a bend, the field's geometry still counts.
    Measured(ResponseCurve),
}

/// One coil pair's sensing law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoilParams {
    /// Height above the floor (the wire), m.
    pub height_m: f64,
    /// Reading over a straight wire with the axis across it, counts (physical law).
    pub full_scale_adc: f64,
    /// How the reading follows the field.
    pub law: CoilLaw,
}

impl CoilParams {
    /// Analogue reading (before noise and quantisation), counts, from the scaled field
    /// (`Wire::horizontal_field`) and the coil axis (world-frame unit vector).
    pub fn reading(&self, field: [f64; 2], axis: [f64; 2]) -> f64 {
        let along_axis = (field[0] * axis[0] + field[1] * axis[1]).abs();
        match &self.law {
            CoilLaw::Physical => self.full_scale_adc * along_axis,
            CoilLaw::Measured(curve) => {
                if along_axis >= 1.0 {
                    curve.peak_adc()
                } else if along_axis > 0.0 {
                    // h^2 / (h^2 + y^2) = p  =>  y = h sqrt(1/p - 1).
                    curve.reading(self.height_m * (1.0 / along_axis - 1.0).sqrt())
                } else {
                    curve.reading(f64::INFINITY)
                }
            }
        }
    }

    /// Reading of a coil `lateral_m` off an infinite straight wire, axis across it.
    pub fn straight_wire_reading(&self, lateral_m: f64) -> f64 {
        match &self.law {
            CoilLaw::Physical => {
                let h2 = self.height_m * self.height_m;
                self.full_scale_adc * h2 / (h2 + lateral_m * lateral_m)
            }
            CoilLaw::Measured(curve) => curve.reading(lateral_m),
        }
    }

    /// Slope of the difference (left minus right) near the wire, counts per metre of the
    /// pair's lateral offset (left positive): the "ideal position feedback" gain of the
    /// thesis's linear model.
    pub fn difference_slope_counts_per_m(&self, half_spacing_m: f64) -> f64 {
        let (h, a) = (self.height_m, half_spacing_m);
        match &self.law {
            CoilLaw::Physical => -4.0 * self.full_scale_adc * h * h * a / (h * h + a * a).powi(2),
            // d/dy [g(y + a) - g(y - a)] at y = 0, g even: 2 g'(a).
            CoilLaw::Measured(curve) => 2.0 * curve.slope(a),
        }
    }
}

/// The 8-bit ADC: rounds and clips to 0..255.
pub fn adc_counts(analogue: f64) -> f64 {
    analogue.round().clamp(0.0, 255.0)
}

/// Clips without rounding (the thesis's level 2 has infinite resolution).
pub fn adc_unquantised(analogue: f64) -> f64 {
    analogue.clamp(0.0, 255.0)
}

/// Fits coil half spacing and height to the thesis's calibration table (the only free
/// parameters), by grid refinement on the RMS error. Returns (half_spacing_m, height_m,
/// rms_counts). `x_mm` is the table's position column, `s_near`/`s_far` the coil over
/// which the wire passes at larger x and the other.
pub fn fit_calibration_table(
    x_mm: &[f64],
    s_near: &[f64],
    s_far: &[f64],
    full_scale: f64,
) -> (f64, f64, f64) {
    let rms = |a: f64, h: f64| {
        let c = CoilParams {
            height_m: h,
            full_scale_adc: full_scale,
            law: CoilLaw::Physical,
        };
        let mut e2 = 0.0;
        for i in 0..x_mm.len() {
            let x = x_mm[i] / 1000.0;
            // The table's x = 0 is midway between the coils.
            let near = adc_counts(c.straight_wire_reading(x - a));
            let far = adc_counts(c.straight_wire_reading(x + a));
            e2 += (near - s_near[i]).powi(2) + (far - s_far[i]).powi(2);
        }
        (e2 / (2 * x_mm.len()) as f64).sqrt()
    };
    let (mut best_a, mut best_h, mut best) = (0.03, 0.03, f64::INFINITY);
    let (mut lo_a, mut hi_a, mut lo_h, mut hi_h) = (0.005, 0.15, 0.005, 0.15);
    for _ in 0..6 {
        let n = 40;
        for i in 0..=n {
            for j in 0..=n {
                let a = lo_a + (hi_a - lo_a) * i as f64 / n as f64;
                let h = lo_h + (hi_h - lo_h) * j as f64 / n as f64;
                let e = rms(a, h);
                if e < best {
                    (best_a, best_h, best) = (a, h, e);
                }
            }
        }
        let (da, dh) = ((hi_a - lo_a) / 10.0, (hi_h - lo_h) / 10.0);
        (lo_a, hi_a, lo_h, hi_h) = (
            (best_a - da).max(1e-4),
            best_a + da,
            (best_h - dh).max(1e-4),
            best_h + dh,
        );
    }
    (best_a, best_h, best)
}
