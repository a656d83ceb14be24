//! Marching cubes in flying-edges passes over x-rows, on bit rows.
//!
//! The volume is seen through a one-node frame of "outside" around the grid
//! (the padding that closes surfaces touching the grid border). Every node is
//! one bit: node (i, j, k) is bit i + 1 of the bit row (j + 1, k + 1), so a
//! 512-sample row is nine u64 words and 64 edges or cells are classified by a
//! handful of word operations. Passes:
//! 1. the one full read: inside bits of every row (64 samples → one word),
//!    and the bounding box of the inside bits;
//! 2. per node row of the box: cut x/y/z edges are `a ^ (a >> 1)`, `a ^ a_y`,
//!    `a ^ a_z` and the vertex count is their popcount; per cell row the cells
//!    that are neither all in nor all out are `or8 & !and8` of the four rows
//!    and their shifts, and only those are looked up in the triangle table;
//! 3. prefix sums give every row its exact slice of the output arrays;
//! 4. per row: vertices in node order (x, y, z edge), then triangles, whose
//!    vertex ids are the row's first id plus popcounts of the cut edges before
//!    the node. No hash map, no welding, no per-cell array: an edge's vertex
//!    is made once, by the row that owns the edge's lower node.
//!
//! Rows are independent, so every pass runs in parallel with rayon and the
//! output does not depend on the thread count.

use std::mem::MaybeUninit;
use std::sync::OnceLock;

use rayon::prelude::*;

use super::huge_pages::advise_huge_pages;
use super::tables::{CaseTable, EDGE_CORNERS, table};
use coapt_geom::{Matrix4, Point3, Volume};

/// Sample types the extractor reads.
pub trait Sample: Copy + Send + Sync {
    /// What the inside test compares against (an integer for integer samples,
    /// so that the classification loops vectorise).
    type Threshold: Copy + Send + Sync;
    fn threshold(iso: f64) -> Self::Threshold;
    /// value > iso
    fn above(self, t: Self::Threshold) -> bool;
    fn value(self) -> f64;
    /// Bit k set when `s[k]` is above `t`; `s` has at most 64 samples.
    #[inline]
    fn bits(s: &[Self], t: Self::Threshold) -> u64 {
        pack(s, |v| v.above(t))
    }
    /// Whether every sample of `s` is 0 or 1 (then an edge's interpolation
    /// weight follows from its lower node's bit and the samples need not be
    /// read again). Types without a cheap test say no.
    #[inline]
    fn zero_one(_s: &[Self]) -> bool {
        false
    }
}

/// Bit k set when `f(s[k])`, for at most 64 samples: the compares go to a
/// byte array (a vectorised loop), eight bytes of 0/1 become eight bits by
/// one multiply.
#[inline]
fn pack<T: Copy>(s: &[T], f: impl Fn(T) -> bool) -> u64 {
    let mut b = [0u8; 64];
    for (o, &v) in b.iter_mut().zip(s) {
        *o = f(v) as u8;
    }
    let mut m = 0;
    for (k, c) in b.chunks_exact(8).enumerate() {
        let x = u64::from_le_bytes(c.try_into().expect("8 bytes"));
        // Byte i (0 or 1) lands on bit 56 + i of the product.
        m |= (x.wrapping_mul(0x0102_0408_1020_4080) >> 56) << (8 * k);
    }
    m
}

/// [`pack`] for whole 64-sample chunks of the integer types: the pass that
/// reads the volume is then bound by memory, not by the compares. SSE2 is
/// part of x86-64, so no run-time test is needed.
#[cfg(target_arch = "x86_64")]
pub(super) mod simd {
    use std::arch::x86_64::*;

    /// Bit k set when `s[k] > t`; `s` has 64 samples.
    #[inline]
    pub fn bits_u8(s: &[u8], t: u8) -> u64 {
        assert_eq!(s.len(), 64);
        // SAFETY: SSE2 is part of every x86-64 CPU; the loads read bytes
        // 16q..16q + 16 of `s`, which has 64 (checked), unaligned.
        unsafe {
            // SSE2 compares signed bytes: flipping the top bit of both sides
            // turns the unsigned order into the signed one.
            let bias = _mm_set1_epi8(i8::MIN);
            let tv = _mm_xor_si128(_mm_set1_epi8(t as i8), bias);
            let mut m = 0u64;
            for q in 0..4 {
                let v = _mm_loadu_si128(s.as_ptr().add(16 * q).cast());
                let gt = _mm_cmpgt_epi8(_mm_xor_si128(v, bias), tv);
                m |= (_mm_movemask_epi8(gt) as u32 as u64) << (16 * q);
            }
            m
        }
    }

    /// Bit k set when `s[k] > t`; `s` has 64 samples.
    #[inline]
    pub fn bits_i16(s: &[i16], t: i16) -> u64 {
        assert_eq!(s.len(), 64);
        // SAFETY: SSE2 is part of every x86-64 CPU; the loads read samples
        // 16q..16q + 16 of `s`, which has 64 (checked), unaligned.
        unsafe {
            let tv = _mm_set1_epi16(t);
            let mut m = 0u64;
            for q in 0..4 {
                let p = s.as_ptr().add(16 * q);
                let (a, b) = (_mm_loadu_si128(p.cast()), _mm_loadu_si128(p.add(8).cast()));
                // 0 / -1 lanes saturate to 0 / -1 bytes, in sample order.
                let gt = _mm_packs_epi16(_mm_cmpgt_epi16(a, tv), _mm_cmpgt_epi16(b, tv));
                m |= (_mm_movemask_epi8(gt) as u32 as u64) << (16 * q);
            }
            m
        }
    }
}

/// All `n` ≤ 64 low bits.
#[inline]
fn low_bits(n: usize) -> u64 {
    if n >= 64 { !0 } else { (1 << n) - 1 }
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
    #[inline]
    fn bits(s: &[u8], t: i16) -> u64 {
        // Compare bytes with a byte (no widening); t ∈ [-1, 255].
        match u8::try_from(t) {
            #[cfg(target_arch = "x86_64")]
            Ok(t) if s.len() == 64 => simd::bits_u8(s, t),
            Ok(t) => pack(s, |v| v > t),
            Err(_) if t < 0 => low_bits(s.len()),
            Err(_) => 0,
        }
    }
    #[inline]
    fn zero_one(s: &[u8]) -> bool {
        s.iter().fold(0, |m, &v| m | v) <= 1
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
    #[inline]
    fn bits(s: &[i16], t: i32) -> u64 {
        // Compare 16-bit lanes with a 16-bit threshold; t ∈ [-32769, 32767].
        match i16::try_from(t) {
            #[cfg(target_arch = "x86_64")]
            Ok(t) if s.len() == 64 => simd::bits_i16(s, t),
            Ok(t) => pack(s, |v| v > t),
            Err(_) if t < 0 => low_bits(s.len()),
            Err(_) => 0,
        }
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

/// Inside bits of the padded node grid, `w` words per row, rows (j + 1) +
/// ny·(k + 1); only words [w0, w1) of a row can hold a cut edge or cell.
struct BitGrid {
    words: Vec<u64>,
    w: usize,
    ny: usize,
    nz: usize,
    w0: usize,
    w1: usize,
    zeros: Vec<u64>,
}

impl BitGrid {
    /// Words [w0, w1) of padded row (jp, kp); zeros beyond the grid.
    #[inline]
    fn row(&self, jp: usize, kp: usize) -> &[u64] {
        if jp < self.ny && kp < self.nz {
            let s = (jp + self.ny * kp) * self.w;
            &self.words[s + self.w0..s + self.w1]
        } else {
            &self.zeros[..self.w1 - self.w0]
        }
    }
}

/// Node (x) and its successor's bit (x + 1) for the 64 nodes of word `x`.
#[inline]
fn shifted(a: &[u64], x: usize) -> u64 {
    // The word after the span is all outside (see `BitGrid::w1`).
    a[x] >> 1 | a.get(x + 1).map_or(0, |n| n << 63)
}

/// Cut x, y and z edges of the 64 nodes of word `x` of node row `a`, whose
/// +y and +z neighbour rows are `ay` and `az`.
#[inline]
fn cut_edges(a: &[u64], ay: &[u64], az: &[u64], x: usize) -> [u64; 3] {
    [a[x] ^ shifted(a, x), a[x] ^ ay[x], a[x] ^ az[x]]
}

/// Cells of word `x` of a cell row (node rows (y, z) = (0,0), (1,0), (0,1),
/// (1,1)) with both inside and outside corners: the only ones with triangles.
#[inline(always)] // out of line it cost a call per word in two hot loops
fn mixed_cells(rows: &[&[u64]; 4], x: usize) -> (u64, [u64; 4], [u64; 4]) {
    // Written out: `array::map` stayed an out-of-line call in the hot loops.
    let lo = [rows[0][x], rows[1][x], rows[2][x], rows[3][x]];
    let hi = [
        shifted(rows[0], x),
        shifted(rows[1], x),
        shifted(rows[2], x),
        shifted(rows[3], x),
    ];
    let all = lo.iter().chain(&hi).fold(!0, |m, w| m & w);
    let any = lo.iter().chain(&hi).fold(0, |m, w| m | w);
    (any & !all, lo, hi)
}

/// Case of cell `p` of a word; bit c is corner c = dx + 2·dy + 4·dz.
#[inline]
fn case_of(lo: &[u64; 4], hi: &[u64; 4], p: u32) -> u8 {
    let mut c = 0u8;
    for q in 0..4 {
        c |= ((lo[q] >> p & 1) as u8) << (2 * q);
        c |= ((hi[q] >> p & 1) as u8) << (2 * q + 1);
    }
    c
}

/// Byte i: how many of bits 8i..8i+8 of the three words are set (≤ 24).
/// The target has no popcount instruction, so the three words share one
/// bit-slicing count, and one multiply turns bytes into prefix sums.
#[inline]
fn byte_counts3(e: &[u64; 3]) -> u64 {
    const M1: u64 = 0x5555_5555_5555_5555;
    const M2: u64 = 0x3333_3333_3333_3333;
    const M4: u64 = 0x0f0f_0f0f_0f0f_0f0f;
    // Nibbles of each word count ≤ 4; summed over three words ≤ 12.
    let nib = |x: u64| {
        let x = x - (x >> 1 & M1);
        (x & M2) + (x >> 2 & M2)
    };
    let s = nib(e[0]) + nib(e[1]) + nib(e[2]);
    (s & M4) + (s >> 4 & M4)
}

/// Byte i: the set bits of the three words below bit 8(i + 1) (≤ 192).
#[inline]
fn prefix_counts3(e: &[u64; 3]) -> u64 {
    byte_counts3(e).wrapping_mul(0x0101_0101_0101_0101)
}

/// Set bits of the three words below bit `p` < 64, from their prefix counts.
#[inline]
fn count_below(e: &[u64; 3], prefix: u64, p: u32) -> u32 {
    let byte = p / 8;
    let whole = if byte == 0 {
        0
    } else {
        (prefix >> (8 * byte - 8) & 0xff) as u32
    };
    let low = (1u32 << (p % 8)) - 1;
    let part = |x: u64| POP8[(x >> (8 * byte)) as usize & low as usize] as u32;
    whole + part(e[0]) + part(e[1]) + part(e[2])
}

/// Set bits of every byte value.
const POP8: [u8; 256] = {
    let mut t = [0u8; 256];
    let mut i = 0;
    while i < 256 {
        t[i] = (i as u32).count_ones() as u8;
        i += 1;
    }
    t
};

#[inline(never)] // one symbol per pass in profiles
/// Pass 1: the padded bit grid, the box of inside nodes in padded
/// coordinates ([lo, hi] per axis, bit / row index), and whether every sample
/// is 0 or 1 ([`Sample::zero_one`]); `None` when nothing is inside.
fn classify<T: Sample>(
    data: &[T],
    dims: [usize; 3],
    thr: T::Threshold,
) -> Option<(BitGrid, [[usize; 2]; 3], bool)> {
    let [dx, dy, dz] = dims;
    let (ny, nz) = (dy + 2, dz + 2);
    let w = (dx + 2).div_ceil(64);
    let n = w * ny * nz;
    // Every word is written once below, so the grid is not zeroed first (a
    // serial memset when the allocator reuses memory).
    let mut words = Vec::with_capacity(n);
    advise_huge_pages(&mut words.spare_capacity_mut()[..n]);
    let extent: Vec<(u32, u32, bool)> = words.spare_capacity_mut()[..n]
        .par_chunks_mut(w)
        .with_min_len(64)
        .enumerate()
        .map(|(r, out)| {
            let (jp, kp) = (r % ny, r / ny);
            if jp == 0 || kp == 0 || jp > dy || kp > dz {
                out.fill(MaybeUninit::new(0));
                return (0, 0, true);
            }
            let vr = (jp - 1) + dy * (kp - 1);
            let row = &data[vr * dx..(vr + 1) * dx];
            // Sample i is bit i + 1: each word takes its chunk shifted up by
            // one and the top bit of the chunk before.
            let mut chunks = row.chunks(64);
            let (mut carry, mut first, mut last) = (0, None, 0);
            for (c, o) in out.iter_mut().enumerate() {
                let m = chunks.next().map_or(0, |s| T::bits(s, thr));
                let word = m << 1 | carry;
                carry = m >> 63;
                o.write(word);
                if word != 0 {
                    let f = 64 * c + word.trailing_zeros() as usize;
                    first.get_or_insert(f);
                    last = 64 * c + 63 - word.leading_zeros() as usize;
                }
            }
            // The row is in L1 now: the 0/1 test costs no memory traffic.
            let zero_one = T::zero_one(row);
            match first {
                Some(f) => (f as u32, last as u32 + 1, zero_one),
                None => (0, 0, zero_one),
            }
        })
        .collect();
    // SAFETY: the chunks cover the first `n` slots and every slot of every
    // chunk was written above.
    unsafe { words.set_len(n) };
    let zero_one = extent.iter().all(|e| e.2);
    let mut lo = [usize::MAX; 3];
    let mut hi = [0usize; 3];
    for (r, &(f, l, _)) in extent.iter().enumerate() {
        if l > f {
            let (jp, kp) = (r % ny, r / ny);
            lo = [lo[0].min(f as usize), lo[1].min(jp), lo[2].min(kp)];
            hi = [hi[0].max(l as usize - 1), hi[1].max(jp), hi[2].max(kp)];
        }
    }
    if lo[0] == usize::MAX {
        return None;
    }
    // Cut edges and cells start one node before the first inside node and end
    // at the last one; the word after `w1` is all outside (it holds bits above
    // hi + 1, or lies beyond the row).
    let (w0, w1) = ((lo[0] - 1) / 64, (hi[0] + 1) / 64 + 1);
    let w1 = w1.min(w);
    let grid = BitGrid {
        words,
        w,
        ny,
        nz,
        w0,
        w1,
        zeros: vec![0; w1 - w0],
    };
    Some((grid, [0, 1, 2].map(|a| [lo[a] - 1, hi[a] + 1]), zero_one))
}

/// Extract the `iso` surface of `vol` (inside: value > iso) in world
/// coordinates, closed at the grid border, outward-facing.
pub fn extract<T: Sample>(vol: &Volume<T>, iso: f64) -> Isosurface {
    extract_with(vol, iso, Emit::Fast { hw: hw_popcount() })
}

/// Whether this CPU counts the bits of a word in one instruction. The build
/// targets plain x86-64, where `count_ones` is a dozen instructions, so the
/// two bit-counting passes come in a popcnt variant chosen at run time; both
/// compute the same integers.
fn hw_popcount() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("popcnt") && std::arch::is_x86_feature_detected!("bmi1")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// [`extract`] without the popcnt variants, as on a CPU without popcnt.
#[cfg(test)]
pub(super) fn extract_portable<T: Sample>(vol: &Volume<T>, iso: f64) -> Isosurface {
    extract_with(vol, iso, Emit::Fast { hw: false })
}

/// The same surface through the plain per-vertex emission loops that the
/// branch-free ones replaced: the tests' reference for them.
#[cfg(test)]
pub(super) fn extract_reference<T: Sample>(vol: &Volume<T>, iso: f64) -> Isosurface {
    extract_with(vol, iso, Emit::Reference)
}

#[derive(Clone, Copy)]
enum Emit {
    Fast {
        hw: bool,
    },
    #[cfg(test)]
    Reference,
}

fn extract_with<T: Sample>(vol: &Volume<T>, iso: f64, how: Emit) -> Isosurface {
    let thr = T::threshold(iso);
    let dims = vol.dims();
    let data = vol.as_slice();
    if data.is_empty() {
        return Isosurface::default();
    }
    let Some((g, bx, zero_one)) = classify(data, dims, thr) else {
        return Isosurface::default();
    };
    // In a 0/1 volume an edge's weight is that of (lower node out, in):
    // the same expression on the same values as for any other volume.
    let weights = zero_one.then(|| [(iso - 0.0) / (1.0 - 0.0), (iso - 1.0) / (0.0 - 1.0)]);
    let [dx, dy, dz] = dims;
    // Node rows of the box (one node of outside around the inside nodes).
    let (j0, k0) = (bx[1][0], bx[2][0]);
    let nj = bx[1][1] - j0 + 1;
    let rows = nj * (bx[2][1] - k0 + 1);
    let jk = |r: usize| (j0 + r % nj, k0 + r / nj);
    let nw = g.w1 - g.w0;
    let tab = table();
    let hw = match how {
        Emit::Fast { hw } => hw,
        #[cfg(test)]
        Emit::Reference => false,
    };

    // Pass 2: vertices per node row, triangles per cell row.
    let counts: Vec<(u32, u32)> = (0..rows)
        .into_par_iter()
        .with_min_len(16)
        .map(|r| {
            let (j, k) = jk(r);
            count_row(&g, tab, j, k, hw)
        })
        .collect();

    // Pass 3: prefix sums → exact output sizes and each row's offsets, and
    // blocks of consecutive rows of about equal counted work (rows differ by
    // orders of magnitude), the unit of parallel emission.
    let mut voff = Vec::with_capacity(rows + 1);
    let mut toff = Vec::with_capacity(rows + 1);
    let mut blocks = vec![0];
    let (mut sv, mut st, mut work) = (0usize, 0usize, 0usize);
    for (r, &(v, t)) in counts.iter().enumerate() {
        voff.push(sv);
        toff.push(st);
        sv += v as usize;
        st += t as usize;
        work += v as usize + 2 * t as usize + 1;
        if work >= BLOCK_WORK {
            blocks.push(r + 1);
            work = 0;
        }
    }
    voff.push(sv);
    toff.push(st);
    if blocks.last() != Some(&rows) {
        blocks.push(rows);
    }
    assert!(sv <= u32::MAX as usize, "more than 2³² vertices");

    // The emission writes every slot once, so the outputs are not
    // initialised first: their first touch (page faults, the kernel's
    // zeroing) happens in the parallel emission, on huge pages where the
    // kernel allows.
    let mut vertices: Vec<Point3> = Vec::with_capacity(sv);
    let mut on_border: Vec<bool> = Vec::with_capacity(sv);
    let mut triangles: Vec<[u32; 3]> = Vec::with_capacity(st);
    let mut parts = Vec::with_capacity(blocks.len() - 1);
    {
        let (mut vrest, mut brest, mut trest) = (
            &mut vertices.spare_capacity_mut()[..sv],
            &mut on_border.spare_capacity_mut()[..sv],
            &mut triangles.spare_capacity_mut()[..st],
        );
        advise_huge_pages(vrest);
        advise_huge_pages(trest);
        for b in blocks.windows(2) {
            let (v, t) = (voff[b[1]] - voff[b[0]], toff[b[1]] - toff[b[0]]);
            let (va, vb) = std::mem::take(&mut vrest).split_at_mut(v);
            let (ba, bb) = std::mem::take(&mut brest).split_at_mut(v);
            let (ta, tb) = std::mem::take(&mut trest).split_at_mut(t);
            parts.push((b[0]..b[1], va, ba, ta));
            (vrest, brest, trest) = (vb, bb, tb);
        }
    }

    let m: &Matrix4 = vol.affine();
    // A mirroring affine turns outward index-space triangles inward.
    let flip = m.fixed_view::<3, 3>(0, 0).determinant() < 0.0;
    let mm: [[f64; 4]; 3] = [0, 1, 2].map(|r| [0, 1, 2, 3].map(|c| m[(r, c)]));
    // Samples of padded row (jp, kp) when it lies inside the volume.
    let data_row = |jp: usize, kp: usize| -> Option<&[T]> {
        (jp >= 1 && kp >= 1 && jp <= dy && kp <= dz).then(|| {
            let vr = (jp - 1) + dy * (kp - 1);
            &data[vr * dx..(vr + 1) * dx]
        })
    };

    // Pass 4: emit vertices (node row) and triangles (cell row).
    let emit_row = |r: usize,
                    vs: &mut [MaybeUninit<Point3>],
                    bs: &mut [MaybeUninit<bool>],
                    ts: &mut [MaybeUninit<[u32; 3]>]| {
        let (j, k) = jk(r);
        let mut n = 0;
        if !vs.is_empty() {
            let samples = [data_row(j, k), data_row(j + 1, k), data_row(j, k + 1)];
            n = match how {
                Emit::Fast { .. } => {
                    emit_vertices(&g, j, k, samples, dx, iso, weights, &mm, vs, bs)
                }
                #[cfg(test)]
                Emit::Reference => emit_vertices_reference(&g, j, k, samples, dx, iso, &mm, vs, bs),
            };
        }
        let mut w = 0;
        if !ts.is_empty() {
            // A cell row with triangles has all four node rows in the box.
            let firsts = [r, r + 1, r + nj, r + nj + 1].map(|q| voff[q] as u32);
            w = match how {
                Emit::Fast { hw } => emit_triangles(&g, j, k, nw, firsts, flip, ts, hw),
                #[cfg(test)]
                Emit::Reference => emit_triangles_reference(&g, tab, j, k, nw, firsts, flip, ts),
            };
        }
        // The counts of pass 2 and the emission read the same bits, so they
        // agree; were they ever not to, the slots left over must still hold
        // values before the vectors take them as initialised.
        debug_assert_eq!((n, w), (vs.len(), ts.len()));
        let n = n.min(vs.len());
        vs[n..].fill(MaybeUninit::new(Point3::origin()));
        bs[n..].fill(MaybeUninit::new(false));
        let w = w.min(ts.len());
        ts[w..].fill(MaybeUninit::new([0; 3]));
    };
    parts
        .into_par_iter()
        .for_each(|(block, mut vs, mut bs, mut ts)| {
            for r in block {
                let (v, t) = (voff[r + 1] - voff[r], toff[r + 1] - toff[r]);
                let (va, vb) = std::mem::take(&mut vs).split_at_mut(v);
                let (ba, bb) = std::mem::take(&mut bs).split_at_mut(v);
                let (ta, tb) = std::mem::take(&mut ts).split_at_mut(t);
                emit_row(r, va, ba, ta);
                (vs, bs, ts) = (vb, bb, tb);
            }
        });
    // SAFETY: the blocks' slices partition the first `sv`, `sv` and `st`
    // slots, and `emit_row` wrote every slot of every row's slice.
    unsafe {
        vertices.set_len(sv);
        on_border.set_len(sv);
        triangles.set_len(st);
    }

    Isosurface {
        vertices,
        triangles,
        on_border,
    }
}

/// Counted work (vertices + 2 · triangles + 1 per row) of an emission
/// block: a few hundred blocks for a CT's millions of triangles, so that
/// threads stealing blocks end together, while a block's row loop and output
/// slices stay long.
const BLOCK_WORK: usize = 1 << 14;

/// Of each cell edge: the node row (y, z) = (0,0), (1,0), (0,1), (1,1) that
/// owns it, and its slot 3·node + axis there (node 0 or 1 along x).
const EDGE_SLOT: [(u8, u8); 12] = {
    let mut t = [(0u8, 0u8); 12];
    let mut e = 0;
    while e < 12 {
        let c = EDGE_CORNERS[e][0];
        t[e] = ((c >> 1 & 1) + 2 * (c >> 2), 3 * (c & 1) + (e / 4) as u8);
        e += 1;
    }
    t
};

/// Vertices of node row (j, k) (padded) into `vs` and `bs`, from the samples
/// of the node row and its +y and +z neighbours (`None`: padding), or from
/// `weights` (lower node outside, inside) in a 0/1 volume. Returns how many
/// were written.
///
/// Which of a node's three edges are cut is a coin toss to the branch
/// predictor, so every node with a cut writes all three candidates at the
/// next free slot and advances by the edge's cut bit: an uncut edge's
/// candidate is overwritten by the next one. Only nodes next to the padding
/// take a branch (rare and predictable).
#[inline(never)] // one symbol per pass in profiles
#[allow(clippy::too_many_arguments)]
fn emit_vertices<T: Sample>(
    g: &BitGrid,
    j: usize,
    k: usize,
    samples: [Option<&[T]>; 3],
    dx: usize,
    iso: f64,
    weights: Option<[f64; 2]>,
    mm: &[[f64; 4]; 3],
    vs: &mut [MaybeUninit<Point3>],
    bs: &mut [MaybeUninit<bool>],
) -> usize {
    let (a, ay, az) = (g.row(j, k), g.row(j + 1, k), g.row(j, k + 1));
    let world = |p: [f64; 3]| {
        let row = |r: usize| mm[r][0] * p[0] + mm[r][1] * p[1] + mm[r][2] * p[2] + mm[r][3];
        Point3::new(row(0), row(1), row(2))
    };
    let (vj, vk) = (j as f64 - 1.0, k as f64 - 1.0);
    let (len, mut n) = (vs.len(), 0);
    for x in 0..a.len() {
        let e = cut_edges(a, ay, az, x);
        let mut any = e[0] | e[1] | e[2];
        while any != 0 {
            let p = any.trailing_zeros();
            any &= any - 1;
            let vi = (64 * (g.w0 + x) + p as usize) as i64 - 1;
            let inside = (a[x] >> p & 1) as usize;
            // Weight along each axis, and whether the edge reaches the padding.
            let (t, border) = match (samples, vi >= 0 && (vi as usize) + 1 < dx) {
                // Node and all three far ends are samples.
                ([Some(s0), Some(s1), Some(s2)], true) => {
                    let i = vi as usize;
                    let t = match weights {
                        Some(w) => [w[inside]; 3],
                        None => {
                            let f0 = s0[i].value();
                            let f = [s0[i + 1].value(), s1[i].value(), s2[i].value()];
                            f.map(|f1| (iso - f0) / (f1 - f0))
                        }
                    };
                    (t, [false; 3])
                }
                _ => {
                    // Beside the padding: as the plain loop, edge by edge. A
                    // padding node sits just outside: the vertex goes
                    // half-way, as if the mask continued to the border.
                    let sample = |q: usize, i: i64| -> Option<f64> {
                        let row = samples[q]?;
                        (i >= 0 && (i as usize) < dx).then(|| row[i as usize].value())
                    };
                    let f0 = sample(0, vi);
                    let f = [sample(0, vi + 1), sample(1, vi), sample(2, vi)];
                    let t = f.map(|f1| match (f0, f1) {
                        (Some(u), Some(v)) => weights.map_or((iso - u) / (v - u), |w| w[inside]),
                        _ => 0.5,
                    });
                    (t, f.map(|f1| f0.is_none() || f1.is_none()))
                }
            };
            for (axis, ea) in e.iter().enumerate() {
                let mut pt = [vi as f64, vj, vk];
                pt[axis] += t[axis];
                if n < len {
                    vs[n] = MaybeUninit::new(world(pt));
                    bs[n] = MaybeUninit::new(border[axis]);
                }
                n += (ea >> p & 1) as usize;
            }
        }
    }
    n
}

/// The case table as [`emit_triangles`] reads it: the first [`FIRST`]
/// triangles (corners are cell edges) of every case padded to a fixed count,
/// and the rest in [`CaseTable::tris`] order.
struct SlotTable {
    first: [[[u8; 3]; FIRST]; 256],
    count: [u8; 256],
    start: [u16; 257],
    all: Vec<[u8; 3]>,
}

/// Triangles every mixed cell writes whether it has them or not: a loop of
/// varying length per cell would mispredict its exit about once a cell.
const FIRST: usize = 4;

fn slot_table() -> &'static SlotTable {
    static T: OnceLock<SlotTable> = OnceLock::new();
    T.get_or_init(|| {
        let tab = table();
        let all = tab.tris.clone();
        let mut first = [[[0u8; 3]; FIRST]; 256];
        let mut count = [0u8; 256];
        for c in 0..256 {
            let tris = &all[tab.start[c] as usize..tab.start[c + 1] as usize];
            count[c] = tris.len() as u8;
            for (f, t) in first[c].iter_mut().zip(tris) {
                *f = *t;
            }
        }
        SlotTable {
            first,
            count,
            start: tab.start,
            all,
        }
    })
}

/// Cut edges of the four node rows of a cell row at word `x` (none past the
/// span: the word after it is all outside).
#[inline(always)] // out of line it was a call per word
fn edges4(
    node: &[&[u64]; 4],
    ny: &[&[u64]; 4],
    nz: &[&[u64]; 4],
    nw: usize,
    x: usize,
) -> [[u64; 3]; 4] {
    if x < nw {
        [
            cut_edges(node[0], ny[0], nz[0], x),
            cut_edges(node[1], ny[1], nz[1], x),
            cut_edges(node[2], ny[2], nz[2], x),
            cut_edges(node[3], ny[3], nz[3], x),
        ]
    } else {
        [[0; 3]; 4]
    }
}

/// Triangles of cell row (j, k) (padded) into `ts`; `firsts` are the first
/// vertex ids of its node rows (y, z) = (0,0), (1,0), (0,1), (1,1). Returns
/// how many were written. `hw`: see [`hw_popcount`].
#[allow(clippy::too_many_arguments)]
fn emit_triangles(
    g: &BitGrid,
    j: usize,
    k: usize,
    nw: usize,
    firsts: [u32; 4],
    flip: bool,
    ts: &mut [MaybeUninit<[u32; 3]>],
    hw: bool,
) -> usize {
    #[cfg(target_arch = "x86_64")]
    if hw {
        // SAFETY: `hw` comes from `hw_popcount`, which saw popcnt and bmi1.
        return unsafe { emit_triangles_popcnt(g, j, k, nw, firsts, flip, ts) };
    }
    let _ = hw;
    emit_triangles_portable(g, j, k, nw, firsts, flip, ts)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "popcnt,bmi1")]
#[allow(clippy::too_many_arguments)]
#[inline(never)] // one symbol per pass in profiles
fn emit_triangles_popcnt(
    g: &BitGrid,
    j: usize,
    k: usize,
    nw: usize,
    firsts: [u32; 4],
    flip: bool,
    ts: &mut [MaybeUninit<[u32; 3]>],
) -> usize {
    emit_triangles_with::<true>(g, j, k, nw, firsts, flip, ts)
}

#[allow(clippy::too_many_arguments)]
#[inline(never)] // one symbol per pass in profiles
fn emit_triangles_portable(
    g: &BitGrid,
    j: usize,
    k: usize,
    nw: usize,
    firsts: [u32; 4],
    flip: bool,
    ts: &mut [MaybeUninit<[u32; 3]>],
) -> usize {
    emit_triangles_with::<false>(g, j, k, nw, firsts, flip, ts)
}

/// [`emit_triangles`]; `HW`: count bits with `count_ones` (one instruction
/// where inlined into a popcnt function) instead of bytes of prefix counts.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn emit_triangles_with<const HW: bool>(
    g: &BitGrid,
    j: usize,
    k: usize,
    nw: usize,
    firsts: [u32; 4],
    flip: bool,
    ts: &mut [MaybeUninit<[u32; 3]>],
) -> usize {
    let st = slot_table();
    // Node rows of the cell row, and each one's +y and +z neighbours.
    let node = [(j, k), (j + 1, k), (j, k + 1), (j + 1, k + 1)].map(|(a, b)| g.row(a, b));
    let ny = [(j + 1, k), (j + 2, k), (j + 1, k + 1), (j + 2, k + 1)].map(|(a, b)| g.row(a, b));
    let nz = [(j, k + 1), (j + 1, k + 1), (j, k + 2), (j + 1, k + 2)].map(|(a, b)| g.row(a, b));
    let edges = |x: usize| edges4(&node, &ny, &nz, nw, x);
    let mut base = firsts;
    let mut cur = edges(0);
    let mut w = 0;
    for x in 0..nw {
        let next = edges(x + 1);
        let (mut m, lo, hi) = mixed_cells(&node, x);
        let prefix = if HW {
            [0; 4]
        } else {
            [
                prefix_counts3(&cur[0]),
                prefix_counts3(&cur[1]),
                prefix_counts3(&cur[2]),
                prefix_counts3(&cur[3]),
            ]
        };
        while m != 0 {
            let p = m.trailing_zeros();
            m &= m - 1;
            // Vertex ids of the six edges (node 0/1 of the cell × axis) each
            // node row owns: the cut edges of the earlier nodes of the row,
            // then the lower axes at the node.
            let mut six = [[0u32; 6]; 4];
            for q in 0..4 {
                let e = &cur[q];
                let below = if HW {
                    let low = (1u64 << p) - 1;
                    (e[0] & low).count_ones()
                        + (e[1] & low).count_ones()
                        + (e[2] & low).count_ones()
                } else {
                    count_below(e, prefix[q], p)
                };
                let pre = base[q] + below;
                let at = |e: &[u64; 3], b: u32| -> [u32; 3] {
                    let x = (e[0] >> b & 1) as u32;
                    [0, x, x + (e[1] >> b & 1) as u32]
                };
                let a0 = at(e, p);
                let n0 = a0[2] + (e[2] >> p & 1) as u32;
                let a1 = if p < 63 {
                    at(e, p + 1)
                } else {
                    at(&next[q], 0)
                };
                six[q] = [
                    pre + a0[0],
                    pre + a0[1],
                    pre + a0[2],
                    pre + n0 + a1[0],
                    pre + n0 + a1[1],
                    pre + n0 + a1[2],
                ];
            }
            // The cell's twelve edges, picked at constant indices (the loop
            // unrolls), so the compiler drops the ids no edge uses. 16
            // entries so that a 4-bit index needs no bounds check.
            let mut ids = [0u32; 16];
            for (id, &(q, slot)) in ids.iter_mut().zip(&EDGE_SLOT) {
                *id = six[q as usize][slot as usize];
            }
            let c = case_of(&lo, &hi, p) as usize;
            let corners = |t: &[u8; 3]| {
                let v = t.map(|e| ids[e as usize & 15]);
                if flip { [v[0], v[2], v[1]] } else { v }
            };
            // Padding triangles land where the next cell's go (or past the
            // row's end, not written).
            for (i, t) in st.first[c].iter().enumerate() {
                if let Some(o) = ts.get_mut(w + i) {
                    *o = MaybeUninit::new(corners(t));
                }
            }
            let n = st.count[c] as usize;
            if n > FIRST {
                let rest = st.start[c] as usize + FIRST..st.start[c + 1] as usize;
                for (i, t) in st.all[rest].iter().enumerate() {
                    ts[w + FIRST + i] = MaybeUninit::new(corners(t));
                }
            }
            w += n;
        }
        for q in 0..4 {
            base[q] += if HW {
                cur[q].iter().map(|e| e.count_ones()).sum::<u32>()
            } else {
                (prefix[q] >> 56) as u32
            };
        }
        cur = next;
    }
    w
}

/// [`emit_vertices`] one vertex at a time, with a branch per edge.
#[cfg(test)]
#[allow(clippy::too_many_arguments)]
fn emit_vertices_reference<T: Sample>(
    g: &BitGrid,
    j: usize,
    k: usize,
    samples: [Option<&[T]>; 3],
    dx: usize,
    iso: f64,
    mm: &[[f64; 4]; 3],
    vs: &mut [MaybeUninit<Point3>],
    bs: &mut [MaybeUninit<bool>],
) -> usize {
    let (a, ay, az) = (g.row(j, k), g.row(j + 1, k), g.row(j, k + 1));
    let sample = |q: usize, i: i64| -> Option<f64> {
        let row = samples[q]?;
        (i >= 0 && (i as usize) < dx).then(|| row[i as usize].value())
    };
    let world = |p: [f64; 3]| {
        let row = |r: usize| mm[r][0] * p[0] + mm[r][1] * p[1] + mm[r][2] * p[2] + mm[r][3];
        Point3::new(row(0), row(1), row(2))
    };
    let (vj, vk) = (j as f64 - 1.0, k as f64 - 1.0);
    let mut n = 0;
    for x in 0..a.len() {
        let e = cut_edges(a, ay, az, x);
        let mut any = e[0] | e[1] | e[2];
        while any != 0 {
            let p = any.trailing_zeros();
            any &= any - 1;
            let vi = (64 * (g.w0 + x) + p as usize) as i64 - 1;
            let f0 = sample(0, vi);
            for (axis, ea) in e.iter().enumerate() {
                if ea >> p & 1 == 0 {
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
                let mut pt = [vi as f64, vj, vk];
                pt[axis] += t;
                vs[n] = MaybeUninit::new(world(pt));
                bs[n] = MaybeUninit::new(f0.is_none() || f1.is_none());
                n += 1;
            }
        }
    }
    n
}

/// Pass 2 for node row (j, k) and the cell row above it (padded
/// coordinates): (vertices, triangles). `hw`: see [`hw_popcount`].
fn count_row(g: &BitGrid, tab: &CaseTable, j: usize, k: usize, hw: bool) -> (u32, u32) {
    #[cfg(target_arch = "x86_64")]
    if hw {
        // SAFETY: `hw` comes from `hw_popcount`, which saw popcnt and bmi1.
        return unsafe { count_row_popcnt(g, tab, j, k) };
    }
    let _ = hw;
    count_row_portable(g, tab, j, k)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "popcnt,bmi1")]
#[inline(never)] // one symbol per pass in profiles
fn count_row_popcnt(g: &BitGrid, tab: &CaseTable, j: usize, k: usize) -> (u32, u32) {
    count_row_with::<true>(g, tab, j, k)
}

#[inline(never)] // one symbol per pass in profiles
fn count_row_portable(g: &BitGrid, tab: &CaseTable, j: usize, k: usize) -> (u32, u32) {
    count_row_with::<false>(g, tab, j, k)
}

#[inline(always)]
fn count_row_with<const HW: bool>(g: &BitGrid, tab: &CaseTable, j: usize, k: usize) -> (u32, u32) {
    let a = g.row(j, k);
    let (ay, az, ayz) = (g.row(j + 1, k), g.row(j, k + 1), g.row(j + 1, k + 1));
    let (mut nv, mut nt) = (0, 0);
    for x in 0..a.len() {
        let e = cut_edges(a, ay, az, x);
        nv += if HW {
            e[0].count_ones() + e[1].count_ones() + e[2].count_ones()
        } else {
            (prefix_counts3(&e) >> 56) as u32
        };
        let (mut m, lo, hi) = mixed_cells(&[a, ay, az, ayz], x);
        while m != 0 {
            nt += tab.count(case_of(&lo, &hi, m.trailing_zeros()));
            m &= m - 1;
        }
    }
    (nv, nt)
}

/// [`emit_triangles`] looking each triangle corner up through [`EDGE_SLOT`].
#[cfg(test)]
#[allow(clippy::too_many_arguments)]
fn emit_triangles_reference(
    g: &BitGrid,
    tab: &CaseTable,
    j: usize,
    k: usize,
    nw: usize,
    firsts: [u32; 4],
    flip: bool,
    ts: &mut [MaybeUninit<[u32; 3]>],
) -> usize {
    // Node rows of the cell row, and each one's +y and +z neighbours.
    let node = [(j, k), (j + 1, k), (j, k + 1), (j + 1, k + 1)].map(|(a, b)| g.row(a, b));
    let ny = [(j + 1, k), (j + 2, k), (j + 1, k + 1), (j + 2, k + 1)].map(|(a, b)| g.row(a, b));
    let nz = [(j, k + 1), (j + 1, k + 1), (j, k + 2), (j + 1, k + 2)].map(|(a, b)| g.row(a, b));
    let edges = |x: usize| -> [[u64; 3]; 4] {
        if x < nw {
            [
                cut_edges(node[0], ny[0], nz[0], x),
                cut_edges(node[1], ny[1], nz[1], x),
                cut_edges(node[2], ny[2], nz[2], x),
                cut_edges(node[3], ny[3], nz[3], x),
            ]
        } else {
            [[0; 3]; 4]
        }
    };
    let mut base = firsts;
    let mut cur = edges(0);
    let mut w = 0;
    for x in 0..nw {
        let next = edges(x + 1);
        let (mut m, lo, hi) = mixed_cells(&node, x);
        let prefix = [
            prefix_counts3(&cur[0]),
            prefix_counts3(&cur[1]),
            prefix_counts3(&cur[2]),
            prefix_counts3(&cur[3]),
        ];
        while m != 0 {
            let p = m.trailing_zeros();
            m &= m - 1;
            // Vertex ids of the six edges (node 0/1 of the cell × axis) each
            // node row owns: the cut edges of the earlier nodes of the row,
            // then the lower axes at the node.
            let mut ids = [[0u32; 6]; 4];
            for q in 0..4 {
                let e = &cur[q];
                let pre = base[q] + count_below(e, prefix[q], p);
                let at = |e: &[u64; 3], b: u32| -> [u32; 3] {
                    let x = (e[0] >> b & 1) as u32;
                    [0, x, x + (e[1] >> b & 1) as u32]
                };
                let a0 = at(e, p);
                let n0 = a0[2] + (e[2] >> p & 1) as u32;
                let a1 = if p < 63 {
                    at(e, p + 1)
                } else {
                    at(&next[q], 0)
                };
                ids[q] = [
                    pre + a0[0],
                    pre + a0[1],
                    pre + a0[2],
                    pre + n0 + a1[0],
                    pre + n0 + a1[1],
                    pre + n0 + a1[2],
                ];
            }
            for t in tab.triangles(case_of(&lo, &hi, p)) {
                let id = |e: u8| {
                    let (q, slot) = EDGE_SLOT[e as usize];
                    ids[q as usize][slot as usize]
                };
                let v = [id(t[0]), id(t[1]), id(t[2])];
                ts[w] = MaybeUninit::new(if flip { [v[0], v[2], v[1]] } else { v });
                w += 1;
            }
        }
        for q in 0..4 {
            base[q] += (prefix[q] >> 56) as u32;
        }
        cur = next;
    }
    w
}

#[cfg(test)]
mod simd_tests {
    use super::pack;
    use coapt_base::rng::SplitMix64 as Rng;

    /// The SSE2 compares give the bits of the byte-array packing for every
    /// threshold, on random samples and on runs of the extremes.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn simd_bits_equal_the_packed_compares() {
        use super::simd::{bits_i16, bits_u8};
        let mut rng = Rng::new(7);
        for round in 0..40 {
            let r: Vec<u64> = (0..64).map(|_| rng.next_u64()).collect();
            let u: Vec<u8> = match round % 4 {
                0 => r
                    .iter()
                    .map(|&x| [0, 255, 127, 128][x as usize % 4])
                    .collect(),
                _ => r.iter().map(|&x| x as u8).collect(),
            };
            for t in 0..=255u8 {
                assert_eq!(
                    bits_u8(&u, t),
                    pack(&u, |v| v > t),
                    "u8 round {round} t {t}"
                );
            }
            let i: Vec<i16> = match round % 4 {
                0 => r
                    .iter()
                    .map(|&x| [i16::MIN, i16::MAX, -1, 0][x as usize % 4])
                    .collect(),
                1 => r.iter().map(|&x| (x % 400) as i16 - 200).collect(),
                _ => r.iter().map(|&x| x as i16).collect(),
            };
            for t in [
                i16::MIN,
                i16::MIN + 1,
                -1001,
                -1,
                0,
                1,
                150,
                151,
                i16::MAX - 1,
                i16::MAX,
            ]
            .into_iter()
            .chain((0..64).map(|k| i[k]))
            {
                assert_eq!(
                    bits_i16(&i, t),
                    pack(&i, |v| v > t),
                    "i16 round {round} t {t}"
                );
            }
        }
    }
}
