//! The figure shown instead of a picture when there is nothing sound to draw
//! (no mesh, no finite positions, no solver history): the page keeps its
//! slot and says why.

use super::palette::{BACKGROUND, INK};
use super::text::{HAlign, TextStyle, VAlign, draw_text, text_width};
use super::to_figure;
use crate::Figure;
use crate::raster::Canvas;

const WIDTH: u32 = 640;
const SIZE: f64 = 16.0;

/// Split `message` into lines no wider than `max_px` (a word longer than
/// that gets a line of its own).
fn wrap(message: &str, max_px: f64) -> Vec<String> {
    let mut lines = Vec::new();
    let mut cur = String::new();
    for word in message.split_whitespace() {
        let trial = if cur.is_empty() {
            word.to_string()
        } else {
            format!("{cur} {word}")
        };
        if !cur.is_empty() && text_width(SIZE, &trial) > max_px {
            lines.push(std::mem::replace(&mut cur, word.to_string()));
        } else {
            cur = trial;
        }
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    lines
}

/// A figure holding `message` as text, with the caption saying the same.
pub fn notice(id: &str, title: &str, message: &str) -> Figure {
    let lines = wrap(message, WIDTH as f64 - 40.0);
    let height = (40.0 + 1.5 * SIZE * lines.len().max(1) as f64).ceil() as u32;
    let mut c = Canvas::new(WIDTH, height, 2, BACKGROUND);
    c.rect_outline(0.0, 0.0, WIDTH as f64, height as f64, 1.0, [180; 3]);
    let style = TextStyle::new(SIZE, INK).align(HAlign::Left, VAlign::Top);
    for (k, l) in lines.iter().enumerate() {
        draw_text(&mut c, 20.0, 20.0 + 1.5 * SIZE * k as f64, l, &style);
    }
    to_figure(id, title, &format!("Not drawn: {message}"), &c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_messages_wrap_and_the_figure_is_a_png() {
        let msg = "the closed valve has no triangle with finite positions, so there is no surface to show from the aorta or from the side";
        let lines = wrap(msg, 300.0);
        assert!(lines.len() >= 3);
        assert!(lines.iter().all(|l| text_width(SIZE, l) <= 300.0));
        assert_eq!(lines.join(" "), msg);
        let f = notice("valve_top", "Valve", msg);
        assert_eq!(&f.png[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(f.width, WIDTH);
        assert!(f.caption.contains("no triangle"));
    }
}
