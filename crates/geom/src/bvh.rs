//! A small axis-aligned bounding-box tree over the triangles of a mesh
//! (the broad phase of the closest-point and intersection searches).
//!
//! Built once by median split on the longest axis of the triangle
//! centroids (leaves hold at most [`LEAF_SIZE`] triangles), then kept up to
//! date by [`Bvh::refit`], which recomputes the boxes bottom-up for new
//! positions without changing the topology. Boxes are tight; queries inflate
//! the query box instead (by the contact reach), which is equivalent to
//! inflating every box by the same amount.
//!
//! Determinism: the build orders triangles by (centroid coordinate, index),
//! so the tree, and the order in which queries visit triangles, depends only
//! on the input, never on hashing or threads.
//!
//! Non-finite triangles (any vertex coordinate NaN or ±∞) get an empty box
//! and are never visited.

use super::Vector3 as V3;

/// Maximum number of triangles in a leaf.
pub const LEAF_SIZE: usize = 4;

/// Axis-aligned box `[min, max]`. Empty when `min > max` on some axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    pub min: V3,
    pub max: V3,
}

impl Aabb {
    /// The empty box (contains nothing, overlaps nothing).
    pub fn empty() -> Aabb {
        Aabb {
            min: V3::repeat(f64::INFINITY),
            max: V3::repeat(f64::NEG_INFINITY),
        }
    }

    /// The cube `center ± half` (the broad phase queries a box of ±m, the
    /// contact margin, about each node).
    pub fn around(center: &V3, half: f64) -> Aabb {
        Aabb {
            min: center - V3::repeat(half),
            max: center + V3::repeat(half),
        }
    }

    pub fn is_empty(&self) -> bool {
        !(self.min.x <= self.max.x && self.min.y <= self.max.y && self.min.z <= self.max.z)
    }

    /// Box of a triangle; empty when a coordinate is not finite.
    pub fn of_triangle(a: &V3, b: &V3, c: &V3) -> Aabb {
        if !(finite(a) && finite(b) && finite(c)) {
            return Aabb::empty();
        }
        Aabb {
            min: a.inf(b).inf(c),
            max: a.sup(b).sup(c),
        }
    }

    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.inf(&o.min),
            max: self.max.sup(&o.max),
        }
    }

    /// Closed overlap test (touching boxes overlap). False for empty boxes.
    #[inline]
    pub fn overlaps(&self, o: &Aabb) -> bool {
        self.min.x <= o.max.x
            && o.min.x <= self.max.x
            && self.min.y <= o.max.y
            && o.min.y <= self.max.y
            && self.min.z <= o.max.z
            && o.min.z <= self.max.z
    }

    /// `o ⊆ self` (an empty `o` is contained in anything).
    pub fn contains(&self, o: &Aabb) -> bool {
        o.is_empty()
            || (self.min.x <= o.min.x
                && self.min.y <= o.min.y
                && self.min.z <= o.min.z
                && o.max.x <= self.max.x
                && o.max.y <= self.max.y
                && o.max.z <= self.max.z)
    }

    /// Squared distance from `p` to the box (0 inside).
    #[inline]
    pub fn dist2(&self, p: &V3) -> f64 {
        let mut s = 0.0;
        for k in 0..3 {
            let d = (self.min[k] - p[k]).max(p[k] - self.max[k]).max(0.0);
            s += d * d;
        }
        s
    }
}

fn finite(v: &V3) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

#[derive(Debug, Clone)]
struct Node {
    aabb: Aabb,
    /// Leaf: first index into `order`; inner: index of the left child
    /// (the right child is `right`).
    first: u32,
    /// Leaf: number of triangles (≥ 1); inner: 0.
    count: u32,
    right: u32,
}

/// AABB tree over a set of triangles (global triangle indices).
#[derive(Debug, Clone)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Triangle indices, leaves reference contiguous ranges.
    order: Vec<u32>,
    /// The triangles' vertex indices, kept for `refit`.
    tris: Vec<[u32; 3]>,
    /// Current box of every triangle (global index; only the tree's
    /// triangles are kept up to date).
    tri_boxes: Vec<Aabb>,
    /// Per tree node, the groups (bodies) of its triangles as bits
    /// ([`group_bit`]); empty until [`Bvh::set_groups`].
    groups: Vec<u64>,
}

/// The bit of group `g` in a node's group mask; groups from 63 on share
/// the last bit (such a node is never skipped for them).
fn group_bit(g: u16) -> u64 {
    1u64 << u32::from(g.min(63))
}

impl Bvh {
    /// Tree over all triangles of the mesh.
    pub fn build(x: &[V3], tris: &[[u32; 3]]) -> Bvh {
        let ids: Vec<u32> = (0..tris.len() as u32).collect();
        Bvh::build_subset(x, tris, &ids)
    }

    /// Tree over the triangles `ids` only (e.g. one body); queries report the
    /// global indices.
    pub fn build_subset(x: &[V3], tris: &[[u32; 3]], ids: &[u32]) -> Bvh {
        let mut bvh = Bvh {
            nodes: Vec::with_capacity(2 * ids.len() / LEAF_SIZE + 2),
            order: ids.to_vec(),
            tris: tris.to_vec(),
            tri_boxes: vec![Aabb::empty(); tris.len()],
            groups: Vec::new(),
        };
        for &t in ids {
            bvh.tri_boxes[t as usize] = tri_box(x, &tris[t as usize]);
        }
        let boxes = bvh.tri_boxes.clone();
        let cent: Vec<V3> = boxes
            .iter()
            .map(|b| {
                if b.is_empty() {
                    V3::zeros()
                } else {
                    (b.min + b.max) * 0.5
                }
            })
            .collect();
        if !ids.is_empty() {
            let n = ids.len();
            bvh.build_rec(&boxes, &cent, 0, n);
        }
        bvh
    }

    /// Builds the node for `order[lo..hi]`, returns its index (pre-order:
    /// children always come after their parent).
    fn build_rec(&mut self, boxes: &[Aabb], cent: &[V3], lo: usize, hi: usize) -> u32 {
        let idx = self.nodes.len() as u32;
        let mut bb = Aabb::empty();
        let mut cb = Aabb::empty();
        for &t in &self.order[lo..hi] {
            bb = bb.union(&boxes[t as usize]);
            let c = cent[t as usize];
            cb = cb.union(&Aabb { min: c, max: c });
        }
        self.nodes.push(Node {
            aabb: bb,
            first: lo as u32,
            count: (hi - lo) as u32,
            right: 0,
        });
        if hi - lo <= LEAF_SIZE {
            return idx;
        }
        let ext = cb.max - cb.min;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let mid = lo + (hi - lo) / 2;
        // Total order (coordinate, index): deterministic median split.
        self.order[lo..hi].select_nth_unstable_by(mid - lo, |&a, &b| {
            cent[a as usize][axis]
                .total_cmp(&cent[b as usize][axis])
                .then(a.cmp(&b))
        });
        let left = self.build_rec(boxes, cent, lo, mid);
        let right = self.build_rec(boxes, cent, mid, hi);
        let n = &mut self.nodes[idx as usize];
        n.first = left;
        n.count = 0;
        n.right = right;
        idx
    }

    /// Recomputes every box bottom-up for the positions `x` (same
    /// triangles, same topology).
    pub fn refit(&mut self, x: &[V3]) {
        for &t in &self.order {
            self.tri_boxes[t as usize] = tri_box(x, &self.tris[t as usize]);
        }
        for i in (0..self.nodes.len()).rev() {
            let n = &self.nodes[i];
            let bb = if n.count > 0 {
                let (f, c) = (n.first as usize, n.count as usize);
                self.order[f..f + c]
                    .iter()
                    .fold(Aabb::empty(), |b, &t| b.union(&self.tri_boxes[t as usize]))
            } else {
                self.nodes[n.first as usize]
                    .aabb
                    .union(&self.nodes[n.right as usize].aabb)
            };
            self.nodes[i].aabb = bb;
        }
    }

    /// Labels every triangle with a group (`group[t]`, e.g. its leaflet),
    /// so [`Bvh::query_aabb_apart`] and [`Bvh::query_sphere_apart`] can skip
    /// whole subtrees of one group. The labels depend on the topology only:
    /// refits keep them.
    pub fn set_groups(&mut self, group: &[u16]) {
        let mut m = vec![0u64; self.nodes.len()];
        // Pre-order: children come after their parent.
        for i in (0..self.nodes.len()).rev() {
            let n = &self.nodes[i];
            m[i] = if n.count > 0 {
                let (f, c) = (n.first as usize, n.count as usize);
                self.order[f..f + c].iter().fold(0, |b, &t| {
                    b | group.get(t as usize).map_or(!0, |&g| group_bit(g))
                })
            } else {
                m[n.first as usize] | m[n.right as usize]
            };
        }
        self.groups = m;
    }

    /// [`Bvh::query_aabb`] without the subtrees that hold only triangles of
    /// group `g` (after [`Bvh::set_groups`]; otherwise none is skipped):
    /// the same triangles of other groups in the same order. Triangles of
    /// `g` in mixed leaves are still reported.
    pub fn query_aabb_apart(&self, query: &Aabb, g: u16, mut f: impl FnMut(u32)) {
        self.traverse_apart(|b| b.overlaps(query), g, &mut f);
    }

    /// [`Bvh::query_sphere`] without the subtrees that hold only triangles
    /// of group `g` (as [`Bvh::query_aabb_apart`]).
    pub fn query_sphere_apart(&self, center: &V3, radius: f64, g: u16, mut f: impl FnMut(u32)) {
        let r2 = radius * radius;
        if !(finite(center) && r2.is_finite()) {
            return;
        }
        self.traverse_apart(|b| !b.is_empty() && b.dist2(center) <= r2, g, &mut f);
    }

    fn traverse_apart(&self, hit: impl Fn(&Aabb) -> bool, g: u16, f: &mut impl FnMut(u32)) {
        if self.groups.len() != self.nodes.len() || g >= 63 {
            return self.traverse(hit, f);
        }
        let own = group_bit(g);
        self.walk(hit, |i| self.groups[i] & !own == 0, f);
    }

    /// Number of triangles in the tree.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// Number of tree nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Quality of the tree for the current boxes: the summed surface area of
    /// all node boxes divided by the root's (≈ expected number of nodes a
    /// random query visits). Refits keep the topology, so this grows as the
    /// mesh deforms; rebuild when it exceeds, say, 1.5× its value right
    /// after the last build.
    pub fn cost(&self) -> f64 {
        let area = |b: &Aabb| {
            if b.is_empty() {
                return 0.0;
            }
            let e = b.max - b.min;
            2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
        };
        let root = self.nodes.first().map_or(0.0, |n| area(&n.aabb));
        if root <= 0.0 {
            return self.nodes.len() as f64;
        }
        self.nodes.iter().map(|n| area(&n.aabb)).sum::<f64>() / root
    }

    /// Box of the whole tree (empty for an empty tree).
    pub fn root_box(&self) -> Aabb {
        self.nodes.first().map_or(Aabb::empty(), |n| n.aabb)
    }

    /// Calls `f(tri)` for every triangle whose box overlaps `query`
    /// (closed test), in a deterministic order.
    pub fn query_aabb(&self, query: &Aabb, mut f: impl FnMut(u32)) {
        self.traverse(|b| b.overlaps(query), &mut f);
    }

    /// Calls `f(tri)` for every triangle whose box is within `radius` of
    /// `center` (i.e. the box inflated by `radius` meets the point; this is
    /// the sphere–box test, tighter than the sphere's bounding box).
    pub fn query_sphere(&self, center: &V3, radius: f64, mut f: impl FnMut(u32)) {
        let r2 = radius * radius;
        if !(finite(center) && r2.is_finite()) {
            return;
        }
        self.traverse(|b| !b.is_empty() && b.dist2(center) <= r2, &mut f);
    }

    fn traverse(&self, hit: impl Fn(&Aabb) -> bool, f: &mut impl FnMut(u32)) {
        self.walk(hit, |_| false, f);
    }

    /// Depth-first over the nodes whose boxes `hit` and that `skip` does
    /// not rule out (by node index), reporting the leaves' triangles whose
    /// boxes hit.
    fn walk(
        &self,
        hit: impl Fn(&Aabb) -> bool,
        skip: impl Fn(usize) -> bool,
        f: &mut impl FnMut(u32),
    ) {
        if self.nodes.is_empty() {
            return;
        }
        // Median splits give a balanced tree: depth ≤ log2(n) + 1, so a
        // fixed stack of 64 entries never overflows.
        let mut stack = [0u32; 64];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let i = stack[top] as usize;
            let n = &self.nodes[i];
            if skip(i) || !hit(&n.aabb) {
                continue;
            }
            if n.count > 0 {
                let (fst, c) = (n.first as usize, n.count as usize);
                for &t in &self.order[fst..fst + c] {
                    // Leaves hold up to four triangles: test each box.
                    if c == 1 || hit(&self.tri_boxes[t as usize]) {
                        f(t);
                    }
                }
            } else {
                stack[top] = n.right;
                stack[top + 1] = n.first;
                top += 2;
            }
        }
    }

    /// Current box of triangle `t` (as of the last build or refit).
    pub fn tri_box(&self, t: u32) -> Aabb {
        self.tri_boxes[t as usize]
    }

    /// Verifies the tree: every triangle appears exactly once, every leaf
    /// box contains its triangles' boxes for positions `x`, and every inner
    /// box contains its children's boxes.
    pub fn sanity_check(&self, x: &[V3]) -> Result<(), String> {
        let mut seen = vec![0u32; self.tris.len()];
        let mut reached = vec![false; self.nodes.len()];
        let mut stack = vec![];
        if !self.nodes.is_empty() {
            stack.push(0u32);
        }
        while let Some(i) = stack.pop() {
            let iu = i as usize;
            if iu >= self.nodes.len() || reached[iu] {
                return Err(format!("node {i} out of range or reached twice"));
            }
            reached[iu] = true;
            let n = &self.nodes[iu];
            if n.count > 0 {
                let (f, c) = (n.first as usize, n.count as usize);
                if c > LEAF_SIZE || f + c > self.order.len() {
                    return Err(format!("leaf {i}: bad range {f}+{c}"));
                }
                for &t in &self.order[f..f + c] {
                    seen[t as usize] += 1;
                    let tb = tri_box(x, &self.tris[t as usize]);
                    if !n.aabb.contains(&tb) {
                        return Err(format!("leaf {i} box does not contain triangle {t}"));
                    }
                }
            } else {
                for ch in [n.first, n.right] {
                    if ch <= i || ch as usize >= self.nodes.len() {
                        return Err(format!("node {i}: bad child {ch}"));
                    }
                    if !n.aabb.contains(&self.nodes[ch as usize].aabb) {
                        return Err(format!("node {i} box does not contain child {ch}"));
                    }
                    stack.push(ch);
                }
            }
        }
        if let Some(i) = reached.iter().position(|r| !r) {
            return Err(format!("node {i} unreachable"));
        }
        for &t in &self.order {
            if seen[t as usize] != 1 {
                return Err(format!("triangle {t} appears {} times", seen[t as usize]));
            }
        }
        Ok(())
    }
}

fn tri_box(x: &[V3], t: &[u32; 3]) -> Aabb {
    Aabb::of_triangle(&x[t[0] as usize], &x[t[1] as usize], &x[t[2] as usize])
}
