//! What the vehicle senses: the guide wire through two pick-up coils and an 8-bit ADC,
//! and the bumper.

pub mod bumper;
pub mod coil;
mod response;
pub mod wire;

/// The thesis's calibration table (`AGVPOS.C`): position index and the two readings.
pub mod calibration_table {
    /// Position index of the table's rows, mm from the centred pair.
    pub const LU_X: [f64; 21] = [
        0., 6., 13., 19., 25., 32., 38., 45., 51., 58., 64., 70., 77., 83., 90., 96., 102., 109.,
        115., 121., 127.,
    ];
    /// The right coil's (S2's) readings, counts.
    pub const LU_S2: [f64; 21] = [
        80., 121., 151., 186., 214., 237., 240., 226., 210., 164., 132., 109., 85., 67., 51., 41.,
        32., 25., 19., 14., 10.,
    ];
    /// The left coil's (S1's) readings, counts.
    pub const LU_S1: [f64; 21] = [
        80., 70., 55., 40., 30., 21., 14., 11., 7., 5., 3., 2., 1., 1., 1., 0., 0., 0., 0., 0., 0.,
    ];
}
