//! A scale bar: a round length in mm and its span in pixels.

use super::palette::INK;
use super::text::{HAlign, TextStyle, VAlign, draw_text};
use crate::raster::Canvas;

/// The largest 1, 2 or 5 × 10ᵏ mm not above `max_mm` (`None` unless positive and finite).
pub fn nice_length(max_mm: f64) -> Option<f64> {
    if !(max_mm.is_finite() && max_mm > 0.0) {
        return None;
    }
    let p = 10f64.powf(max_mm.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|m| m * p)
        .find(|&l| l <= max_mm * (1.0 + 1e-12))
}

/// Draw a bar no longer than `max_px`, its left end at (x, y) (the bar's
/// baseline), label above. Returns the bar length in mm, if one fits.
pub fn draw_scale_bar(
    canvas: &mut Canvas,
    x: f64,
    y: f64,
    mm_per_px: f64,
    max_px: f64,
) -> Option<f64> {
    if !(mm_per_px.is_finite() && mm_per_px > 0.0) {
        return None;
    }
    let mm = nice_length(max_px * mm_per_px)?;
    let len = mm / mm_per_px;
    canvas.rect(x, y - 3.0, x + len, y, INK);
    canvas.rect(x, y - 8.0, x + 1.5, y, INK);
    canvas.rect(x + len - 1.5, y - 8.0, x + len, y, INK);
    let label = if mm >= 1.0 {
        format!("{mm:.0} mm")
    } else {
        format!("{mm} mm")
    };
    let style = TextStyle::new(13.0, INK).align(HAlign::Centre, VAlign::Baseline);
    draw_text(canvas, x + 0.5 * len, y - 11.0, &label, &style);
    Some(mm)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_lengths_are_round_and_fit() {
        assert_eq!(nice_length(27.0), Some(20.0));
        assert_eq!(nice_length(10.0), Some(10.0));
        assert_eq!(nice_length(9.99), Some(5.0));
        assert_eq!(nice_length(0.7), Some(0.5));
        assert_eq!(nice_length(0.0), None);
        assert_eq!(nice_length(f64::NAN), None);
    }

    #[test]
    fn bar_spans_its_length_in_pixels() {
        let mut c = Canvas::new(200, 40, 1, [255; 3]);
        // 0.25 mm/px and 150 px available: 37.5 mm → a 20 mm bar of 80 px.
        assert_eq!(draw_scale_bar(&mut c, 10.0, 30.0, 0.25, 150.0), Some(20.0));
        let img = c.finish();
        let row = |y: usize| {
            (0..200)
                .filter(|&x| img.px[x + 200 * y] == INK)
                .collect::<Vec<_>>()
        };
        let r = row(28);
        assert_eq!((r[0], *r.last().unwrap()), (10, 89));
        assert_eq!(draw_scale_bar(&mut c, 0.0, 0.0, f64::NAN, 100.0), None);
    }
}
