//! `coapt bench segment`: accuracy against the phantom's truth (Dice, mean
//! and 95 % surface distance, voxels leaked into neighbouring structures)
//! and seconds per step, over a one-factor-at-a-time grid of phantoms.

use std::collections::HashMap;
use std::time::Instant;

use crate::geom::{Point3, TriMesh, Volume};
use crate::phantom::structures::{Structure, Structures};
use crate::phantom::{PhantomParams, Preset, generate};
use crate::segment::{SegmentParams, segment};
use crate::{Error, Result};

/// One phantom of the grid.
struct Case {
    label: String,
    params: PhantomParams,
}

fn case(label: &str, preset: Preset, f: impl FnOnce(&mut PhantomParams)) -> Case {
    let mut params = PhantomParams::new(preset, 1);
    f(&mut params);
    Case {
        label: label.into(),
        params,
    }
}

/// `quick`: the sample variations; `grid`: plus spacings and the full preset.
fn cases(set: &str) -> Result<Vec<Case>> {
    let s = Preset::Sample;
    let mut v = vec![
        case("sample t35 n25", s, |_| {}),
        case("sample t0", s, |p| p.tilt_rad = 0.0),
        case("sample t60", s, |p| p.tilt_rad = 60f64.to_radians()),
        case("sample n10", s, |p| p.noise_hu = 10.0),
        case("sample n50", s, |p| p.noise_hu = 50.0),
        case("sample n80", s, |p| p.noise_hu = 80.0),
        case("sample calcium", s, |p| p.calcium = true),
        case("sample seed 2", s, |p| p.seed = 2),
        case("sample seed 3", s, |p| p.seed = 3),
    ];
    match set {
        "quick" => {}
        "grid" => {
            v.push(case("sample sp .44/.6", s, |p| {
                p.spacing_mm = Some([0.44, 0.44, 0.6])
            }));
            v.push(case("sample sp .4/1.0", s, |p| {
                p.spacing_mm = Some([0.4, 0.4, 1.0])
            }));
            v.push(case("full t35 n25", Preset::Full, |_| {}));
            v.push(case("full t60 n50", Preset::Full, |p| {
                p.tilt_rad = 60f64.to_radians();
                p.noise_hu = 50.0;
            }));
        }
        other => {
            return Err(Error::usage(format!(
                "--cases {other}: expected quick or grid"
            )));
        }
    }
    Ok(v)
}

/// Accuracy of one mask (on a cropped grid) against the truth.
struct Accuracy {
    dice: f64,
    mean_mm: f64,
    p95_mm: f64,
    leaks: Vec<(Structure, usize)>,
}

/// Offset of `mask`'s grid inside `truth`'s (same spacing, integer shift).
fn offset<T, U>(mask: &Volume<T>, truth: &Volume<U>) -> [i64; 3] {
    truth
        .world_to_index(&mask.index_to_world([0.0; 3]))
        .map(|x| x.round() as i64)
}

fn truth_at(truth: &Volume<u8>, o: [i64; 3], i: usize, j: usize, k: usize) -> bool {
    let d = truth.dims();
    let (a, b, c) = (i as i64 + o[0], j as i64 + o[1], k as i64 + o[2]);
    a >= 0
        && b >= 0
        && c >= 0
        && (a as usize) < d[0]
        && (b as usize) < d[1]
        && (c as usize) < d[2]
        && truth.as_slice()[truth.linear_index(a as usize, b as usize, c as usize)] != 0
}

/// Face centres between inside and outside voxels of a mask (world mm).
/// Faces on the grid border are skipped: the lumen continues beyond them.
fn boundary_points(mask: &Volume<u8>) -> Vec<Point3> {
    let [ni, nj, nk] = mask.dims();
    let m = mask.as_slice();
    let mut out = Vec::new();
    for k in 0..nk {
        for j in 0..nj {
            for i in 0..ni {
                if m[i + ni * (j + nj * k)] == 0 {
                    continue;
                }
                let c = [i as f64, j as f64, k as f64];
                for (a, s) in [(0, -1i64), (0, 1), (1, -1), (1, 1), (2, -1), (2, 1)] {
                    let mut q = [i as i64, j as i64, k as i64];
                    q[a] += s;
                    let d = [ni, nj, nk];
                    if q[a] < 0 || q[a] >= d[a] as i64 {
                        continue;
                    }
                    if m[q[0] as usize + ni * (q[1] as usize + nj * q[2] as usize)] == 0 {
                        let mut f = c;
                        f[a] += 0.5 * s as f64;
                        out.push(mask.index_to_world(f));
                    }
                }
            }
        }
    }
    out
}

/// Uniform-grid index of items with bounding boxes, for nearest queries.
struct Buckets {
    lo: Point3,
    cell: f64,
    dims: [usize; 3],
    items: HashMap<usize, Vec<u32>>,
}

impl Buckets {
    fn new(boxes: &[(Point3, Point3)], cell: f64) -> Self {
        let mut lo = Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY);
        let mut hi = -lo;
        for (a, b) in boxes {
            lo = lo.inf(a);
            hi = hi.sup(b);
        }
        let dims = [0, 1, 2].map(|a| ((hi[a] - lo[a]) / cell).floor() as usize + 1);
        let mut items: HashMap<usize, Vec<u32>> = HashMap::new();
        let me = |p: &Point3| {
            [0, 1, 2].map(|a| (((p[a] - lo[a]) / cell).floor().max(0.0) as usize).min(dims[a] - 1))
        };
        for (t, (a, b)) in boxes.iter().enumerate() {
            let (x, y) = (me(a), me(b));
            for k in x[2]..=y[2] {
                for j in x[1]..=y[1] {
                    for i in x[0]..=y[0] {
                        items
                            .entry(i + dims[0] * (j + dims[1] * k))
                            .or_default()
                            .push(t as u32);
                    }
                }
            }
        }
        Buckets {
            lo,
            cell,
            dims,
            items,
        }
    }

    /// Least `dist(item)` over items in cells within growing cubes around p.
    fn nearest(&self, p: &Point3, dist: impl Fn(u32) -> f64) -> f64 {
        let c = [0, 1, 2].map(|a| ((p[a] - self.lo[a]) / self.cell).floor() as i64);
        let mut best = f64::INFINITY;
        for ring in 1..64i64 {
            for k in c[2] - ring..=c[2] + ring {
                for j in c[1] - ring..=c[1] + ring {
                    for i in c[0] - ring..=c[0] + ring {
                        let q = [i, j, k];
                        if (0..3).any(|a| q[a] < 0 || q[a] >= self.dims[a] as i64) {
                            continue;
                        }
                        // Only the shell of this ring is new.
                        if ring > 1 && (0..3).all(|a| (q[a] - c[a]).abs() < ring) {
                            continue;
                        }
                        if let Some(v) = self.items.get(
                            &(i as usize + self.dims[0] * (j as usize + self.dims[1] * k as usize)),
                        ) {
                            for &t in v {
                                best = best.min(dist(t));
                            }
                        }
                    }
                }
            }
            if best <= (ring - 1) as f64 * self.cell {
                break;
            }
        }
        best
    }
}

/// Distance from p to triangle abc (Ericson, Real-Time Collision Detection 5.1.5).
fn point_triangle(p: &Point3, a: &Point3, b: &Point3, c: &Point3) -> f64 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.norm();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.norm();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (p - (a + ab * v)).norm();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.norm();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (p - (a + ac * w)).norm();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (p - (b + (c - b) * w)).norm();
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    (p - (a + ab * v + ac * w)).norm()
}

/// Symmetric surface distance: mask boundary → truth mesh (exact) and truth
/// vertices → mask boundary points; mean and 95th percentile of the union.
fn surface_distance(mask: &Volume<u8>, mesh: &TriMesh) -> (f64, f64) {
    let pts = boundary_points(mask);
    let boxes: Vec<(Point3, Point3)> = (0..mesh.triangles.len())
        .map(|t| {
            let [a, b, c] = mesh.corners(t);
            (a.inf(&b).inf(&c), a.sup(&b).sup(&c))
        })
        .collect();
    let tri = Buckets::new(&boxes, 2.0);
    let mut d: Vec<f64> = pts
        .iter()
        .map(|p| {
            tri.nearest(p, |t| {
                let [a, b, c] = mesh.corners(t as usize);
                point_triangle(p, &a, &b, &c)
            })
        })
        .collect();
    let pb: Vec<(Point3, Point3)> = pts.iter().map(|p| (*p, *p)).collect();
    let near = Buckets::new(&pb, 2.0);
    d.extend(
        mesh.vertices
            .iter()
            .map(|v| near.nearest(v, |i| (pts[i as usize] - v).norm())),
    );
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    d.sort_unstable_by(f64::total_cmp);
    (mean, d[(0.95 * (d.len() - 1) as f64).round() as usize])
}

fn accuracy(mask: &Volume<u8>, truth: &Volume<u8>, mesh: &TriMesh, st: &Structures) -> Accuracy {
    let o = offset(mask, truth);
    let [ni, nj, nk] = mask.dims();
    let (mut inter, mut m_n) = (0usize, 0usize);
    let mut leaks: Vec<(Structure, usize)> = Structure::ALL.iter().map(|&s| (s, 0)).collect();
    for k in 0..nk {
        for j in 0..nj {
            for i in 0..ni {
                if mask.as_slice()[mask.linear_index(i, j, k)] == 0 {
                    continue;
                }
                m_n += 1;
                if truth_at(truth, o, i, j, k) {
                    inter += 1;
                }
                let p = mask.index_to_world([i as f64, j as f64, k as f64]);
                for (s, n) in leaks.iter_mut() {
                    if st.contains(*s, &p) {
                        *n += 1;
                    }
                }
            }
        }
    }
    let t_n = truth.as_slice().iter().filter(|&&v| v != 0).count();
    let (mean_mm, p95_mm) = surface_distance(mask, mesh);
    Accuracy {
        dice: 2.0 * inter as f64 / (m_n + t_n) as f64,
        mean_mm,
        p95_mm,
        leaks,
    }
}

/// Run the benchmark; `baseline` names a command that runs the SimpleITK
/// baseline (`tools/segment_baseline.py`), if wanted.
pub fn run(set: &str, baseline: Option<&str>) -> Result<String> {
    let mut rows = vec![format!(
        "{:<18} {:>7} {:>7} {:>7} {:>10} {:>7} {:>8} {:>7} {:>7} {:>8}  {}",
        "case",
        "Dice",
        "mean mm",
        "95% mm",
        "leak vox",
        "floor",
        "Dice noL",
        "seg s",
        "Mvox",
        "ROI %",
        "slowest steps (s)"
    )];
    let mut notes = Vec::new();
    for c in cases(set)? {
        let ph = generate(&c.params, &|_| {})?;
        let st = Structures::new(&c.params)?;
        let sp = SegmentParams::default();
        let t0 = Instant::now();
        let seg = segment(&ph.ct, Some(&ph.landmarks), &sp)?;
        let secs = t0.elapsed().as_secs_f64();
        let acc = accuracy(&seg.mask, &ph.truth_mask, &ph.truth_surface, &st);
        let no_lm = segment(&ph.ct, None, &sp)?;
        let acc_n = accuracy(&no_lm.mask, &ph.truth_mask, &ph.truth_surface, &st);
        // The voxelisation floor: the truth mask's own surface distance.
        let (floor, _) = surface_distance(&ph.truth_mask, &ph.truth_surface);
        let leak: usize = acc.leaks.iter().map(|l| l.1).sum::<usize>()
            + acc_n.leaks.iter().map(|l| l.1).sum::<usize>();
        let mut steps = seg.report.timings_s.clone();
        steps.sort_by(|a, b| b.1.total_cmp(&a.1));
        let steps: Vec<String> = steps
            .iter()
            .take(4)
            .map(|(n, s)| format!("{n} {s:.2}"))
            .collect();
        rows.push(format!(
            "{:<18} {:>7.4} {:>7.3} {:>7.3} {:>10} {:>7.3} {:>8.4} {:>7.2} {:>7.1} {:>8.1}  {}",
            c.label,
            acc.dice,
            acc.mean_mm,
            acc.p95_mm,
            leak,
            floor,
            acc_n.dice,
            secs,
            ph.ct.len() as f64 / 1e6,
            100.0 * seg.report.roi.fraction_of_volume,
            steps.join(", ")
        ));
        if leak > 0 {
            let l: Vec<String> = acc
                .leaks
                .iter()
                .chain(&acc_n.leaks)
                .filter(|l| l.1 > 0)
                .map(|(s, n)| format!("{} {n}", s.name()))
                .collect();
            notes.push(format!("{}: voxels inside {}", c.label, l.join(", ")));
        }
        if let Some(cmd) = baseline {
            notes.push(format!(
                "{}: {}",
                c.label,
                run_baseline(cmd, &ph, &seg, secs)?
            ));
        }
    }
    rows.push(
        "Dice/mean/95%: with landmarks (nadir plane); Dice noL: without landmarks (measured VAJ)."
            .into(),
    );
    rows.push("leak vox: mask voxels inside the LV, PA, LA, DA or spine (both runs). floor: mean surface distance of the truth mask itself (voxelisation).".into());
    rows.extend(notes);
    Ok(rows.join("\n"))
}

/// Run the SimpleITK baseline on the same CT and seed; compare.
fn run_baseline(
    cmd: &str,
    ph: &crate::phantom::Phantom,
    seg: &crate::segment::Segmentation,
    secs: f64,
) -> Result<String> {
    let dir = std::env::temp_dir().join(format!("coapt-bench-segment-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| Error::write(&dir, e))?;
    let ct = dir.join("ct.nii.gz");
    crate::io::nifti::write(&ct, &ph.ct)?;
    let out = dir.join("baseline.nii.gz");
    let s = seg.report.seed_mm;
    let o = std::process::Command::new(cmd)
        .arg(&ct)
        .arg(&out)
        // "=" form: the coordinates may start with a minus sign.
        .arg(format!("--seed-mm={},{},{}", s[0], s[1], s[2]))
        .arg(format!("--threshold={}", seg.report.threshold_hu))
        .output()
        .map_err(|e| Error::read(cmd, e))?;
    if !o.status.success() {
        return Ok(format!(
            "baseline failed: {}",
            String::from_utf8_lossy(&o.stderr).trim()
        ));
    }
    let text = String::from_utf8_lossy(&o.stdout);
    let b_secs: f64 = text
        .lines()
        .find_map(|l| l.strip_prefix("seconds "))
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(f64::NAN);
    let bm = crate::io::nifti::read_u8(&out)?;
    let b_dice = {
        let o = offset(&bm, &ph.truth_mask);
        let [ni, nj, nk] = bm.dims();
        let (mut inter, mut m_n) = (0usize, 0usize);
        for k in 0..nk {
            for j in 0..nj {
                for i in 0..ni {
                    if bm.as_slice()[bm.linear_index(i, j, k)] != 0 {
                        m_n += 1;
                        inter += truth_at(&ph.truth_mask, o, i, j, k) as usize;
                    }
                }
            }
        }
        let t_n = ph.truth_mask.as_slice().iter().filter(|&&v| v != 0).count();
        2.0 * inter as f64 / (m_n + t_n) as f64
    };
    let _ = std::fs::remove_dir_all(&dir);
    Ok(format!(
        "SimpleITK baseline Dice {b_dice:.4} in {b_secs:.2} s; coapt {secs:.2} s (baseline/coapt time ratio {:.2})",
        b_secs / secs
    ))
}
