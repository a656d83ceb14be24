//! Where each leaflet touches its neighbours, drawn on the flat template it
//! was cut from (as seed 001, Figs. 21–24): the surgeon reads the zone in
//! the same millimetres as the pericardium template.

use super::legend::{LegendItem, Swatch, draw_legend, legend_size};
use super::mesh_edges::{EdgeKind, boundary_edges, edge_kind};
use super::notice::notice;
use super::palette::{
    BACKGROUND, ContactClass, FREE_EDGE, INK, PAIR, SUTURE, TRIPLE, class_colour, dominant,
    leaflet_tint, node_classes, node_leaflets, one_hot,
};
use super::scale_bar::nice_length;
use super::text::{HAlign, TextStyle, VAlign, draw_text};
use super::to_figure;
use crate::raster::{Camera, Canvas, MeshLayer, Shading};
use crate::{ClosedValve, Figure};
use coapt_geom::{Point3, Vector3};

const WIDTH: u32 = 980;
/// Panels live in [LEFT, RIGHT] × [TOP, at most BOTTOM]; the legend right
/// of them; the image ends below whichever is lower.
const LEFT: f64 = 56.0;
const RIGHT: f64 = 760.0;
const TOP: f64 = 44.0;
const BOTTOM: f64 = 420.0;
/// Gap between leaflet panels, in mm of template.
const GAP_MM: f64 = 6.0;
const ID: &str = "coaptation_map";
const TITLE: &str = "Coaptation zones on the leaflet templates";

/// One leaflet's nodes on its template.
struct Panel {
    leaflet: usize,
    tris: Vec<[u32; 3]>,
    lo: [f64; 2],
    hi: [f64; 2],
    /// Draw v downwards when the free edge has the smaller v, so that the
    /// free edge is always at the top, as a template lies on the table.
    flip: bool,
}

/// `None` when the mesh has no template coordinates; a notice figure when
/// it has them but no drawable triangle.
pub fn coaptation_maps(v: &ClosedValve, contact: &[u8]) -> Option<Figure> {
    let uv = v.ref_uv.as_ref()?;
    let finite = |i: u32| {
        uv.get(i as usize)
            .is_some_and(|p| p[0].is_finite() && p[1].is_finite())
    };
    let n = v.x.len().max(uv.len());
    let leaflets = v
        .tri_leaflet
        .iter()
        .map(|&l| l as usize + 1)
        .max()
        .unwrap_or(0);
    let mut panels: Vec<Panel> = (0..leaflets)
        .map(|j| Panel {
            leaflet: j,
            tris: Vec::new(),
            lo: [f64::INFINITY; 2],
            hi: [f64::NEG_INFINITY; 2],
            flip: false,
        })
        .collect();
    for (t, tri) in v.tris.iter().enumerate() {
        let Some(&l) = v.tri_leaflet.get(t) else {
            continue;
        };
        if tri.iter().all(|&i| finite(i)) {
            let p = &mut panels[l as usize];
            p.tris.push(*tri);
            for &i in tri {
                let q = uv[i as usize];
                for (k, &qk) in q.iter().enumerate() {
                    p.lo[k] = p.lo[k].min(qk);
                    p.hi[k] = p.hi[k].max(qk);
                }
            }
        }
    }
    panels.retain(|p| !p.tris.is_empty());
    if panels.is_empty() {
        return Some(notice(
            ID,
            TITLE,
            "no leaflet triangle has finite template coordinates, so the coaptation zones cannot be drawn flat",
        ));
    }
    for p in &mut panels {
        p.flip = free_edge_below(p, uv, &v.boundary);
    }
    // Common scale: the panels side by side, gaps included, fill the area.
    let total_w: f64 =
        panels.iter().map(|p| p.hi[0] - p.lo[0]).sum::<f64>() + GAP_MM * (panels.len() - 1) as f64;
    let max_h = panels.iter().map(|p| p.hi[1] - p.lo[1]).fold(0.0, f64::max);
    let mm_per_px = (total_w / (RIGHT - LEFT))
        .max(max_h / (BOTTOM - TOP))
        .max(1e-6);
    // Lay the panels out in one flat "world" (x right, y up) in mm.
    let mut pos = vec![Point3::new(f64::NAN, f64::NAN, 0.0); n];
    let mut x_off = 0.0;
    let mut offsets = Vec::new();
    for p in &panels {
        offsets.push(x_off);
        for tri in &p.tris {
            for &i in tri {
                let q = uv[i as usize];
                let y = if p.flip {
                    p.hi[1] - q[1]
                } else {
                    q[1] - p.lo[1]
                };
                pos[i as usize] = Point3::new(x_off + q[0] - p.lo[0], y, 0.0);
            }
        }
        x_off += p.hi[0] - p.lo[0] + GAP_MM;
    }
    // World (0, 0), the bottom-left of the first panel, goes where the
    // panels end up centred in their area.
    let x_start = LEFT + 0.5 * ((RIGHT - LEFT) - total_w / mm_per_px);
    let y_bottom = TOP + max_h / mm_per_px;
    let legend_h = legend_size(&legend_items(&panels), LEGEND_SIZE).1;
    let notes_top = (TOP + legend_h + 16.0).max(y_bottom - 28.0);
    let height = ((y_bottom + 44.0).max(notes_top + 44.0)).ceil() as u32;
    let centre = Point3::new(
        (0.5 * WIDTH as f64 - x_start) * mm_per_px,
        (y_bottom - 0.5 * height as f64) * mm_per_px,
        0.0,
    );
    let cam = Camera::new(
        -Vector3::z(),
        Vector3::y(),
        centre,
        mm_per_px,
        WIDTH,
        height,
    )?;
    let mut c = Canvas::new(WIDTH, height, 2, BACKGROUND);
    let step = grid_step(mm_per_px);
    for (p, &off) in panels.iter().zip(&offsets) {
        draw_grid(&mut c, &cam, p, off, step, p.leaflet == panels[0].leaflet);
    }
    let leaflet = node_leaflets(v.x.len().max(uv.len()), &v.tris, &v.tri_leaflet);
    let classes = node_classes(contact, &leaflet);
    for p in &panels {
        let corner = |t: usize, k: usize| {
            one_hot(
                classes
                    .get(p.tris[t][k] as usize)
                    .copied()
                    .unwrap_or(ContactClass::Free),
            )
        };
        let paint = |_: usize, w: [f32; 3]| class_colour(dominant(w), p.leaflet);
        c.draw_mesh(
            &cam,
            &MeshLayer {
                positions: &pos,
                triangles: &p.tris,
                corner: &corner,
                paint: &paint,
                shading: Shading::None,
            },
        );
    }
    for p in &panels {
        for e in boundary_edges(&p.tris, pos.len()) {
            let (a, b) = (
                cam.project(&pos[e[0] as usize]),
                cam.project(&pos[e[1] as usize]),
            );
            let (colour, width) = match edge_kind(e, &v.boundary) {
                EdgeKind::Free => (FREE_EDGE, 2.4),
                EdgeKind::Sutured => (SUTURE, 2.4),
                EdgeKind::Other => ([120; 3], 1.2),
            };
            c.line([a[0], a[1]], [b[0], b[1]], width, colour);
        }
    }
    let head = TextStyle::new(15.0, INK).align(HAlign::Centre, VAlign::Baseline);
    for (p, &off) in panels.iter().zip(&offsets) {
        let mid = cam.project(&Point3::new(
            off + 0.5 * (p.hi[0] - p.lo[0]),
            p.hi[1] - p.lo[1],
            0.0,
        ));
        draw_text(
            &mut c,
            mid[0],
            TOP - 18.0,
            &format!("Leaflet {}", p.leaflet + 1),
            &head,
        );
    }
    draw_legend(
        &mut c,
        RIGHT + 16.0,
        TOP,
        &legend_items(&panels),
        LEGEND_SIZE,
    );
    let note = TextStyle::new(12.0, [90; 3]).align(HAlign::Left, VAlign::Top);
    draw_text(
        &mut c,
        RIGHT + 16.0,
        notes_top,
        &format!("grid: {step} mm"),
        &note,
    );
    draw_text(
        &mut c,
        RIGHT + 16.0,
        notes_top + 18.0,
        "free edge at the top",
        &note,
    );
    let caption = format!(
        "Each leaflet on its flat template (mm, free edge at the top, grid every {step} mm), coloured where \
         the closed leaflet touches others: pale tint, no contact; blue, touching one other leaflet \
         (coaptation zone); red, touching both others (central coaptation). Dark line: free edge; \
         brown: sutured edge."
    );
    Some(to_figure(ID, TITLE, &caption, &c))
}

const LEGEND_SIZE: f64 = 12.5;

fn legend_items(panels: &[Panel]) -> Vec<LegendItem> {
    let mut items: Vec<LegendItem> = panels
        .iter()
        .map(|p| {
            LegendItem::new(
                Swatch::Square(leaflet_tint(p.leaflet)),
                format!("leaflet {}: no contact", p.leaflet + 1),
            )
        })
        .collect();
    items.push(LegendItem::new(
        Swatch::Square(PAIR),
        "touches 1 other leaflet",
    ));
    items.push(LegendItem::new(
        Swatch::Square(TRIPLE),
        "touches 2 others (central)",
    ));
    items.push(LegendItem::new(Swatch::Line(FREE_EDGE), "free edge"));
    items.push(LegendItem::new(Swatch::Line(SUTURE), "sutured edge"));
    items
}

/// True when the free-edge nodes lie at smaller v than the sutured ones.
fn free_edge_below(p: &Panel, uv: &[[f64; 2]], boundary: &[u8]) -> bool {
    let mut sum = [0.0f64; 2];
    let mut cnt = [0usize; 2];
    let mut seen = std::collections::BTreeSet::new();
    for tri in &p.tris {
        for &i in tri {
            if !seen.insert(i) {
                continue;
            }
            match boundary.get(i as usize) {
                Some(1) => {
                    sum[0] += uv[i as usize][1];
                    cnt[0] += 1;
                }
                Some(2) => {
                    sum[1] += uv[i as usize][1];
                    cnt[1] += 1;
                }
                _ => {}
            }
        }
    }
    cnt[0] > 0 && cnt[1] > 0 && sum[1] / (cnt[1] as f64) < sum[0] / (cnt[0] as f64)
}

/// Grid spacing: a round number of mm about 50 px apart.
fn grid_step(mm_per_px: f64) -> f64 {
    nice_length(50.0 * mm_per_px).unwrap_or(5.0).max(1.0)
}

/// Light mm grid over the panel's template box, with tick labels in the
/// template's own coordinates (u below; v left of the first panel only).
fn draw_grid(c: &mut Canvas, cam: &Camera, p: &Panel, off: f64, step: f64, first: bool) {
    let (w, h) = (p.hi[0] - p.lo[0], p.hi[1] - p.lo[1]);
    let at = |x: f64, y: f64| cam.project(&Point3::new(off + x, y, 0.0));
    let (bl, tr) = (at(0.0, 0.0), at(w, h));
    let grid = [228; 3];
    let tick = TextStyle::new(11.0, [110; 3]).align(HAlign::Centre, VAlign::Top);
    let mut u = (p.lo[0] / step).ceil() * step;
    while u <= p.hi[0] + 1e-9 {
        let x = at(u - p.lo[0], 0.0)[0];
        c.line([x, bl[1]], [x, tr[1]], 1.0, grid);
        draw_text(c, x, bl[1] + 5.0, &format!("{u:.0}"), &tick);
        u += step;
    }
    let tick_v = TextStyle::new(11.0, [110; 3]).align(HAlign::Right, VAlign::Middle);
    let mut vv = (p.lo[1] / step).ceil() * step;
    while vv <= p.hi[1] + 1e-9 {
        let y = if p.flip { p.hi[1] - vv } else { vv - p.lo[1] };
        let py = at(0.0, y)[1];
        c.line([bl[0], py], [tr[0], py], 1.0, grid);
        if first {
            draw_text(c, bl[0] - 6.0, py, &format!("{vv:.0}"), &tick_v);
        }
        vv += step;
    }
    if first {
        let unit = TextStyle::new(11.0, [110; 3]).align(HAlign::Right, VAlign::Top);
        draw_text(c, bl[0] - 6.0, bl[1] + 5.0, "mm", &unit);
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_valve::{count, decode, synthetic_valve};
    use super::*;

    #[test]
    fn none_without_template_coordinates() {
        let (mut v, contact) = synthetic_valve(5);
        v.ref_uv = None;
        assert!(coaptation_maps(&v, &contact).is_none());
    }

    #[test]
    fn every_leaflet_shows_its_tint_and_both_contact_classes() {
        let (v, contact) = synthetic_valve(16);
        let f = coaptation_maps(&v, &contact).unwrap();
        let img = decode(&f.png);
        assert_eq!((img.w as u32, img.h as u32), (WIDTH, f.height));
        for j in 0..3 {
            assert!(count(&img, leaflet_tint(j)) > 1000, "leaflet {j}");
        }
        assert!(count(&img, PAIR) > 1000 && count(&img, TRIPLE) > 300);
        // Three panels side by side: the pair colour occurs in each third of the panel area.
        let third = (RIGHT - LEFT) / 3.0;
        for k in 0..3 {
            let x0 = (LEFT + third * k as f64) as usize;
            let x1 = (LEFT + third * (k + 1) as f64) as usize;
            let n = (0..img.h)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .filter(|&(x, y)| img.px[x + y * img.w] == PAIR)
                .count();
            assert!(n > 200, "panel {k}: {n}");
        }
    }

    #[test]
    fn free_edge_is_drawn_at_the_top() {
        // In the synthetic template the sutured edge has the largest v: flip.
        let (v, contact) = synthetic_valve(10);
        let f = coaptation_maps(&v, &contact).unwrap();
        let img = decode(&f.png);
        let rows_with = |c: [u8; 3]| -> Vec<usize> {
            (0..img.h)
                .filter(|&y| (0..RIGHT as usize).any(|x| img.px[x + y * img.w] == c))
                .collect()
        };
        let suture = rows_with(SUTURE);
        let triple = rows_with(TRIPLE);
        // The central zone is at the free-edge end: above the sutured edge's lowest row.
        let mean = |r: &[usize]| r.iter().sum::<usize>() as f64 / r.len() as f64;
        assert!(
            mean(&triple) < mean(&suture),
            "{} {}",
            mean(&triple),
            mean(&suture)
        );
    }

    #[test]
    fn bad_template_coordinates_are_skipped() {
        let (mut v, contact) = synthetic_valve(6);
        if let Some(uv) = v.ref_uv.as_mut() {
            uv.iter_mut().for_each(|p| p[0] = f64::NAN);
        }
        let f = coaptation_maps(&v, &contact).unwrap();
        assert!(f.caption.starts_with("Not drawn"));
        let (mut v, contact) = synthetic_valve(6);
        v.ref_uv.as_mut().unwrap().truncate(10);
        v.tri_leaflet[0] = 5;
        assert!(coaptation_maps(&v, &contact).is_some());
    }
}
