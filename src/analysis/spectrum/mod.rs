//! Spectra of responses: the exact integer-period DFT, the windowed FFT, order labels and the
//! run-up waterfall (`docs/spectrum.md`).

mod dft;
mod labels;
mod waterfall;
mod window;

pub use dft::{exact_dft, windowed_fft, Spectrum};
pub use labels::{label_lines, OrderLabel, ShaftFrequency};
pub use waterfall::{waterfall, Waterfall, WaterfallOptions};
pub use window::Window;
