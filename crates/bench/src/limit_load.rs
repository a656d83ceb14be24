//! Whether a failed stress case had an equilibrium to find: the pressure
//! ladder (`coapt bench stress-close --explain`).
//!
//! A membrane under a follower pressure has a limit load, past which no
//! equilibrium exists and every solver must fail: a neo-Hookean sphere
//! carries at most p r / (μ t) = 2 (λ⁻¹ − λ⁻⁷) = 1.24, at λ = 7^(1/6), and
//! a membrane of linear springs stops stiffening as well. So a failed case
//! is closed again at fractions of its pressure, from rest each time, and
//! the rungs that converge trace the equilibrium path p(V), V the volume
//! the leaflet sweeps from its start (the work conjugate of the pressure,
//! dW = p dV). Near a limit point p(V) ≈ p* − α (V − V*)², so a parabola
//! through the three highest converged rungs estimates p*. An estimate
//! below the case's pressure says the case has no equilibrium on the path
//! from rest; a path still stiffening, or a p* above the case's pressure,
//! says an equilibrium is there and the solver missed it. The estimate is
//! an extrapolation, and the report says so.

use rayon::prelude::*;

use super::stress_close::{Case, prepare};
use coapt_mech::closure;
use coapt_mech::element::V3;

/// One closure of the ladder.
#[derive(Debug, Clone, PartialEq)]
pub struct Rung {
    pub fraction: f64,
    pub pressure_mmhg: f64,
    pub converged: bool,
    /// Volume swept from the case's start (mm³); NaN where it did not
    /// converge.
    pub volume_mm3: f64,
    pub iterations: usize,
}

/// What the ladder says about the case.
#[derive(Debug, Clone, PartialEq)]
pub enum Finding {
    /// The case could not be set up, or no rung converged down to this
    /// fraction of its pressure.
    NoRung { lowest_fraction: f64 },
    /// The swept volume fell as the pressure rose between these two rungs:
    /// the closures found another branch of equilibria (a snap or a fold).
    Branch { from_mmhg: f64, to_mmhg: f64 },
    /// Fewer than three converged rungs to fit.
    TooFew,
    /// The path has softened to `stiffness` (at most [`SOFTENED`]) of its
    /// peak secant stiffness dp/dV, towards a limit load below the case's
    /// pressure: there is no equilibrium on the path from rest.
    BeyondLimit { limit_mmhg: f64, stiffness: f64 },
    /// The path softens, but not enough to tell whether the limit
    /// (`None`: not extrapolable) lies below the case's pressure.
    Undecided {
        limit_mmhg: Option<f64>,
        stiffness: f64,
    },
    /// The path has not softened (`stiffness` above [`HOLDS`]), is
    /// stiffening at its top (`limit_mmhg` None), or its limit lies above
    /// the case's pressure: an equilibrium exists and the solver missed it.
    SolverShort {
        limit_mmhg: Option<f64>,
        stiffness: f64,
    },
}

/// A path whose top secant stiffness is at most this fraction of its peak
/// has softened: the limit point is near.
pub const SOFTENED: f64 = 0.5;

/// A path whose top secant stiffness is above this fraction of its peak
/// has not softened. Neighbouring rungs of a crumpled membrane converge to
/// slightly different equilibria, so one secant can be off by a third
/// (an MSM case at 42 mmHg: 0.17–0.21 mmHg/mm³ with no trend).
pub const HOLDS: f64 = 0.8;

#[derive(Debug, Clone)]
pub struct Ladder {
    pub index: usize,
    pub pressure_mmhg: f64,
    pub rungs: Vec<Rung>,
    pub finding: Finding,
}

/// Volume swept by the straight-line motion of the triangles from `x0` to
/// `x1`: for each triangle ∫₀¹ A(s) ds · ū, A the (quadratic in s) area
/// vector and ū the mean displacement of its corners, which is ∫ n·u dA
/// exactly for a displacement linear over the triangle. Simpson's rule is
/// exact for the quadratic.
pub fn swept_volume(x0: &[V3], x1: &[V3], tris: &[[u32; 3]]) -> f64 {
    let area = |p: [V3; 3]| 0.5 * (p[1] - p[0]).cross(&(p[2] - p[0]));
    tris.iter()
        .map(|t| {
            let at = |s: f64| t.map(|i| x0[i as usize] + (x1[i as usize] - x0[i as usize]) * s);
            let a = (area(at(0.0)) + 4.0 * area(at(0.5)) + area(at(1.0))) / 6.0;
            let u = t
                .iter()
                .map(|&i| x1[i as usize] - x0[i as usize])
                .fold(V3::zeros(), |s, d| s + d)
                / 3.0;
            a.dot(&u)
        })
        .sum()
}

/// The limit load of the parabola p(V) through three points of a path
/// ordered by pressure; `None` when the path is not softening there.
pub fn parabola_limit(pts: [(f64, f64); 3]) -> Option<f64> {
    let [(v1, p1), (v2, p2), (v3, p3)] = pts;
    let (d1, d2) = ((p2 - p1) / (v2 - v1), (p3 - p2) / (v3 - v2));
    let c = (d2 - d1) / (v3 - v1);
    if !(c < 0.0) {
        return None;
    }
    let s3 = d2 + c * (v3 - v2);
    Some(p3 - s3 * s3 / (4.0 * c))
}

fn rung(c: &Case, fraction: f64, time_limit_s: f64) -> Option<Rung> {
    let mut at = c.clone();
    at.pressure_mmhg *= fraction;
    let (l, axis, cfg) = prepare(&at, time_limit_s).ok()?;
    let (converged, volume, iterations) = match closure::close(&l, &cfg, Some(axis)) {
        Ok(closed) => {
            let ok = closed.outcome.converged
                && closed.x.iter().all(|p| p.iter().all(|v| v.is_finite()));
            let v = if ok {
                swept_volume(&l.x, &closed.x, &l.tris)
            } else {
                f64::NAN
            };
            (ok, v, closed.outcome.iterations)
        }
        Err(_) => (false, f64::NAN, 0),
    };
    Some(Rung {
        fraction,
        pressure_mmhg: at.pressure_mmhg,
        converged,
        volume_mm3: volume,
        iterations,
    })
}

/// Bisection steps between the highest converged rung and the lowest
/// failed one above it.
const BISECTIONS: usize = 3;

/// Close `c` at fractions of its pressure: 1/8, 1/4, 1/2, 3/4 up to the
/// first failure (down to 1/32 when 1/8 fails), three bisections towards the
/// highest pressure that converges, and two rungs below that as far apart
/// as the last bracket, so that the parabola is fitted where the path ends.
pub fn ladder(c: &Case, time_limit_s: f64) -> Ladder {
    let mut rungs: Vec<Rung> = Vec::new();
    let run = |f: f64, rungs: &mut Vec<Rung>| match rung(c, f, time_limit_s) {
        Some(r) => {
            let ok = r.converged;
            rungs.push(r);
            ok
        }
        None => false,
    };
    let (mut lo, mut hi) = (0.0, 1.0);
    for f in [0.125, 0.25, 0.5, 0.75] {
        if run(f, &mut rungs) {
            lo = f;
        } else {
            hi = f;
            break;
        }
    }
    if lo == 0.0 {
        for f in [0.0625, 0.03125] {
            if run(f, &mut rungs) {
                lo = f;
                break;
            }
            hi = f;
        }
    }
    let finding = if lo == 0.0 {
        Finding::NoRung {
            lowest_fraction: hi,
        }
    } else {
        for _ in 0..BISECTIONS {
            let m = 0.5 * (lo + hi);
            if run(m, &mut rungs) {
                lo = m;
            } else {
                hi = m;
            }
        }
        let d = hi - lo;
        for f in [lo - 2.0 * d, lo - d] {
            if f > 0.0 && !rungs.iter().any(|r| (r.fraction - f).abs() < 1e-12) {
                run(f, &mut rungs);
            }
        }
        judge(&rungs, lo, c.pressure_mmhg)
    };
    rungs.sort_by(|a, b| a.fraction.total_cmp(&b.fraction));
    Ladder {
        index: c.index,
        pressure_mmhg: c.pressure_mmhg,
        rungs,
        finding,
    }
}

/// The finding from the converged rungs at or below `top` (the highest of
/// the unbroken run from rest), by pressure.
fn judge(rungs: &[Rung], top: f64, pressure_mmhg: f64) -> Finding {
    let mut path: Vec<&Rung> = rungs
        .iter()
        .filter(|r| r.converged && r.fraction <= top + 1e-12)
        .collect();
    path.sort_by(|a, b| a.fraction.total_cmp(&b.fraction));
    if path.len() < 3 {
        return Finding::TooFew;
    }
    // Pressure pushes the leaflet one way: orient V so that it grows.
    let sign = (path[path.len() - 1].volume_mm3 - path[0].volume_mm3).signum();
    if let Some(w) = path
        .windows(2)
        .find(|w| sign * (w[1].volume_mm3 - w[0].volume_mm3) <= 0.0)
    {
        return Finding::Branch {
            from_mmhg: w[0].pressure_mmhg,
            to_mmhg: w[1].pressure_mmhg,
        };
    }
    let secants: Vec<f64> = path
        .windows(2)
        .map(|w| {
            (w[1].pressure_mmhg - w[0].pressure_mmhg) / (sign * (w[1].volume_mm3 - w[0].volume_mm3))
        })
        .collect();
    let peak = secants.iter().copied().fold(0.0, f64::max);
    let stiffness = secants[secants.len() - 1] / peak;
    let n = path.len();
    let pts =
        [path[n - 3], path[n - 2], path[n - 1]].map(|r| (sign * r.volume_mm3, r.pressure_mmhg));
    let limit = parabola_limit(pts);
    match limit {
        Some(p) if p < pressure_mmhg && stiffness <= SOFTENED => Finding::BeyondLimit {
            limit_mmhg: p,
            stiffness,
        },
        Some(p) if p < pressure_mmhg && stiffness <= HOLDS => Finding::Undecided {
            limit_mmhg: limit,
            stiffness,
        },
        _ => Finding::SolverShort {
            limit_mmhg: limit,
            stiffness,
        },
    }
}

impl Ladder {
    /// The highest pressure that converged from rest, if any.
    pub fn highest_mmhg(&self) -> Option<f64> {
        self.rungs
            .iter()
            .filter(|r| r.converged)
            .map(|r| r.pressure_mmhg)
            .reduce(f64::max)
    }

    /// One line for the table.
    pub fn line(&self) -> String {
        let top = self
            .highest_mmhg()
            .map_or("none".to_string(), |p| format!("{p:.1} mmHg"));
        let what = match &self.finding {
            Finding::NoRung { lowest_fraction } => format!(
                "no rung converged down to {:.1} mmHg",
                lowest_fraction * self.pressure_mmhg
            ),
            Finding::Branch { from_mmhg, to_mmhg } => format!(
                "the path jumps to another branch between {from_mmhg:.1} and {to_mmhg:.1} mmHg (the swept volume falls)"
            ),
            Finding::TooFew => "too few converged rungs to fit the path".into(),
            Finding::BeyondLimit {
                limit_mmhg,
                stiffness,
            } => format!(
                "no equilibrium: the path has softened to {:.0} % of its peak stiffness dp/dV, towards a limit load of about {limit_mmhg:.1} mmHg (extrapolated)",
                100.0 * stiffness
            ),
            Finding::Undecided {
                limit_mmhg,
                stiffness,
            } => format!(
                "undecided: the path has softened to {:.0} % of its peak stiffness, towards a limit load of about {} (extrapolated), too little to tell",
                100.0 * stiffness,
                limit_mmhg.map_or("?".to_string(), |p| format!("{p:.1} mmHg"))
            ),
            Finding::SolverShort {
                limit_mmhg,
                stiffness,
            } => format!(
                "the solver missed an equilibrium: the path holds {:.0} % of its peak stiffness{}",
                100.0 * stiffness,
                match limit_mmhg {
                    Some(p) if *p >= self.pressure_mmhg => {
                        format!(", its limit load extrapolated at {p:.1} mmHg, above the case's")
                    }
                    Some(_) => String::new(),
                    None => " and is stiffening at its top".to_string(),
                }
            ),
        };
        format!(
            "  case {:>4} at {:.1} mmHg: converges from rest up to {top}; {what}",
            self.index, self.pressure_mmhg
        )
    }
}

/// The ladders of `cases`, in parallel and in the order given.
pub fn explain(cases: &[Case], time_limit_s: f64) -> Vec<Ladder> {
    cases.par_iter().map(|c| ladder(c, time_limit_s)).collect()
}

/// The ladders' lines and their count by finding; `converged` and `total`
/// are the run's, so the share of the cases that have an equilibrium which
/// converged can be stated.
pub fn table(ladders: &[Ladder], converged: usize, total: usize) -> String {
    let mut t = format!(
        "pressure ladder of the {} failed case(s) (closed from rest at fractions of each case's pressure; limits extrapolated by a parabola p(V) through the three highest converged rungs):\n",
        ladders.len()
    );
    for l in ladders {
        t.push_str(&l.line());
        t.push('\n');
    }
    let beyond = ladders
        .iter()
        .filter(|l| matches!(l.finding, Finding::BeyondLimit { .. }))
        .count();
    let short = ladders
        .iter()
        .filter(|l| matches!(l.finding, Finding::SolverShort { .. }))
        .count();
    t.push_str(&format!(
        "{beyond} failed case(s) lie beyond their limit load, in {short} the solver missed an equilibrium, {} are undecided or jump branches; of the {} cases not beyond their limit, {converged} converged ({:.1} %)\n",
        ladders.len() - beyond - short,
        total - beyond,
        100.0 * converged as f64 / (total - beyond).max(1) as f64
    ));
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The parabola's vertex is the limit of a path that is one.
    #[test]
    fn a_parabolic_path_gives_its_vertex() {
        let (ps, vs, a) = (84.0, 2400.0, 1.2e-4);
        let p = |v: f64| ps - a * (v - vs) * (v - vs);
        let pts = [2000.0, 2100.0, 2180.0].map(|v| (v, p(v)));
        assert!((parabola_limit(pts).unwrap() - ps).abs() < 1e-9);
    }

    /// On the neo-Hookean sphere's path p(λ) = 2 (λ⁻¹ − λ⁻⁷) (in units of
    /// μ t / r), V ∝ λ³, three rungs short of the top estimate its limit
    /// 1.2395 within 2 %, and a stiffening path has none.
    #[test]
    fn the_neo_hookean_sphere_limit_is_found_from_below() {
        let p = |l: f64| 2.0 * (1.0 / l - l.powi(-7));
        let pts = [1.25, 1.28, 1.31].map(|l: f64| (l.powi(3), p(l)));
        let est = parabola_limit(pts).unwrap();
        let exact = p(7f64.powf(1.0 / 6.0));
        assert!((exact - 1.2395).abs() < 1e-4, "{exact}");
        assert!((est - exact).abs() < 0.02 * exact, "{est} against {exact}");
        assert!(est >= pts[2].1);
        let stiff = [1.0, 2.0, 3.0].map(|v: f64| (v, v * v));
        assert_eq!(parabola_limit(stiff), None);
    }

    /// A rigid translation along the normal sweeps area × distance, and
    /// the volume does not depend on where the origin is.
    #[test]
    fn swept_volume_is_area_times_distance_and_origin_free() {
        let x0 = vec![
            V3::new(0.0, 0.0, 0.0),
            V3::new(2.0, 0.0, 0.0),
            V3::new(0.0, 3.0, 0.0),
            V3::new(2.0, 3.0, 0.0),
        ];
        let tris = [[0, 1, 2], [1, 3, 2]];
        let up: Vec<V3> = x0.iter().map(|p| p + V3::new(0.0, 0.0, 0.5)).collect();
        assert!((swept_volume(&x0, &up, &tris) - 3.0).abs() < 1e-12);
        // A bulge: the middle of the far edge moves; shifting everything
        // by a constant changes nothing.
        let mut bulged = x0.clone();
        bulged[3] += V3::new(0.3, -0.2, 1.0);
        let shift = V3::new(5.0, -7.0, 11.0);
        let (s0, s1): (Vec<V3>, Vec<V3>) = (
            x0.iter().map(|p| p + shift).collect(),
            bulged.iter().map(|p| p + shift).collect(),
        );
        let v = swept_volume(&x0, &bulged, &tris);
        assert!((v - swept_volume(&s0, &s1, &tris)).abs() < 1e-12);
        assert!(v > 0.0);
    }
}
