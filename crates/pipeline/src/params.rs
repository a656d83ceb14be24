//! Parameter values, parsed from the command line or a run config, always
//! with explicit units where the parameter is a physical quantity.

use std::collections::BTreeMap;

use super::spec::{Param, ParamKind, StageSpec};
use coapt_base::units::{self, Kind};
use coapt_base::{Error, Result};

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
///
/// A stage reads them once, into its own typed struct (`TryFrom<&Params>`),
/// through the accessors below; a name the stage did not declare, or a value
/// of another kind than the stage reads, is an [`Error`], never a panic.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Params {
    /// The declaring stage, for the errors of a lookup that does not match it.
    stage: &'static str,
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
        Ok(Params {
            stage: spec.name,
            values,
        })
    }

    fn value(&self, name: &str) -> Result<&Value> {
        self.values.get(name).ok_or_else(|| {
            Error::failed(
                self.stage,
                format!(
                    "parameter '{name}' is read but not declared: add it to the stage's SPEC.params (the CLI, configs and provenance come from there) or read a declared name"
                ),
            )
        })
    }

    /// The error for a value the stage reads as another kind than it holds:
    /// the SPEC's kind and the stage's typed field disagree.
    fn not_a(&self, name: &str, v: &Value, what: &str) -> Error {
        Error::failed(
            self.stage,
            format!(
                "parameter '{name}' holds {v:?}, but the stage reads it as {what}: make its SPEC kind and its typed field agree"
            ),
        )
    }

    /// A quantity of `kind`, in internal units (mm, MPa, rad, HU, N, s, …).
    pub fn quantity(&self, name: &str, kind: Kind) -> Result<f64> {
        match self.value(name)? {
            Value::Quantity(v, k) if *k == kind => Ok(*v),
            other => Err(self.not_a(name, other, &format!("a {}", kind.name()))),
        }
    }

    /// An optional quantity of `kind` (no default declared): `None` when unset.
    pub fn quantity_opt(&self, name: &str, kind: Kind) -> Result<Option<f64>> {
        match self.value(name)? {
            Value::Unset => Ok(None),
            _ => self.quantity(name, kind).map(Some),
        }
    }

    /// Three lengths (mm): `None` when unset.
    pub fn lengths3(&self, name: &str) -> Result<Option<[f64; 3]>> {
        match self.value(name)? {
            Value::Lengths3(v) => Ok(Some(*v)),
            Value::Unset => Ok(None),
            other => Err(self.not_a(name, other, "three lengths")),
        }
    }

    pub fn int(&self, name: &str) -> Result<i64> {
        match self.value(name)? {
            Value::Int(i) => Ok(*i),
            other => Err(self.not_a(name, other, "an integer")),
        }
    }

    pub fn float(&self, name: &str) -> Result<f64> {
        match self.value(name)? {
            Value::Float(f) => Ok(*f),
            other => Err(self.not_a(name, other, "a number")),
        }
    }

    pub fn flag(&self, name: &str) -> Result<bool> {
        match self.value(name)? {
            Value::Bool(b) => Ok(*b),
            other => Err(self.not_a(name, other, "true or false")),
        }
    }

    /// One of the declared options, as written in the SPEC.
    pub fn choice(&self, name: &str) -> Result<&str> {
        match self.value(name)? {
            Value::Choice(s) => Ok(s),
            other => Err(self.not_a(name, other, "a choice")),
        }
    }

    /// An optional path parameter: `None` when unset.
    pub fn path(&self, name: &str) -> Result<Option<&str>> {
        match self.value(name)? {
            Value::Path(s) => Ok(Some(s)),
            Value::Unset => Ok(None),
            other => Err(self.not_a(name, other, "a path")),
        }
    }

    /// The error for a choice the stage's typed field has no variant for
    /// (the SPEC's options and the field's enum disagree).
    pub fn unknown_choice(&self, name: &str, option: &str) -> Error {
        Error::failed(
            self.stage,
            format!(
                "parameter '{name}' is '{option}', which the stage's typed field has no variant for: make the SPEC's options and the field's enum agree"
            ),
        )
    }

    /// Canonical text of every parameter, for provenance and skip decisions.
    pub fn canonical(&self) -> BTreeMap<String, String> {
        self.values
            .iter()
            .map(|(k, v)| (k.clone(), v.canonical()))
            .collect()
    }
}

/// For each stage's unit test: `read` (the stage's `TryFrom<&Params>`) takes
/// every parameter `spec` declares, as the kind it declares, and nothing it
/// does not.
///
/// Nothing undeclared: reading the declared defaults succeeds (an undeclared
/// name is an error). Every declared one: with that one parameter holding a
/// value of a kind no reader of its declared kind accepts, reading fails
/// naming it. As its declared kind: with it holding a value of that kind
/// (given, so an optional one is read too), reading does not fail for the
/// kind (it may refuse the value itself). For each stage's tests (they live
/// beside the stages, above this crate); it panics, as an assertion does.
pub fn assert_reads_exactly<T>(spec: &StageSpec, read: impl Fn(&Params) -> Result<T>) {
    let defaults = Params::resolve(spec, BTreeMap::new()).unwrap();
    if let Err(e) = read(&defaults) {
        panic!("{}: reading the declared defaults fails: {e}", spec.name);
    }
    for p in spec.params {
        let wrong = match p.kind {
            ParamKind::Choice(_) => Value::Bool(false),
            _ => Value::Choice("not of the declared kind".into()),
        };
        let given = BTreeMap::from([(p.name.to_string(), one_of(p.kind))]);
        if let Err(e) = read(&Params::resolve(spec, given).unwrap()) {
            assert!(
                !e.to_string().contains("the stage reads it as"),
                "{}.{}: {e}",
                spec.name,
                p.name
            );
        }
        let given = BTreeMap::from([(p.name.to_string(), wrong)]);
        let params = Params::resolve(spec, given).unwrap();
        match read(&params) {
            Ok(_) => panic!(
                "{}.{} is declared but the typed parameters do not read it",
                spec.name, p.name
            ),
            Err(e) => assert!(
                e.to_string().contains(&format!("'{}'", p.name)),
                "{}.{}: {e}",
                spec.name,
                p.name
            ),
        }
    }
}

/// A value of the kind `k`, as a user could give it.
fn one_of(k: ParamKind) -> Value {
    match k {
        ParamKind::Quantity(kind) => Value::Quantity(1.0, kind),
        ParamKind::Lengths3 => Value::Lengths3([1.0; 3]),
        ParamKind::Int { min, .. } => Value::Int(min),
        ParamKind::Float { min, .. } => Value::Float(min),
        ParamKind::Bool => Value::Bool(false),
        ParamKind::Choice(options) => Value::Choice(options[0].to_string()),
        ParamKind::Path => Value::Path("somewhere".into()),
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

    fn no_run(
        _: &super::super::StageIo,
        _: &Params,
        _: &super::super::Progress,
    ) -> Result<serde_json::Value> {
        Ok(serde_json::Value::Null)
    }

    static STAGE: StageSpec = StageSpec {
        name: "demo",
        about: "",
        inputs: &[],
        outputs: &[],
        out_dir: None,
        params: &[P],
        check: |_| Ok(()),
        run: no_run,
    };

    /// A stage whose typed struct and SPEC disagree gets an error saying
    /// which parameter and how to fix it, not a panic.
    #[test]
    fn undeclared_names_and_other_kinds_are_errors() {
        let p = Params::resolve(&STAGE, BTreeMap::new()).unwrap();
        let mpa = units::parse(Kind::Pressure, "80 mmHg").unwrap();
        assert_eq!(p.quantity("pressure", Kind::Pressure).unwrap(), mpa);
        assert_eq!(
            p.quantity_opt("pressure", Kind::Pressure).unwrap(),
            Some(mpa)
        );
        let e = p
            .quantity("presure", Kind::Pressure)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("demo: ") && e.contains("'presure'") && e.contains("not declared"),
            "{e}"
        );
        let e = p
            .quantity("pressure", Kind::Length)
            .unwrap_err()
            .to_string();
        assert!(e.contains("'pressure'") && e.contains("as a length"), "{e}");
        let e = p.flag("pressure").unwrap_err().to_string();
        assert!(e.contains("as true or false"), "{e}");
        assert!(p.path("pressure").is_err() && p.lengths3("pressure").is_err());
    }

    #[test]
    #[should_panic(expected = "demo.pressure is declared but the typed parameters do not read it")]
    fn the_per_stage_check_finds_a_declared_parameter_left_unread() {
        assert_reads_exactly(&STAGE, |_| Ok(()));
    }

    #[test]
    #[should_panic(expected = "demo: reading the declared defaults fails")]
    fn the_per_stage_check_finds_an_undeclared_name_read() {
        assert_reads_exactly(&STAGE, |p| {
            p.quantity("pressure", Kind::Pressure)?;
            p.float("presure")
        });
    }

    #[test]
    #[should_panic(expected = "the stage reads it as a length")]
    fn the_per_stage_check_finds_a_parameter_read_as_another_quantity() {
        assert_reads_exactly(&STAGE, |p| p.quantity_opt("pressure", Kind::Length));
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
