//! The discrete problem: node positions, prescribed coordinates, membrane
//! elements, pressure and extra terms (contact, suturing); it evaluates the
//! energy, the nodal residual (force) and the tangent.

use rayon::prelude::*;

use super::element::{Grad9, Hess9, Membrane, RefTri, V3, project_psd};
use super::pressure;
use super::sparse::{Dofs, Pattern};

/// How the pressure enters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PressureMode {
    /// Seed 000's follower load (exact; non-symmetric tangent).
    Follower,
    /// −P·V about a point: conservative, exact only where the boundary of
    /// the loaded surface is fixed (closed surfaces, clamped membranes).
    Volume { origin: [f64; 3] },
}

/// An additional term of the model: contact, penalty planes, suturing.
pub trait Term: Send + Sync {
    fn name(&self) -> &'static str;
    /// Refresh state that depends on the configuration (the contact broad
    /// phase); called once per outer iteration, never inside a line search.
    fn update(&mut self, _x: &[V3]) {}
    /// Its energy, or `None` when the term is a force without a potential.
    fn energy(&self, x: &[V3]) -> Option<f64>;
    /// Whether [`Term::energy`] gives a potential (known without computing it).
    fn has_potential(&self) -> bool {
        true
    }
    /// Add its force (−gradient for potentials) to `f`.
    fn add_force(&self, x: &[V3], f: &mut [V3]);
    /// Node pairs its tangent couples (for the sparsity pattern).
    fn couplings(&self, _out: &mut Vec<[u32; 2]>) {}
    /// Add its tangent (∂(−f)/∂x) into the pattern's values.
    fn add_tangent(&self, _x: &[V3], _dofs: &Dofs, _pat: &Pattern, _vals: &mut [f64]) {}
    /// A short record for the solver history (e.g. active contact pairs).
    fn stats(&self) -> Option<(&'static str, usize)> {
        None
    }
    /// The solver wants a positive semi-definite tangent from now on (its
    /// continuation phase) or the exact one; terms whose Hessian can be
    /// indefinite follow it.
    fn set_projected(&mut self, _projected: bool) {}
    /// Per node, bit b set when it touches body b (contact terms only).
    fn contact_mask(&self, _x: &[V3]) -> Option<Vec<u8>> {
        None
    }
    /// Largest fraction of the move `dx` (per node) from `x` the term
    /// allows (a barrier's collision-free step); `x` is the state of the
    /// last [`Term::update`].
    fn max_step(&self, _x: &[V3], _dx: &[V3]) -> f64 {
        1.0
    }
    /// Whether the state may be taken at all (a barrier: nothing crossed).
    fn admissible(&self, _x: &[V3]) -> bool {
        true
    }
}

pub struct System {
    pub tris: Vec<[u32; 3]>,
    pub refs: Vec<RefTri>,
    pub materials: Vec<Box<dyn Membrane>>,
    /// Material index of each triangle.
    pub tri_material: Vec<u16>,
    pub fixed: Vec<[bool; 3]>,
    pub dofs: Dofs,
    /// Pressure (MPa) on each triangle, signed: the load pushes along the
    /// triangle's oriented normal for positive values.
    pub tri_pressure: Vec<f64>,
    pub pressure_scale: f64,
    pub pressure_mode: PressureMode,
    pub terms: Vec<Box<dyn Term>>,
    /// Project element Hessians to PSD in the tangent.
    pub project: bool,
    /// Include the load stiffness of the pressure in the tangent.
    pub pressure_tangent: bool,
    /// Told the residual norm (N) after each Newton iteration, for a
    /// progress bar; it never changes the solve.
    pub watch: Option<Watch>,
}

/// See [`System::watch`].
pub type Watch = std::sync::Arc<dyn Fn(f64) + Send + Sync>;

/// The state is outside a material's domain (an inverted or collapsed
/// triangle, Gent beyond lock-up), naming the first offending triangle.
#[derive(Debug, Clone, Copy)]
pub struct Inadmissible {
    pub triangle: usize,
}

impl System {
    pub fn n_nodes(&self) -> usize {
        self.fixed.len()
    }

    fn tri_q(&self, x: &[V3], t: usize) -> [V3; 3] {
        self.tris[t].map(|i| x[i as usize])
    }

    /// Each element's energy and gradient. Kept apart from the Hessians so
    /// a residual does not move 650 bytes of empty Hessian per triangle.
    fn eval_grads(&self, x: &[V3]) -> Result<Vec<(f64, Grad9)>, Inadmissible> {
        let out: Vec<Option<(f64, Grad9)>> = (0..self.tris.len())
            .into_par_iter()
            .with_min_len(256)
            .map(|t| {
                let m = &self.materials[self.tri_material[t] as usize];
                let e = m.eval(&self.refs[t], &self.tri_q(x, t), false)?;
                Some((e.energy, e.grad))
            })
            .collect();
        let mut v = Vec::with_capacity(out.len());
        for (t, o) in out.into_iter().enumerate() {
            v.push(o.ok_or(Inadmissible { triangle: t })?);
        }
        Ok(v)
    }

    /// Each element's Hessian (projected when `self.project`); every entry
    /// is `Some` when the result is `Ok`.
    fn eval_hessians(&self, x: &[V3]) -> Result<Vec<Option<Hess9>>, Inadmissible> {
        let out: Vec<Option<Hess9>> = (0..self.tris.len())
            .into_par_iter()
            .with_min_len(256)
            .map(|t| {
                let m = &self.materials[self.tri_material[t] as usize];
                let h = m.eval(&self.refs[t], &self.tri_q(x, t), true)?.hess?;
                Some(if self.project { project_psd(&h) } else { h })
            })
            .collect();
        match out.iter().position(Option::is_none) {
            Some(t) => Err(Inadmissible { triangle: t }),
            None => Ok(out),
        }
    }

    /// Total potential, or `Ok(None)` when some load has no potential.
    pub fn energy(&self, x: &[V3]) -> Result<Option<f64>, Inadmissible> {
        let el = self.eval_grads(x)?;
        let mut e: f64 = el.iter().map(|v| v.0).sum();
        match self.pressure_mode {
            PressureMode::Follower => {
                if self.tri_pressure.iter().any(|&p| p != 0.0) && self.pressure_scale != 0.0 {
                    return Ok(None);
                }
            }
            PressureMode::Volume { origin } => {
                let c = V3::from(origin);
                for t in 0..self.tris.len() {
                    let p = self.tri_pressure[t] * self.pressure_scale;
                    e += pressure::volume_potential(&self.tri_q(x, t), &c, p, false).0;
                }
            }
        }
        for term in &self.terms {
            match term.energy(x) {
                Some(v) => e += v,
                None => return Ok(None),
            }
        }
        Ok(Some(e))
    }

    /// Nodal force (N), zero on prescribed coordinates.
    pub fn residual(&self, x: &[V3]) -> Result<Vec<V3>, Inadmissible> {
        let el = self.eval_grads(x)?;
        let mut f = vec![V3::zeros(); x.len()];
        for (t, (_, g)) in el.iter().enumerate() {
            for k in 0..3 {
                f[self.tris[t][k] as usize] -= g.fixed_rows::<3>(3 * k).into_owned();
            }
        }
        self.add_pressure_force(x, &mut f);
        for term in &self.terms {
            term.add_force(x, &mut f);
        }
        self.zero_fixed(&mut f);
        Ok(f)
    }

    fn add_pressure_force(&self, x: &[V3], f: &mut [V3]) {
        for t in 0..self.tris.len() {
            let p = self.tri_pressure[t] * self.pressure_scale;
            if p == 0.0 {
                continue;
            }
            let q = self.tri_q(x, t);
            match self.pressure_mode {
                PressureMode::Follower => {
                    let ff = pressure::follower_force(&q, p);
                    for k in 0..3 {
                        f[self.tris[t][k] as usize] += ff[k];
                    }
                }
                PressureMode::Volume { origin } => {
                    let (_, g, _) = pressure::volume_potential(&q, &V3::from(origin), p, false);
                    for k in 0..3 {
                        f[self.tris[t][k] as usize] -= g.fixed_rows::<3>(3 * k).into_owned();
                    }
                }
            }
        }
    }

    pub fn zero_fixed(&self, f: &mut [V3]) {
        for (v, fx) in f.iter_mut().zip(&self.fixed) {
            for c in 0..3 {
                if fx[c] {
                    v[c] = 0.0;
                }
            }
        }
    }

    /// Whether the tangent is symmetric (all loads conservative).
    pub fn symmetric(&self) -> bool {
        !(self.pressure_mode == PressureMode::Follower
            && self.pressure_scale != 0.0
            && self.tri_pressure.iter().any(|&p| p != 0.0))
    }

    /// Node pairs coupled by the current model.
    pub fn couplings(&self) -> Vec<[u32; 2]> {
        let mut v = Vec::with_capacity(3 * self.tris.len());
        for t in &self.tris {
            v.push([t[0], t[1]]);
            v.push([t[1], t[2]]);
            v.push([t[2], t[0]]);
        }
        for term in &self.terms {
            term.couplings(&mut v);
        }
        v
    }

    /// Fill `vals` with the tangent K = −∂f/∂x at `x`.
    pub fn tangent(&self, x: &[V3], pat: &Pattern, vals: &mut [f64]) -> Result<(), Inadmissible> {
        vals.iter_mut().for_each(|v| *v = 0.0);
        let el = self.eval_hessians(x)?;
        let slots = pat.element_slots(&self.dofs, &self.tris);
        for (t, h) in el.iter().enumerate() {
            Pattern::add_block_at(
                vals,
                &slots[81 * t..81 * (t + 1)],
                h.as_ref().expect("asked for"),
            );
        }
        for t in 0..self.tris.len() {
            let p = self.tri_pressure[t] * self.pressure_scale;
            if p == 0.0 || !self.pressure_tangent {
                continue;
            }
            let q = self.tri_q(x, t);
            let k = match self.pressure_mode {
                PressureMode::Follower => -pressure::follower_jacobian(&q, p),
                PressureMode::Volume { origin } => {
                    pressure::volume_potential(&q, &V3::from(origin), p, true)
                        .2
                        .expect("asked for")
                }
            };
            Pattern::add_block_at(vals, &slots[81 * t..81 * (t + 1)], &k);
        }
        for term in &self.terms {
            term.add_tangent(x, &self.dofs, pat, vals);
        }
        Ok(())
    }

    /// Pack the free coordinates of a nodal vector.
    pub fn pack(&self, f: &[V3]) -> Vec<f64> {
        let mut v = vec![0.0; self.dofs.n_eq];
        for (i, fi) in f.iter().enumerate() {
            for c in 0..3 {
                let e = self.dofs.eq[3 * i + c];
                if e != super::sparse::NONE {
                    v[e as usize] = fi[c];
                }
            }
        }
        v
    }

    /// x + α·d, d given over the free coordinates.
    pub fn step(&self, x: &[V3], d: &[f64], alpha: f64) -> Vec<V3> {
        let mut y = x.to_vec();
        for (i, yi) in y.iter_mut().enumerate() {
            for c in 0..3 {
                let e = self.dofs.eq[3 * i + c];
                if e != super::sparse::NONE {
                    yi[c] += alpha * d[e as usize];
                }
            }
        }
        y
    }
}

/// Euclidean norm of a nodal vector.
pub fn norm(f: &[V3]) -> f64 {
    f.iter().map(|v| v.norm_squared()).sum::<f64>().sqrt()
}

/// Largest nodal force magnitude.
pub fn max_norm(f: &[V3]) -> f64 {
    f.iter().map(|v| v.norm()).fold(0.0, f64::max)
}

/// A term's assembled tangent as a dense matrix, every coordinate free
/// (tests: held against central differences of its forces).
#[cfg(test)]
pub(crate) fn dense_tangent(term: &dyn Term, x: &[V3]) -> nalgebra::DMatrix<f64> {
    let n = x.len();
    let dofs = Dofs::new(&vec![[false; 3]; n]);
    let mut pairs = Vec::new();
    term.couplings(&mut pairs);
    let pat = Pattern::new(n, &dofs, &pairs);
    let mut vals = vec![0.0; pat.nnz()];
    term.add_tangent(x, &dofs, &pat, &mut vals);
    let mut k = nalgebra::DMatrix::zeros(3 * n, 3 * n);
    for j in 0..3 * n {
        let mut e = vec![0.0; dofs.n_eq];
        e[dofs.eq[j] as usize] = 1.0;
        let col = pat.mul(&vals, &e);
        for i in 0..3 * n {
            k[(i, j)] = col[dofs.eq[i] as usize];
        }
    }
    k
}
