//! Parameter files: `name = value` lines that set a model's variables by name.
//!
//! The format is deliberately small so that people and tools can write it: one assignment per
//! line, `#` starts a comment, names are the variable names of the model description, values
//! are numbers, `true`/`false`, or double-quoted strings. Example:
//!
//! ```text
//! # Azimuth drive, measured on antenna m012 (2026-03-02)
//! path.stiffness = 7.3e9      # N.m/rad, per pinion, axis side
//! friction.coulomb = 0.31     # N.m
//! ```

use std::fmt;

use crate::model::Model;
use crate::variables::{BaseType, SetPhase, Values, VariableSet};

/// One value in a parameter file.
#[derive(Debug, Clone, PartialEq)]
pub enum ParameterValue {
    Number(f64),
    Boolean(bool),
    Text(String),
}

impl fmt::Display for ParameterValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParameterValue::Number(x) => write!(f, "{}", crate::xml::format_real(*x)),
            ParameterValue::Boolean(b) => write!(f, "{b}"),
            ParameterValue::Text(s) => write!(f, "\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\"")),
        }
    }
}

/// One assignment, with the line it came from for error messages.
#[derive(Debug, Clone, PartialEq)]
pub struct Assignment {
    pub name: String,
    pub value: ParameterValue,
    pub line: usize,
}

/// Parses a parameter file. Errors name the origin (usually the file path) and the line.
pub fn parse(text: &str, origin: &str) -> Result<Vec<Assignment>, String> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let content = strip_comment(raw);
        let content = content.trim();
        if content.is_empty() {
            continue;
        }
        let (name, value) = content
            .split_once('=')
            .ok_or_else(|| format!("{origin}:{line}: expected `name = value`, found `{}`", raw.trim()))?;
        let name = name.trim();
        if name.is_empty() || name.contains(char::is_whitespace) {
            return Err(format!("{origin}:{line}: invalid variable name `{name}`"));
        }
        let value = parse_value(value.trim()).map_err(|e| format!("{origin}:{line}: {name}: {e}"))?;
        if out.iter().any(|a: &Assignment| a.name == name) {
            return Err(format!("{origin}:{line}: {name} is assigned twice"));
        }
        out.push(Assignment { name: name.to_string(), value, line });
    }
    Ok(out)
}

/// Removes a `#` comment, leaving `#` inside a quoted string alone.
fn strip_comment(line: &str) -> &str {
    let mut in_string = false;
    let mut escaped = false;
    for (i, c) in line.char_indices() {
        match c {
            '\\' if in_string => escaped = !escaped,
            '"' if !escaped => in_string = !in_string,
            '#' if !in_string => return &line[..i],
            _ => escaped = false,
        }
    }
    line
}

fn parse_value(text: &str) -> Result<ParameterValue, String> {
    if let Some(inner) = text.strip_prefix('"') {
        let inner = inner.strip_suffix('"').ok_or("string value is missing its closing quote")?;
        let mut out = String::new();
        let mut chars = inner.chars();
        while let Some(c) = chars.next() {
            if c == '\\' {
                match chars.next() {
                    Some(e @ ('\\' | '"')) => out.push(e),
                    Some(other) => return Err(format!("unknown escape `\\{other}` in string")),
                    None => return Err("string ends with a lone backslash".into()),
                }
            } else {
                out.push(c);
            }
        }
        return Ok(ParameterValue::Text(out));
    }
    match text {
        "true" => return Ok(ParameterValue::Boolean(true)),
        "false" => return Ok(ParameterValue::Boolean(false)),
        "" => return Err("value is missing".into()),
        _ => {}
    }
    let x: f64 = text.parse().map_err(|_| format!("`{text}` is not a number, true/false or a quoted string"))?;
    if !x.is_finite() {
        return Err(format!("`{text}` is not a finite number"));
    }
    Ok(ParameterValue::Number(x))
}

/// Applies a parameter file to a model's values with the checks a master's set would get
/// (known name, type, settable before initialisation, range, the model's own checks). Nothing
/// changes unless every assignment is valid. Returns how many values were set.
pub fn apply<M: Model>(text: &str, origin: &str, values: &mut Values<M::Var>) -> Result<usize, String> {
    let assignments = parse(text, origin)?;
    let mut updated = values.clone();
    for a in &assignments {
        let var =
            M::Var::by_name(&a.name).ok_or_else(|| format!("{origin}:{}: unknown variable `{}`", a.line, a.name))?;
        let decl = var.var();
        if !decl.settable_in(SetPhase::Initialization) {
            return Err(format!(
                "{origin}:{}: `{}` is a {} and cannot be set from a parameter file",
                a.line,
                a.name,
                decl.causality.xml_name()
            ));
        }
        let mismatch = || {
            format!("{origin}:{}: `{}` is of type {}, the file gives `{}`", a.line, a.name, decl.base_type(), a.value)
        };
        match (decl.base_type(), &a.value) {
            (BaseType::Real, ParameterValue::Number(x)) => {
                crate::instance::check_real_value::<M>(var, *x, &updated)
                    .map_err(|e| format!("{origin}:{}: {e}", a.line))?;
                updated.set_real(var, *x);
            }
            (BaseType::Integer, ParameterValue::Number(x)) => {
                if x.fract() != 0.0 || *x < f64::from(i32::MIN) || *x > f64::from(i32::MAX) {
                    return Err(format!("{origin}:{}: `{}` needs an integer, the file gives {x}", a.line, a.name));
                }
                crate::instance::check_integer_value::<M>(var, *x as i32, &updated)
                    .map_err(|e| format!("{origin}:{}: {e}", a.line))?;
                updated.set_integer(var, *x as i32);
            }
            (BaseType::Integer, ParameterValue::Text(item)) => {
                // Enumerations may be given by item name.
                let crate::variables::Kind::Enumeration { declared_type, .. } = decl.kind else {
                    return Err(mismatch());
                };
                let value = declared_type
                    .value_of(item)
                    .ok_or_else(|| format!("{origin}:{}: `{item}` is not an item of {}", a.line, declared_type.name))?;
                updated.set_integer(var, value);
            }
            (BaseType::Boolean, ParameterValue::Boolean(b)) => updated.set_boolean(var, *b),
            (BaseType::String, ParameterValue::Text(s)) => updated.set_string(var, s.clone()),
            _ => return Err(mismatch()),
        }
    }
    *values = updated;
    Ok(assignments.len())
}

/// Writes assignments in the file format, one per line, with an optional comment each.
pub fn format(entries: &[(String, ParameterValue, String)]) -> String {
    let mut out = String::new();
    for (name, value, comment) in entries {
        if comment.is_empty() {
            out.push_str(&format!("{name} = {value}\n"));
        } else {
            out.push_str(&format!("{name} = {value}  # {comment}\n"));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comments_blank_lines_and_quoted_hashes_are_handled() {
        let text = "# header\n\na = 1.5e3 # unit\nb = true\nc = \"x # not a comment \\\"q\\\"\"\n";
        let parsed = parse(text, "t").unwrap();
        assert_eq!(parsed.len(), 3);
        assert_eq!(parsed[0].value, ParameterValue::Number(1500.0));
        assert_eq!(parsed[1].value, ParameterValue::Boolean(true));
        assert_eq!(parsed[2].value, ParameterValue::Text("x # not a comment \"q\"".into()));
        assert_eq!(parsed[2].line, 5);
    }

    #[test]
    fn malformed_lines_are_errors_naming_the_line() {
        for (text, needle) in [
            ("a 1", "t:1: expected"),
            ("x = 1\na = nan", "t:2: a: `nan` is not a finite number"),
            ("a = abc", "not a number"),
            ("a = \"open", "closing quote"),
            ("a = 1\na = 2", "assigned twice"),
            ("my var = 1", "invalid variable name"),
        ] {
            let err = parse(text, "t").unwrap_err();
            assert!(err.contains(needle), "{text:?} gave {err:?}");
        }
    }

    #[test]
    fn formatted_files_parse_back_to_the_same_values() {
        let entries = vec![
            ("a".to_string(), ParameterValue::Number(7.3e9), "N.m/rad".to_string()),
            ("b".to_string(), ParameterValue::Text("p \"q\" # r".into()), String::new()),
            ("c".to_string(), ParameterValue::Number(-1.25e-7), String::new()),
        ];
        let parsed = parse(&format(&entries), "t").unwrap();
        for (e, p) in entries.iter().zip(&parsed) {
            assert_eq!(e.0, p.name);
            assert_eq!(e.1, p.value);
        }
    }
}
