//! Physical quantities with explicit units at every boundary.
//!
//! Configs and the command line take values such as "80 mmHg", "900 kPa",
//! "0.4 mm", "30 deg", "25 HU". Internally coapt uses mm, N, MPa (= N/mm²)
//! and radians. A bare number where a unit is expected is an error that names
//! the expected kind of quantity and an example.

use std::fmt;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::{Error, Result};

/// 1 mmHg in MPa (133.322 Pa).
pub const MMHG_IN_MPA: f64 = 133.322e-6;

/// The kinds of quantity coapt reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Internal unit: mm.
    Length,
    /// Pressure or stress (moduli). Internal unit: MPa.
    Pressure,
    /// Internal unit: rad.
    Angle,
    /// CT number. Internal unit: HU.
    Intensity,
    /// Internal unit: N (solver tolerances).
    Force,
    /// Internal unit: s (time limits).
    Time,
    /// Force per length. Internal unit: N/mm (the suturing force's K).
    LineForce,
    /// Internal unit: mm² (the regurgitant orifice bound).
    Area,
}

impl Kind {
    pub fn name(self) -> &'static str {
        match self {
            Kind::Length => "length",
            Kind::Pressure => "pressure or stress",
            Kind::Angle => "angle",
            Kind::Intensity => "CT intensity",
            Kind::Force => "force",
            Kind::Time => "time",
            Kind::LineForce => "force per length",
            Kind::Area => "area",
        }
    }

    pub fn example(self) -> &'static str {
        match self {
            Kind::Length => "\"0.4 mm\"",
            Kind::Pressure => "\"80 mmHg\" or \"900 kPa\"",
            Kind::Angle => "\"30 deg\"",
            Kind::Intensity => "\"25 HU\"",
            Kind::Force => "\"1e-7 N\"",
            Kind::Time => "\"600 s\"",
            Kind::LineForce => "\"1 N/m\"",
            Kind::Area => "\"1 mm2\" or \"0.01 cm2\"",
        }
    }

    /// The unit values are printed in.
    pub fn display_unit(self) -> &'static str {
        match self {
            Kind::Length => "mm",
            Kind::Pressure => "MPa",
            Kind::Angle => "deg",
            Kind::Intensity => "HU",
            Kind::Force => "N",
            Kind::Time => "s",
            Kind::LineForce => "N/mm",
            Kind::Area => "mm2",
        }
    }

    fn units(self) -> &'static [(&'static str, f64)] {
        match self {
            Kind::Length => &[
                ("mm", 1.0),
                ("cm", 10.0),
                ("m", 1000.0),
                ("um", 1e-3),
                ("µm", 1e-3),
            ],
            Kind::Pressure => &[
                ("MPa", 1.0),
                ("kPa", 1e-3),
                ("Pa", 1e-6),
                ("GPa", 1e3),
                ("mmHg", MMHG_IN_MPA),
                ("N/mm2", 1.0),
                ("N/mm^2", 1.0),
            ],
            Kind::Angle => &[
                ("deg", std::f64::consts::PI / 180.0),
                ("°", std::f64::consts::PI / 180.0),
                ("rad", 1.0),
            ],
            Kind::Intensity => &[("HU", 1.0)],
            Kind::Force => &[("N", 1.0), ("mN", 1e-3), ("uN", 1e-6)],
            Kind::Time => &[("s", 1.0), ("min", 60.0), ("ms", 1e-3)],
            Kind::LineForce => &[("N/mm", 1.0), ("N/m", 1e-3), ("mN/mm", 1e-3)],
            Kind::Area => &[("mm2", 1.0), ("mm²", 1.0), ("cm2", 100.0), ("cm²", 100.0)],
        }
    }

    fn accepted(self) -> String {
        self.units()
            .iter()
            .map(|(u, _)| *u)
            .filter(|u| !u.contains('^') && *u != "µm")
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// Parse "<number> <unit>" of the given kind into internal units.
pub fn parse(kind: Kind, text: &str) -> Result<f64> {
    let s = text.trim();
    let split = s
        .char_indices()
        .find(|&(i, c)| {
            !(c.is_ascii_digit()
                || c == '.'
                || c == '+'
                || c == '-'
                || ((c == 'e' || c == 'E') && i > 0 && exponent_follows(s, i)))
        })
        .map(|(i, _)| i)
        .unwrap_or(s.len());
    let (num, unit) = (s[..split].trim(), s[split..].trim());
    if num.is_empty() {
        return Err(Error::value(format!(
            "'{text}' is not a {}: expected a number and a unit, e.g. {}",
            kind.name(),
            kind.example()
        )));
    }
    let value: f64 = num.parse().map_err(|_| {
        Error::value(format!(
            "'{text}': '{num}' is not a number (expected e.g. {})",
            kind.example()
        ))
    })?;
    if !value.is_finite() {
        return Err(Error::value(format!("'{text}' is not finite")));
    }
    if unit.is_empty() {
        return Err(bare_number(kind, &num.to_string()));
    }
    for &(u, factor) in kind.units() {
        if unit == u {
            return Ok(value * factor);
        }
    }
    // Case-insensitive second chance except where case carries meaning (mPa ≠ MPa).
    for &(u, factor) in kind.units() {
        if unit.eq_ignore_ascii_case(u) && !matches!(u, "MPa" | "Pa" | "GPa" | "kPa") {
            return Ok(value * factor);
        }
    }
    Err(Error::value(format!(
        "'{text}': unknown {} unit '{unit}' (accepted: {})",
        kind.name(),
        kind.accepted()
    )))
}

fn exponent_follows(s: &str, i: usize) -> bool {
    let rest = &s[i + 1..];
    let rest = rest.strip_prefix(['+', '-']).unwrap_or(rest);
    rest.starts_with(|c: char| c.is_ascii_digit())
}

/// The error for a number given without its unit.
pub fn bare_number(kind: Kind, num: &str) -> Error {
    Error::value(format!(
        "the bare number {num} has no unit: expected a {} with a unit, e.g. {}",
        kind.name(),
        kind.example()
    ))
}

/// Format an internal value in the kind's display unit, e.g. "0.4 mm".
pub fn format(kind: Kind, value: f64) -> String {
    let shown = match kind {
        Kind::Angle => value.to_degrees(),
        _ => value,
    };
    format!("{} {}", trim_float(shown), kind.display_unit())
}

/// A number for a message: as [`format`] writes it, or in scientific
/// notation when that would run to many digits (1e300 is "1e300", not 301
/// characters).
pub fn short(x: f64) -> String {
    if x != 0.0 && x.is_finite() && !(1e-4..1e7).contains(&x.abs()) {
        let s = format!("{x:.3e}");
        match s.split_once('e') {
            Some((m, e)) => format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.')),
            None => s,
        }
    } else {
        trim_float(x)
    }
}

/// Shortest decimal that reads back to the same f64 (Rust's `{}`), with
/// angles rounded to 12 significant digits so 35° prints as "35".
fn trim_float(x: f64) -> String {
    let r = format!("{:.12e}", x).parse::<f64>().unwrap_or(x);
    format!("{r}")
}

macro_rules! quantity {
    ($name:ident, $kind:expr, $doc:literal) => {
        #[doc = $doc]
        #[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
        pub struct $name(pub f64);

        impl $name {
            pub const KIND: Kind = $kind;
            pub fn parse(text: &str) -> Result<Self> {
                parse($kind, text).map($name)
            }
            pub fn value(self) -> f64 {
                self.0
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(&format($kind, self.0))
            }
        }

        impl Serialize for $name {
            fn serialize<S: Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
                s.serialize_str(&self.to_string())
            }
        }

        impl<'de> Deserialize<'de> for $name {
            fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
                d.deserialize_any(QuantityVisitor($kind)).map($name)
            }
        }
    };
}

quantity!(Length, Kind::Length, "A length, stored in mm.");
quantity!(
    Pressure,
    Kind::Pressure,
    "A pressure or stress, stored in MPa."
);
quantity!(Angle, Kind::Angle, "An angle, stored in radians.");
quantity!(Intensity, Kind::Intensity, "A CT number, stored in HU.");

struct QuantityVisitor(Kind);

impl<'de> serde::de::Visitor<'de> for QuantityVisitor {
    type Value = f64;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "a {} with a unit, e.g. {}",
            self.0.name(),
            self.0.example()
        )
    }

    fn visit_str<E: serde::de::Error>(self, v: &str) -> std::result::Result<f64, E> {
        parse(self.0, v).map_err(|e| E::custom(e.to_string()))
    }

    fn visit_f64<E: serde::de::Error>(self, v: f64) -> std::result::Result<f64, E> {
        Err(E::custom(bare_number(self.0, &v.to_string())))
    }

    fn visit_i64<E: serde::de::Error>(self, v: i64) -> std::result::Result<f64, E> {
        Err(E::custom(bare_number(self.0, &v.to_string())))
    }

    fn visit_u64<E: serde::de::Error>(self, v: u64) -> std::result::Result<f64, E> {
        Err(E::custom(bare_number(self.0, &v.to_string())))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_documented_forms() {
        assert!((Pressure::parse("80 mmHg").unwrap().0 - 80.0 * 133.322e-6).abs() < 1e-15);
        assert!((Pressure::parse("900 kPa").unwrap().0 - 0.9).abs() < 1e-15);
        assert_eq!(Pressure::parse("1 MPa").unwrap().0, 1.0);
        assert_eq!(Length::parse("0.4 mm").unwrap().0, 0.4);
        assert_eq!(Length::parse("0.4mm").unwrap().0, 0.4);
        assert!((Length::parse("1.5 cm").unwrap().0 - 15.0).abs() < 1e-12);
        assert!((Angle::parse("30 deg").unwrap().0 - std::f64::consts::PI / 6.0).abs() < 1e-15);
        assert_eq!(Angle::parse("0.5 rad").unwrap().0, 0.5);
        assert_eq!(Intensity::parse("-25 HU").unwrap().0, -25.0);
        assert!((Pressure::parse("1e3 Pa").unwrap().0 - 1e-3).abs() < 1e-18);
        assert!((Length::parse("2.5e-1 mm").unwrap().0 - 0.25).abs() < 1e-15);
    }

    #[test]
    fn refuses_bare_numbers_and_wrong_units() {
        let e = Pressure::parse("80").unwrap_err().to_string();
        assert!(e.contains("no unit") && e.contains("mmHg"), "{e}");
        let e = Length::parse("80 mmHg").unwrap_err().to_string();
        assert!(e.contains("unknown length unit 'mmHg'"), "{e}");
        assert!(Pressure::parse("80 mpa").is_err());
        assert!(Length::parse("mm").is_err());
        assert!(Length::parse("").is_err());
        assert!(Length::parse("1.2.3 mm").is_err());
        assert!(Length::parse("nan mm").is_err());
    }

    #[test]
    fn serde_round_trip_and_bare_number_message() {
        #[derive(Deserialize, Serialize)]
        struct C {
            p: Pressure,
            h: Length,
            a: Angle,
        }
        let c: C = toml::from_str("p = \"80 mmHg\"\nh = \"0.5 mm\"\na = \"35 deg\"").unwrap();
        let s = toml::to_string(&c).unwrap();
        assert!(s.contains("a = \"35 deg\""), "{s}");
        let back: C = toml::from_str(&s).unwrap();
        assert_eq!(back.p, c.p);
        assert_eq!(back.h, c.h);
        assert!((back.a.0 - c.a.0).abs() < 1e-15);
        let e = toml::from_str::<C>("p = 80\nh = \"0.5 mm\"\na = \"1 rad\"")
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("bare number 80") && e.contains("pressure"),
            "{e}"
        );
    }
}
