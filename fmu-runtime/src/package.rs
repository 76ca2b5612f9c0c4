//! Describes each FMU a model crate ships and writes `.fmu` archives deterministically.
//!
//! A model crate lists its FMUs as [`FmuSpec`]s; the packaging tool builds the shared library
//! and calls [`write_fmu`]. The archive is byte-for-byte reproducible: entries are sorted, every
//! timestamp is 1980-01-01 00:00 (the zip epoch), permissions are fixed, and nothing about the
//! build machine (paths, user, clock) goes in.

use std::io::Write;
use std::path::Path;

use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, DateTime, ZipWriter};

use crate::model::Model;
use crate::variables::{Causality, Kind, VariableSet};

/// One FMU of a model crate.
#[derive(Clone, Copy)]
pub struct FmuSpec {
    pub model_identifier: &'static str,
    /// The cargo library name whose `lib<name>.so` is the binary (several FMUs may share one).
    pub library_name: &'static str,
    pub model_description: fn() -> String,
    pub validate: fn() -> Result<(), String>,
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

/// Writes one `.fmu`: `modelDescription.xml`, `binaries/linux64/<id>.so` and the resources.
pub fn write_fmu(spec: &FmuSpec, shared_library: &Path, output: &Path) -> Result<(), String> {
    (spec.validate)().map_err(|e| format!("{}: invalid variable table: {e}", spec.model_identifier))?;
    let binary = std::fs::read(shared_library).map_err(|e| format!("cannot read {}: {e}", shared_library.display()))?;
    let mut entries: Vec<(String, Vec<u8>, u32)> = vec![
        ("modelDescription.xml".to_string(), (spec.model_description)().into_bytes(), 0o644),
        (format!("binaries/linux64/{}.so", spec.model_identifier), binary, 0o755),
    ];
    for (path, bytes) in (spec.resources)() {
        if path.contains("..") || path.starts_with('/') {
            return Err(format!("resource path '{path}' must be relative and stay inside resources/"));
        }
        entries.push((format!("resources/{path}"), bytes, 0o644));
    }
    entries.sort_by(|a, b| a.0.cmp(&b.0));
    let file = std::fs::File::create(output).map_err(|e| format!("cannot create {}: {e}", output.display()))?;
    let mut zip = ZipWriter::new(file);
    for (path, bytes, mode) in entries {
        let options = SimpleFileOptions::default()
            .compression_method(CompressionMethod::Deflated)
            .compression_level(Some(6))
            .last_modified_time(DateTime::default())
            .unix_permissions(mode);
        zip.start_file(path.as_str(), options).map_err(|e| format!("zip: {e}"))?;
        zip.write_all(&bytes).map_err(|e| format!("zip: {e}"))?;
    }
    zip.finish().map_err(|e| format!("zip: {e}"))?;
    Ok(())
}
