//! The tangent matrix: a 3×3-block sparsity pattern over the free degrees
//! of freedom, built for a coupling set (a solve keeps it while it covers
//! the couplings: `solve::newton`), filled in element order (so the sum is
//! the same whatever the thread count), and factorised by faer in an order
//! found on the nodes, with the symbolic analysis reused while the pattern
//! does not change. The
//! numeric factors and the work space are kept too: a Newton solve
//! factorises the same pattern dozens of times, and allocating (and
//! zero-filling fresh pages for) a supernodal LU each time cost a quarter
//! of the suturing pre-stage.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::SymmetricOrdering;
use faer::sparse::linalg::{amd, cholesky, lu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side};
use rayon::prelude::*;
use std::sync::{Arc, Mutex};

pub const NONE: u32 = u32::MAX;

/// Equation numbering: `eq[3·node + c]` is the row of that coordinate, or
/// [`NONE`] when it is prescribed (sutured, symmetry plane).
#[derive(Debug, Clone)]
pub struct Dofs {
    pub eq: Vec<u32>,
    pub n_eq: usize,
}

impl Dofs {
    pub fn new(fixed: &[[bool; 3]]) -> Dofs {
        let mut eq = Vec::with_capacity(3 * fixed.len());
        let mut n = 0u32;
        for f in fixed {
            for &c in f {
                if c {
                    eq.push(NONE);
                } else {
                    eq.push(n);
                    n += 1;
                }
            }
        }
        Dofs {
            eq,
            n_eq: n as usize,
        }
    }
}

/// Column-compressed pattern over the equations, with a node-pair lookup.
pub struct Pattern {
    /// Per node: sorted neighbour nodes (itself included) and, for each,
    /// the offset of its first free row inside the node's columns.
    nb_off: Vec<u32>,
    nb: Vec<u32>,
    row_off: Vec<u32>,
    /// Node i's free equations are `node_eq[i]..node_eq[i + 1]` (Dofs
    /// numbers them by node, then component).
    node_eq: Vec<u32>,
    col_ptr: Vec<usize>,
    row_idx: Vec<u32>,
    /// The coupling list, as a system last listed it, that gave this pattern:
    /// an identical list is recognised without a lookup.
    pub listed: Vec<[u32; 2]>,
    /// Stored entries of the last pattern in this one's line that was built
    /// from a system's couplings alone; a pattern that also keeps earlier
    /// couplings (`solve::newton`'s reuse) is measured against it.
    pub base_nnz: usize,
    llt: Option<LltFactor>,
    lu: Option<LuFactor>,
    sym: SymbolicSparseColMat<u32>,
    /// For each stored entry, the index of its transpose (the pattern is
    /// structurally symmetric); built on the first non-symmetric solve.
    transpose: Vec<u32>,
    /// How the non-symmetric solves went.
    pub stats: SolveStats,
    /// Element lists seen by [`Pattern::element_slots`] (their nodes,
    /// flattened) and their slot tables.
    slot_tables: Mutex<Vec<(Vec<u32>, Arc<[u32]>)>>,
}

/// Counts of [`Pattern::solve_nonsymmetric`]'s paths.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct SolveStats {
    /// Solved by GMRES preconditioned with the symmetric part's Cholesky.
    pub gmres_solves: usize,
    pub gmres_iterations: usize,
    /// Solved by LU: the symmetric part was not positive definite, or
    /// GMRES did not reach its tolerance.
    pub lu_solves: usize,
    /// Of the GMRES solves, those preconditioned with an earlier solve's
    /// factor (no factorisation).
    pub reused_factor: usize,
}

/// Cholesky of one pattern: symbolic analysis, factor values and work space,
/// all reused from one factorisation to the next.
struct LltFactor {
    symbolic: cholesky::SymbolicCholesky<u32>,
    values: Vec<f64>,
    mem: MemBuffer,
}

/// LU with partial pivoting of one pattern, reused likewise.
struct LuFactor {
    symbolic: lu::SymbolicLu<u32>,
    numeric: lu::NumericLu<u32, f64>,
    mem: MemBuffer,
}

fn par() -> Par {
    faer::get_global_parallelism()
}

impl Pattern {
    /// `pairs`: node pairs that interact (any order, duplicates allowed).
    pub fn new(n_nodes: usize, dofs: &Dofs, pairs: &[[u32; 2]]) -> Pattern {
        // Per node its neighbours (itself included), bucketed by node and
        // sorted within each bucket: no sort of the whole pair list (a
        // closure with contact lists ~10⁵ pairs and changes them at every
        // step).
        let mut deg = vec![1u32; n_nodes + 1];
        deg[0] = 0;
        for &[a, b] in pairs {
            if a != b {
                deg[a as usize + 1] += 1;
                deg[b as usize + 1] += 1;
            }
        }
        for i in 0..n_nodes {
            deg[i + 1] += deg[i];
        }
        let mut fill = deg.clone();
        let mut all = vec![0u32; deg[n_nodes] as usize];
        for i in 0..n_nodes {
            all[fill[i] as usize] = i as u32;
            fill[i] += 1;
        }
        for &[a, b] in pairs {
            if a != b {
                all[fill[a as usize] as usize] = b;
                fill[a as usize] += 1;
                all[fill[b as usize] as usize] = a;
                fill[b as usize] += 1;
            }
        }
        let mut nb_off = vec![0u32; n_nodes + 1];
        let mut nb = Vec::with_capacity(all.len());
        for i in 0..n_nodes {
            let s = &mut all[deg[i] as usize..deg[i + 1] as usize];
            s.sort_unstable();
            let mut last = None;
            for &v in s.iter() {
                if last != Some(v) {
                    nb.push(v);
                    last = Some(v);
                }
            }
            nb_off[i + 1] = nb.len() as u32;
        }
        let free = |n: u32| {
            (0..3)
                .filter(|&c| dofs.eq[3 * n as usize + c] != NONE)
                .count() as u32
        };
        let mut row_off = vec![0u32; nb.len()];
        for i in 0..n_nodes {
            let mut acc = 0;
            for k in nb_off[i] as usize..nb_off[i + 1] as usize {
                row_off[k] = acc;
                acc += free(nb[k]);
            }
        }
        let mut col_ptr = vec![0usize; dofs.n_eq + 1];
        let mut row_idx = Vec::new();
        for i in 0..n_nodes {
            for c in 0..3 {
                let e = dofs.eq[3 * i + c];
                if e == NONE {
                    continue;
                }
                for &a in &nb[nb_off[i] as usize..nb_off[i + 1] as usize] {
                    let a = a as usize;
                    for r in 0..3 {
                        let er = dofs.eq[3 * a + r];
                        if er != NONE {
                            row_idx.push(er);
                        }
                    }
                }
                col_ptr[e as usize + 1] = row_idx.len();
            }
        }
        // Equation numbers grow with (node, component), and each node's
        // neighbours are sorted, so every column's rows are sorted.
        let sym = SymbolicSparseColMat::new_checked(
            dofs.n_eq,
            dofs.n_eq,
            col_ptr.iter().map(|&p| p as u32).collect(),
            None,
            row_idx.clone(),
        );
        let nnz = row_idx.len();
        let mut node_eq = vec![0u32; n_nodes + 1];
        for i in 0..n_nodes {
            node_eq[i + 1] = node_eq[i] + free(i as u32);
        }
        Pattern {
            nb_off,
            nb,
            row_off,
            node_eq,
            col_ptr,
            row_idx,
            listed: pairs.to_vec(),
            base_nnz: nnz,
            llt: None,
            lu: None,
            sym,
            transpose: Vec::new(),
            stats: SolveStats::default(),
            slot_tables: Mutex::new(Vec::new()),
        }
    }

    /// Whether this pattern couples every pair of `pairs` (it may couple
    /// more: its extra entries are assembled as zeros).
    pub fn covers(&self, pairs: &[[u32; 2]]) -> bool {
        let n = self.nb_off.len() - 1;
        pairs.iter().all(|&[a, b]| {
            let (lo, hi) = (a.min(b) as usize, a.max(b));
            lo < n && {
                let (s, e) = (self.nb_off[lo] as usize, self.nb_off[lo + 1] as usize);
                self.nb[s..e].binary_search(&hi).is_ok()
            }
        })
    }

    /// The node pairs this pattern couples, each once (lower node first,
    /// the diagonal left out).
    pub fn node_pairs(&self) -> Vec<[u32; 2]> {
        let n = self.nb_off.len() - 1;
        let mut out = Vec::with_capacity(self.nb.len() / 2);
        for a in 0..n {
            for &b in &self.nb[self.nb_off[a] as usize..self.nb_off[a + 1] as usize] {
                if b > a as u32 {
                    out.push([a as u32, b]);
                }
            }
        }
        out
    }

    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Add a dense block over `nodes` (k nodes, 3k×3k, row-major by node
    /// then component) into `vals`.
    pub fn add_block<const N: usize>(
        &self,
        dofs: &Dofs,
        vals: &mut [f64],
        nodes: &[u32],
        block: &nalgebra::SMatrix<f64, N, N>,
    ) {
        self.for_each_slot(dofs, nodes, |r, c, slot| vals[slot] += block[(r, c)]);
    }

    /// Visit every entry (r, c) of the block over `nodes` that lands in the
    /// matrix, with its index in `vals`: what `slot` would find, with one
    /// neighbour search per node pair instead of one per entry (the search
    /// dominated assembly), in a fixed order, so the sums are the same.
    fn for_each_slot(&self, dofs: &Dofs, nodes: &[u32], mut f: impl FnMut(usize, usize, usize)) {
        for (bi, &a) in nodes.iter().enumerate() {
            let ea = [0, 1, 2].map(|r| dofs.eq[3 * a as usize + r]);
            let mut before = [0usize; 3];
            for r in 1..3 {
                before[r] = before[r - 1] + usize::from(ea[r - 1] != NONE);
            }
            for (bj, &b) in nodes.iter().enumerate() {
                let (lo, hi) = (
                    self.nb_off[b as usize] as usize,
                    self.nb_off[b as usize + 1] as usize,
                );
                let Ok(k) = self.nb[lo..hi].binary_search(&a) else {
                    continue;
                };
                let off = self.row_off[lo + k] as usize;
                for r in 0..3 {
                    if ea[r] == NONE {
                        continue;
                    }
                    for c in 0..3 {
                        let col = dofs.eq[3 * b as usize + c];
                        if col != NONE {
                            f(
                                3 * bi + r,
                                3 * bj + c,
                                self.col_ptr[col as usize] + off + before[r],
                            );
                        }
                    }
                }
            }
        }
    }

    /// Where each entry of each element's 3K×3K block goes in `vals`:
    /// `slots[e·(3K)² + 3K·r + c]` for row r, column c of element e, or
    /// [`NONE`] where the row or column is prescribed or the pair is not in
    /// the pattern. Built once per element list and pattern: a Newton solve
    /// assembles the same elements dozens of times, and finding the slots
    /// was most of [`Pattern::add_block`]'s cost.
    pub fn element_slots<const K: usize>(&self, dofs: &Dofs, elems: &[[u32; K]]) -> Arc<[u32]> {
        let flat: Vec<u32> = elems.iter().flatten().copied().collect();
        let mut cache = self.slot_tables.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, s)) = cache.iter().find(|(n, _)| *n == flat) {
            return s.clone();
        }
        let n = 3 * K;
        let mut slots = vec![NONE; elems.len() * n * n];
        // Each element's table is its own: filled in parallel, the same
        // tables whatever the thread count.
        slots
            .par_chunks_exact_mut(n * n)
            .with_min_len(256)
            .zip(elems.par_iter())
            .for_each(|(s, nodes)| {
                self.for_each_slot(dofs, nodes, |r, c, slot| s[r * n + c] = slot as u32);
            });
        let slots: Arc<[u32]> = slots.into();
        cache.push((flat, slots.clone()));
        slots
    }

    /// Add an element's block at the slots [`Pattern::element_slots`] gave
    /// for it: the same sums as [`Pattern::add_block`].
    pub fn add_block_at<const N: usize>(
        vals: &mut [f64],
        slots: &[u32],
        block: &nalgebra::SMatrix<f64, N, N>,
    ) {
        for r in 0..N {
            for c in 0..N {
                let s = slots[r * N + c];
                if s != NONE {
                    vals[s as usize] += block[(r, c)];
                }
            }
        }
    }

    /// Add `v` to every diagonal entry (a Levenberg shift).
    pub fn add_diagonal(&self, vals: &mut [f64], v: &[f64]) {
        for (col, w) in self.col_ptr.windows(2).enumerate() {
            let rows = &self.row_idx[w[0]..w[1]];
            if let Ok(k) = rows.binary_search(&(col as u32)) {
                vals[w[0] + k] += v[col];
            }
        }
    }

    pub fn diagonal(&self, vals: &[f64]) -> Vec<f64> {
        self.col_ptr
            .windows(2)
            .enumerate()
            .map(|(col, w)| {
                let rows = &self.row_idx[w[0]..w[1]];
                rows.binary_search(&(col as u32))
                    .map_or(0.0, |k| vals[w[0] + k])
            })
            .collect()
    }

    /// y = A x (for residual checks and tests).
    pub fn mul(&self, vals: &[f64], x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; x.len()];
        mul_into(&self.col_ptr, &self.row_idx, vals, x, &mut y);
        y
    }

    /// Solve A x = b by Cholesky (A symmetric); `Err` when A is not
    /// positive definite.
    pub fn solve_llt(&mut self, vals: &[f64], b: &mut [f64]) -> Result<(), String> {
        self.factor_llt(vals)?;
        let f = self.llt.as_mut().expect("factored");
        cholesky::LltRef::<'_, u32, f64>::new(&f.symbolic, &f.values).solve_in_place_with_conj(
            Conj::No,
            column(b),
            par(),
            MemStack::new(&mut f.mem),
        );
        Ok(())
    }

    /// A fill-reducing order of the equations: AMD on the graph of the
    /// nodes, each node's free equations kept together in component order.
    /// The equations' own graph is the nodes' with every vertex tripled, so
    /// the order is AMD's on it (which finds those triples itself) from a
    /// graph a ninth the size: the ordering was most of the 15 ms symbolic
    /// analysis that every new contact pattern costs on the real CT.
    /// Returns (new → old, old → new).
    fn node_ordering(&self) -> Result<(Vec<u32>, Vec<u32>), String> {
        let n_nodes = self.nb_off.len() - 1;
        // Column k of the node graph: the k-th node with a free equation.
        let eqs = |i: usize| self.node_eq[i]..self.node_eq[i + 1];
        let mut index = vec![NONE; n_nodes];
        let mut nodes = Vec::new();
        for i in 0..n_nodes {
            if !eqs(i).is_empty() {
                index[i] = nodes.len() as u32;
                nodes.push(i as u32);
            }
        }
        let m = nodes.len();
        let mut col_ptr = Vec::with_capacity(m + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0u32);
        for &i in &nodes {
            let i = i as usize;
            for &a in &self.nb[self.nb_off[i] as usize..self.nb_off[i + 1] as usize] {
                if index[a as usize] != NONE {
                    row_idx.push(index[a as usize]);
                }
            }
            col_ptr.push(row_idx.len() as u32);
        }
        let graph = SymbolicSparseColMat::new_checked(m, m, col_ptr, None, row_idx);
        let (mut perm, mut perm_inv) = (vec![0u32; m], vec![0u32; m]);
        let mut mem = MemBuffer::try_new(amd::order_scratch::<u32>(m, graph.compute_nnz()))
            .map_err(|e| format!("{e:?}"))?;
        amd::order(
            &mut perm,
            &mut perm_inv,
            graph.as_ref(),
            amd::Control::default(),
            MemStack::new(&mut mem),
        )
        .map_err(|e| format!("{e:?}"))?;
        let n_eq = self.col_ptr.len() - 1;
        let (mut fwd, mut inv) = (Vec::with_capacity(n_eq), vec![0u32; n_eq]);
        for &k in &perm {
            let i = nodes[k as usize] as usize;
            for e in eqs(i) {
                inv[e as usize] = fwd.len() as u32;
                fwd.push(e);
            }
        }
        debug_assert_eq!(fwd.len(), n_eq);
        Ok((fwd, inv))
    }

    /// Cholesky factorisation of `vals` into `self.llt`.
    fn factor_llt(&mut self, vals: &[f64]) -> Result<(), String> {
        if self.llt.is_none() {
            let (fwd, inv) = self.node_ordering()?;
            let symbolic = cholesky::factorize_symbolic_cholesky(
                self.sym.as_ref(),
                Side::Lower,
                SymmetricOrdering::Custom(PermRef::new_checked(&fwd, &inv, fwd.len())),
                Default::default(),
            )
            .map_err(|e| format!("{e:?}"))?;
            let req = StackReq::any_of(&[
                symbolic.factorize_numeric_llt_scratch::<f64>(par(), Default::default()),
                symbolic.solve_in_place_scratch::<f64>(1, par()),
            ]);
            self.llt = Some(LltFactor {
                values: vec![0.0; symbolic.len_val()],
                mem: MemBuffer::try_new(req).map_err(|e| format!("{e:?}"))?,
                symbolic,
            });
        }
        let a = SparseColMatRef::new(self.sym.as_ref(), vals);
        let f = self.llt.as_mut().expect("built");
        f.symbolic
            .factorize_numeric_llt(
                &mut f.values,
                a,
                Side::Lower,
                Default::default(),
                par(),
                MemStack::new(&mut f.mem),
                Default::default(),
            )
            .map_err(|e| format!("{e:?}"))?;
        Ok(())
    }

    /// Solve A x = b for a non-symmetric A whose asymmetry is small and
    /// local (the follower pressure on the free edge, the suturing force on
    /// the first row): GMRES preconditioned with the Cholesky factor of
    /// (A + Aᵀ)/2, to a relative residual of [`NONSYMMETRIC_TOL`]; LU when
    /// that part is not positive definite or GMRES has not converged after
    /// [`NONSYMMETRIC_MAX_ITERATIONS`]. A Cholesky costs a third to a sixth
    /// of the LU on these patterns, and the answer is the LU's to the
    /// tolerance, so Newton takes the same steps.
    pub fn solve_nonsymmetric(&mut self, vals: &[f64], b: &mut [f64]) -> Result<(), String> {
        self.solve_nonsymmetric_reusing(vals, b, NONSYMMETRIC_TOL, false)
    }

    /// [`Pattern::solve_nonsymmetric`] to the relative residual `tol`
    /// (at least [`NONSYMMETRIC_TOL`]; an inexact Newton step needs no
    /// more than a fraction of the reduction it must make), and with
    /// `reuse` first trying the Cholesky factor left from the last solve as
    /// the preconditioner, without factorising, accepted when GMRES reaches
    /// `tol` within [`REUSED_MAX_ITERATIONS`]. For a sequence of nearby
    /// systems solved loosely (the suturing rounds: K doubles, so the old
    /// factor is off by a factor of two on the sutured rows, a cluster GMRES
    /// resolves in a few products) this skips the factorisation, the
    /// dearest part of a Newton step.
    pub fn solve_nonsymmetric_reusing(
        &mut self,
        vals: &[f64],
        b: &mut [f64],
        tol: f64,
        reuse: bool,
    ) -> Result<(), String> {
        let tol = tol.max(NONSYMMETRIC_TOL);
        if self.transpose.len() != vals.len() {
            self.transpose = self.transpose_map();
        }
        if reuse {
            if self.gmres_with_factor(vals, b, tol, REUSED_MAX_ITERATIONS) {
                self.stats.reused_factor += 1;
                return Ok(());
            }
        }
        let sym: Vec<f64> = vals
            .iter()
            .zip(&self.transpose)
            .map(|(v, &t)| 0.5 * (v + vals[t as usize]))
            .collect();
        if self.factor_llt(&sym).is_ok()
            && self.gmres_with_factor(vals, b, tol, NONSYMMETRIC_MAX_ITERATIONS)
        {
            return Ok(());
        }
        self.stats.lu_solves += 1;
        self.solve_lu(vals, b)
    }

    /// GMRES on A = `vals` preconditioned with the Cholesky factor held in
    /// `self.llt`; on convergence `b` becomes the solution and the solve is
    /// counted. False (and `b` untouched) without a factor or convergence.
    fn gmres_with_factor(&mut self, vals: &[f64], b: &mut [f64], tol: f64, max: usize) -> bool {
        let Pattern {
            llt,
            col_ptr,
            row_idx,
            stats,
            ..
        } = &mut *self;
        let Some(f) = llt.as_mut() else {
            return false;
        };
        let l = cholesky::LltRef::<'_, u32, f64>::new(&f.symbolic, &f.values);
        let (x, out) = super::gmres::gmres(
            b,
            |v, y| mul_into(col_ptr, row_idx, vals, v, y),
            |v| l.solve_in_place_with_conj(Conj::No, column(v), par(), MemStack::new(&mut f.mem)),
            tol,
            max,
        );
        stats.gmres_iterations += out.iterations;
        if out.converged {
            stats.gmres_solves += 1;
            b.copy_from_slice(&x);
        }
        out.converged
    }

    fn transpose_map(&self) -> Vec<u32> {
        let mut t = vec![0u32; self.row_idx.len()];
        for (col, w) in self.col_ptr.windows(2).enumerate() {
            for k in w[0]..w[1] {
                let row = self.row_idx[k] as usize;
                let rows = &self.row_idx[self.col_ptr[row]..self.col_ptr[row + 1]];
                let j = rows
                    .binary_search(&(col as u32))
                    .expect("the pattern is structurally symmetric");
                t[k] = (self.col_ptr[row] + j) as u32;
            }
        }
        t
    }

    /// Solve A x = b by LU with partial pivoting (A non-symmetric).
    pub fn solve_lu(&mut self, vals: &[f64], b: &mut [f64]) -> Result<(), String> {
        if self.lu.is_none() {
            let symbolic = lu::factorize_symbolic_lu(self.sym.as_ref(), Default::default())
                .map_err(|e| format!("{e:?}"))?;
            let req = StackReq::any_of(&[
                symbolic.factorize_numeric_lu_scratch::<f64>(par(), Default::default()),
                symbolic.solve_in_place_scratch::<f64>(1, par()),
            ]);
            self.lu = Some(LuFactor {
                numeric: lu::NumericLu::new(),
                mem: MemBuffer::try_new(req).map_err(|e| format!("{e:?}"))?,
                symbolic,
            });
        }
        let a = SparseColMatRef::new(self.sym.as_ref(), vals);
        let f = self.lu.as_mut().expect("built");
        let l = f
            .symbolic
            .factorize_numeric_lu(
                &mut f.numeric,
                a,
                par(),
                MemStack::new(&mut f.mem),
                Default::default(),
            )
            .map_err(|e| format!("{e:?}"))?;
        l.solve_in_place_with_conj(Conj::No, column(b), par(), MemStack::new(&mut f.mem));
        if b.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err("singular matrix".into())
        }
    }
}

/// Relative residual at which [`Pattern::solve_nonsymmetric`] takes GMRES's
/// answer: about what LU with partial pivoting leaves on these systems.
pub const NONSYMMETRIC_TOL: f64 = 1e-10;
/// Past this many GMRES iterations the LU is cheaper.
pub const NONSYMMETRIC_MAX_ITERATIONS: usize = 40;

/// GMRES products allowed with a reused factor before a fresh one is made:
/// past this, the factorisation is cheaper.
pub const REUSED_MAX_ITERATIONS: usize = 12;

fn mul_into(col_ptr: &[usize], row_idx: &[u32], vals: &[f64], x: &[f64], y: &mut [f64]) {
    y.iter_mut().for_each(|v| *v = 0.0);
    for (col, w) in col_ptr.windows(2).enumerate() {
        let xc = x[col];
        for k in w[0]..w[1] {
            y[row_idx[k] as usize] += vals[k] * xc;
        }
    }
}

fn column(b: &mut [f64]) -> MatMut<'_, f64> {
    let n = b.len();
    MatMut::from_column_major_slice_mut(b, n, 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::SMatrix;

    #[test]
    fn assembled_system_solves_like_a_dense_one() {
        // A chain of 5 nodes, node 0 fully fixed, node 4's z and node 2's
        // y fixed (a gap inside a node's rows).
        let mut fixed = vec![[false; 3]; 5];
        fixed[0] = [true; 3];
        fixed[4][2] = true;
        fixed[2][1] = true;
        let dofs = Dofs::new(&fixed);
        let pairs: Vec<[u32; 2]> = (0..4).map(|i| [i, i + 1]).collect();
        let mut pat = Pattern::new(5, &dofs, &pairs);
        let mut vals = vec![0.0; pat.nnz()];
        let mut dense = nalgebra::DMatrix::<f64>::zeros(dofs.n_eq, dofs.n_eq);
        let mut rng = coapt_base::rng::SplitMix64::new(3);
        for i in 0..4u32 {
            let m = SMatrix::<f64, 6, 6>::from_fn(|_, _| rng.range(-1.0, 1.0));
            let spd = m * m.transpose() + SMatrix::<f64, 6, 6>::identity();
            pat.add_block(&dofs, &mut vals, &[i, i + 1], &spd);
            for a in 0..6 {
                for b in 0..6 {
                    let (ea, eb) = (dofs.eq[3 * i as usize + a], dofs.eq[3 * i as usize + b]);
                    if ea != NONE && eb != NONE {
                        dense[(ea as usize, eb as usize)] += spd[(a, b)];
                    }
                }
            }
        }
        let rhs: Vec<f64> = (0..dofs.n_eq).map(|i| (i as f64).sin()).collect();
        let want = dense
            .clone()
            .lu()
            .solve(&nalgebra::DVector::from_vec(rhs.clone()))
            .unwrap();
        let mut x = rhs.clone();
        pat.solve_llt(&vals, &mut x).unwrap();
        let mut y = rhs.clone();
        pat.solve_lu(&vals, &mut y).unwrap();
        for i in 0..dofs.n_eq {
            assert!((x[i] - want[i]).abs() < 1e-10);
            assert!((y[i] - want[i]).abs() < 1e-10);
        }
        let ax = pat.mul(&vals, &x);
        for i in 0..dofs.n_eq {
            assert!((ax[i] - rhs[i]).abs() < 1e-10);
        }
        // A non-symmetric block: LU must solve A x = b, not Aᵀ x = b.
        let mut ns = vals.clone();
        let skew = SMatrix::<f64, 6, 6>::from_fn(|i, j| {
            if i < j {
                0.7
            } else if i > j {
                -0.7
            } else {
                0.0
            }
        });
        pat.add_block(&dofs, &mut ns, &[1, 2], &skew);
        let mut y = rhs.clone();
        pat.solve_lu(&ns, &mut y).unwrap();
        let ay = pat.mul(&ns, &y);
        for i in 0..dofs.n_eq {
            assert!((ay[i] - rhs[i]).abs() < 1e-10, "LU solves the transpose");
        }
        // Not positive definite → a clear error, not a panic.
        let neg: Vec<f64> = vals.iter().map(|v| -v).collect();
        let mut z = rhs.clone();
        assert!(pat.solve_llt(&neg, &mut z).is_err());
    }

    /// A strip of triangles over a 2 × n grid with some coordinates fixed.
    fn strip(n: u32) -> (Dofs, Vec<[u32; 3]>, Pattern) {
        let nodes = 2 * n;
        let mut fixed = vec![[false; 3]; nodes as usize];
        fixed[0] = [true; 3];
        fixed[3][1] = true;
        let dofs = Dofs::new(&fixed);
        let mut tris = Vec::new();
        for i in 0..n - 1 {
            tris.push([2 * i, 2 * i + 1, 2 * i + 2]);
            tris.push([2 * i + 1, 2 * i + 3, 2 * i + 2]);
        }
        let mut pairs = Vec::new();
        for t in &tris {
            pairs.extend([[t[0], t[1]], [t[1], t[2]], [t[0], t[2]]]);
        }
        let pat = Pattern::new(nodes as usize, &dofs, &pairs);
        (dofs, tris, pat)
    }

    /// [`strip`] with a random symmetric positive definite matrix on it:
    /// a random PSD 9×9 block per triangle plus 0.1 on the diagonal.
    fn spd_strip(n: u32, seed: u64) -> (Dofs, Vec<[u32; 3]>, Pattern, Vec<f64>) {
        let (dofs, tris, pat) = strip(n);
        let mut rng = coapt_base::rng::SplitMix64::new(seed);
        let mut vals = vec![0.0; pat.nnz()];
        for t in &tris {
            let m = SMatrix::<f64, 9, 9>::from_fn(|_, _| rng.range(-1.0, 1.0));
            pat.add_block(&dofs, &mut vals, t, &(m * m.transpose()));
        }
        pat.add_diagonal(&mut vals, &vec![0.1; dofs.n_eq]);
        (dofs, tris, pat, vals)
    }

    #[test]
    fn a_pattern_is_its_pair_set_whatever_the_order_and_repeats() {
        let (dofs, tris, pat) = strip(9);
        let mut pairs: Vec<[u32; 2]> = Vec::new();
        for t in &tris {
            pairs.extend([[t[2], t[0]], [t[1], t[2]], [t[0], t[1]], [t[1], t[0]]]);
        }
        pairs.push([4, 4]);
        // A far coupling (contact-like) both ways round.
        pairs.extend([[0, 17], [17, 0]]);
        let mut rng = coapt_base::rng::SplitMix64::new(7);
        for i in (1..pairs.len()).rev() {
            let j = (rng.range(0.0, (i + 1) as f64) as usize).min(i);
            pairs.swap(i, j);
        }
        let a = Pattern::new(18, &dofs, &pairs);
        // The same set listed plainly gives the same matrix structure.
        let mut plain: Vec<[u32; 2]> = pairs.iter().map(|&[x, y]| [x.min(y), x.max(y)]).collect();
        plain.sort_unstable();
        plain.dedup();
        let b = Pattern::new(18, &dofs, &plain);
        assert_eq!(a.nb, b.nb);
        assert_eq!(a.nb_off, b.nb_off);
        assert_eq!(a.col_ptr, b.col_ptr);
        assert_eq!(a.row_idx, b.row_idx);
        // Every node's neighbours sorted, each once, itself included.
        for i in 0..18 {
            let nb = &a.nb[a.nb_off[i] as usize..a.nb_off[i + 1] as usize];
            assert!(nb.windows(2).all(|w| w[0] < w[1]));
            assert!(nb.contains(&(i as u32)));
        }
        assert!(a.nb[a.nb_off[17] as usize..a.nb_off[18] as usize].contains(&0));
        assert!(a.covers(&pairs) && a.covers(&plain) && b.covers(&pairs));
        // Its node pairs give it again.
        let again = Pattern::new(18, &dofs, &a.node_pairs());
        assert_eq!((&again.nb, &again.row_idx), (&a.nb, &a.row_idx));
        assert_eq!(
            a.node_pairs().len(),
            plain.iter().filter(|p| p[0] != p[1]).count()
        );
        // One pair fewer is covered; one more, or a node out of range, not.
        let k = plain.iter().position(|p| p == &[0, 17]).unwrap();
        let mut fewer = plain.clone();
        fewer.remove(k);
        assert!(a.covers(&fewer));
        let mut more = plain.clone();
        more.push([3, 12]);
        assert!(!a.covers(&more));
        more.pop();
        more.push([2, 40]);
        assert!(!a.covers(&more));
        let _ = pat;
    }

    #[test]
    fn slot_tables_assemble_exactly_what_add_block_does() {
        let (dofs, tris, pat) = strip(7);
        let mut rng = coapt_base::rng::SplitMix64::new(5);
        let blocks: Vec<SMatrix<f64, 9, 9>> = tris
            .iter()
            .map(|_| SMatrix::from_fn(|_, _| rng.range(-1.0, 1.0)))
            .collect();
        let mut a = vec![0.0; pat.nnz()];
        let mut b = vec![0.0; pat.nnz()];
        for (t, k) in tris.iter().zip(&blocks) {
            pat.add_block(&dofs, &mut a, t, k);
        }
        let slots = pat.element_slots(&dofs, &tris);
        assert_eq!(slots.len(), 81 * tris.len());
        for (s, k) in slots.chunks_exact(81).zip(&blocks) {
            Pattern::add_block_at(&mut b, s, k);
        }
        assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
        // The same list again is served from the cache; another list is not.
        assert!(Arc::ptr_eq(&slots, &pat.element_slots(&dofs, &tris)));
        assert!(!Arc::ptr_eq(&slots, &pat.element_slots(&dofs, &tris[1..])));
    }

    #[test]
    fn nearly_symmetric_systems_are_solved_by_gmres_to_the_lu_answer() {
        let (dofs, tris, mut pat, mut vals) = spd_strip(40, 9);
        // A skew part on the last triangle only, as the follower pressure
        // leaves on a free edge.
        let skew = SMatrix::<f64, 9, 9>::from_fn(|i, j| (i as f64 - j as f64) * 0.05);
        pat.add_block(&dofs, &mut vals, &tris[tris.len() - 1], &skew);
        let rhs: Vec<f64> = (0..dofs.n_eq).map(|i| (0.3 * i as f64).cos()).collect();
        let mut want = rhs.clone();
        pat.solve_lu(&vals, &mut want).unwrap();
        let mut got = rhs.clone();
        pat.solve_nonsymmetric(&vals, &mut got).unwrap();
        assert_eq!(pat.stats.gmres_solves, 1);
        assert!(pat.stats.gmres_iterations <= 10, "{:?}", pat.stats);
        let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() <= 1e-8 * scale, "{g} vs {w}");
        }
        // An inexact Newton step asks for less. With a skew part on every
        // triangle GMRES converges gradually: a looser tolerance takes
        // fewer products and leaves the residual it asked for.
        let mut spread = vals.clone();
        for t in &tris {
            pat.add_block(&dofs, &mut spread, t, &(skew * 2.0));
        }
        let products = |pat: &mut Pattern, tol: f64| {
            let mut y = rhs.clone();
            let before = pat.stats.gmres_iterations;
            pat.solve_nonsymmetric_reusing(&spread, &mut y, tol, false)
                .unwrap();
            let r: Vec<f64> = pat
                .mul(&spread, &y)
                .iter()
                .zip(&rhs)
                .map(|(a, b)| a - b)
                .collect();
            let rel = (r.iter().map(|v| v * v).sum::<f64>()
                / rhs.iter().map(|v| v * v).sum::<f64>())
            .sqrt();
            (pat.stats.gmres_iterations - before, rel)
        };
        let (tight, tight_rel) = products(&mut pat, 1e-10);
        let (loose, loose_rel) = products(&mut pat, 1e-3);
        assert!(
            tight_rel <= 1e-10 && loose_rel <= 1e-3,
            "{tight_rel} {loose_rel}"
        );
        assert!(
            loose_rel > 1e-6,
            "the loose solve was not loose: {loose_rel}"
        );
        assert!(2 * loose < tight, "{loose} vs {tight} products");
        // An indefinite symmetric part: LU answers.
        let neg: Vec<f64> = vals.iter().map(|v| -v).collect();
        let mut y = rhs.clone();
        pat.solve_nonsymmetric(&neg, &mut y).unwrap();
        assert_eq!(pat.stats.lu_solves, 1);
        let ay = pat.mul(&neg, &y);
        for (a, r) in ay.iter().zip(&rhs) {
            assert!((a - r).abs() < 1e-9);
        }
    }

    #[test]
    fn an_earlier_factor_preconditions_a_nearby_system_without_a_factorisation() {
        let (dofs, tris, mut pat, vals) = spd_strip(40, 11);
        let rhs: Vec<f64> = (0..dofs.n_eq).map(|i| (0.7 * i as f64).sin()).collect();
        let mut first = rhs.clone();
        pat.solve_nonsymmetric(&vals, &mut first).unwrap();
        // The next round: one node's stiffness doubled (a sutured row as K
        // doubles) and a small skew part on the free end.
        let mut next = vals.clone();
        let node = [tris[5][2]; 1];
        let block = SMatrix::<f64, 3, 3>::from_fn(|i, j| if i == j { 3.0 } else { 0.5 });
        pat.add_block(&dofs, &mut next, &node, &block);
        let skew = SMatrix::<f64, 9, 9>::from_fn(|i, j| (i as f64 - j as f64) * 0.02);
        pat.add_block(&dofs, &mut next, &tris[tris.len() - 1], &skew);
        let mut want = rhs.clone();
        pat.solve_lu(&next, &mut want).unwrap();
        let before = pat.stats;
        let mut got = rhs.clone();
        pat.solve_nonsymmetric_reusing(&next, &mut got, 1e-9, true)
            .unwrap();
        assert_eq!(
            pat.stats.reused_factor,
            before.reused_factor + 1,
            "{:?}",
            pat.stats
        );
        let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() <= 1e-7 * scale, "{g} vs {w}");
        }
        // A system far from the factored one (every stiffness scaled
        // unevenly): the reused try gives up and a fresh factor answers.
        let far: Vec<f64> = next
            .iter()
            .enumerate()
            .map(|(k, v)| v * (1.0 + 50.0 * ((k % 7) as f64)))
            .collect();
        let far: Vec<f64> = far
            .iter()
            .zip(&pat.transpose)
            .map(|(a, &t)| 0.5 * (a + far[t as usize]))
            .collect();
        let before = pat.stats;
        let mut y = rhs.clone();
        pat.solve_nonsymmetric_reusing(&far, &mut y, 1e-9, true)
            .unwrap();
        assert_eq!(
            pat.stats.reused_factor, before.reused_factor,
            "{:?}",
            pat.stats
        );
        let ay = pat.mul(&far, &y);
        let scale = ay.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (a, r) in ay.iter().zip(&rhs) {
            assert!((a - r).abs() < 1e-8 * scale, "{a} vs {r}");
        }
    }
}
