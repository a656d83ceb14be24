//! The one typeface of every figure, embedded so that text renders the same
//! on every machine: DejaVu Sans (Bitstream Vera licence, see
//! `assets/fonts/LICENSE`).

use std::sync::Once;

use ab_glyph::FontRef;

static DEJAVU_SANS: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

/// Family name under which plotters finds the embedded font.
pub const FAMILY: &str = "sans-serif";

/// The embedded font; `None` only if the embedded file were corrupt, which
/// the tests rule out.
pub fn font() -> Option<FontRef<'static>> {
    FontRef::try_from_slice(DEJAVU_SANS).ok()
}

/// Make the embedded font plotters' "sans-serif" (all styles fall back to
/// it). Plotters keeps a global table, so registering once is enough.
pub fn register_with_plotters() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // A failure leaves the table empty: charts then come back as text
        // errors from plotters, which `xy_chart` turns into a notice figure.
        let _ =
            plotters::style::register_font(FAMILY, plotters::style::FontStyle::Normal, DEJAVU_SANS);
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use ab_glyph::Font;

    #[test]
    fn embedded_font_parses_and_has_the_glyphs_figures_use() {
        let f = font().expect("embedded DejaVu Sans parses");
        for c in "0123456789 mm² N C1 N3 µ × – ≥ ·".chars() {
            assert_ne!(f.glyph_id(c).0, 0, "missing glyph for {c:?}");
        }
    }
}
