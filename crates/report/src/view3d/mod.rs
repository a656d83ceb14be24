//! The report's interactive 3-D view of the closed valve: leaflets coloured
//! by contact, the aortic root translucent, turned and zoomed in the
//! browser by a small WebGL 1 script of our own. Everything is inline, so
//! the page stays one file that needs no network; the static figures stay
//! for print, and the view is not printed.
//!
//! - `scene.rs`: what is shown (valve frame, wall cropped to the root);
//! - `pack.rs`: the quantised, base64 payload;
//! - `viewer.js`: the viewer, allowed to run by its SHA-256 in the page's
//!   Content Security Policy (and nothing else is).

pub mod pack;
pub mod scene;

use std::fmt::Write as _;

pub use scene::{Scene, build};

use base64::{Engine as _, engine::general_purpose::STANDARD as BASE64};

use crate::figures::palette::{PAIR, TRIPLE, leaflet_tint};
use crate::raster::Rgb8;
use coapt_io::sha256;

/// The viewer, verbatim in the page.
pub const SCRIPT: &str = include_str!("viewer.js");

/// Styles of the view's markup (added to the page's style sheet).
pub const CSS: &str = r#"
.view3d-stage { position: relative; border: 1px solid var(--line); }
.view3d-stage canvas { display: block; width: 100%; height: 540px; touch-action: none; cursor: grab; }
.view3d-stage canvas:active { cursor: grabbing; }
.view3d-msg { position: absolute; inset: 0; margin: 0; display: flex; align-items: center; justify-content: center; padding: 2em; text-align: center; color: #4a4f57; background: #f7f8fa; }
.view3d-msg[hidden] { display: none; }
.view3d-stage button { position: absolute; top: 8px; right: 8px; font: inherit; font-size: 0.9em; padding: 2px 10px; }
ul.view3d-legend { list-style: none; padding: 0; margin: 0.4em 0; display: flex; flex-wrap: wrap; gap: 0.3em 1.2em; font-size: 0.92em; }
.view3d-legend .sw { display: inline-block; width: 1.4em; height: 0.9em; margin-right: 0.4em; vertical-align: -0.1em; border: 1px solid #888; }
@media print { .view3d { display: none; } }
"#;

/// The CSP source that lets the viewer, and only it, run.
pub fn script_source() -> String {
    format!(
        "'sha256-{}'",
        BASE64.encode(sha256::digest(SCRIPT.as_bytes()))
    )
}

fn swatch(h: &mut String, c: Rgb8, alpha: Option<f64>, label: &str) {
    let style = match alpha {
        Some(a) => format!("background:rgba({},{},{},{a})", c[0], c[1], c[2]),
        None => format!("background:rgb({},{},{})", c[0], c[1], c[2]),
    };
    let _ = writeln!(
        h,
        "<li><span class=\"sw\" style=\"{style}\"></span>{label}</li>"
    );
}

/// The view as one `<figure>`: canvas, reset button, legend, caption, the
/// payload and the script. `s` comes from [`build`].
pub fn markup(s: &Scene) -> String {
    let mut h = String::new();
    h.push_str("<figure id=\"view3d\" class=\"view3d\">\n<div class=\"view3d-stage\">\n");
    h.push_str(
        "<canvas id=\"view3d-canvas\" width=\"900\" height=\"540\" \
         aria-label=\"Interactive 3-D view of the closed valve: drag to rotate, wheel to zoom\"></canvas>\n",
    );
    h.push_str(
        "<p id=\"view3d-msg\" class=\"view3d-msg\">The interactive view needs JavaScript and WebGL; \
         the static figures below show the same valve.</p>\n",
    );
    h.push_str(
        "<button type=\"button\" id=\"view3d-reset\" disabled>Reset view</button>\n</div>\n",
    );
    h.push_str("<ul class=\"view3d-legend\">\n");
    for j in 0..s.leaflet_count {
        swatch(
            &mut h,
            leaflet_tint(j),
            None,
            &format!("leaflet {}: no contact", j + 1),
        );
    }
    swatch(&mut h, PAIR, None, "touches 1 other leaflet");
    swatch(&mut h, TRIPLE, None, "touches 2 others (central)");
    if s.wall.is_some() {
        swatch(&mut h, pack::WALL, Some(0.35), "aortic wall (translucent)");
    }
    h.push_str("</ul>\n");
    let wall = match &s.wall {
        Some((_, c)) => format!(
            " The wall is that of aorta.vtp from {:.1} to {:.1} mm along the axis \
             ({} mm beyond the leaflets and commissures) and within {:.1} mm of it.",
            c.height_min,
            c.height_max,
            scene::WALL_MARGIN_MM,
            c.radius_max
        ),
        None => " No wall surface (aorta.vtp) was given, so only the leaflets are shown.".into(),
    };
    let _ = writeln!(
        h,
        "<figcaption><strong>Interactive view of the closed valve.</strong> Drag to rotate about the valve axis \
         (up) and tilt, use the wheel to zoom; Reset view returns to the start: axis up, viewer opposite C1 \
         and 30° above the side view. Colours as in the static views. Valve frame, mm, positions rounded to \
         {:.0} µm or finer.{wall} Not printed: the figures below are.</figcaption>",
        pack::quantum_mm(max_exp(s)) * 1000.0,
    );
    let _ = writeln!(
        h,
        "<script type=\"application/json\" id=\"view3d-data\">{}</script>",
        pack::payload(s)
    );
    let _ = writeln!(h, "<script>{SCRIPT}</script>\n</figure>");
    h
}

/// The coarsest quantum exponent of the scene's parts.
fn max_exp(s: &Scene) -> u32 {
    let l = pack::quantise(&s.leaflets.positions).exp;
    s.wall
        .as_ref()
        .map_or(l, |(w, _)| l.max(pack::quantise(&w.positions).exp))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::figures::test_valve::synthetic_valve;

    #[test]
    fn markup_holds_payload_script_and_legend() {
        let (v, contact) = synthetic_valve(6);
        let s = build(&v, &contact, None).unwrap();
        let m = markup(&s);
        assert!(m.starts_with("<figure id=\"view3d\""));
        assert!(m.ends_with("</figure>\n"));
        assert_eq!(m.matches("<script").count(), 2);
        // The script element ends only where it should.
        assert_eq!(m.matches("</script>").count(), 2);
        assert!(!SCRIPT.contains("</script"));
        assert!(!SCRIPT.contains("http"), "no URL in the viewer");
        assert!(m.contains(&pack::payload(&s)));
        assert_eq!(m.matches("class=\"sw\"").count(), 3 + 2);
        assert!(m.contains("only the leaflets are shown"));
        assert!(m.contains("10 µm or finer"));
        assert_eq!(markup(&s), m);
    }

    #[test]
    fn script_source_is_the_hash_of_the_script() {
        let src = script_source();
        assert!(src.starts_with("'sha256-") && src.ends_with('\''));
        let b = BASE64.decode(&src[8..src.len() - 1]).unwrap();
        assert_eq!(b, sha256::digest(SCRIPT.as_bytes()));
    }
}
