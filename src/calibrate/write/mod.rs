//! What a calibration writes: the calibrated scene's text ([`scene_text`]), the console's
//! report ([`text`]), the JSON ([`json`]) and the figures ([`figures`]).

mod figures;
mod json;
mod scene_text;
mod text;

pub use figures::{figures, write_plots};
pub use json::json;
pub use scene_text::calibrated_text;
pub use text::render;
pub(crate) use text::{key_cells, verdict};

/// Mean replay fit over the calibration's outputs, %.
pub fn mean_fit(r: &crate::replay::Replay, outputs: &[String]) -> f64 {
    let fits: Vec<f64> = outputs
        .iter()
        .filter_map(|n| r.output(n))
        .map(|o| o.fit_pct)
        .filter(|f| f.is_finite())
        .collect();
    fits.iter().sum::<f64>() / fits.len().max(1) as f64
}
