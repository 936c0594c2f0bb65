//! Spectra of responses: the exact integer-period DFT, the windowed FFT, order labels and the
//! run-up waterfall (`docs/spectrum.md`).

mod aliasing;
mod dft;
mod fixed_frame;
mod labels;
mod orbit_fourier;
mod order_track;
mod waterfall;
mod window;

pub use aliasing::{
    aliasing_warning, highest_mesh_harmonic, model_aliasing_warning, HARMONIC_THRESHOLD,
};
pub use dft::{exact_dft, windowed_fft, Spectrum};
pub use fixed_frame::fixed_frame_lines;
pub use labels::{label_lines, OrderLabel, ShaftFrequency};
pub use orbit_fourier::orbit_lines;
pub use order_track::{order_cuts, OrderCuts, OrderTrackOptions, ShaftClock};
pub use waterfall::{waterfall, Waterfall, WaterfallOptions, WaterfallPlot};
pub use window::Window;
