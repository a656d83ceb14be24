//! The tangent matrix: a 3×3-block sparsity pattern over the free degrees
//! of freedom, built once per coupling set, filled in element order (so the
//! sum is the same whatever the thread count), and factorised by faer with
//! the symbolic analysis reused while the pattern does not change. The
//! numeric factors and the work space are kept too: a Newton solve
//! factorises the same pattern dozens of times, and allocating (and
//! zero-filling fresh pages for) a supernodal LU each time cost a quarter
//! of the suturing pre-stage.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::sparse::linalg::{cholesky, lu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side};

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
    col_ptr: Vec<usize>,
    row_idx: Vec<u32>,
    /// The couplings it was built from (to detect a change).
    pub key: Vec<[u32; 2]>,
    llt: Option<LltFactor>,
    lu: Option<LuFactor>,
    sym: SymbolicSparseColMat<u32>,
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
        let mut key: Vec<[u32; 2]> = pairs
            .iter()
            .map(|&[a, b]| if a < b { [a, b] } else { [b, a] })
            .chain((0..n_nodes as u32).map(|i| [i, i]))
            .collect();
        key.sort_unstable();
        key.dedup();
        let mut deg = vec![0u32; n_nodes + 1];
        for &[a, b] in &key {
            deg[a as usize + 1] += 1;
            if a != b {
                deg[b as usize + 1] += 1;
            }
        }
        for i in 0..n_nodes {
            deg[i + 1] += deg[i];
        }
        let nb_off = deg.clone();
        let mut fill = deg;
        let mut nb = vec![0u32; nb_off[n_nodes] as usize];
        for &[a, b] in &key {
            nb[fill[a as usize] as usize] = b;
            fill[a as usize] += 1;
            if a != b {
                nb[fill[b as usize] as usize] = a;
                fill[b as usize] += 1;
            }
        }
        let free = |n: u32| {
            (0..3)
                .filter(|&c| dofs.eq[3 * n as usize + c] != NONE)
                .count() as u32
        };
        let mut row_off = vec![0u32; nb.len()];
        for i in 0..n_nodes {
            let s = &mut nb[nb_off[i] as usize..nb_off[i + 1] as usize];
            s.sort_unstable();
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
        Pattern {
            nb_off,
            nb,
            row_off,
            col_ptr,
            row_idx,
            key,
            llt: None,
            lu: None,
            sym,
        }
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
        // What `slot` finds, with one neighbour search per node pair instead
        // of one per entry (the search dominated assembly); entries are
        // visited in the same order, so the sums are the same.
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
                            vals[self.col_ptr[col as usize] + off + before[r]] +=
                                block[(3 * bi + r, 3 * bj + c)];
                        }
                    }
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
        for (col, w) in self.col_ptr.windows(2).enumerate() {
            for k in w[0]..w[1] {
                y[self.row_idx[k] as usize] += vals[k] * x[col];
            }
        }
        y
    }

    /// Solve A x = b by Cholesky (A symmetric); `Err` when A is not
    /// positive definite.
    pub fn solve_llt(&mut self, vals: &[f64], b: &mut [f64]) -> Result<(), String> {
        if self.llt.is_none() {
            let symbolic = cholesky::factorize_symbolic_cholesky(
                self.sym.as_ref(),
                Side::Lower,
                Default::default(),
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
        let l = f
            .symbolic
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
        l.solve_in_place_with_conj(Conj::No, column(b), par(), MemStack::new(&mut f.mem));
        Ok(())
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
        let mut rng = crate::rng::SplitMix64::new(3);
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
}
