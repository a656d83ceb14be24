//! The closed valve in 3-D, coloured by contact: seen from the aorta (as the
//! surgeon sees it through the aortotomy) and from the side.

use super::legend::{LegendItem, Swatch, draw_legend};
use super::mesh_edges::{EdgeKind, boundary_edges, edge_kind};
use super::notice::notice;
use super::palette::{
    BACKGROUND, ContactClass, FREE_EDGE, INK, PAIR, SUTURE, TRIPLE, class_colour, dominant,
    leaflet_tint, node_classes, node_leaflets, one_hot,
};
use super::scale_bar::draw_scale_bar;
use super::text::{HAlign, TextStyle, VAlign, draw_text};
use super::to_figure;
use crate::raster::{Camera, Canvas, MeshLayer, Shading};
use crate::{ClosedValve, Figure};
use coapt_geom::{Point3, Vector3};

const WIDTH: u32 = 820;
const HEIGHT: u32 = 600;
/// The valve is drawn in the left square; legend and scale bar to its right.
const VIEW: u32 = 600;
const MARGIN: f64 = 36.0;

struct View {
    id: &'static str,
    title: &'static str,
    orientation: &'static str,
    view: Vector3,
    up: Vector3,
}

/// Top view (from the aorta, C1 at the top) and side view (axis up, the
/// viewer facing commissure C1 across the valve), at one common scale.
/// When the valve has no drawable triangle, one notice figure says so.
pub fn valve_views(v: &ClosedValve, contact: &[u8]) -> Vec<Figure> {
    let drawable = drawable_triangles(v);
    if drawable == 0 {
        return vec![notice(
            "valve_views",
            "Closed valve",
            "the closed valve has no triangle with valid indices and finite positions, so there is no surface to show",
        )];
    }
    let f = &v.frame;
    let views = [
        View {
            id: "valve_top",
            title: "Closed valve seen from the aorta",
            orientation: "viewer in the aorta, looking down the flow axis; C1 at the top",
            view: -f.axis,
            up: f.e1,
        },
        View {
            id: "valve_side",
            title: "Closed valve seen from the side",
            orientation: "flow axis up; viewer opposite C1, looking towards it",
            view: f.e1,
            up: f.axis,
        },
    ];
    let mut pts: Vec<Point3> = v.x.clone();
    pts.extend(f.commissures_mm);
    pts.push(f.origin_mm);
    let fitted: Vec<Option<Camera>> = views
        .iter()
        .map(|w| Camera::fit(w.view, w.up, &pts, VIEW, HEIGHT, MARGIN, f.origin_mm))
        .collect();
    let Some(scale) = fitted
        .iter()
        .flatten()
        .map(|c| c.mm_per_px())
        .reduce(f64::max)
    else {
        return vec![notice(
            "valve_views",
            "Closed valve",
            "the valve frame's directions are not finite, so no view of the valve can be set up",
        )];
    };
    let leaflet = node_leaflets(v.x.len(), &v.tris, &v.tri_leaflet);
    let classes = node_classes(contact, &leaflet);
    let leaflets = v.leaflet_count();
    views
        .iter()
        .zip(fitted)
        .map(
            |(w, cam)| match cam.and_then(|c| c.with_scale(scale, VIEW, HEIGHT)) {
                Some(cam) => render(v, &classes, leaflets, w, &cam),
                None => notice(
                    w.id,
                    w.title,
                    "this view of the valve cannot be set up from the valve frame",
                ),
            },
        )
        .collect()
}

fn drawable_triangles(v: &ClosedValve) -> usize {
    let ok = |p: &Point3| p.coords.iter().all(|c| c.is_finite());
    v.tris
        .iter()
        .filter(|t| t.iter().all(|&i| v.x.get(i as usize).is_some_and(ok)))
        .count()
}

fn render(
    v: &ClosedValve,
    classes: &[ContactClass],
    leaflets: usize,
    w: &View,
    cam: &Camera,
) -> Figure {
    let mut c = Canvas::new(WIDTH, HEIGHT, 2, BACKGROUND);
    // Triangles with a bad index are dropped before the corner lookup.
    let tris: Vec<[u32; 3]> = v
        .tris
        .iter()
        .copied()
        .filter(|t| t.iter().all(|&i| (i as usize) < v.x.len()))
        .collect();
    let tri_leaflet: Vec<u8> = v
        .tris
        .iter()
        .zip(v.tri_leaflet.iter().copied().chain(std::iter::repeat(0)))
        .filter(|(t, _)| t.iter().all(|&i| (i as usize) < v.x.len()))
        .map(|(_, l)| l)
        .collect();
    let corner_f = |t: usize, k: usize| corner_of(&tris, classes, t, k);
    let paint_f = |t: usize, wts: [f32; 3]| {
        class_colour(
            dominant(wts),
            tri_leaflet.get(t).copied().unwrap_or(0) as usize,
        )
    };
    c.draw_mesh(
        cam,
        &MeshLayer {
            positions: &v.x,
            triangles: &tris,
            corner: &corner_f,
            paint: &paint_f,
            shading: Shading::Smooth,
        },
    );
    // Edges sit on the surface; a small depth allowance keeps them visible
    // there while nearer leaflets still hide them.
    let tol = 0.6;
    for e in boundary_edges(&tris, v.x.len()) {
        let (a, b) = (&v.x[e[0] as usize], &v.x[e[1] as usize]);
        match edge_kind(e, &v.boundary) {
            EdgeKind::Free => c.line3(cam, a, b, 2.2, FREE_EDGE, tol),
            EdgeKind::Sutured => c.line3(cam, a, b, 2.2, SUTURE, tol),
            EdgeKind::Other => c.line3(cam, a, b, 1.2, FREE_EDGE, tol),
        }
    }
    let f = &v.frame;
    if w.id == "valve_side" {
        let o = cam.project(&f.origin_mm);
        c.dashed_polyline(
            &[[8.0, o[1]], [VIEW as f64 - 8.0, o[1]]],
            1.5,
            8.0,
            5.0,
            [90; 3],
        );
        let st = TextStyle::new(13.0, INK)
            .align(HAlign::Left, VAlign::Baseline)
            .halo(BACKGROUND);
        draw_text(&mut c, 10.0, o[1] - 6.0, "annulus (VAJ)", &st);
    }
    label_commissures(
        &mut c,
        cam,
        f.commissures_mm,
        f.origin_mm + f.axis * mean_height(v),
    );
    c.rect(VIEW as f64, 0.0, VIEW as f64 + 1.0, HEIGHT as f64, [210; 3]);
    let mut items: Vec<LegendItem> = (0..leaflets)
        .map(|j| {
            LegendItem::new(
                Swatch::Square(leaflet_tint(j)),
                format!("leaflet {}: no contact", j + 1),
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
    items.push(LegendItem::new(Swatch::Line(SUTURE), "suture line"));
    draw_legend(&mut c, VIEW as f64 + 12.0, 16.0, &items, 12.5);
    draw_scale_bar(
        &mut c,
        VIEW as f64 + 20.0,
        HEIGHT as f64 - 24.0,
        cam.mm_per_px(),
        170.0,
    );
    // Bottom left: the commissure labels crowd the top of both views.
    let st = TextStyle::new(12.5, [90; 3]).align(HAlign::Left, VAlign::Baseline);
    draw_text(&mut c, 10.0, HEIGHT as f64 - 10.0, w.orientation, &st);
    let caption = format!(
        "{} ({}). Pale tints: leaflet surface touching no other leaflet (one tint per leaflet); \
         blue: touching one other leaflet (coaptation); red: touching both others (central coaptation). \
         Dark line: free edge; brown: suture line. Scale bar in mm.",
        w.title, w.orientation
    );
    to_figure(w.id, w.title, &caption, &c)
}

fn corner_of(tris: &[[u32; 3]], classes: &[ContactClass], t: usize, k: usize) -> [f32; 3] {
    one_hot(
        classes
            .get(tris[t][k] as usize)
            .copied()
            .unwrap_or(ContactClass::Free),
    )
}

/// Mean commissure height above the annulus (0 when not finite): where the
/// commissure labels are pushed away from.
fn mean_height(v: &ClosedValve) -> f64 {
    let f = &v.frame;
    let h = f
        .commissures_mm
        .iter()
        .map(|c| (c - f.origin_mm).dot(&f.axis))
        .sum::<f64>()
        / 3.0;
    if h.is_finite() { h } else { 0.0 }
}

/// Dots at the commissures, labels pushed outwards from the axis so that
/// they do not sit on the leaflets.
fn label_commissures(c: &mut Canvas, cam: &Camera, comm: [Point3; 3], centre: Point3) {
    let o = cam.project(&centre);
    let st = TextStyle::new(15.0, INK)
        .align(HAlign::Centre, VAlign::Middle)
        .halo(BACKGROUND);
    for (k, p) in comm.iter().enumerate() {
        let q = cam.project(p);
        let (dx, dy) = (q[0] - o[0], q[1] - o[1]);
        let d = dx.hypot(dy);
        let (ux, uy) = if d > 1.0 {
            (dx / d, dy / d)
        } else {
            (0.0, -1.0)
        };
        c.disc(q[0], q[1], 4.0, INK);
        draw_text(
            c,
            q[0] + 16.0 * ux,
            q[1] + 16.0 * uy,
            &format!("C{}", k + 1),
            &st,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_valve::{count, decode, synthetic_valve};
    use super::*;

    #[test]
    fn both_views_show_every_contact_class() {
        let (v, contact) = synthetic_valve(14);
        let figs = valve_views(&v, &contact);
        assert_eq!(figs.len(), 2);
        assert_eq!(figs[0].id, "valve_top");
        assert_eq!(figs[1].id, "valve_side");
        for f in &figs {
            if let Ok(dir) = std::env::var("COAPT_FIGS_DEBUG") {
                std::fs::write(format!("{dir}/synthetic_{}.png", f.id), &f.png).unwrap();
            }
            let img = decode(&f.png);
            assert_eq!((img.w as u32, img.h as u32), (f.width, f.height));
            // Shading darkens colours, so count hues rather than exact values.
            let reddish = img
                .px
                .iter()
                .filter(|p| p[0] > 120 && p[1] < 60 && p[2] < 60)
                .count();
            let bluish = img
                .px
                .iter()
                .filter(|p| p[2] > 110 && p[0] < 30 && p[1] < 100)
                .count();
            assert!(reddish > 200, "{}: {reddish} red", f.id);
            assert!(bluish > 200, "{}: {bluish} blue", f.id);
            assert!(count(&img, BACKGROUND) < img.px.len() * 95 / 100);
            assert!(f.caption.contains("red") && f.caption.contains("blue"));
        }
    }

    #[test]
    fn top_view_puts_commissure_one_at_the_top() {
        let (v, contact) = synthetic_valve(8);
        let img = decode(&valve_views(&v, &contact)[0].png);
        // The C1 dot (ink) is in the upper half of the drawing area, centred.
        let ink: Vec<(usize, usize)> = (0..img.h)
            .flat_map(|y| (0..VIEW as usize).map(move |x| (x, y)))
            .filter(|&(x, y)| img.px[x + y * img.w] == INK)
            .collect();
        assert!(!ink.is_empty());
        let top = ink.iter().min_by_key(|p| p.1).unwrap();
        assert!(top.1 < 80 && (top.0 as i64 - 300).abs() < 40, "{top:?}");
    }

    #[test]
    fn renders_are_bit_identical_across_runs_and_thread_counts() {
        let (v, contact) = synthetic_valve(12);
        let a = valve_views(&v, &contact);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let b = pool.install(|| valve_views(&v, &contact));
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let c = one.install(|| valve_views(&v, &contact));
        for k in 0..2 {
            assert_eq!(a[k].png, b[k].png);
            assert_eq!(a[k].png, c[k].png);
        }
    }

    #[test]
    fn degenerate_valves_give_a_notice_not_a_panic() {
        let (mut v, contact) = synthetic_valve(4);
        v.x.iter_mut().for_each(|p| p.x = f64::NAN);
        let f = valve_views(&v, &contact);
        assert_eq!(f.len(), 1);
        assert!(f[0].caption.starts_with("Not drawn"));
        let (mut v, _) = synthetic_valve(4);
        v.tris.clear();
        assert_eq!(valve_views(&v, &[]).len(), 1);
        // Short contact and leaflet arrays, a bad index and a NaN node still draw.
        let (mut v, _) = synthetic_valve(6);
        v.tris.push([0, 1, 99_999]);
        v.tri_leaflet.truncate(3);
        v.x[5] = Point3::new(f64::NAN, 0.0, 0.0);
        let f = valve_views(&v, &[0b010; 4]);
        assert_eq!(f.len(), 2);
    }
}
