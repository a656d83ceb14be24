//! `cargo bench --bench mesher [-- --outlines-dir DIR]`: our advancing-front
//! mesher against spade's constrained Delaunay refinement (Ruppert, 25°
//! angle limit, max area of the equilateral triangle of side h) on the same
//! boundary nodes, h = 0.5 mm. Prints time per leaflet (median and minimum
//! of 7) and quality for both, and the ratios ours / spade of the medians
//! and of the minima (the minimum is the least disturbed by other jobs). Time is this thread's CPU
//! time (CLOCK_THREAD_CPUTIME_ID): on a shared machine wall time mostly
//! measures the other jobs; wall time is printed too.
//!
//! With `--outlines-dir DIR` it also writes, per template, DIR/NN.json with
//! the boundary nodes exactly as our mesher splits the outline (Triangle
//! and gmsh get the same nodes), both meshes and both timings, for
//! `tools/mesh_crosscheck.py`, which adds Triangle and gmsh to the table.

use std::collections::HashSet;
use std::time::Instant;

use coapt::leaflet::aft::{self, shape};
use coapt::template::Template;
use serde_json::json;
use spade::{
    AngleLimit, ConstrainedDelaunayTriangulation, Point2, RefinementParameters, Triangulation,
};

const REPS: usize = 7;

/// CPU time of the calling thread, ms.
fn thread_cpu_ms() -> f64 {
    coapt::bench::cpu_time::thread_cpu_s().expect("thread CPU time (Linux, 64-bit)") * 1e3
}

/// Median CPU ms, median wall ms and minimum CPU ms of REPS runs of `f`.
fn time<T>(mut f: impl FnMut() -> T) -> (f64, f64, f64) {
    let (mut cpu, mut wall) = (Vec::new(), Vec::new());
    for _ in 0..REPS {
        let (c0, w0) = (thread_cpu_ms(), Instant::now());
        std::hint::black_box(f());
        wall.push(w0.elapsed().as_secs_f64() * 1e3);
        cpu.push(thread_cpu_ms() - c0);
    }
    let min = cpu.iter().copied().fold(f64::INFINITY, f64::min);
    (median(cpu), median(wall), min)
}

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

fn all_templates() -> Vec<Template> {
    coapt::template::reference_templates()
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
        "ours (advancing front) | spade (Ruppert, 25°); ms = median CPU ms per leaflet, min = minimum CPU ms, wall (median) in ()"
    );
    println!(
        "{:<36} {:>6} {:>7} {:>7} {:>7} {:>6} {:>6} {:>6} | {:>6} {:>7} {:>7} {:>7} {:>6} {:>6} | {:>6} {:>6}",
        "template (h = 0.5 mm)",
        "tris",
        "ms",
        "min",
        "(wall)",
        "minang",
        "q",
        "band",
        "tris",
        "ms",
        "min",
        "(wall)",
        "minang",
        "q",
        "ratio",
        "r(min)"
    );
    for (ti, t) in templates.iter().enumerate() {
        let o = t.outline();
        let (bpts, tags) = o.discretise(h);
        let (to, wo, mo) = time(|| aft::mesh(&o, h).unwrap());
        let m = aft::mesh(&o, h).unwrap();
        let s = m.stats(h);
        let (ts, ws, ms) = time(|| spade_mesh(&bpts, h));
        let spm = spade_mesh(&bpts, h);
        let (n2, a2, q2) = quality(&spm);
        println!(
            "{:<36} {:>6} {:>7.2} {:>7.2} {:>7.2} {:>6.1} {:>6.3} {:>5.1}% | {:>6} {:>7.2} {:>7.2} {:>7.2} {:>6.1} {:>6.3} | {:>6.2} {:>6.2}",
            t.name().chars().take(36).collect::<String>(),
            s.triangles,
            to,
            mo,
            wo,
            s.min_angle_deg,
            s.mean_shape,
            100.0 * s.edges_in_range,
            n2,
            ts,
            ms,
            ws,
            a2,
            q2,
            to / ts,
            mo / ms
        );
        if let Some(d) = &dir {
            let doc = json!({
                "template": t.name(),
                "h_mm": h,
                "boundary_mm": bpts,
                "sutured": tags.iter().map(|e| e.code() == 1).collect::<Vec<_>>(),
                "ours": {"ms": to, "min_ms": mo, "wall_ms": wo, "nodes_mm": m.nodes, "tris": m.tris},
                "spade": {"ms": ts, "min_ms": ms, "wall_ms": ws, "tris_mm": spm},
            });
            let path = d.join(format!("{ti:02}.json"));
            std::fs::write(&path, serde_json::to_string(&doc).unwrap() + "\n")
                .expect("write outline json");
        }
    }
}
