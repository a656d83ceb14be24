//! `cargo bench --bench mesher [-- --outlines-dir DIR]`: our advancing-front
//! mesher against spade's constrained Delaunay refinement (Ruppert, 25°
//! angle limit, max area of the equilateral triangle of side h) on the same
//! boundary nodes, h = 0.5 mm. Prints time per leaflet (median of 7) and
//! quality for both, and the ratio ours / spade.
//!
//! With `--outlines-dir DIR` it also writes, per template, DIR/NN.json with
//! the boundary nodes exactly as our mesher splits the outline (Triangle
//! and gmsh get the same nodes), both meshes and both timings, for
//! `tools/mesh_crosscheck.py`, which adds Triangle and gmsh to the table.

use std::collections::HashSet;
use std::f64::consts::PI;
use std::time::Instant;

use coapt::leaflet::aft::{self, shape};
use coapt::leaflet::seed001::Seed001;
use coapt::leaflet::template::{ArcTemplate, OZAKI_SIZES, OzakiTemplate, Template, TemplateSpec};
use coapt::units::{Angle, Length};
use serde_json::json;
use spade::{
    AngleLimit, ConstrainedDelaunayTriangulation, Point2, RefinementParameters, Triangulation,
};

const REPS: usize = 7;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// (triangles, min angle °, mean shape) of a triangle soup.
fn quality(tris: &[[[f64; 2]; 3]]) -> (usize, f64, f64) {
    let mut min_a = f64::INFINITY;
    let mut sq = 0.0;
    for t in tris {
        sq += shape(t[0], t[1], t[2]);
        for k in 0..3 {
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let u = [b[0] - a[0], b[1] - a[1]];
            let v = [c[0] - a[0], c[1] - a[1]];
            let ang = (u[0] * v[1] - u[1] * v[0])
                .abs()
                .atan2(u[0] * v[0] + u[1] * v[1]);
            min_a = min_a.min(ang.to_degrees());
        }
    }
    (tris.len(), min_a, sq / tris.len() as f64)
}

fn spade_mesh(bpts: &[[f64; 2]], h: f64) -> Vec<[[f64; 2]; 3]> {
    let verts: Vec<Point2<f64>> = bpts.iter().map(|p| Point2::new(p[0], p[1])).collect();
    let n = verts.len();
    let edges: Vec<[usize; 2]> = (0..n).map(|i| [i, (i + 1) % n]).collect();
    let mut cdt =
        ConstrainedDelaunayTriangulation::<Point2<f64>>::bulk_load_cdt(verts, edges).unwrap();
    let res = cdt.refine(
        RefinementParameters::<f64>::new()
            .exclude_outer_faces(true)
            .keep_constraint_edges()
            .with_max_allowed_area(0.433 * h * h)
            .with_angle_limit(AngleLimit::from_deg(25.0))
            .with_max_additional_vertices(200_000),
    );
    let excluded: HashSet<_> = res.excluded_faces.iter().copied().collect();
    cdt.inner_faces()
        .filter(|f| !excluded.contains(&f.fix()))
        .map(|f| f.positions().map(|p| [p.x, p.y]))
        .collect()
}

/// The 18 templates of the quality test (src/leaflet/tests.rs): four
/// seed 000 templates, the twelve Ozaki sizer presets, the parametric
/// Ozaki template and the seed 001 §3.1 case.
fn all_templates() -> Vec<Template> {
    let mut v = Vec::new();
    for (r, a, b) in [
        (11.0, 11.0, 11.0),
        (12.0, 13.0, 13.0),
        (13.0, 13.0, 14.0),
        (14.5, 15.8, 13.5),
    ] {
        v.push(
            TemplateSpec::FourParameter {
                r: Length(r),
                alpha: Angle(160f64.to_radians()),
                a: Length(a),
                b: Length(b),
            }
            .build()
            .unwrap(),
        );
    }
    for &(size, ..) in &OZAKI_SIZES {
        v.push(Template::Arc(ArcTemplate::ozaki_size(size).unwrap()));
    }
    v.push(Template::Ozaki(
        OzakiTemplate::new(19.0, 11.0, 2.0, 24.0).unwrap(),
    ));
    v.push(Template::Seed001(
        Seed001::new(15.0, 2.0 * PI / 3.0 - 0.4, 1.5, 15.0, -2.0 * PI / 9.0).unwrap(),
    ));
    v
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = args
        .iter()
        .position(|a| a == "--outlines-dir")
        .and_then(|i| args.get(i + 1))
        .map(std::path::PathBuf::from);
    if let Some(d) = &dir {
        std::fs::create_dir_all(d).expect("create --outlines-dir");
    }
    let h = 0.5;
    let templates = all_templates();
    println!(
        "{:<44} {:>6} {:>8} {:>6} {:>6} | {:>6} {:>8} {:>6} {:>6} | {:>6}",
        "template (h = 0.5 mm)", "tris", "ms", "minang", "q", "tris", "ms", "minang", "q", "ratio"
    );
    for (ti, t) in templates.iter().enumerate() {
        let o = t.outline();
        let (bpts, tags) = o.discretise(h);
        let ours: Vec<f64> = (0..REPS)
            .map(|_| {
                let t0 = Instant::now();
                std::hint::black_box(aft::mesh(&o, h).unwrap());
                t0.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        let m = aft::mesh(&o, h).unwrap();
        let s = m.stats(h);
        let sp: Vec<f64> = (0..REPS)
            .map(|_| {
                let t0 = Instant::now();
                std::hint::black_box(spade_mesh(&bpts, h));
                t0.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        let spm = spade_mesh(&bpts, h);
        let (n2, a2, q2) = quality(&spm);
        let (to, ts) = (median(ours), median(sp));
        println!(
            "{:<44} {:>6} {:>8.2} {:>6.1} {:>6.3} | {:>6} {:>8.2} {:>6.1} {:>6.3} | {:>6.2}",
            t.name().chars().take(44).collect::<String>(),
            s.triangles,
            to,
            s.min_angle_deg,
            s.mean_shape,
            n2,
            ts,
            a2,
            q2,
            to / ts
        );
        if let Some(d) = &dir {
            let doc = json!({
                "template": t.name(),
                "h_mm": h,
                "boundary_mm": bpts,
                "sutured": tags.iter().map(|e| e.code() == 1).collect::<Vec<_>>(),
                "ours": {"ms": to, "nodes_mm": m.nodes, "tris": m.tris},
                "spade": {"ms": ts, "tris_mm": spm},
            });
            let path = d.join(format!("{ti:02}.json"));
            std::fs::write(&path, serde_json::to_string(&doc).unwrap() + "\n")
                .expect("write outline json");
        }
    }
}
