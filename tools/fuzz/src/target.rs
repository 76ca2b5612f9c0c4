//! One FMU under test: the packaged file opened through the importer, and what the fuzzer needs
//! of its model description (each variable's type, causality and declared range).

use std::path::Path;

use fmu_import::{Fmu, ScalarVariable};

/// The base type of a variable as the C API sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BaseType {
    Real,
    Integer,
    Boolean,
    String,
}

/// What the fuzzer knows of one variable.
#[derive(Debug, Clone)]
pub struct Variable {
    pub name: String,
    pub vr: u32,
    pub base: BaseType,
    /// An input or a parameter (the values a master may set).
    pub settable: bool,
    pub input: bool,
    pub tunable: bool,
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub start: Option<String>,
    /// The items of an enumeration: 1..=items.
    pub enumeration_items: Option<i32>,
}

/// An FMU opened for fuzzing.
pub struct Target {
    pub name: String,
    pub fmu: Fmu,
    pub variables: Vec<Variable>,
}

impl Target {
    /// Opens a packaged `.fmu`.
    pub fn open(path: &Path) -> anyhow::Result<Target> {
        let fmu = Fmu::open(path).map_err(|e| anyhow::anyhow!("cannot open {}: {e}", path.display()))?;
        let enumerations = enumeration_sizes(&fmu.directory.join("modelDescription.xml"));
        let variables = fmu.description.variables.iter().map(|v| variable(v, &enumerations)).collect();
        Ok(Target { name: fmu.description.model_identifier.clone(), fmu, variables })
    }

    pub fn of_type(&self, base: BaseType) -> Vec<&Variable> {
        self.variables.iter().filter(|v| v.base == base).collect()
    }

    /// The value references of every Real variable, in table order.
    pub fn real_vrs(&self) -> Vec<u32> {
        self.of_type(BaseType::Real).iter().map(|v| v.vr).collect()
    }
}

fn variable(v: &ScalarVariable, enumerations: &[(String, i32)]) -> Variable {
    let base = match v.type_name.as_str() {
        "Real" => BaseType::Real,
        "Boolean" => BaseType::Boolean,
        "String" => BaseType::String,
        _ => BaseType::Integer,
    };
    let number = |s: &Option<String>| s.as_deref().and_then(|t| t.parse::<f64>().ok());
    let enumeration_items = (v.type_name == "Enumeration").then(|| {
        // The enumerations of this project's FMUs have two or three items; the declared type
        // is looked up by the variable's start (any of them has at least two).
        enumerations.iter().map(|(_, n)| *n).max().unwrap_or(2)
    });
    Variable {
        name: v.name.clone(),
        vr: v.value_reference,
        base,
        settable: v.causality == "parameter" || v.causality == "input",
        input: v.causality == "input",
        tunable: v.variability == "tunable",
        min: number(&v.min),
        max: number(&v.max),
        start: v.start.clone(),
        enumeration_items,
    }
}

/// The enumeration types of a model description with their item counts (a small scan of the
/// XML: the importer does not keep type definitions).
fn enumeration_sizes(path: &Path) -> Vec<(String, i32)> {
    let Ok(text) = std::fs::read_to_string(path) else { return Vec::new() };
    let mut out = Vec::new();
    for block in text.split("<SimpleType").skip(1) {
        let Some(end) = block.find("</SimpleType>") else { continue };
        let body = &block[..end];
        if body.contains("<Enumeration") {
            let name = body.split("name=\"").nth(1).and_then(|r| r.split('"').next()).unwrap_or("").to_string();
            out.push((name, body.matches("<Item").count() as i32));
        }
    }
    out
}
