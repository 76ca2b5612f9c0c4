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

use crate::files::FileError;
use crate::model::Model;
use crate::variables::{BaseType, SetPhase, Values, VariableError, VariableSet};

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

/// One `name = value  # comment` line as written: the value not yet interpreted, so that a
/// reader with its own value rules (numbers with units, say) shares this one syntax.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    pub name: String,
    /// The value text, trimmed.
    pub value: String,
    /// The text after the `#`, trimmed (empty without a comment).
    pub comment: String,
    /// 1-based line number.
    pub line: usize,
}

/// What is wrong with a parameter file, and on which line (1-based).
#[derive(Debug, Clone, PartialEq)]
pub struct ParseError {
    pub line: usize,
    pub kind: ParseErrorKind,
}

/// The kinds of syntax error in a parameter file.
#[derive(Debug, Clone, PartialEq)]
pub enum ParseErrorKind {
    /// A line that is not blank, not a comment and has no `=`.
    MissingEquals { found: String },
    /// An empty name or one with white space in it.
    InvalidName { name: String },
    /// A name assigned on an earlier line too.
    Duplicate { name: String },
    /// A value that is not a number, `true`/`false` or a quoted string.
    InvalidValue { name: String, error: ValueError },
}

/// Why a value text is not a valid value.
#[derive(Debug, Clone, PartialEq)]
pub enum ValueError {
    Missing,
    MissingClosingQuote,
    UnknownEscape(char),
    LoneBackslash,
    NotANumber(String),
    NotFinite(String),
}

impl fmt::Display for ValueError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ValueError::Missing => write!(f, "value is missing"),
            ValueError::MissingClosingQuote => write!(f, "string value is missing its closing quote"),
            ValueError::UnknownEscape(c) => write!(f, "unknown escape `\\{c}` in string"),
            ValueError::LoneBackslash => write!(f, "string ends with a lone backslash"),
            ValueError::NotANumber(text) => write!(f, "`{text}` is not a number, true/false or a quoted string"),
            ValueError::NotFinite(text) => write!(f, "`{text}` is not a finite number"),
        }
    }
}

impl std::error::Error for ValueError {}

impl fmt::Display for ParseErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParseErrorKind::MissingEquals { found } => write!(f, "expected `name = value`, found `{found}`"),
            ParseErrorKind::InvalidName { name } => write!(f, "invalid variable name `{name}`"),
            ParseErrorKind::Duplicate { name } => write!(f, "{name} is assigned twice"),
            ParseErrorKind::InvalidValue { name, error } => write!(f, "{name}: {error}"),
        }
    }
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.kind)
    }
}

// A hand-written error type: this crate is linked into every FMU and stays free of
// dependencies beyond the FMI essentials.
impl std::error::Error for ParseError {}

/// Splits a parameter file into its entries: blank lines and `#` comments skipped, names
/// checked, each name assigned once. The one parser of the format; values are left as text.
pub fn entries(text: &str) -> Result<Vec<Entry>, ParseError> {
    let mut out: Vec<Entry> = Vec::new();
    // Names seen so far: a set, so that a long file costs time in proportion to its length.
    let mut seen = std::collections::HashSet::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let (content, comment) = split_comment(raw);
        let content = content.trim();
        if content.is_empty() {
            continue;
        }
        let error = |kind| ParseError { line, kind };
        let (name, value) =
            content.split_once('=').ok_or_else(|| error(ParseErrorKind::MissingEquals { found: raw.trim().into() }))?;
        let name = name.trim();
        if name.is_empty() || name.contains(char::is_whitespace) {
            return Err(error(ParseErrorKind::InvalidName { name: name.into() }));
        }
        if !seen.insert(name) {
            return Err(error(ParseErrorKind::Duplicate { name: name.into() }));
        }
        out.push(Entry { name: name.into(), value: value.trim().into(), comment: comment.trim().into(), line });
    }
    Ok(out)
}

/// Parses a parameter file into typed assignments. Errors name the line.
pub fn parse_assignments(text: &str) -> Result<Vec<Assignment>, ParseError> {
    entries(text)?
        .into_iter()
        .map(|e| match parse_value(&e.value) {
            Ok(value) => Ok(Assignment { name: e.name, value, line: e.line }),
            Err(error) => Err(ParseError { line: e.line, kind: ParseErrorKind::InvalidValue { name: e.name, error } }),
        })
        .collect()
}

/// Parses a parameter file. Errors name the origin (usually the file path) and the line.
pub fn parse(text: &str, origin: &str) -> Result<Vec<Assignment>, ParamsError> {
    parse_assignments(text).map_err(|error| ParamsError::Syntax { origin: origin.into(), error })
}

/// Splits a line at its `#` comment, leaving `#` inside a quoted string alone.
fn split_comment(line: &str) -> (&str, &str) {
    let mut in_string = false;
    let mut escaped = false;
    for (i, c) in line.char_indices() {
        match c {
            '\\' if in_string => escaped = !escaped,
            '"' if !escaped => in_string = !in_string,
            '#' if !in_string => return (&line[..i], &line[i + 1..]),
            _ => escaped = false,
        }
    }
    (line, "")
}

/// Interprets a value text: a finite number, `true`/`false`, or a double-quoted string with
/// `\\` and `\"` escapes.
pub fn parse_value(text: &str) -> Result<ParameterValue, ValueError> {
    if let Some(inner) = text.strip_prefix('"') {
        let inner = inner.strip_suffix('"').ok_or(ValueError::MissingClosingQuote)?;
        let mut out = String::new();
        let mut chars = inner.chars();
        while let Some(c) = chars.next() {
            if c == '\\' {
                match chars.next() {
                    Some(e @ ('\\' | '"')) => out.push(e),
                    Some(other) => return Err(ValueError::UnknownEscape(other)),
                    None => return Err(ValueError::LoneBackslash),
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
        "" => return Err(ValueError::Missing),
        _ => {}
    }
    let x: f64 = text.parse().map_err(|_| ValueError::NotANumber(text.into()))?;
    if !x.is_finite() {
        return Err(ValueError::NotFinite(text.into()));
    }
    Ok(ParameterValue::Number(x))
}

/// Why a parameter file was not applied: where (origin, usually the file path, and line) and
/// what to change there.
#[derive(Debug, thiserror::Error)]
pub enum ParamsError {
    #[error("{origin}:{}: {}", .error.line, .error.kind)]
    Syntax { origin: String, error: ParseError },
    #[error("{origin}:{line}: unknown variable `{name}`")]
    UnknownVariable { origin: String, line: usize, name: String },
    #[error("{origin}:{line}: `{name}` is a {causality} and cannot be set from a parameter file")]
    NotSettable { origin: String, line: usize, name: String, causality: &'static str },
    #[error("{origin}:{line}: `{name}` is of type {expected}, the file gives `{value}`")]
    TypeMismatch { origin: String, line: usize, name: String, expected: BaseType, value: ParameterValue },
    #[error("{origin}:{line}: `{name}` needs an integer, the file gives {value}")]
    NotAnInteger { origin: String, line: usize, name: String, value: f64 },
    #[error("{origin}:{line}: `{item}` is not an item of {type_name}")]
    NotAnItem { origin: String, line: usize, item: String, type_name: &'static str },
    /// The value is refused by the checks a master's set gets (range, the model's own).
    #[error("{origin}:{line}: {source}")]
    Refused { origin: String, line: usize, source: VariableError },
    #[error(transparent)]
    File(#[from] FileError),
}

/// Applies a parameter file to a model's values with the checks a master's set would get
/// (known name, type, settable before initialisation, range, the model's own checks). Nothing
/// changes unless every assignment is valid. Returns how many values were set.
pub fn apply<M: Model>(text: &str, origin: &str, values: &mut Values<M::Var>) -> Result<usize, ParamsError> {
    let assignments = parse(text, origin)?;
    let mut updated = values.clone();
    for a in &assignments {
        let (line, name) = (a.line, || a.name.clone());
        let origin = || origin.to_string();
        let var = M::Var::by_name(&a.name).ok_or_else(|| ParamsError::UnknownVariable {
            origin: origin(),
            line,
            name: name(),
        })?;
        let decl = var.var();
        if !decl.settable_in(SetPhase::Initialization) {
            return Err(ParamsError::NotSettable {
                origin: origin(),
                line,
                name: name(),
                causality: decl.causality.xml_name(),
            });
        }
        let mismatch = || ParamsError::TypeMismatch {
            origin: origin(),
            line,
            name: name(),
            expected: decl.base_type(),
            value: a.value.clone(),
        };
        let refused = |source| ParamsError::Refused { origin: origin(), line, source };
        match (decl.base_type(), &a.value) {
            (BaseType::Real, ParameterValue::Number(x)) => {
                crate::instance::check_real_value::<M>(var, *x, &updated).map_err(refused)?;
                updated.set_real(var, *x);
            }
            (BaseType::Integer, ParameterValue::Number(x)) => {
                if x.fract() != 0.0 || *x < f64::from(i32::MIN) || *x > f64::from(i32::MAX) {
                    return Err(ParamsError::NotAnInteger { origin: origin(), line, name: name(), value: *x });
                }
                crate::instance::check_integer_value::<M>(var, *x as i32, &updated).map_err(refused)?;
                updated.set_integer(var, *x as i32);
            }
            (BaseType::Integer, ParameterValue::Text(item)) => {
                // Enumerations may be given by item name.
                let crate::variables::Kind::Enumeration { declared_type, .. } = decl.kind else {
                    return Err(mismatch());
                };
                let value = declared_type.value_of(item).ok_or_else(|| ParamsError::NotAnItem {
                    origin: origin(),
                    line,
                    item: item.clone(),
                    type_name: declared_type.name,
                })?;
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

/// Loads the parameter file named by a model's `parameter_file` variable `file_var` (nothing
/// when it is empty), resolving a relative path against the FMU's resources folder, so that
/// `realistic.params` finds the shipped file. The models call it from
/// [`Model::string_changed`], so a bad file is refused by the call that names it.
pub fn load_file<M: Model>(
    file_var: M::Var,
    values: &mut Values<M::Var>,
    context: &crate::model::Context,
) -> Result<(), ParamsError> {
    let name = values.string(file_var).to_string();
    if name.is_empty() {
        return Ok(());
    }
    let path = std::path::PathBuf::from(&name);
    let path = match &context.resource_dir {
        Some(dir) if path.is_relative() => dir.join(&path),
        _ => path,
    };
    let text = crate::files::read_regular_file(&path, crate::files::MAX_PARAMETER_FILE_BYTES, "parameter file")?;
    apply::<M>(&text, &path.display().to_string(), values)?;
    Ok(())
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
            let err = parse(text, "t").unwrap_err().to_string();
            assert!(err.contains(needle), "{text:?} gave {err:?}");
        }
    }

    #[test]
    fn entries_keep_comments_and_raw_values_for_other_readers() {
        let parsed = entries("# header\nx = 1.5 kN m  # N m, measured\ny = \"a # b\"\n").unwrap();
        assert_eq!(parsed.len(), 2);
        assert_eq!(
            (parsed[0].value.as_str(), parsed[0].comment.as_str(), parsed[0].line),
            ("1.5 kN m", "N m, measured", 2)
        );
        assert_eq!((parsed[1].value.as_str(), parsed[1].comment.as_str()), ("\"a # b\"", ""));
        let error = parse_assignments("a = 1\nb = nan\n").unwrap_err();
        assert_eq!(error.line, 2);
        assert_eq!(
            error.kind,
            ParseErrorKind::InvalidValue { name: "b".into(), error: ValueError::NotFinite("nan".into()) }
        );
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
