//! The grey-box model structures agvsim identifies.

pub mod coast_down;
pub mod dcmc_pair;
pub mod falling_weight;
pub mod linear_axis;
pub mod rotary_axis;
pub mod vehicle;
