//! The one table of the antenna's uncertain parameters, `docs/parameters.csv`: for each, the
//! value of the paper's model, the default of the realistic antenna, the plausible range a sweep
//! draws from, which FMU variables (or scenario settings) it sets, and its source or "estimate".
//! The coupled master's configurations, the sweeps and the generated `docs/parameters.md` all
//! read this table, so a range is written once.

use std::fmt::Write as _;

/// The table as committed, compiled in so that every tool carries the same ranges.
pub const PARAMETERS_CSV: &str = include_str!("../../../docs/parameters.csv");

/// Where the committed table lives, relative to the workspace root (for messages).
pub const PARAMETERS_CSV_PATH: &str = "docs/parameters.csv";

/// How a sweep spreads its samples over a range.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scale {
    /// Uniform in the value.
    Linear,
    /// Uniform in the logarithm of the value (stiffnesses, damping ratios, noise levels).
    Log,
    /// Uniform over the integers `low..=high` (enumerations, seeds).
    Integer,
    /// An angle in degrees over the whole circle (`high - low = 360`), uniform: its statistics
    /// are circular (a rank correlation on 0-360 deg would call 359 deg far from 1 deg).
    Circular,
}

/// Whether a value comes from a publication, from the paper itself, or is an estimate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Basis {
    Source,
    Paper,
    Estimate,
}

/// What a parameter sets.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Target {
    /// A variable of an FMU, by model identifier and variable name.
    Variable { model_identifier: String, name: String },
    /// A field of the Structure FMU's modes file (`mode<k>.<field>`).
    StructureMode { field: String },
    /// A setting the master applies itself (wind condition factors, load scales, seeds).
    Scenario { name: String },
}

/// One row of the table.
#[derive(Debug, Clone, PartialEq)]
pub struct UncertainParameter {
    pub name: String,
    pub unit: String,
    /// The value in the paper's model; `None` where the paper's model lacks the part.
    pub paper: Option<f64>,
    /// The realistic antenna's default.
    pub default: f64,
    pub low: f64,
    pub high: f64,
    pub scale: Scale,
    pub targets: Vec<Target>,
    pub basis: Basis,
    pub source: String,
}

impl UncertainParameter {
    /// The value at `u` in [0, 1] of the range, spread as the scale says (the inverse
    /// cumulative distribution of the uniform law on the range).
    pub fn value_at(&self, u: f64) -> f64 {
        let u = u.clamp(0.0, 1.0);
        match self.scale {
            Scale::Linear | Scale::Circular => self.low + u * (self.high - self.low),
            Scale::Log => (self.low.ln() + u * (self.high.ln() - self.low.ln())).exp(),
            Scale::Integer => {
                let span = self.high - self.low + 1.0;
                (self.low + (u * span).floor()).min(self.high)
            }
        }
    }
}

/// A malformed table.
#[derive(Debug, thiserror::Error)]
pub enum ParameterTableError {
    #[error("{origin}: {source}")]
    Csv { origin: String, source: csv::Error },
    /// The header does not name the ten columns in order.
    #[error("{origin}:{line}: the header must be `{}`", COLUMNS.join(","))]
    Header { origin: String, line: u64 },
    /// A second row names a parameter that an earlier row already defined.
    #[error("{origin}:{line}: `{name}` appears twice")]
    Duplicate { origin: String, line: u64, name: String },
    /// One row is malformed; the problem says which field and why.
    #[error("{origin}:{line}: {problem}")]
    Row { origin: String, line: u64, problem: RowError },
}

/// What is wrong with one row of the table; every variant names the row's parameter.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RowError {
    #[error("{parameter}: {column} = `{text}` is not a number")]
    NotANumber { parameter: String, column: &'static str, text: String },
    #[error("{parameter}: {column} = `{text}` is not finite")]
    NotFinite { parameter: String, column: &'static str, text: String },
    #[error("{parameter}: scale `{scale}` is not linear, log, integer or circular")]
    UnknownScale { parameter: String, scale: String },
    #[error("{parameter}: the range [{low}, {high}] is empty")]
    EmptyRange { parameter: String, low: f64, high: f64 },
    #[error("{parameter}: the default {default} lies outside the range [{low}, {high}]")]
    DefaultOutsideRange { parameter: String, default: f64, low: f64, high: f64 },
    #[error("{parameter}: a log scale needs a positive range, not [{low}, {high}]")]
    LogScaleNotPositive { parameter: String, low: f64, high: f64 },
    #[error("{parameter}: a circular scale spans the whole circle, 360 deg, not [{low}, {high}]")]
    CircularScaleSpan { parameter: String, low: f64, high: f64 },
    #[error("{parameter}: an integer scale needs whole numbers, got default {default} in [{low}, {high}]")]
    IntegerScaleFractional { parameter: String, default: f64, low: f64, high: f64 },
    #[error("{parameter}: no targets")]
    NoTargets { parameter: String },
    #[error("{parameter}: target `{target}` is not <FMU>:<variable>")]
    TargetForm { parameter: String, target: String },
    #[error("{parameter}: target `{target}` names no variable")]
    TargetWithoutVariable { parameter: String, target: String },
    #[error("{parameter}: basis `{basis}` is not source, paper or estimate")]
    UnknownBasis { parameter: String, basis: String },
    #[error("{parameter}: every parameter names its source or why it is an estimate")]
    NoSource { parameter: String },
}

const COLUMNS: [&str; 10] = ["name", "unit", "paper", "default", "low", "high", "scale", "targets", "basis", "source"];

/// Reads a table in the format of `docs/parameters.csv` (`#` comment lines, a header naming the
/// ten columns in order). `origin` names the text in messages.
pub fn parse_parameters(text: &str, origin: &str) -> Result<Vec<UncertainParameter>, ParameterTableError> {
    let csv_error = |source| ParameterTableError::Csv { origin: origin.to_string(), source };
    let mut reader = csv::ReaderBuilder::new().comment(Some(b'#')).trim(csv::Trim::All).from_reader(text.as_bytes());
    let header = reader.headers().map_err(csv_error)?.clone();
    if header.iter().collect::<Vec<_>>() != COLUMNS {
        return Err(ParameterTableError::Header {
            origin: origin.to_string(),
            line: header.position().map_or(1, |p| p.line()),
        });
    }
    let mut parameters: Vec<UncertainParameter> = Vec::new();
    for record in reader.records() {
        let record = record.map_err(csv_error)?;
        let line = record.position().map_or(0, |p| p.line());
        let parameter = parse_row(&record).map_err(|problem| ParameterTableError::Row {
            origin: origin.to_string(),
            line,
            problem,
        })?;
        if parameters.iter().any(|p| p.name == parameter.name) {
            return Err(ParameterTableError::Duplicate { origin: origin.to_string(), line, name: parameter.name });
        }
        parameters.push(parameter);
    }
    Ok(parameters)
}

fn parse_row(record: &csv::StringRecord) -> Result<UncertainParameter, RowError> {
    let field = |i: usize| record.get(i).unwrap_or("");
    let name = field(0).to_string();
    let parameter = || name.clone();
    let number = |i: usize| -> Result<f64, RowError> {
        let text = field(i);
        let value: f64 = text.parse().map_err(|_| RowError::NotANumber {
            parameter: parameter(),
            column: COLUMNS[i],
            text: text.to_string(),
        })?;
        if value.is_finite() {
            Ok(value)
        } else {
            Err(RowError::NotFinite { parameter: parameter(), column: COLUMNS[i], text: text.to_string() })
        }
    };
    let paper = if field(2).is_empty() { None } else { Some(number(2)?) };
    let (default, low, high) = (number(3)?, number(4)?, number(5)?);
    let scale = match field(6) {
        "linear" => Scale::Linear,
        "log" => Scale::Log,
        "integer" => Scale::Integer,
        "circular" => Scale::Circular,
        other => return Err(RowError::UnknownScale { parameter: parameter(), scale: other.to_string() }),
    };
    if low >= high {
        return Err(RowError::EmptyRange { parameter: parameter(), low, high });
    }
    if !(low..=high).contains(&default) {
        return Err(RowError::DefaultOutsideRange { parameter: parameter(), default, low, high });
    }
    if scale == Scale::Log && low <= 0.0 {
        return Err(RowError::LogScaleNotPositive { parameter: parameter(), low, high });
    }
    if scale == Scale::Circular && (high - low - 360.0).abs() > 1e-9 {
        return Err(RowError::CircularScaleSpan { parameter: parameter(), low, high });
    }
    if scale == Scale::Integer && [low, high, default].iter().any(|v| v.fract() != 0.0) {
        return Err(RowError::IntegerScaleFractional { parameter: parameter(), default, low, high });
    }
    let targets = field(7).split_whitespace().map(|t| parse_target(&name, t)).collect::<Result<Vec<_>, _>>()?;
    if targets.is_empty() {
        return Err(RowError::NoTargets { parameter: parameter() });
    }
    let basis = match field(8) {
        "source" => Basis::Source,
        "paper" => Basis::Paper,
        "estimate" => Basis::Estimate,
        other => return Err(RowError::UnknownBasis { parameter: parameter(), basis: other.to_string() }),
    };
    let source = field(9).to_string();
    if source.is_empty() {
        return Err(RowError::NoSource { parameter: parameter() });
    }
    Ok(UncertainParameter {
        name,
        unit: field(1).to_string(),
        paper,
        default,
        low,
        high,
        scale,
        targets,
        basis,
        source,
    })
}

fn parse_target(name: &str, text: &str) -> Result<Target, RowError> {
    let (unit, variable) = text
        .split_once(':')
        .ok_or_else(|| RowError::TargetForm { parameter: name.to_string(), target: text.to_string() })?;
    if variable.is_empty() {
        return Err(RowError::TargetWithoutVariable { parameter: name.to_string(), target: text.to_string() });
    }
    Ok(match unit {
        "scenario" => Target::Scenario { name: variable.to_string() },
        "Structure" if variable.starts_with("mode") => Target::StructureMode { field: variable.to_string() },
        _ => Target::Variable { model_identifier: unit.to_string(), name: variable.to_string() },
    })
}

/// The committed table.
pub fn parameters() -> Vec<UncertainParameter> {
    parse_parameters(PARAMETERS_CSV, PARAMETERS_CSV_PATH).expect("docs/parameters.csv is checked by its tests")
}

fn format_value(value: f64) -> String {
    if value != 0.0 && (value.abs() >= 1e5 || value.abs() < 1e-3) {
        format!("{value:e}")
    } else {
        format!("{value}")
    }
}

/// The plants' sub-step while Stribeck friction is on (`numerics.nonlinear_substep`), s. The
/// plant holds the Stribeck excess over each sub-step; the fastest friction feedback it holds
/// has a time constant of about 0.1 s at the load (load inertia 8.5e5 kg m^2 over the
/// bearing's friction slope near the 0.005 deg/s Stribeck speed, about 7e6 N m s/rad) and
/// 0.02 s at a motor, so holding it for the 1 ms communication step errs by a few percent of
/// that feedback. Measured on the requirement report: every figure the same to its printed
/// digit as with the FMU's default 0.1 ms, at a tenth of the sub-steps. Numerics, not physics:
/// every configuration of the coupled master sets it.
pub const STRIBECK_SUBSTEP_S: f64 = 1e-3;

/// The file name of the realistic antenna's parameter file in an FMU's `resources/`.
pub const REALISTIC_PARAMETER_FILE: &str = "realistic.params";

/// The realistic antenna's parameter file for the FMU `model_identifier`: every variable of it
/// that the table sets, at its default, after the plants' sub-step ([`STRIBECK_SUBSTEP_S`]).
/// Packaged as `resources/realistic.params`, so that a master that sets only
/// `parameter_file = realistic.params` runs the antenna the coupled master runs by default
/// (the structure's shipped modes are already the realistic ones; the wind's mean speed and
/// direction are each scenario's). `None` for an FMU the table does not set.
pub fn realistic_parameter_file(model_identifier: &str) -> Option<String> {
    let mut lines = Vec::new();
    if model_identifier.ends_with("Plant") {
        lines.push(format!(
            "numerics.nonlinear_substep = {}  # [s] numerics: Stribeck friction held over 1 ms",
            format_value(STRIBECK_SUBSTEP_S)
        ));
    }
    for parameter in parameters() {
        for target in &parameter.targets {
            let Target::Variable { model_identifier: unit, name } = target else { continue };
            if unit != model_identifier {
                continue;
            }
            let value = match parameter.scale {
                Scale::Integer => format!("{}", parameter.default as i64),
                Scale::Linear | Scale::Log | Scale::Circular => format_value(parameter.default),
            };
            let unit = if parameter.unit.is_empty() || parameter.unit == "1" {
                String::new()
            } else {
                format!("[{}] ", parameter.unit)
            };
            lines.push(format!("{name} = {value}  # {unit}{}", parameter.name));
        }
    }
    if lines.is_empty() {
        return None;
    }
    Some(format!(
        "# The realistic antenna's parameters of {model_identifier}: the defaults of docs/parameters.csv\n\
         # (generated by `cargo xtask package`; docs/parameters.md gives each source and range).\n\
         # Load it with parameter_file = {REALISTIC_PARAMETER_FILE}; the FMU's start values are the paper's model.\n{}\n",
        lines.join("\n")
    ))
}

/// `docs/parameters.md`: the table for people, generated from the CSV.
pub fn render_markdown(parameters: &[UncertainParameter]) -> String {
    let mut out = String::from(
        "# Uncertain parameters: paper value, default, range, source\n\n\
         Generated by `cargo xtask codegen` from [`parameters.csv`](parameters.csv), the one table \
         the coupled master's configurations (`--config paper` applies the paper column, i.e. the \
         FMUs' start values with no structure and a coherent gust; the default applies the default \
         column) and `antenna sweep` read. Edit the CSV, not this file. Scale says how a sweep \
         spreads its samples over the range; basis says whether the default comes from a source, \
         from the paper, or is an estimate. Each plant and the wind ship the default column for \
         their variables as `resources/realistic.params` (`parameter_file = realistic.params`).\n\n\
         | parameter | unit | paper | default | range | scale | sets | basis | source or reasoning |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    for p in parameters {
        let targets: Vec<String> = p
            .targets
            .iter()
            .map(|t| match t {
                Target::Variable { model_identifier, name } => format!("`{model_identifier}`: `{name}`"),
                Target::StructureMode { field } => format!("`Structure` modes file: `{field}`"),
                Target::Scenario { name } => format!("master: `{name}`"),
            })
            .collect();
        let _ = writeln!(
            out,
            "| `{}` | {} | {} | {} | {} - {} | {} | {} | {} | {} |",
            p.name,
            p.unit,
            p.paper.map_or("(absent)".to_string(), format_value),
            format_value(p.default),
            format_value(p.low),
            format_value(p.high),
            match p.scale {
                Scale::Linear => "linear",
                Scale::Log => "log",
                Scale::Integer => "integer",
                Scale::Circular => "circular",
            },
            targets.join("<br>"),
            match p.basis {
                Basis::Source => "source",
                Basis::Paper => "paper",
                Basis::Estimate => "estimate",
            },
            p.source.replace('|', "\\|"),
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn committed_table_parses_with_every_default_inside_its_range() {
        let parameters = parameters();
        assert!(parameters.len() >= 30, "{} rows", parameters.len());
        for p in &parameters {
            assert!(p.low <= p.default && p.default <= p.high, "{}", p.name);
        }
    }

    #[test]
    fn values_spread_over_the_range_as_the_scale_says() {
        let mut p = parameters().into_iter().find(|p| p.scale == Scale::Log).unwrap();
        assert!((p.value_at(0.5) - (p.low * p.high).sqrt()).abs() < 1e-9 * p.high);
        p.scale = Scale::Linear;
        assert_eq!(p.value_at(0.0), p.low);
        assert_eq!(p.value_at(1.0), p.high);
        p.scale = Scale::Integer;
        (p.low, p.high) = (1.0, 2.0);
        assert_eq!(p.value_at(0.49), 1.0);
        assert_eq!(p.value_at(0.51), 2.0);
        assert_eq!(p.value_at(1.0), 2.0);
    }

    #[test]
    fn malformed_rows_are_refused_with_their_line() {
        let header = COLUMNS.join(",");
        let cases = [
            ("x,1,,5,1,2,linear,scenario:x,estimate,why", "outside the range"),
            ("x,1,,1,2,1,linear,scenario:x,estimate,why", "is empty"),
            ("x,1,,1,0,2,log,scenario:x,estimate,why", "positive range"),
            ("x,1,,1,0,2,cubic,scenario:x,estimate,why", "scale `cubic`"),
            ("x,1,,1,0,2,linear,,estimate,why", "no targets"),
            ("x,1,,1,0,2,linear,nothing,estimate,why", "not <FMU>:<variable>"),
            ("x,1,,1,0,2,linear,scenario:x,estimate,", "names its source"),
            ("x,1,,one,0,2,linear,scenario:x,estimate,why", "not a number"),
            ("x,1,,1,0,inf,linear,scenario:x,estimate,why", "not finite"),
        ];
        for (row, expected) in cases {
            let error = parse_parameters(&format!("{header}\n{row}\n"), "t.csv").unwrap_err().to_string();
            assert!(error.starts_with("t.csv:2: ") && error.contains(expected), "{row}: {error}");
        }
        let twice =
            format!("{header}\nx,1,,1,0,2,linear,scenario:x,estimate,why\nx,1,,1,0,2,linear,scenario:x,estimate,why\n");
        assert!(parse_parameters(&twice, "t.csv").unwrap_err().to_string().contains("twice"));
    }
}
