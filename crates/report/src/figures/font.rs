//! The one typeface of every figure, embedded so that text renders the same
//! on every machine: DejaVu Sans (Bitstream Vera licence, see
//! `assets/fonts/LICENSE`).

use ab_glyph::FontRef;

static DEJAVU_SANS: &[u8] = include_bytes!("../../../../assets/fonts/DejaVuSans.ttf");

/// The embedded font; `None` only if the embedded file were corrupt, which
/// the tests rule out.
pub fn font() -> Option<FontRef<'static>> {
    FontRef::try_from_slice(DEJAVU_SANS).ok()
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
