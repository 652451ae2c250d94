//! The bundled font, a drawing primitive below every figure: the plots, the profile's heat map
//! and the convergence plot register it, and none of them needs the rest of [`super`].

use std::sync::Once;

static FONT: Once = Once::new();

/// Register the bundled font as "sans-serif" (once per process).
pub fn register_font() {
    FONT.call_once(|| {
        let bytes: &'static [u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
        plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, bytes)
            .unwrap_or_else(|_| panic!("the bundled DejaVuSans.ttf is a valid font"));
    });
}
