//! Describes each FMU a model crate ships: its identifier, the library that holds it, its model
//! description and its resources. The build task (`xtask`) turns these into `.fmu` archives.

use crate::model::Model;
use crate::variables::{Causality, Kind, VariableSet};

/// One FMU of a model crate.
#[derive(Clone, Copy)]
pub struct FmuSpec {
    pub model_identifier: &'static str,
    /// The cargo library name whose `lib<name>.so` is the binary (several FMUs may share one).
    pub library_name: &'static str,
    pub model_description: fn() -> String,
    pub validate: fn() -> Result<(), crate::xml::DescriptionError>,
    /// Files under `resources/`: (relative path, contents).
    pub resources: fn() -> Vec<(String, Vec<u8>)>,
}

impl FmuSpec {
    pub fn of<M: Model>(library_name: &'static str, resources: fn() -> Vec<(String, Vec<u8>)>) -> FmuSpec {
        FmuSpec {
            model_identifier: M::info().model_identifier,
            library_name,
            model_description: crate::xml::model_description::<M>,
            validate: crate::xml::validate::<M>,
            resources,
        }
    }
}

/// The default parameter set of a model as a parameter file: every parameter with its start
/// value, unit and description, so a user can copy it and edit.
pub fn default_parameter_file<M: Model>() -> String {
    let info = M::info();
    let mut out = format!(
        "# Default parameters of {} {} (generated from the variable table; edit a copy and load it\n# through the `parameter_file` parameter, or set values individually).\n",
        info.model_identifier, info.version
    );
    for var in M::Var::TABLE.iter().filter(|v| v.causality == Causality::Parameter) {
        let (value, unit) = match var.kind {
            Kind::Real { start, unit, .. } => (crate::xml::format_real(start.unwrap_or(0.0)), unit.to_string()),
            Kind::Integer { start, .. } => (start.unwrap_or(0).to_string(), String::new()),
            Kind::Enumeration { declared_type, start } => {
                (format!("\"{}\"", declared_type.name_of(start.unwrap_or(1)).unwrap_or("?")), String::new())
            }
            Kind::Boolean { start } => (start.unwrap_or(false).to_string(), String::new()),
            Kind::String { start } => {
                (format!("\"{}\"", start.unwrap_or("").replace('\\', "\\\\").replace('"', "\\\"")), String::new())
            }
        };
        // A parameter file may not set the file-loading parameter itself.
        if var.name == "parameter_file" {
            continue;
        }
        let unit = if unit.is_empty() || unit == "1" { String::new() } else { format!("[{unit}] ") };
        out.push_str(&format!("{} = {}  # {}{}\n", var.name, value, unit, var.description));
    }
    out
}
