//! Text on a canvas, through the embedded font's own outlines (ab_glyph),
//! anti-aliased by glyph coverage on the supersampled grid.

use ab_glyph::{Font, FontRef, ScaleFont, point};

use super::font::font;
use crate::raster::{Canvas, Rgb8};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HAlign {
    Left,
    Centre,
    Right,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VAlign {
    /// `y` is the top of the tallest letters.
    Top,
    /// `y` is halfway up the capitals.
    Middle,
    /// `y` is the baseline.
    Baseline,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TextStyle {
    /// Font size in output pixels (the em height).
    pub size: f64,
    pub colour: Rgb8,
    pub h: HAlign,
    pub v: VAlign,
    /// A one-pixel rim of this colour keeps text legible over images.
    pub halo: Option<Rgb8>,
}

impl TextStyle {
    pub fn new(size: f64, colour: Rgb8) -> Self {
        Self {
            size,
            colour,
            h: HAlign::Left,
            v: VAlign::Baseline,
            halo: None,
        }
    }
    pub fn align(self, h: HAlign, v: VAlign) -> Self {
        Self { h, v, ..self }
    }
    pub fn halo(self, c: Rgb8) -> Self {
        Self {
            halo: Some(c),
            ..self
        }
    }
}

/// Advance width of `s` in output pixels at `size`.
pub fn text_width(size: f64, s: &str) -> f64 {
    let Some(f) = font() else { return 0.0 };
    if !(size.is_finite() && size > 0.0) {
        return 0.0;
    }
    layout(&f, size as f32, s).1 as f64
}

/// Glyph origins along the baseline (in units of the given scale) and the
/// total advance, kerning included.
fn layout(f: &FontRef<'static>, scale: f32, s: &str) -> (Vec<(ab_glyph::GlyphId, f32)>, f32) {
    let sf = f.as_scaled(scale);
    let mut caret = 0.0f32;
    let mut prev = None;
    let mut out = Vec::with_capacity(s.len());
    for c in s.chars() {
        let id = sf.glyph_id(c);
        if let Some(p) = prev {
            caret += sf.kern(p, id);
        }
        out.push((id, caret));
        caret += sf.h_advance(id);
        prev = Some(id);
    }
    (out, caret)
}

/// Draw `s` anchored at (x, y) in output pixels.
pub fn draw_text(canvas: &mut Canvas, x: f64, y: f64, s: &str, style: &TextStyle) {
    let Some(f) = font() else { return };
    if !(style.size.is_finite() && style.size > 0.0 && x.is_finite() && y.is_finite()) {
        return;
    }
    let ss = canvas.samples_per_side() as f64;
    let scale = (style.size * ss) as f32;
    let (glyphs, advance) = layout(&f, scale, s);
    let x0 = x * ss
        - match style.h {
            HAlign::Left => 0.0,
            HAlign::Centre => 0.5 * advance as f64,
            HAlign::Right => advance as f64,
        };
    // DejaVu's capitals are 0.73 em tall; its ascent (0.93 em) includes accents.
    let cap = 0.73 * scale as f64;
    let baseline = y * ss
        + match style.v {
            VAlign::Top => cap,
            VAlign::Middle => 0.5 * cap,
            VAlign::Baseline => 0.0,
        };
    let mut passes: Vec<(f64, f64, Rgb8)> = Vec::new();
    if let Some(h) = style.halo {
        for (dx, dy) in [
            (-1.0, 0.0),
            (1.0, 0.0),
            (0.0, -1.0),
            (0.0, 1.0),
            (-1.0, -1.0),
            (1.0, 1.0),
            (-1.0, 1.0),
            (1.0, -1.0),
        ] {
            passes.push((dx * ss, dy * ss, h));
        }
    }
    passes.push((0.0, 0.0, style.colour));
    for (dx, dy, colour) in passes {
        for &(id, caret) in &glyphs {
            let g = id.with_scale_and_position(
                scale,
                point((x0 + dx) as f32 + caret, (baseline + dy) as f32),
            );
            if let Some(o) = f.outline_glyph(g) {
                let b = o.px_bounds();
                let (bx, by) = (b.min.x as i64, b.min.y as i64);
                o.draw(|gx, gy, cov| {
                    canvas.blend_sample(bx + gx as i64, by + gy as i64, colour, cov)
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_marks_pixels_inside_its_box_only() {
        let mut c = Canvas::new(120, 40, 2, [255; 3]);
        let style = TextStyle::new(16.0, [0; 3]).align(HAlign::Left, VAlign::Top);
        draw_text(&mut c, 10.0, 10.0, "C1 12 mm", &style);
        let img = c.finish();
        let w = text_width(16.0, "C1 12 mm");
        assert!(w > 50.0 && w < 90.0, "{w}");
        let mut dark = 0;
        for y in 0..40 {
            for x in 0..120 {
                if img.px[x + 120 * y][0] < 128 {
                    dark += 1;
                    // Capitals span 0.73 em below the top; descenders none here.
                    assert!((10..=(10 + w.ceil() as usize + 1)).contains(&x), "x {x}");
                    assert!((9..=23).contains(&y), "y {y}");
                }
            }
        }
        assert!(dark > 60, "{dark}");
    }

    #[test]
    fn alignment_moves_text_by_its_width() {
        let draw = |h| {
            let mut c = Canvas::new(100, 20, 1, [255; 3]);
            draw_text(
                &mut c,
                50.0,
                10.0,
                "mm",
                &TextStyle::new(12.0, [0; 3]).align(h, VAlign::Middle),
            );
            let img = c.finish();
            (0..100)
                .find(|&x| (0..20).any(|y| img.px[x + 100 * y][0] < 200))
                .unwrap_or(999)
        };
        let w = text_width(12.0, "mm");
        let (l, c, r) = (
            draw(HAlign::Left),
            draw(HAlign::Centre),
            draw(HAlign::Right),
        );
        assert!((50..=52).contains(&l), "{l}");
        assert!(((l as f64 - c as f64) - w / 2.0).abs() <= 1.5);
        assert!(((l as f64 - r as f64) - w).abs() <= 1.5);
    }

    #[test]
    fn bad_sizes_draw_nothing() {
        let mut c = Canvas::new(10, 10, 1, [255; 3]);
        draw_text(&mut c, 0.0, 5.0, "x", &TextStyle::new(f64::NAN, [0; 3]));
        draw_text(
            &mut c,
            f64::INFINITY,
            5.0,
            "x",
            &TextStyle::new(10.0, [0; 3]),
        );
        assert!(c.finish().px.iter().all(|p| *p == [255; 3]));
        assert_eq!(text_width(-1.0, "abc"), 0.0);
    }
}
