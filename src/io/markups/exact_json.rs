//! A small JSON reader whose numbers are exactly what the text says.
//!
//! serde_json is built here without its `float_roundtrip` feature, and its
//! default float parser can be one ulp off for 17-digit numbers — enough to
//! break the exact round trips landmark files promise. This reader builds the
//! same `serde_json::Value`, but parses every number with Rust's correctly
//! rounded `str::parse::<f64>`. For the error message of a malformed file it
//! defers to serde_json, whose messages carry line and column.
//!
//! It also refuses duplicate object keys (serde_json keeps the last one
//! silently), because in `{"points": {"C1": …, "C1": …}}` that would hide a
//! duplicated landmark.

use serde_json::{Map, Number, Value};

/// serde_json's recursion limit; deeper input is refused, never overflows the stack.
const MAX_DEPTH: usize = 128;

/// Parse `text`; on failure a message saying what is wrong and where.
pub(super) fn parse(text: &str) -> Result<Value, String> {
    let mut p = Parser {
        s: text.as_bytes(),
        i: 0,
        dup: None,
    };
    let v = p.value(0).and_then(|v| {
        p.ws();
        (p.i == p.s.len()).then_some(v)
    });
    match (v, p.dup) {
        (_, Some((key, at))) => {
            let (line, col) = line_col(text, at);
            Err(format!(
                "key \"{key}\" appears twice in one object at line {line} column {col}: \
                 each key (and each landmark label) must appear once; delete or rename one"
            ))
        }
        (Some(v), None) => Ok(v),
        (None, None) => Err(serde_message(text)),
    }
}

/// Why serde_json rejects `text`, with a hint for the usual cause in landmark files.
fn serde_message(text: &str) -> String {
    let e = match serde_json::from_str::<Value>(text) {
        Err(e) => e,
        // Only reachable if the two parsers disagree; keep the answer useful anyway.
        Ok(_) => return "malformed JSON (rejected by coapt's exact-number reader)".to_string(),
    };
    let line = text.lines().nth(e.line().saturating_sub(1)).unwrap_or("");
    let non_finite = ["NaN", "nan", "Infinity", "inf"]
        .iter()
        .any(|t| line.contains(t))
        || e.to_string().contains("number out of range");
    if non_finite {
        format!(
            "malformed JSON: {e}: a coordinate is NaN, Infinity or out of range; \
             every coordinate must be a finite number of millimetres"
        )
    } else {
        format!(
            "malformed JSON: {e}: fix the file (a JSON validator shows the spot) or re-save it from 3D Slicer"
        )
    }
}

/// 1-based line and column (in characters) of byte offset `at`.
fn line_col(text: &str, at: usize) -> (usize, usize) {
    let before = &text[..at.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

struct Parser<'a> {
    s: &'a [u8],
    i: usize,
    /// First duplicated key and its byte offset.
    dup: Option<(String, usize)>,
}

impl Parser<'_> {
    fn peek(&self) -> Option<u8> {
        self.s.get(self.i).copied()
    }

    fn ws(&mut self) {
        while matches!(self.peek(), Some(b' ' | b'\t' | b'\n' | b'\r')) {
            self.i += 1;
        }
    }

    fn eat(&mut self, lit: &[u8]) -> Option<()> {
        if self.s[self.i..].starts_with(lit) {
            self.i += lit.len();
            Some(())
        } else {
            None
        }
    }

    fn value(&mut self, depth: usize) -> Option<Value> {
        if depth > MAX_DEPTH || self.dup.is_some() {
            return None;
        }
        self.ws();
        match self.peek()? {
            b'{' => self.object(depth),
            b'[' => self.array(depth),
            b'"' => self.string().map(Value::String),
            b't' => self.eat(b"true").map(|_| Value::Bool(true)),
            b'f' => self.eat(b"false").map(|_| Value::Bool(false)),
            b'n' => self.eat(b"null").map(|_| Value::Null),
            b'-' | b'0'..=b'9' => self.number(),
            _ => None,
        }
    }

    fn object(&mut self, depth: usize) -> Option<Value> {
        self.i += 1; // '{'
        let mut map = Map::new();
        self.ws();
        if self.eat(b"}").is_some() {
            return Some(Value::Object(map));
        }
        loop {
            self.ws();
            let at = self.i;
            let key = self.string()?;
            self.ws();
            self.eat(b":")?;
            let v = self.value(depth + 1)?;
            if map.contains_key(&key) {
                self.dup = Some((key, at));
                return None;
            }
            map.insert(key, v);
            self.ws();
            match self.peek()? {
                b',' => self.i += 1,
                b'}' => {
                    self.i += 1;
                    return Some(Value::Object(map));
                }
                _ => return None,
            }
        }
    }

    fn array(&mut self, depth: usize) -> Option<Value> {
        self.i += 1; // '['
        let mut items = Vec::new();
        self.ws();
        if self.eat(b"]").is_some() {
            return Some(Value::Array(items));
        }
        loop {
            items.push(self.value(depth + 1)?);
            self.ws();
            match self.peek()? {
                b',' => self.i += 1,
                b']' => {
                    self.i += 1;
                    return Some(Value::Array(items));
                }
                _ => return None,
            }
        }
    }

    fn string(&mut self) -> Option<String> {
        if self.peek()? != b'"' {
            return None;
        }
        self.i += 1;
        let mut out: Vec<u8> = Vec::new();
        loop {
            let c = self.peek()?;
            self.i += 1;
            match c {
                b'"' => return String::from_utf8(out).ok(),
                b'\\' => {
                    let e = self.peek()?;
                    self.i += 1;
                    let ch = match e {
                        b'"' => '"',
                        b'\\' => '\\',
                        b'/' => '/',
                        b'b' => '\u{8}',
                        b'f' => '\u{c}',
                        b'n' => '\n',
                        b'r' => '\r',
                        b't' => '\t',
                        b'u' => self.unicode_escape()?,
                        _ => return None,
                    };
                    out.extend_from_slice(ch.encode_utf8(&mut [0; 4]).as_bytes());
                }
                0x00..=0x1f => return None,
                // Bytes of multi-byte UTF-8 characters are copied as they are;
                // the input is a &str, so they form valid characters.
                _ => out.push(c),
            }
        }
    }

    /// After `\u`: four hex digits, or a surrogate pair written as two escapes.
    fn unicode_escape(&mut self) -> Option<char> {
        let hi = self.hex4()?;
        if (0xD800..0xDC00).contains(&hi) {
            self.eat(b"\\u")?;
            let lo = self.hex4()?;
            if !(0xDC00..0xE000).contains(&lo) {
                return None;
            }
            char::from_u32(0x10000 + ((hi - 0xD800) << 10) + (lo - 0xDC00))
        } else {
            char::from_u32(hi)
        }
    }

    fn hex4(&mut self) -> Option<u32> {
        let digits = std::str::from_utf8(self.s.get(self.i..self.i + 4)?).ok()?;
        let v = u32::from_str_radix(digits, 16).ok()?;
        self.i += 4;
        Some(v)
    }

    /// JSON number grammar; integers stay integers (as serde_json keeps them),
    /// everything else goes through the correctly rounded f64 parser.
    fn number(&mut self) -> Option<Value> {
        let start = self.i;
        let digits = |p: &mut Self| {
            let s = p.i;
            while matches!(p.peek(), Some(b'0'..=b'9')) {
                p.i += 1;
            }
            p.i > s
        };
        if self.peek() == Some(b'-') {
            self.i += 1;
        }
        if self.peek() == Some(b'0') {
            self.i += 1;
        } else if !digits(self) {
            return None;
        }
        let mut integer = true;
        if self.peek() == Some(b'.') {
            self.i += 1;
            integer = false;
            if !digits(self) {
                return None;
            }
        }
        if matches!(self.peek(), Some(b'e' | b'E')) {
            self.i += 1;
            integer = false;
            if matches!(self.peek(), Some(b'+' | b'-')) {
                self.i += 1;
            }
            if !digits(self) {
                return None;
            }
        }
        let text = std::str::from_utf8(&self.s[start..self.i]).ok()?;
        if integer {
            if let Ok(u) = text.parse::<u64>() {
                return Some(Value::Number(u.into()));
            }
            if let Ok(i) = text.parse::<i64>() {
                return Some(Value::Number(i.into()));
            }
        }
        // Non-finite (1e400) is refused, as serde_json does.
        Number::from_f64(text.parse::<f64>().ok()?).map(Value::Number)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    #[test]
    fn same_tree_as_serde_for_ordinary_json() {
        let t = r#"{"a": [1, -2, 3.5, 1e3, true, false, null], "b\u00e9\n": {"c": "x\"y\\z\ud83d\ude00"}, "d": []}"#;
        assert_eq!(parse(t).unwrap(), serde_json::from_str::<Value>(t).unwrap());
    }

    #[test]
    fn floats_are_exact() {
        let mut r = SplitMix64::new(11);
        for _ in 0..20_000 {
            let x = r.range(-300.0, 300.0) * 10f64.powi((r.uniform() * 8.0) as i32 - 4);
            let t = serde_json::to_string(&x).unwrap();
            let back = parse(&t).unwrap().as_f64().unwrap();
            assert_eq!(back.to_bits(), x.to_bits(), "{t}");
        }
    }

    #[test]
    fn errors_carry_line_and_column() {
        let e = parse("{\n  \"a\": [1, 2,]\n}").unwrap_err();
        assert!(e.contains("line 2"), "{e}");
        let e = parse("{\"p\": [NaN, 1, 2]}").unwrap_err();
        assert!(e.contains("NaN") && e.contains("finite"), "{e}");
        let e = parse("[1e400]").unwrap_err();
        assert!(e.contains("out of range") && e.contains("finite"), "{e}");
        let e = parse("{\"C1\": 1,\n \"C1\": 2}").unwrap_err();
        assert!(
            e.contains("\"C1\" appears twice") && e.contains("line 2"),
            "{e}"
        );
        assert!(parse("[1] x").is_err());
        assert!(parse(&"[".repeat(10_000)).is_err());
    }
}
