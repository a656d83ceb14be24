//! Ozaki's own sizing beside coapt's: the surgeon measures each
//! intercommissural distance with the sizer and cuts the template of that
//! number. The sweep's recommendation is stated against it, in sizer steps
//! (2 mm), so every `coapt design` answers the closure-trust issue's
//! question for its root: how far do the physics and the rule part?

use crate::template::sizer_size_for;

/// The rule for one root.
#[derive(Debug, Clone, PartialEq)]
pub struct OzakiRule {
    /// C1–C2, C2–C3, C3–C1 (mm), as the valve stage snapped them.
    pub distances_mm: [f64; 3],
    /// The size the rule cuts for each leaflet; `None` beyond the sizer.
    pub sizes: [Option<u32>; 3],
}

impl OzakiRule {
    pub fn of(distances_mm: [f64; 3]) -> Self {
        OzakiRule {
            distances_mm,
            sizes: distances_mm.map(|d| sizer_size_for(d).ok()),
        }
    }

    /// Sizer steps from the rule to `size` for each leaflet (positive:
    /// `size` is larger), where the rule has a size.
    pub fn steps(&self, size: u32) -> Vec<i64> {
        self.sizes
            .iter()
            .flatten()
            .map(|&r| (size as i64 - r as i64) / 2)
            .collect()
    }

    /// The rule and how the recommendation stands to it, in words.
    pub fn sentence(&self, recommended: Option<u32>) -> String {
        let sizes: Vec<String> = self
            .sizes
            .iter()
            .map(|s| s.map_or("—".to_string(), |s| s.to_string()))
            .collect();
        let d = self.distances_mm;
        let rule = format!(
            "Ozaki's rule (the sizer size nearest each intercommissural distance: C1–C2 {:.1}, C2–C3 {:.1}, C3–C1 {:.1} mm) cuts {}",
            d[0],
            d[1],
            d[2],
            sizes.join(" / ")
        );
        let Some(size) = recommended else {
            return format!("{rule}; no size is recommended to compare with it.");
        };
        let steps = self.steps(size);
        let (Some(&lo), Some(&hi)) = (steps.iter().min(), steps.iter().max()) else {
            return format!("{rule}.");
        };
        let word = |n: i64| if n.abs() == 1 { "size" } else { "sizes" };
        let part = if lo == 0 && hi == 0 {
            "the recommendation is the rule's size for every leaflet".to_string()
        } else if hi <= 0 {
            let (a, b) = (-hi, -lo);
            if a == b {
                format!("the recommendation, {size}, is {a} {} below it", word(a))
            } else {
                format!("the recommendation, {size}, is {a}–{b} sizes below it")
            }
        } else if lo >= 0 {
            if lo == hi {
                format!("the recommendation, {size}, is {lo} {} above it", word(lo))
            } else {
                format!("the recommendation, {size}, is {lo}–{hi} sizes above it")
            }
        } else {
            format!(
                "the recommendation, {size}, is {} {} below and {hi} {} above it",
                -lo,
                word(lo),
                word(hi)
            )
        };
        format!("{rule}; {part} (a size is a 2 mm step of the sizer).")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_real_cts_rule_and_a_recommendation_below_it() {
        // The real CT's snapped commissures.
        let r = OzakiRule::of([21.05, 25.62, 24.75]);
        assert_eq!(r.sizes, [Some(21), Some(25), Some(25)]);
        assert_eq!(r.steps(19), [-1, -3, -3]);
        let s = r.sentence(Some(19));
        assert!(s.contains("cuts 21 / 25 / 25"), "{s}");
        assert!(s.contains("19, is 1–3 sizes below it"), "{s}");
        assert!(
            r.sentence(None)
                .ends_with("no size is recommended to compare with it."),
            "{}",
            r.sentence(None)
        );
    }

    #[test]
    fn equal_above_straddling_and_beyond_the_sizer() {
        let r = OzakiRule::of([23.0, 23.4, 22.6]);
        assert_eq!(r.sizes, [Some(23); 3]);
        assert!(
            r.sentence(Some(23))
                .contains("the rule's size for every leaflet")
        );
        assert!(r.sentence(Some(25)).contains("25, is 1 size above it"));
        let mixed = OzakiRule::of([21.0, 25.0, 23.0]);
        assert!(
            mixed
                .sentence(Some(23))
                .contains("23, is 1 size below and 1 size above it"),
            "{}",
            mixed.sentence(Some(23))
        );
        // A distance off the sizer has no rule size, and is left out.
        let off = OzakiRule::of([40.0, 25.0, 25.0]);
        assert_eq!(off.sizes[0], None);
        assert_eq!(off.steps(21), [-2, -2]);
        assert!(off.sentence(Some(21)).contains("cuts — / 25 / 25"));
    }
}
