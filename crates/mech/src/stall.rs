//! Why a solve ran out of iterations or time when its last state shows no
//! physical cause (no balloon, no collapse): read from the residual history,
//! so that the user knows whether more iterations would help, or whether
//! the iterates creep, cycle or are held back.

use super::solve::Record;

/// Fewest records worth reading: below this the history says nothing.
const MIN_RECORDS: usize = 10;

/// Per-iteration factor of the residual that still counts as converging
/// (a 0.2-fold drop over 50 iterations) and that counts as rising.
const FALLING: f64 = 0.97;
const RISING: f64 = 1.03;

/// Spread of the residual (largest over smallest) beyond which full steps
/// wander rather than cycle.
const WANDER: f64 = 10.0;

/// Share of the tail's steps that must move the residual one way for a
/// slow trend to be a creep rather than a cycle. A stress case (pure
/// neo-Hookean membrane, h 0.75 mm) was called cycling while all 60 of its
/// last steps lowered the residual, 0.985-fold each. Steps cut
/// short are the held-back case, whatever their trend.
const MONOTONE: f64 = 0.9;

/// The solver's behaviour over the last third of `history` (10 to 60
/// iterations), in words; `None` for a history too short to judge.
pub fn stall_cause(history: &[Record]) -> Option<String> {
    let n = history.len();
    if n < MIN_RECORDS {
        return None;
    }
    let w = (n / 3).clamp(MIN_RECORDS, 60);
    let tail = &history[n - w..];
    // The trend from the halves' geometric means: one wild iterate at
    // either end must not decide it.
    if tail
        .iter()
        .any(|r| !(r.residual_n > 0.0 && r.residual_n.is_finite()))
    {
        return None;
    }
    let h = w / 2;
    let log_mean =
        |rs: &[Record]| rs.iter().map(|r| r.residual_n.ln()).sum::<f64>() / rs.len() as f64;
    let (m1, m2) = (log_mean(&tail[..h]), log_mean(&tail[w - h..]));
    let rate = ((m2 - m1) / (w - h) as f64).exp();
    let (first, last) = (m1.exp(), m2.exp());
    let (lo, hi) = tail.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| {
        (a.min(r.residual_n), b.max(r.residual_n))
    });
    let mean_step = tail.iter().map(|r| r.step).sum::<f64>() / w as f64;
    let falls = tail
        .windows(2)
        .filter(|p| p[1].residual_n < p[0].residual_n)
        .count() as f64;
    let monotone = MONOTONE * (w - 1) as f64;
    let (pmin, pmax) = tail.iter().fold((usize::MAX, 0usize), |(a, b), r| {
        (a.min(r.contact_pairs), b.max(r.contact_pairs))
    });
    let pairs = if pmax > pmin {
        format!(", contact pairs {pmin}–{pmax}")
    } else {
        String::new()
    };
    Some(if rate < FALLING {
        format!(
            "still converging: the residual fell from about {first:.2e} to {last:.2e} N over the \
             last {w} iterations ({rate:.3} per iteration); more iterations or time would likely finish it"
        )
    } else if rate > RISING {
        format!(
            "the residual rose from about {first:.2e} to {last:.2e} N over the last {w} iterations: \
             the iterates leave the equilibrium (a structure softening or folding under the load)"
        )
    } else if mean_step >= 0.5 && (falls >= monotone || (w - 1) as f64 - falls >= monotone) {
        let (way, per_tenfold) = if rate < 1.0 {
            (
                "lowered",
                format!(
                    "; at this rate a tenfold drop takes about {:.0} more",
                    -(10f64.ln()) / rate.ln()
                ),
            )
        } else {
            ("raised", String::new())
        };
        let why = if tail.iter().all(|r| !r.linear_solver.is_empty()) {
            "their tangent missing part of the stiffness (the projected or shifted tangent \
             of a nearly singular problem)"
        } else {
            "as explicit relaxation steps do"
        };
        format!(
            "creeping: nearly every one of the last {w} iterations {way} the residual, by \
             {rate:.3} per iteration (from about {first:.2e} to {last:.2e} N){per_tenfold}: \
             the steps converge only linearly, {why}"
        )
    } else if mean_step >= 0.5 && hi > WANDER * lo {
        format!(
            "the iterates wander: full steps (mean {mean_step:.2}) over the last {w} iterations \
             took the residual anywhere between {lo:.2e} and {hi:.2e} N{pairs} without settling; \
             the equilibrium is unstable or nearly singular there (a wrinkling or folding membrane)"
        )
    } else if mean_step >= 0.5 {
        format!(
            "the iterates cycle: full steps (mean {mean_step:.2}) over the last {w} iterations \
             left the residual between {lo:.2e} and {hi:.2e} N{pairs}; a contact set or a \
             piecewise law switching back and forth"
        )
    } else {
        format!(
            "held back: the steps were cut to {mean_step:.2} of Newton's on average over the last \
             {w} iterations and the residual stayed between {lo:.2e} and {hi:.2e} N{pairs}; the \
             line search or the barrier's collision limit refuses the steps (a nearly singular or \
             indefinite tangent)"
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn history(residuals: &[f64], step: f64, pairs: impl Fn(usize) -> usize) -> Vec<Record> {
        residuals
            .iter()
            .enumerate()
            .map(|(i, &r)| Record {
                phase: "newton",
                iteration: i + 1,
                residual_n: r,
                max_force_n: r,
                step,
                shift: 0.0,
                correction_mm: 0.0,
                contact_pairs: pairs(i),
                linear_solver: "cholesky",
                gmres_iterations: 0,
            })
            .collect()
    }

    #[test]
    fn tells_converging_cycling_held_back_and_rising_apart() {
        let falling: Vec<f64> = (0..90).map(|i| 0.9f64.powi(i)).collect();
        let why = stall_cause(&history(&falling, 1.0, |_| 0)).unwrap();
        assert!(why.starts_with("still converging"), "{why}");
        assert!(
            why.contains("0.900 per iteration") && why.contains("30 iterations"),
            "{why}"
        );
        let cycling: Vec<f64> = (0..300)
            .map(|i| if i % 2 == 0 { 4.0e-3 } else { 4.1e-3 })
            .collect();
        let why = stall_cause(&history(&cycling, 1.0, |i| 59_370 + i % 3)).unwrap();
        assert!(why.starts_with("the iterates cycle"), "{why}");
        assert!(
            why.contains("60 iterations") && why.contains("contact pairs 59370–59372"),
            "{why}"
        );
        let wandering: Vec<f64> = (0..300).map(|i| [0.1, 20.0, 3.0][i % 3]).collect();
        let why = stall_cause(&history(&wandering, 1.0, |_| 0)).unwrap();
        assert!(why.starts_with("the iterates wander"), "{why}");
        let why = stall_cause(&history(&cycling, 0.01, |_| 5)).unwrap();
        assert!(
            why.starts_with("held back") && !why.contains("contact"),
            "{why}"
        );
        // Slower than "still converging", but every step falls: a creep,
        // not a cycle; and the same slowly rising.
        let creeping: Vec<f64> = (0..180).map(|i| 0.986f64.powi(i)).collect();
        let why = stall_cause(&history(&creeping, 1.0, |_| 0)).unwrap();
        assert!(
            why.starts_with("creeping") && why.contains("lowered") && why.contains("0.986"),
            "{why}"
        );
        assert!(why.contains("about 163 more"), "{why}");
        let why = stall_cause(&history(&creeping, 0.01, |_| 0)).unwrap();
        assert!(why.starts_with("held back"), "{why}");
        let up: Vec<f64> = (0..180).map(|i| 1.02f64.powi(i)).collect();
        let why = stall_cause(&history(&up, 1.0, |_| 0)).unwrap();
        assert!(
            why.starts_with("creeping") && why.contains("raised"),
            "{why}"
        );
        let rising: Vec<f64> = (0..60).map(|i| 1.1f64.powi(i)).collect();
        let why = stall_cause(&history(&rising, 1.0, |_| 0)).unwrap();
        assert!(why.starts_with("the residual rose"), "{why}");
        assert_eq!(stall_cause(&history(&falling[..9], 1.0, |_| 0)), None);
        assert_eq!(stall_cause(&history(&[f64::NAN; 30], 1.0, |_| 0)), None);
    }
}
