//! Isoperimetric distance trees (Grady 2006; docs/segment.md).
//!
//! On the 6-connected lattice of the threshold region: a maximum spanning
//! tree weighted by the distance transform (it follows medial paths, so a
//! thin neck becomes a single tree edge), the isoperimetric system solved in
//! closed form on that tree with the seed as ground, the voxels ordered by
//! the solution, and a sweep that keeps the lattice cut of every prefix.

use super::morphology::neighbours6;

/// A spanning tree of the region: nodes in insertion order (parents first).
pub struct Tree {
    /// Grid index of each node, in insertion order; `order[0]` is the ground.
    pub order: Vec<u32>,
    /// Parent position in `order` (the ground points to itself).
    pub parent: Vec<u32>,
    /// Weight of the edge to the parent (mm; DT_v + DT_parent).
    pub weight: Vec<f64>,
}

/// Distances are bucketed at this resolution for the bucket-queue Prim;
/// the quantisation only decides ties between nearly equal edges.
const BUCKET_MM: f64 = 0.05;

/// Maximum spanning tree of the voxels reachable from `ground` inside
/// `region`, edge weight DT_i + DT_j. Prim with a bucket queue (O(E));
/// within a bucket, last in first out: deterministic.
pub fn max_spanning_tree(region: &[bool], dt: &[f32], dims: [usize; 3], ground: usize) -> Tree {
    // Per voxel, in one record so that looking at a neighbour costs one
    // cache miss: its state (tree position, FREE: region not yet in the
    // tree, OUT: not region), its bucket (computed once, not per pushed
    // edge) and its distance.
    const FREE: u32 = u32::MAX;
    const OUT: u32 = u32::MAX - 1;
    #[derive(Clone, Copy)]
    struct Node {
        pos: u32,
        q: u32,
        dt: f32,
    }
    let mut node: Vec<Node> = region
        .iter()
        .zip(dt)
        .map(|(&r, &d)| {
            if r {
                Node {
                    pos: FREE,
                    q: (d as f64 / BUCKET_MM).round().min(1e6) as u32,
                    dt: d,
                }
            } else {
                Node {
                    pos: OUT,
                    q: 0,
                    dt: d,
                }
            }
        })
        .collect();
    let count = node.iter().filter(|n| n.pos == FREE).count();
    let max_b = node.iter().map(|n| n.q).max().unwrap_or(0);
    // A queued edge carries what accepting it needs (the parent's tree
    // position and both distances): popped long after it was pushed, it
    // then costs one cache miss (the state of u), not four.
    let mut buckets: Vec<Vec<Edge>> = vec![Vec::new(); 2 * max_b as usize + 2];
    let mut tree = Tree {
        order: Vec::with_capacity(count),
        parent: Vec::with_capacity(count),
        weight: Vec::with_capacity(count),
    };
    node[ground].pos = 0;
    tree.order.push(ground as u32);
    tree.parent.push(0);
    tree.weight.push(0.0);
    let mut top = 0usize;
    let push =
        |v: usize, pv: u32, buckets: &mut Vec<Vec<Edge>>, top: &mut usize, node: &Vec<Node>| {
            let (qv, dv) = (node[v].q, node[v].dt);
            neighbours6(v, dims, |u| {
                let nu = node[u];
                if nu.pos == FREE {
                    let b = (nu.q + qv) as usize;
                    buckets[b].push(Edge {
                        u: u as u32,
                        parent: pv,
                        du: nu.dt,
                        dp: dv,
                    });
                    *top = (*top).max(b);
                }
            });
        };
    push(ground, 0, &mut buckets, &mut top, &node);
    loop {
        while top > 0 && buckets[top].is_empty() {
            top -= 1;
        }
        let Some(e) = buckets[top].pop() else {
            break;
        };
        let u = e.u as usize;
        if node[u].pos != FREE {
            continue;
        }
        let pu = tree.order.len() as u32;
        node[u].pos = pu;
        tree.order.push(e.u);
        tree.parent.push(e.parent);
        tree.weight.push(e.du as f64 + e.dp as f64);
        push(u, pu, &mut buckets, &mut top, &node);
    }
    tree
}

/// An edge waiting in the bucket queue.
#[derive(Clone, Copy)]
struct Edge {
    u: u32,
    /// Tree position of the end already in the tree.
    parent: u32,
    du: f32,
    dp: f32,
}

/// Closed-form solve of L₀ x₀ = d₀ on a tree (ground x = 0, unit node
/// volumes): S_v = size of v's subtree, x_v = x_parent + S_v / w_v.
/// Exact Gaussian elimination from the leaves to the root, O(N).
pub fn solve_on_tree(parent: &[u32], weight: &[f64]) -> Vec<f64> {
    let n = parent.len();
    let mut s = vec![1.0f64; n];
    for v in (1..n).rev() {
        let p = parent[v] as usize;
        s[p] += s[v];
    }
    let mut x = vec![0.0f64; n];
    for v in 1..n {
        x[v] = x[parent[v] as usize] + s[v] / weight[v];
    }
    x
}

/// Node positions (in tree order) sorted by `x`, ties by position: a total
/// order (f64::total_cmp, then position), so the result does not depend on
/// threading. An LSD radix sort on the keys' bits (stable, so positions stay
/// ascending within ties): linear, where a comparison sort of the 10⁶–10⁷
/// voxels of a full-size CT costs a random load of `x` per comparison.
pub fn order_by_potential(x: &[f64]) -> Vec<u32> {
    // The bit pattern ordered as total_cmp orders the floats.
    let key = |v: f64| {
        let b = v.to_bits();
        if b >> 63 == 1 { !b } else { b | (1 << 63) }
    };
    let mut a: Vec<(u64, u32)> = x
        .iter()
        .enumerate()
        .map(|(i, &v)| (key(v), i as u32))
        .collect();
    let mut b = vec![(0u64, 0u32); a.len()];
    const BITS: u32 = 11;
    const RADIX: usize = 1 << BITS;
    let mut shift = 0u32;
    while shift < 64 {
        let digit = |k: u64| ((k >> shift) as usize) & (RADIX - 1);
        let mut count = vec![0usize; RADIX];
        for &(k, _) in &a {
            count[digit(k)] += 1;
        }
        // A digit all keys share moves nothing: skip the pass.
        if count.contains(&a.len()) {
            shift += BITS;
            continue;
        }
        let mut start = 0;
        for c in count.iter_mut() {
            let n = *c;
            *c = start;
            start += n;
        }
        for &e in &a {
            let d = digit(e.0);
            b[count[d]] = e;
            count[d] += 1;
        }
        std::mem::swap(&mut a, &mut b);
        shift += BITS;
    }
    a.into_iter().map(|(_, i)| i).collect()
}

/// Lattice cut (unit-weight faces between S_k and the rest of the region)
/// after adding each voxel of `sweep` (grid indices) in turn.
pub fn sweep_cut(region: &[bool], dims: [usize; 3], sweep: &[u32]) -> Vec<u32> {
    let mut in_s = vec![false; region.len()];
    let mut cut: i64 = 0;
    let mut out = Vec::with_capacity(sweep.len());
    for &v in sweep {
        let v = v as usize;
        let (mut deg, mut ins) = (0i64, 0i64);
        neighbours6(v, dims, |u| {
            if region[u] {
                deg += 1;
                if in_s[u] {
                    ins += 1;
                }
            }
        });
        in_s[v] = true;
        cut += deg - 2 * ins;
        out.push(cut as u32);
    }
    out
}

/// Classic IDT: the prefix size k ≤ N/2 of least isoperimetric ratio cut/k.
pub fn isoperimetric_min(cut: &[u32], k_min: usize) -> Option<usize> {
    let n = cut.len();
    (k_min.max(1)..=n / 2).min_by(|&a, &b| {
        let ha = cut[a - 1] as f64 / a as f64;
        let hb = cut[b - 1] as f64 / b as f64;
        ha.total_cmp(&hb).then(a.cmp(&b))
    })
}

/// Volume limits of the steepest-rise rule, in voxels.
#[derive(Debug, Clone, Copy)]
pub struct RiseLimits {
    /// Smoothing window (1 ml).
    pub window: usize,
    /// The cut goes no earlier than this (the root and AA hold ≥ 10 ml).
    pub i_min: usize,
    /// … and no later than this (AA + LV ≤ 500 ml).
    pub i_max: usize,
    /// The rise ends at least this far on (20 ml) …
    pub j_min: usize,
    pub span_min: usize,
    /// … and grows the volume by at least this factor.
    pub ratio_min: f64,
    /// A chamber keeps the cut high: the rise is measured to the lowest
    /// smoothed cut over this much volume past its top (10 ml), so a
    /// transient bump (the sweep crossing the sinus level, 4–6 ml wide on
    /// the sample phantom without coronaries) does not count as one.
    pub hold: usize,
}

impl RiseLimits {
    pub fn from_ml(voxel_mm3: f64) -> Self {
        let ml = |v: f64| (v * 1000.0 / voxel_mm3).round() as usize;
        RiseLimits {
            window: ml(1.0).max(1),
            i_min: ml(10.0),
            i_max: ml(500.0),
            j_min: ml(20.0),
            span_min: ml(20.0),
            ratio_min: 1.2,
            hold: ml(10.0),
        }
    }
}

/// The volume-constrained steepest-rise rule: smooth cut(k) by a sliding
/// minimum then maximum (an opening over 1 ml, which removes the spikes of
/// side branches entering the sweep), take its alternating extrema, find
/// the extremum pair (i < j) of steepest rise (cut_j − cut_i)/(j − i) under
/// the volume limits (cut_j held: its lowest value over `hold` past j), and
/// return the prefix size where that rise has climbed a quarter of its
/// height past its lowest point: the region stops as the cut starts growing
/// fast (a leak into a larger chamber).
pub fn steepest_rise(cut: &[u32], lim: &RiseLimits) -> Option<usize> {
    let n = cut.len();
    if n < 3 {
        return None;
    }
    let f: Vec<f64> = cut.iter().map(|&c| c as f64).collect();
    let smooth = sliding(&sliding(&f, lim.window, false), lim.window, true);
    // Subsample at a quarter window: the extrema are then few.
    let step = (lim.window / 4).max(1);
    let pts: Vec<usize> = (0..n).step_by(step).chain(std::iter::once(n - 1)).collect();
    let mut ext: Vec<usize> = vec![pts[0]];
    for w in pts.windows(3) {
        let (a, b, c) = (smooth[w[0]], smooth[w[1]], smooth[w[2]]);
        if (b < a && b <= c) || (b > a && b >= c) {
            ext.push(w[1]);
        }
    }
    ext.push(n - 1);
    // The held cut depends on j alone: one linear pass, not a scan of the
    // 10 ml window (~10⁵ voxels on the full preset) per extremum pair.
    let ahead = forward_min(&smooth, lim.hold);
    let held: Vec<f64> = ext.iter().map(|&j| ahead[j]).collect();
    let mut best: Option<(f64, usize, usize)> = None;
    for (x, &i) in ext.iter().enumerate() {
        let k_i = i + 1;
        if k_i < lim.i_min || k_i > lim.i_max {
            continue;
        }
        for (&j, &held) in ext[x + 1..].iter().zip(&held[x + 1..]) {
            let k_j = j + 1;
            if k_j < lim.j_min
                || k_j - k_i < lim.span_min
                || (k_j as f64) < lim.ratio_min * k_i as f64
            {
                continue;
            }
            let slope = (held - smooth[i]) / (k_j - k_i) as f64;
            if best.is_none_or(|(s, _, _)| slope > s) {
                best = Some((slope, i, j));
            }
        }
    }
    // The pair locates the rise; the stop is where the rise really starts:
    // the first point past the lowest section between the pair (the LVOT)
    // where the smoothed cut has climbed a quarter of the way to the top of
    // the rise. Stopping at the lowest section itself would be too early:
    // the sinus pockets hang off the tree's trunk and are swept after parts
    // of the LVOT (measured on the sample phantoms); what the sweep adds past
    // the annulus is removed by the VAJ cut.
    let (slope, i, j) = best?;
    if slope <= 0.0 {
        return None;
    }
    let low = (i..=j).min_by(|&a, &b| smooth[a].total_cmp(&smooth[b]).then(b.cmp(&a)))?;
    let top = smooth[low..=j]
        .iter()
        .cloned()
        .fold(f64::NEG_INFINITY, f64::max);
    let level = smooth[low] + RISE_FRACTION * (top - smooth[low]);
    let stop = (low..=j).find(|&x| smooth[x] > level).unwrap_or(j);
    Some(stop.max(1))
}

/// Fraction of the rise after which the sweep is stopped.
const RISE_FRACTION: f64 = 0.25;

/// `out[j]` = min of `f[j..=j + w]` (clipped to the end), by a monotone
/// deque from the right: O(n) whatever `w`.
pub(super) fn forward_min(f: &[f64], w: usize) -> Vec<f64> {
    let n = f.len();
    let mut out = vec![0.0; n];
    let mut dq: std::collections::VecDeque<usize> = std::collections::VecDeque::new();
    for j in (0..n).rev() {
        while dq.back().is_some_and(|&b| f[b] >= f[j]) {
            dq.pop_back();
        }
        dq.push_back(j);
        while dq.front().is_some_and(|&a| a > j + w) {
            dq.pop_front();
        }
        out[j] = f[*dq.front().expect("holds j")];
    }
    out
}

/// Sliding minimum (`max == false`) or maximum over a centred window.
fn sliding(f: &[f64], window: usize, max: bool) -> Vec<f64> {
    let n = f.len();
    let h = window / 2;
    let better = |a: f64, b: f64| if max { a >= b } else { a <= b };
    let mut out = vec![0.0; n];
    let mut dq: std::collections::VecDeque<usize> = std::collections::VecDeque::new();
    let mut next = 0usize;
    for (x, o) in out.iter_mut().enumerate() {
        let hi = (x + h).min(n - 1);
        while next <= hi {
            while let Some(&b) = dq.back() {
                if better(f[next], f[b]) {
                    dq.pop_back();
                } else {
                    break;
                }
            }
            dq.push_back(next);
            next += 1;
        }
        let lo = x.saturating_sub(h);
        while let Some(&a) = dq.front() {
            if a < lo {
                dq.pop_front();
            } else {
                break;
            }
        }
        *o = f[*dq.front().expect("window not empty")];
    }
    out
}
