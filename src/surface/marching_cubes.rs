//! Marching cubes in flying-edges passes over x-rows.
//!
//! The volume is seen through a one-node frame of "outside" around the
//! bounding box of its inside samples (the padding that closes surfaces
//! touching the grid border). Passes:
//! 1. the one full read: first and last inside sample of every row (the
//!    bounding box and the per-row trimming follow);
//! 2. per node row of the box: inside bits, within the row's extent only;
//! 3. per row: cut x/y/z edges of each node and the vertex count; cases of
//!    the cell row (vectorised) and the triangle count;
//! 4. prefix sums give every row its exact slice of the output arrays;
//! 5. per row: vertices in node order (x, y, z edge), then triangles, whose
//!    vertex ids follow from running counts along the four node rows of the
//!    cell row. No hash map, no welding: an edge's vertex is made once, by
//!    the row that owns the edge's lower node.
//!
//! Rows are independent, so passes 2, 3 and 5 run in parallel with rayon and
//! the output does not depend on the thread count.

use rayon::prelude::*;

use super::tables::{EDGE_CORNERS, table};
use crate::geom::{Matrix4, Point3, Volume};

/// Sample types the extractor reads.
pub trait Sample: Copy + Send + Sync {
    /// What the inside test compares against (an integer for integer samples,
    /// so that the classification loops vectorise).
    type Threshold: Copy + Send + Sync;
    fn threshold(iso: f64) -> Self::Threshold;
    /// value > iso
    fn above(self, t: Self::Threshold) -> bool;
    fn value(self) -> f64;
}

impl Sample for u8 {
    type Threshold = i16;
    fn threshold(iso: f64) -> i16 {
        // v > iso ⇔ v > ⌊iso⌋ for integers.
        iso.floor().clamp(-1.0, 255.0) as i16
    }
    #[inline]
    fn above(self, t: i16) -> bool {
        self as i16 > t
    }
    #[inline]
    fn value(self) -> f64 {
        self as f64
    }
}

impl Sample for i16 {
    type Threshold = i32;
    fn threshold(iso: f64) -> i32 {
        iso.floor().clamp(-32769.0, 32767.0) as i32
    }
    #[inline]
    fn above(self, t: i32) -> bool {
        self as i32 > t
    }
    #[inline]
    fn value(self) -> f64 {
        self as f64
    }
}

impl Sample for f32 {
    type Threshold = f64;
    fn threshold(iso: f64) -> f64 {
        iso
    }
    #[inline]
    fn above(self, t: f64) -> bool {
        self as f64 > t
    }
    #[inline]
    fn value(self) -> f64 {
        self as f64
    }
}

/// The raw isosurface: world vertices, outward triangles, and for each vertex
/// whether its edge reaches into the padding (the mask was cut by the border).
#[derive(Debug, Clone, Default)]
pub struct Isosurface {
    pub vertices: Vec<Point3>,
    pub triangles: Vec<[u32; 3]>,
    pub on_border: Vec<bool>,
}

/// [first, last + 1) of the samples above the threshold in one row; (0, 0)
/// when none. Blocks are tested without early exit so the test vectorises.
#[inline]
fn row_extent<T: Sample>(row: &[T], t: T::Threshold) -> (u32, u32) {
    const B: usize = 64;
    let any = |c: &[T]| c.iter().fold(false, |acc, &v| acc | v.above(t));
    let Some(bf) = row.chunks(B).position(any) else {
        return (0, 0);
    };
    let first = bf * B + row[bf * B..].iter().position(|v| v.above(t)).unwrap();
    let nb = row.len().div_ceil(B);
    let bl = (0..nb)
        .rev()
        .find(|&b| any(&row[b * B..((b + 1) * B).min(row.len())]))
        .unwrap();
    let end = ((bl + 1) * B).min(row.len());
    let last = bl * B + row[bl * B..end].iter().rposition(|v| v.above(t)).unwrap();
    (first as u32, last as u32 + 1)
}

/// Extract the `iso` surface of `vol` (inside: value > iso) in world
/// coordinates, closed at the grid border, outward-facing.
pub fn extract<T: Sample>(vol: &Volume<T>, iso: f64) -> Isosurface {
    let thr = T::threshold(iso);
    let dims = vol.dims();
    let data = vol.as_slice();
    if data.is_empty() {
        return Isosurface::default();
    }
    let (dx, dy) = (dims[0], dims[1]);

    // Pass 1: the one full read. Extent of the inside samples of every row.
    let extent: Vec<(u32, u32)> = data
        .par_chunks(dx)
        .with_min_len(64)
        .map(|row| row_extent(row, thr))
        .collect();
    let mut lo = [i64::MAX; 3];
    let mut hi = [i64::MIN; 3];
    for (r, &(f, l)) in extent.iter().enumerate() {
        if l > f {
            let (j, k) = ((r % dy) as i64, (r / dy) as i64);
            lo = [lo[0].min(f as i64), lo[1].min(j), lo[2].min(k)];
            hi = [hi[0].max(l as i64 - 1), hi[1].max(j), hi[2].max(k)];
        }
    }
    if lo[0] == i64::MAX {
        return Isosurface::default();
    }
    // Node box: the inside box plus one node of outside on every side.
    let lo = lo.map(|v| v - 1);
    let hi = hi.map(|v| v + 1);
    let n = [0, 1, 2].map(|a| (hi[a] - lo[a] + 1) as usize);
    let rows = n[1] * n[2];
    // Volume row of node row r, when it lies inside the volume.
    let vrow = |r: usize| -> Option<usize> {
        let (j, k) = (lo[1] + (r % n[1]) as i64, lo[2] + (r / n[1]) as i64);
        (j >= 0 && k >= 0 && j < dy as i64 && k < dims[2] as i64)
            .then(|| j as usize + dy * k as usize)
    };

    // Pass 2: inside bits of the nodes, within each row's extent.
    let mut ins = vec![0u8; n[0] * rows];
    let trim: Vec<(usize, usize)> = ins
        .par_chunks_mut(n[0])
        .with_min_len(16)
        .enumerate()
        .map(|(r, row)| {
            let Some(vr) = vrow(r) else { return (0, 0) };
            let (f, l) = extent[vr];
            if l <= f {
                return (0, 0);
            }
            let src = &data[vr * dx + f as usize..vr * dx + l as usize];
            let a0 = (f as i64 - lo[0]) as usize;
            for (o, v) in row[a0..a0 + src.len()].iter_mut().zip(src) {
                *o = v.above(thr) as u8;
            }
            (a0, a0 + src.len())
        })
        .collect();

    // Pass 3: cut-edge bits of each node (bit 0 x, 1 y, 2 z) and vertex count
    // per node row; cases and triangle count per cell row.
    let tab = table();
    let zeros = vec![0u8; n[0]];
    let ins_row = |r: usize| &ins[r * n[0]..(r + 1) * n[0]];
    let neighbour = |r: usize, dj: usize, dk: usize| -> Option<usize> {
        let (j, k) = (r % n[1] + dj, r / n[1] + dk);
        (j < n[1] && k < n[2]).then_some(j + n[1] * k)
    };
    // Nodes (or cells) of a set of rows that can touch an inside node: from
    // one before the first inside node to the last one, below `len`.
    let span = |rs: &[Option<usize>], len: usize| -> (usize, usize) {
        let (mut a, mut b) = (usize::MAX, 0);
        for &r in rs.iter().flatten() {
            if trim[r].1 > trim[r].0 {
                a = a.min(trim[r].0);
                b = b.max(trim[r].1);
            }
        }
        if a >= b { (0, 0) } else { (a - 1, b.min(len)) }
    };
    let mut ebits = vec![0u8; n[0] * rows];
    // (vertices, triangles, first and end node with cut edges)
    let counts: Vec<(u32, u32, usize, usize)> = ebits
        .par_chunks_mut(n[0])
        .with_min_len(16)
        .enumerate()
        .map_init(Vec::new, |cases, (r, eb)| {
            let (r10, r01, r11) = (neighbour(r, 1, 0), neighbour(r, 0, 1), neighbour(r, 1, 1));
            let (e0, e1) = span(&[Some(r), r10, r01], n[0] - 1);
            let i00 = ins_row(r);
            let i10 = r10.map_or(&zeros[..], ins_row);
            let i01 = r01.map_or(&zeros[..], ins_row);
            // Equal-length slices: no bounds checks, the loop vectorises.
            let l = e1 - e0;
            let (v0, vx) = (&i00[e0..e0 + l], &i00[e0 + 1..e0 + 1 + l]);
            let (vy, vz) = (&i10[e0..e0 + l], &i01[e0..e0 + l]);
            let out = &mut eb[e0..e0 + l];
            let mut nv = 0u32;
            for k in 0..l {
                let (x, y, z) = (v0[k] ^ vx[k], v0[k] ^ vy[k], v0[k] ^ vz[k]);
                out[k] = x | y << 1 | z << 2;
                nv += (x + y + z) as u32;
            }
            let mut nt = 0u32;
            if let (Some(r10), Some(r01), Some(r11)) = (r10, r01, r11) {
                let (c0, c1) = span(&[Some(r), Some(r10), Some(r01), Some(r11)], n[0] - 1);
                let rows4 = [i00, ins_row(r10), ins_row(r01), ins_row(r11)];
                cases_into(cases, rows4, c0, c1);
                for chunk in cases.chunks(8) {
                    if uniform(chunk) {
                        continue;
                    }
                    nt += chunk.iter().map(|&c| tab.count(c)).sum::<u32>();
                }
            }
            (nv, nt, e0, e1)
        })
        .collect();

    // Pass 4: prefix sums → exact output sizes and each row's offsets.
    let mut voff = Vec::with_capacity(rows + 1);
    let (mut sv, mut st) = (0usize, 0usize);
    for &(v, t, _, _) in &counts {
        voff.push(sv);
        sv += v as usize;
        st += t as usize;
    }
    voff.push(sv);
    assert!(sv <= u32::MAX as usize, "more than 2³² vertices");

    let mut vertices = vec![Point3::origin(); sv];
    let mut on_border = vec![false; sv];
    let mut triangles = vec![[0u32; 3]; st];
    let mut slices = Vec::with_capacity(rows);
    {
        let (mut vrest, mut brest, mut trest) =
            (&mut vertices[..], &mut on_border[..], &mut triangles[..]);
        for &(v, t, _, _) in &counts {
            let (va, vb) = vrest.split_at_mut(v as usize);
            let (ba, bb) = brest.split_at_mut(v as usize);
            let (ta, tb) = trest.split_at_mut(t as usize);
            slices.push((va, ba, ta));
            (vrest, brest, trest) = (vb, bb, tb);
        }
    }

    let m: &Matrix4 = vol.affine();
    // A mirroring affine turns outward index-space triangles inward.
    let flip = m.fixed_view::<3, 3>(0, 0).determinant() < 0.0;
    let mm: [[f64; 4]; 3] = [0, 1, 2].map(|r| [0, 1, 2, 3].map(|c| m[(r, c)]));
    let world = |p: [f64; 3]| {
        let row = |r: usize| mm[r][0] * p[0] + mm[r][1] * p[1] + mm[r][2] * p[2] + mm[r][3];
        Point3::new(row(0), row(1), row(2))
    };
    let data_row = |r: Option<usize>| -> Option<&[T]> {
        let vr = vrow(r?)?;
        Some(&data[vr * dx..(vr + 1) * dx])
    };

    // Pass 5: emit vertices (node row) and triangles (cell row).
    slices
        .into_par_iter()
        .with_min_len(16)
        .enumerate()
        .for_each_init(Vec::new, |cases, (r, (vs, bs, ts))| {
            let eb = &ebits[r * n[0]..(r + 1) * n[0]];
            let (_, _, e0, e1) = counts[r];
            if !vs.is_empty() {
                let (r10, r01) = (neighbour(r, 1, 0), neighbour(r, 0, 1));
                let rows3 = [data_row(Some(r)), data_row(r10), data_row(r01)];
                let (vj, vk) = (lo[1] + (r % n[1]) as i64, lo[2] + (r / n[1]) as i64);
                let sample = |q: usize, i: i64| -> Option<f64> {
                    let row = rows3[q]?;
                    (i >= 0 && (i as usize) < dx).then(|| row[i as usize].value())
                };
                let mut w = 0;
                let mut a = e0;
                while a < e1 {
                    // Skip eight nodes without a cut edge at once.
                    if a + 8 <= e1
                        && u64::from_le_bytes(eb[a..a + 8].try_into().expect("8 bytes")) == 0
                    {
                        a += 8;
                        continue;
                    }
                    let b = eb[a];
                    a += 1;
                    if b == 0 {
                        continue;
                    }
                    let a = a - 1;
                    let vi = lo[0] + a as i64;
                    let f0 = sample(0, vi);
                    for axis in 0..3 {
                        if b >> axis & 1 == 0 {
                            continue;
                        }
                        let f1 = match axis {
                            0 => sample(0, vi + 1),
                            1 => sample(1, vi),
                            _ => sample(2, vi),
                        };
                        // A padding node sits just outside: the vertex goes
                        // half-way, as if the mask continued to the border.
                        let t = match (f0, f1) {
                            (Some(x), Some(y)) => (iso - x) / (y - x),
                            _ => 0.5,
                        };
                        let mut p = [vi as f64, vj as f64, vk as f64];
                        p[axis] += t;
                        vs[w] = world(p);
                        bs[w] = f0.is_none() || f1.is_none();
                        w += 1;
                    }
                }
                debug_assert_eq!(w, vs.len());
            }
            if !ts.is_empty() {
                let ids = [
                    r,
                    neighbour(r, 1, 0).unwrap(),
                    neighbour(r, 0, 1).unwrap(),
                    neighbour(r, 1, 1).unwrap(),
                ];
                let (i00, i10, i01, i11) = (
                    ins_row(ids[0]),
                    ins_row(ids[1]),
                    ins_row(ids[2]),
                    ins_row(ids[3]),
                );
                let ebs = ids.map(|q| &ebits[q * n[0]..(q + 1) * n[0]]);
                let (c0, c1) = span(&ids.map(Some), n[0] - 1);
                // Running vertex id of node a in each of the four node rows:
                // the row's first id plus the cut edges before node a.
                let mut base = [0usize; 4];
                for q in 0..4 {
                    let from = counts[ids[q]].2.min(c0);
                    base[q] = voff[ids[q]]
                        + ebs[q][from..c0]
                            .iter()
                            .map(|b| b.count_ones() as usize)
                            .sum::<usize>();
                }
                cases_into(cases, [i00, i10, i01, i11], c0, c1);
                let mut w = 0;
                for (ci, chunk) in cases.chunks(8).enumerate() {
                    let a0 = c0 + 8 * ci;
                    if uniform(chunk) {
                        // No triangle here; the rows' cut edges still count.
                        for q in 0..4 {
                            base[q] += ebs[q][a0..a0 + chunk.len()]
                                .iter()
                                .map(|b| b.count_ones() as usize)
                                .sum::<usize>();
                        }
                        continue;
                    }
                    for (a, &case) in (a0..).zip(chunk) {
                        let tris = tab.triangles(case);
                        if !tris.is_empty() {
                            // Vertex id of each of the 12 cell edges.
                            let mut id = [0u32; 12];
                            for (e, slot) in id.iter_mut().enumerate() {
                                let [c, _] = EDGE_CORNERS[e];
                                let q = (c >> 1 & 1) as usize + 2 * (c >> 2) as usize;
                                let (node, axis) = ((c & 1) as usize, e / 4);
                                let mut v = base[q];
                                if node == 1 {
                                    v += ebs[q][a].count_ones() as usize;
                                }
                                let bits = ebs[q][a + node] & ((1u8 << axis) - 1);
                                *slot = (v + bits.count_ones() as usize) as u32;
                            }
                            for t in tris {
                                let v = t.map(|e| id[e as usize]);
                                ts[w] = if flip { [v[0], v[2], v[1]] } else { v };
                                w += 1;
                            }
                        }
                        for q in 0..4 {
                            base[q] += ebs[q][a].count_ones() as usize;
                        }
                    }
                }
                debug_assert_eq!(w, ts.len());
            }
        });

    Isosurface {
        vertices,
        triangles,
        on_border,
    }
}

/// Cases of cells [c0, c1) of a cell row from its four node rows
/// (y, z) = (0,0), (1,0), (0,1), (1,1); bit c of a case is corner
/// c = dx + 2·dy + 4·dz. Equal-length slices so the loop vectorises.
fn cases_into(out: &mut Vec<u8>, rows: [&[u8]; 4], c0: usize, c1: usize) {
    let l = c1.saturating_sub(c0);
    out.clear();
    out.resize(l, 0);
    let lo = rows.map(|r| &r[c0..c0 + l]);
    let hi = rows.map(|r| &r[c0 + 1..c0 + 1 + l]);
    for k in 0..l {
        out[k] = lo[0][k]
            | hi[0][k] << 1
            | lo[1][k] << 2
            | hi[1][k] << 3
            | lo[2][k] << 4
            | hi[2][k] << 5
            | lo[3][k] << 6
            | hi[3][k] << 7;
    }
}

/// All cells of the chunk entirely outside or entirely inside (no triangle).
#[inline]
fn uniform(chunk: &[u8]) -> bool {
    if let Ok(b) = <[u8; 8]>::try_from(chunk) {
        // One word compare instead of eight byte compares.
        let w = u64::from_le_bytes(b);
        return w == 0 || w == u64::MAX;
    }
    let first = chunk[0];
    (first == 0 || first == 255) && chunk.iter().all(|&c| c == first)
}
