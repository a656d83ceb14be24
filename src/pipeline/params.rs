//! Parameter values, parsed from the command line or a run config, always
//! with explicit units where the parameter is a physical quantity.

use std::collections::BTreeMap;

use super::spec::{Param, ParamKind, StageSpec};
use crate::units::{self, Kind};
use crate::{Error, Result};

/// One resolved parameter value (quantities in internal units).
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Quantity(f64, Kind),
    Lengths3([f64; 3]),
    Int(i64),
    Float(f64),
    Bool(bool),
    Choice(String),
    Path(String),
    /// An optional parameter that was not given.
    Unset,
}

impl Value {
    /// Canonical text: what the manifest records and what reads back to the same value.
    pub fn canonical(&self) -> String {
        match self {
            Value::Quantity(v, k) => units::format(*k, *v),
            Value::Lengths3(v) => format!("{}, {}, {} mm", v[0], v[1], v[2]),
            Value::Int(i) => i.to_string(),
            Value::Float(f) => f.to_string(),
            Value::Bool(b) => b.to_string(),
            Value::Choice(s) | Value::Path(s) => s.clone(),
            Value::Unset => "unset".to_string(),
        }
    }
}

/// Parse a parameter's text form.
pub fn parse_text(p: &Param, text: &str) -> Result<Value> {
    let t = text.trim();
    let v = match p.kind {
        ParamKind::Quantity(k) => Value::Quantity(units::parse(k, t)?, k),
        ParamKind::Lengths3 => Value::Lengths3(parse_lengths3(t)?),
        ParamKind::Int { min, max } => {
            let i: i64 = t
                .parse()
                .map_err(|_| Error::value(format!("'{t}' is not an integer")))?;
            if i < min || i > max {
                return Err(Error::value(format!("{i} is outside {min}..={max}")));
            }
            Value::Int(i)
        }
        ParamKind::Float { min, max } => {
            let f: f64 = t
                .parse()
                .map_err(|_| Error::value(format!("'{t}' is not a number")))?;
            if !(f >= min && f <= max) {
                return Err(Error::value(format!(
                    "{} is outside [{min}, {max}]",
                    units::short(f)
                )));
            }
            Value::Float(f)
        }
        ParamKind::Bool => match t {
            "true" | "yes" | "on" => Value::Bool(true),
            "false" | "no" | "off" => Value::Bool(false),
            _ => return Err(Error::value(format!("'{t}' is not true or false"))),
        },
        ParamKind::Choice(options) => {
            if options.contains(&t) {
                Value::Choice(t.to_string())
            } else {
                return Err(Error::value(format!(
                    "'{t}' is not one of: {}",
                    options.join(", ")
                )));
            }
        }
        ParamKind::Path if t.is_empty() => return Err(Error::value("an empty path")),
        ParamKind::Path => Value::Path(t.to_string()),
    };
    Ok(v)
}

/// "0.44, 0.44, 0.6 mm" (one trailing unit for all three) or "0.44 mm, 0.44 mm, 0.6 mm".
fn parse_lengths3(t: &str) -> Result<[f64; 3]> {
    let parts: Vec<&str> = t.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(Error::value(format!(
            "'{t}' is not three lengths; write e.g. \"0.44, 0.44, 0.6 mm\""
        )));
    }
    let last_unit: String = parts[2]
        .trim_start_matches(|c: char| {
            c.is_ascii_digit() || matches!(c, '.' | '+' | '-' | 'e' | 'E')
        })
        .trim()
        .to_string();
    let mut out = [0.0; 3];
    for (i, part) in parts.iter().enumerate() {
        let has_unit = part
            .chars()
            .any(|c| c.is_alphabetic() && c != 'e' && c != 'E');
        let text = if has_unit || last_unit.is_empty() {
            part.to_string()
        } else {
            format!("{part} {last_unit}")
        };
        out[i] = units::parse(Kind::Length, &text)?;
    }
    Ok(out)
}

/// Parse a run-config value. Strings go through [`parse_text`]; bare numbers
/// are accepted only for dimensionless parameters.
pub fn parse_toml(p: &Param, v: &toml::Value) -> Result<Value> {
    match (p.kind, v) {
        (_, toml::Value::String(s)) => parse_text(p, s),
        (ParamKind::Quantity(k), toml::Value::Integer(i)) => {
            Err(units::bare_number(k, &i.to_string()))
        }
        (ParamKind::Quantity(k), toml::Value::Float(f)) => {
            Err(units::bare_number(k, &f.to_string()))
        }
        (ParamKind::Lengths3, toml::Value::Array(a)) => {
            let texts: Vec<String> = a
                .iter()
                .map(|x| match x {
                    toml::Value::String(s) => Ok(s.clone()),
                    other => Err(units::bare_number(Kind::Length, &other.to_string())),
                })
                .collect::<Result<_>>()?;
            parse_text(p, &texts.join(", "))
        }
        (ParamKind::Int { .. }, toml::Value::Integer(i)) => parse_text(p, &i.to_string()),
        (ParamKind::Float { .. }, toml::Value::Integer(i)) => parse_text(p, &i.to_string()),
        (ParamKind::Float { .. }, toml::Value::Float(f)) => parse_text(p, &f.to_string()),
        (ParamKind::Bool, toml::Value::Boolean(b)) => Ok(Value::Bool(*b)),
        (_, other) => Err(Error::value(format!(
            "{} is not a valid value here ({})",
            other,
            describe_kind(p.kind)
        ))),
    }
}

pub fn describe_kind(k: ParamKind) -> String {
    match k {
        ParamKind::Quantity(k) => format!("a {} with a unit, e.g. {}", k.name(), k.example()),
        ParamKind::Lengths3 => "three lengths, e.g. \"0.44, 0.44, 0.6 mm\"".into(),
        ParamKind::Int { min, max } => format!("an integer in {min}..={max}"),
        ParamKind::Float { min, max } => format!("a number in [{min}, {max}]"),
        ParamKind::Bool => "true or false".into(),
        ParamKind::Choice(o) => format!("one of {}", o.join(", ")),
        ParamKind::Path => "a path".into(),
    }
}

/// A stage's resolved parameters, every declared one present (possibly `Unset`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Params {
    values: BTreeMap<String, Value>,
}

impl Params {
    /// Resolve: given values (already parsed) over declared defaults.
    pub fn resolve(spec: &StageSpec, given: BTreeMap<String, Value>) -> Result<Params> {
        let mut values = BTreeMap::new();
        for p in spec.params {
            let v = match given.get(p.name) {
                Some(v) => v.clone(),
                None => match p.default {
                    Some(d) => parse_text(p, d).map_err(|e| {
                        Error::value(format!(
                            "default of {}.{} is invalid: {e}",
                            spec.name, p.name
                        ))
                    })?,
                    None => Value::Unset,
                },
            };
            values.insert(p.name.to_string(), v);
        }
        if let Some(k) = given.keys().find(|k| spec.param(k).is_none()) {
            return Err(Error::value(format!(
                "stage {} has no parameter '{k}'",
                spec.name
            )));
        }
        Ok(Params { values })
    }

    pub fn get(&self, name: &str) -> &Value {
        self.values
            .get(name)
            .unwrap_or_else(|| panic!("parameter '{name}' is not declared"))
    }

    /// A quantity in internal units.
    pub fn quantity(&self, name: &str) -> f64 {
        match self.get(name) {
            Value::Quantity(v, _) => *v,
            other => panic!("parameter '{name}' is {other:?}, not a quantity"),
        }
    }

    pub fn lengths3(&self, name: &str) -> Option<[f64; 3]> {
        match self.get(name) {
            Value::Lengths3(v) => Some(*v),
            _ => None,
        }
    }

    pub fn int(&self, name: &str) -> i64 {
        match self.get(name) {
            Value::Int(i) => *i,
            other => panic!("parameter '{name}' is {other:?}, not an integer"),
        }
    }

    pub fn float(&self, name: &str) -> f64 {
        match self.get(name) {
            Value::Float(f) => *f,
            other => panic!("parameter '{name}' is {other:?}, not a number"),
        }
    }

    pub fn flag(&self, name: &str) -> bool {
        match self.get(name) {
            Value::Bool(b) => *b,
            other => panic!("parameter '{name}' is {other:?}, not a boolean"),
        }
    }

    pub fn choice(&self, name: &str) -> &str {
        match self.get(name) {
            Value::Choice(s) => s,
            other => panic!("parameter '{name}' is {other:?}, not a choice"),
        }
    }

    /// An optional path parameter: `None` when unset.
    pub fn path(&self, name: &str) -> Option<&str> {
        match self.get(name) {
            Value::Path(s) => Some(s),
            Value::Unset => None,
            other => panic!("parameter '{name}' is {other:?}, not a path"),
        }
    }

    /// Canonical text of every parameter, for provenance and skip decisions.
    pub fn canonical(&self) -> BTreeMap<String, String> {
        self.values
            .iter()
            .map(|(k, v)| (k.clone(), v.canonical()))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const P: Param = Param {
        name: "pressure",
        kind: ParamKind::Quantity(Kind::Pressure),
        default: Some("80 mmHg"),
        help: "",
    };

    #[test]
    fn toml_bare_number_names_the_unit() {
        let e = parse_toml(&P, &toml::Value::Integer(80))
            .unwrap_err()
            .to_string();
        assert!(e.contains("bare number 80") && e.contains("mmHg"), "{e}");
        let v = parse_toml(&P, &toml::Value::String("10 kPa".into())).unwrap();
        assert_eq!(v, Value::Quantity(0.01, Kind::Pressure));
        assert_eq!(v.canonical(), "0.01 MPa");
        // The canonical text parses back to the same value.
        assert_eq!(parse_text(&P, &v.canonical()).unwrap(), v);
    }

    #[test]
    fn lengths3_forms() {
        let p = Param {
            name: "spacing",
            kind: ParamKind::Lengths3,
            default: None,
            help: "",
        };
        assert_eq!(
            parse_text(&p, "0.44, 0.44, 0.6 mm").unwrap(),
            Value::Lengths3([0.44, 0.44, 0.6])
        );
        assert_eq!(
            parse_text(&p, "1 mm, 0.1 cm, 2mm").unwrap(),
            Value::Lengths3([1.0, 1.0, 2.0])
        );
        assert!(parse_text(&p, "0.44, 0.44, 0.6").is_err());
        assert!(parse_text(&p, "0.44, 0.6 mm").is_err());
        let v = parse_text(&p, "0.5, 0.5, 0.8 mm").unwrap();
        assert_eq!(parse_text(&p, &v.canonical()).unwrap(), v);
    }

    #[test]
    fn ints_and_choices() {
        let p = Param {
            name: "seed",
            kind: ParamKind::Int { min: 0, max: 10 },
            default: None,
            help: "",
        };
        assert_eq!(
            parse_toml(&p, &toml::Value::Integer(3)).unwrap(),
            Value::Int(3)
        );
        assert!(parse_toml(&p, &toml::Value::Integer(11)).is_err());
        assert!(parse_text(&p, "x").is_err());
        let c = Param {
            name: "preset",
            kind: ParamKind::Choice(&["a", "b"]),
            default: None,
            help: "",
        };
        assert!(
            parse_text(&c, "c")
                .unwrap_err()
                .to_string()
                .contains("a, b")
        );
    }
}
