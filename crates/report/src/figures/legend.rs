//! A legend: coloured squares (or line samples) with their meaning, on a
//! white panel.

use super::palette::INK;
use super::text::{HAlign, TextStyle, VAlign, draw_text, text_width};
use crate::raster::{Canvas, Rgb8};

#[derive(Debug, Clone, PartialEq)]
pub enum Swatch {
    Square(Rgb8),
    Line(Rgb8),
    ThinLine(Rgb8),
    Dashed(Rgb8),
    Dot(Rgb8),
    Ring(Rgb8),
}

#[derive(Debug, Clone, PartialEq)]
pub struct LegendItem {
    pub swatch: Swatch,
    pub label: String,
}

impl LegendItem {
    pub fn new(swatch: Swatch, label: impl Into<String>) -> Self {
        Self {
            swatch,
            label: label.into(),
        }
    }
}

const PAD: f64 = 8.0;

/// Width and height of the legend panel.
pub fn legend_size(items: &[LegendItem], size: f64) -> (f64, f64) {
    let row = 1.6 * size;
    let label = items
        .iter()
        .map(|i| text_width(size, &i.label))
        .fold(0.0, f64::max);
    (
        2.0 * PAD + 1.8 * size + label,
        2.0 * PAD + row * items.len() as f64,
    )
}

/// Draw the legend with its top-left corner at (x, y); returns its size.
pub fn draw_legend(
    canvas: &mut Canvas,
    x: f64,
    y: f64,
    items: &[LegendItem],
    size: f64,
) -> (f64, f64) {
    let (w, h) = legend_size(items, size);
    if items.is_empty() {
        return (0.0, 0.0);
    }
    canvas.rect(x, y, x + w, y + h, [255; 3]);
    canvas.rect_outline(x, y, x + w, y + h, 1.0, [170; 3]);
    let row = 1.6 * size;
    let style = TextStyle::new(size, INK).align(HAlign::Left, VAlign::Middle);
    for (k, item) in items.iter().enumerate() {
        let cy = y + PAD + row * (k as f64 + 0.5);
        let (sx0, sx1) = (x + PAD, x + PAD + 1.1 * size);
        draw_swatch(canvas, &item.swatch, sx0, sx1, cy, size);
        draw_text(canvas, x + PAD + 1.8 * size, cy, &item.label, &style);
    }
    (w, h)
}

/// Draw the items in one row starting at (x, y) (top-left); returns the
/// row's size. For figures whose width is taken by panels.
pub fn draw_legend_row(
    canvas: &mut Canvas,
    x: f64,
    y: f64,
    items: &[LegendItem],
    size: f64,
) -> (f64, f64) {
    let mut cx = x;
    let mut h: f64 = 0.0;
    for item in items {
        let (w, ih) = draw_legend_item(canvas, cx, y, item, size);
        cx += w + size;
        h = h.max(ih);
    }
    (cx - x, h)
}

/// One borderless item; returns its size.
fn draw_legend_item(
    canvas: &mut Canvas,
    x: f64,
    y: f64,
    item: &LegendItem,
    size: f64,
) -> (f64, f64) {
    let cy = y + 0.8 * size;
    let (sx0, sx1) = (x, x + 1.4 * size);
    draw_swatch(canvas, &item.swatch, sx0, sx1, cy, size);
    let style = TextStyle::new(size, INK).align(HAlign::Left, VAlign::Middle);
    draw_text(canvas, sx1 + 0.5 * size, cy, &item.label, &style);
    (1.9 * size + text_width(size, &item.label), 1.6 * size)
}

fn draw_swatch(canvas: &mut Canvas, swatch: &Swatch, sx0: f64, sx1: f64, cy: f64, size: f64) {
    match *swatch {
        Swatch::Square(c) => {
            let half = 0.55 * size;
            canvas.rect(sx0, cy - half, sx1, cy + half, c);
            canvas.rect_outline(sx0, cy - half, sx1, cy + half, 1.0, [90; 3]);
        }
        Swatch::Line(c) => canvas.line([sx0, cy], [sx1, cy], 2.5, c),
        Swatch::ThinLine(c) => canvas.line([sx0, cy], [sx1, cy], 1.0, c),
        Swatch::Dashed(c) => canvas.dashed_polyline(&[[sx0, cy], [sx1, cy]], 2.0, 4.0, 3.0, c),
        Swatch::Dot(c) => canvas.disc(0.5 * (sx0 + sx1), cy, 0.35 * size, c),
        Swatch::Ring(c) => canvas.ring(0.5 * (sx0 + sx1), cy, 0.3 * size, 1.5, c),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn legend_draws_its_swatches_where_it_says() {
        let items = [
            LegendItem::new(Swatch::Square([0, 0, 255]), "two leaflets"),
            LegendItem::new(Swatch::Square([255, 0, 0]), "three leaflets"),
        ];
        let mut c = Canvas::new(300, 100, 2, [255; 3]);
        let (w, h) = draw_legend(&mut c, 10.0, 10.0, &items, 14.0);
        assert!(w > 100.0 && w < 200.0 && (h - (16.0 + 2.0 * 1.6 * 14.0)).abs() < 1e-9);
        let img = c.finish();
        // Centre of each square: the first row's centre is 8 + 0.8·14 below the top.
        let px = |x: f64, y: f64| img.px[x as usize + 300 * y as usize];
        assert_eq!(px(10.0 + 8.0 + 7.7, 10.0 + 8.0 + 11.2), [0, 0, 255]);
        assert_eq!(px(10.0 + 8.0 + 7.7, 10.0 + 8.0 + 33.6), [255, 0, 0]);
        assert_eq!(draw_legend(&mut c, 0.0, 0.0, &[], 14.0), (0.0, 0.0));
    }
}
