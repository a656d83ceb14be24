//! Formatting shared by the sections: escaping, numbers with units, and
//! lookups that show a missing or mistyped value as "—" instead of failing.

use serde_json::{Map, Value};

use super::{DASH, NOT_MEASURED};

/// Escape text for HTML element content and quoted attribute values; C0
/// control characters other than tab and newlines become U+FFFD.
pub fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 8);
    for ch in s.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            '\t' | '\n' | '\r' => out.push(ch),
            c if c.is_control() => out.push('\u{FFFD}'),
            c => out.push(c),
        }
    }
    out
}

/// `s`, or `default` when empty (a key missing from the report).
pub(super) fn or<'a>(s: &'a str, default: &'a str) -> &'a str {
    if s.is_empty() { default } else { s }
}

pub(super) fn num_text(x: Option<f64>) -> String {
    match x.filter(|x| x.is_finite()) {
        Some(x) => shortest(Some(x)),
        None => NOT_MEASURED.to_string(),
    }
}

/// `x` with `decimals` digits, "—" when absent; never "-0.00".
pub(super) fn fixed(x: Option<f64>, decimals: usize) -> String {
    match x {
        Some(x) if x.is_finite() => {
            let s = format!("{x:.decimals$}");
            if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
                s[1..].to_string()
            } else {
                s
            }
        }
        _ => DASH.to_string(),
    }
}

/// The shortest decimal that reads back as `x` (thresholds: "4", "9.5").
pub(super) fn shortest(x: Option<f64>) -> String {
    x.filter(|x| x.is_finite())
        .map_or(DASH.to_string(), |x| format!("{x}"))
}

pub(super) fn with_unit(value: &str, unit: &str) -> String {
    if unit.is_empty() || value == DASH {
        value.to_string()
    } else {
        format!("{value} {unit}")
    }
}

pub(super) fn mm(x: Option<f64>) -> String {
    x.filter(|x| x.is_finite())
        .map_or(NOT_MEASURED.to_string(), |x| {
            with_unit(&fixed(Some(x), 2), "mm")
        })
}

pub(super) fn mm2(x: Option<f64>) -> String {
    x.filter(|x| x.is_finite())
        .map_or(NOT_MEASURED.to_string(), |x| {
            with_unit(&fixed(Some(x), 1), "mm²")
        })
}

/// A fraction shown as a percentage.
pub(super) fn percent(x: Option<f64>) -> String {
    x.filter(|x| x.is_finite())
        .map_or(NOT_MEASURED.to_string(), |x| {
            format!("{} %", fixed(Some(100.0 * x), 1))
        })
}

pub(super) fn boolean(b: Option<bool>) -> String {
    b.map_or(NOT_MEASURED.to_string(), |b| yes_no(b).to_string())
}

pub(super) fn yes_no(b: bool) -> &'static str {
    if b { "yes" } else { "no" }
}

pub(super) fn result_tag(pass: Option<bool>) -> &'static str {
    match pass {
        Some(true) => "<span class=\"tag pass\">&#10004; PASS</span>",
        Some(false) => "<span class=\"tag fail\">&#10008; FAIL</span>",
        None => "<span class=\"tag na\">? NOT MEASURABLE</span>",
    }
}

/// An HTML id made of `[A-Za-z0-9_-]` from a figure id.
pub(super) fn anchor(id: &str) -> String {
    let s: String = id
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' || c == '-' {
                c
            } else {
                '-'
            }
        })
        .collect();
    if s.is_empty() {
        "figure".to_string()
    } else {
        s
    }
}

/// Compact JSON text with object keys sorted, so equal values print alike
/// whatever order their keys were inserted in.
pub(super) fn canonical(v: &Value) -> String {
    match v {
        Value::Object(o) => {
            let items: Vec<String> = sorted(o)
                .into_iter()
                .map(|(k, x)| format!("{}:{}", Value::String(k.clone()), canonical(x)))
                .collect();
            format!("{{{}}}", items.join(","))
        }
        Value::Array(a) => format!(
            "[{}]",
            a.iter().map(canonical).collect::<Vec<_>>().join(",")
        ),
        other => other.to_string(),
    }
}

pub(super) fn sorted(map: &Map<String, Value>) -> Vec<(&String, &Value)> {
    let mut v: Vec<_> = map.iter().collect();
    v.sort_by(|a, b| a.0.cmp(b.0));
    v
}
