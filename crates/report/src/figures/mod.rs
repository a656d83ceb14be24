//! The report's figures, each a PNG rendered here without a GPU, a window or
//! the network, from the embedded font, so that the same inputs give the
//! same bytes everywhere.
//!
//! - `valve_views.rs`: the closed valve from the aorta and from the side,
//!   coloured by contact; `coaptation_map.rs`: the same classes on the flat
//!   templates; `ct_check.rs`: CT planes with mask contour, landmarks and
//!   suture paths; `convergence.rs`, `xy_chart.rs`: charts, on the frame of `plot_frame.rs`.
//! - Shared pieces: `palette.rs` (contact classes), `text.rs` and `font.rs`,
//!   `legend.rs`, `scale_bar.rs`, `notice.rs` (a figure that says why there
//!   is no picture).

pub mod coaptation_map;
pub mod convergence;
pub mod ct_check;
pub mod ct_plane;
pub mod font;
pub mod label_layout;
pub mod legend;
pub mod mesh_edges;
pub mod notice;
pub mod palette;
pub mod plot_frame;
pub mod scale_bar;
pub mod sizing;
pub mod text;
pub mod valve_views;
pub mod xy_chart;

#[cfg(test)]
mod preview;
#[cfg(test)]
pub(crate) mod test_valve;

pub use coaptation_map::coaptation_maps;
pub use convergence::convergence;
pub use ct_check::ct_check;
pub use valve_views::valve_views;
pub use xy_chart::{Series, XyChart, xy_chart};

use crate::Figure;
use crate::raster::Canvas;
use coapt_io::png;

/// Encode a finished canvas as a figure.
pub(crate) fn to_figure(id: &str, title: &str, caption: &str, canvas: &Canvas) -> Figure {
    let img = canvas.finish();
    Figure {
        id: id.to_string(),
        title: title.to_string(),
        caption: caption.to_string(),
        width: img.w as u32,
        height: img.h as u32,
        png: png::encode(&img),
    }
}
