//! A TOML error as a person needs it: the line, the key, and for a bare
//! number where a quantity belongs, how to write it (`pressure = 80` used to
//! say only "invalid type: integer `80`, expected a string").

/// "line 14, `pressure`: invalid type: …; quantities are strings …".
pub fn describe(text: &str, e: &toml::de::Error) -> String {
    let mut msg = e.message().trim_end().to_string();
    let Some(span) = e.span() else {
        return msg;
    };
    let start = span.start.min(text.len());
    let line = text[..start].matches('\n').count() + 1;
    let src = text.lines().nth(line - 1).unwrap_or("").trim();
    let key = src
        .split_once('=')
        .map(|(k, _)| k.trim().trim_matches('"'))
        .filter(|k| !k.is_empty() && !k.starts_with('['));
    if (msg.contains("expected a string") || msg.contains("bare number"))
        && !msg.contains("with its unit")
    {
        msg += "; quantities are written as strings with their unit, e.g. pressure = \"80 mmHg\", thickness = \"0.5 mm\", mu = \"900 kPa\"";
    }
    match key {
        Some(k) => format!("line {line}, `{k}`: {msg}"),
        None => format!("line {line}: {msg}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Deserialize, Debug)]
    #[allow(dead_code)]
    struct C {
        model: String,
        pressure: String,
    }

    #[test]
    fn a_bare_number_names_its_line_key_and_how_to_write_it() {
        let text = "model = \"goh\"\n# a comment\npressure = 80\n";
        let e = toml::from_str::<C>(text).unwrap_err();
        let m = describe(text, &e);
        assert!(
            m.starts_with("line 3, `pressure`: invalid type: integer `80`, expected a string"),
            "{m}"
        );
        assert!(m.contains("pressure = \"80 mmHg\""), "{m}");
    }

    #[test]
    fn a_syntax_error_names_its_line() {
        let text = "model = \"goh\"\npressure = \"80 mmHg\n";
        let e = toml::from_str::<C>(text).unwrap_err();
        let m = describe(text, &e);
        assert!(m.starts_with("line 2"), "{m}");
        assert!(!m.contains("quantities"), "{m}");
    }
}
