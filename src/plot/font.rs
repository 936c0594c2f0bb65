//! The one font of every plot, bundled so that rendering needs no system font library
//! (plotters' `ab_glyph` backend draws only registered fonts).

use std::sync::Once;

/// DejaVu Sans (Bitstream Vera licence, `assets/fonts/LICENSE-DejaVu.txt`): covers µ, −, ², ω.
static DEJAVU_SANS: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// The family name the plots ask for.
pub const FAMILY: &str = "sans-serif";

/// Registers the font once per process.
pub fn register() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TrueType file checked in with the source; a failure here is a
        // broken checkout, and text would then be missing from plots, never wrong numbers.
        let _ =
            plotters::style::register_font(FAMILY, plotters::style::FontStyle::Normal, DEJAVU_SANS);
    });
}
