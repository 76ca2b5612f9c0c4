//! Generates `modelDescription.xml` from a model's variable table, and the GUID, which is a
//! hash of that description: change anything a master can see and the GUID changes with it.

use std::any::TypeId;
use std::sync::{Mutex, PoisonError};

use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, Event};
use quick_xml::Writer;
use sha2::{Digest, Sha256};

use crate::model::{Model, ModelInfo};
use crate::phase::LOG_CATEGORIES;
use crate::units;
use crate::variables::{Causality, Kind, Var, VariableSet};

/// The name written into `generationTool`.
pub const GENERATION_TOOL: &str = "meerkat-antenna-fmu fmu-runtime";

/// Formats a number so that it reads back to the same `f64` and is a valid `xs:double`.
pub fn format_real(x: f64) -> String {
    let magnitude = x.abs();
    if x == 0.0 || (1e-4..1e15).contains(&magnitude) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

const GUID_PLACEHOLDER: &str = "{00000000-0000-0000-0000-000000000000}";

/// The model description with the GUID filled in.
pub fn model_description<M: Model>() -> String {
    let body = render::<M>(GUID_PLACEHOLDER);
    let guid = guid_of(&body);
    render::<M>(&guid)
}

/// The GUID: the first 128 bits of SHA-256 over the description written with a placeholder
/// GUID, formatted as `{8-4-4-4-12}` hexadecimal digits.
///
/// Written once per model and kept: every instance and every state check needs it (a master
/// that restores a state per window, as `validate` does thousands of times, would otherwise
/// write and hash the whole description each time). A static in a generic function is shared
/// by all its instantiations, hence the key by type: one library serves two models.
pub fn guid<M: Model>() -> String {
    static WRITTEN: Mutex<Vec<(TypeId, String)>> = Mutex::new(Vec::new());
    let model = TypeId::of::<M>();
    let mut written = WRITTEN.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some((_, guid)) = written.iter().find(|(id, _)| *id == model) {
        return guid.clone();
    }
    let guid = guid_of(&render::<M>(GUID_PLACEHOLDER));
    written.push((model, guid.clone()));
    guid
}

fn guid_of(text: &str) -> String {
    let digest = Sha256::digest(text.as_bytes());
    let h: String = digest.iter().take(16).map(|b| format!("{b:02x}")).collect();
    format!("{{{}-{}-{}-{}-{}}}", &h[0..8], &h[8..12], &h[12..16], &h[16..20], &h[20..32])
}

/// Problems a model table can have that a master would trip over; checked by [`validate`].
/// Each names the variable, so that the fix is in that line of the table.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DescriptionError {
    #[error("variable name '{name}' is declared twice")]
    DuplicateName { name: &'static str },
    #[error("variable '{name}' has no description")]
    NoDescription { name: &'static str },
    #[error("variable '{name}' uses unit '{unit}', which is not in units::UNITS")]
    UnknownUnit { name: &'static str, unit: &'static str },
    #[error("variable '{name}' has min {min} > max {max}")]
    EmptyRange { name: &'static str, min: f64, max: f64 },
    #[error("variable '{name}' has its start {start} outside [min, max]")]
    StartOutsideRange { name: &'static str, start: f64 },
    #[error("variable '{name}' ({causality}) needs a start value")]
    MissingStart { name: &'static str, causality: &'static str },
    #[error("variable '{name}' is calculated and must not have a start value")]
    CalculatedWithStart { name: &'static str },
    #[error("'{name}' depends on unknown value reference {vr}")]
    UnknownDependency { name: &'static str, vr: u32 },
    #[error("'{name}' depends on '{target}', which is not an input")]
    DependencyNotInput { name: &'static str, target: &'static str },
    #[error("'{name}' declares dependencies but is not an output")]
    DependenciesOfNonOutput { name: &'static str },
}

/// Checks a model's variable table for the problems of [`DescriptionError`].
pub fn validate<M: Model>() -> Result<(), DescriptionError> {
    let table = M::Var::TABLE;
    let mut names = std::collections::BTreeSet::new();
    for var in table {
        let name = var.name;
        if !names.insert(var.name) {
            return Err(DescriptionError::DuplicateName { name });
        }
        if var.description.is_empty() {
            return Err(DescriptionError::NoDescription { name });
        }
        if let Kind::Real { unit, start, min, max, .. } = var.kind {
            if units::lookup(unit).is_none() {
                return Err(DescriptionError::UnknownUnit { name, unit });
            }
            if let (Some(min), Some(max)) = (min, max) {
                if min > max {
                    return Err(DescriptionError::EmptyRange { name, min, max });
                }
            }
            if let Some(start) = start {
                if min.is_some_and(|lo| start < lo) || max.is_some_and(|hi| start > hi) {
                    return Err(DescriptionError::StartOutsideRange { name, start });
                }
            }
        }
        let needs_start = matches!(var.causality, Causality::Parameter | Causality::Input);
        let has_start = start_attribute(var).is_some();
        if needs_start && !has_start {
            return Err(DescriptionError::MissingStart { name, causality: var.causality.xml_name() });
        }
        if !needs_start && has_start && var.initial == Some(crate::variables::Initial::Calculated) {
            return Err(DescriptionError::CalculatedWithStart { name });
        }
        for &vr in var.depends_on.iter().chain(var.initial_inputs()) {
            let target = table.get(vr as usize).ok_or(DescriptionError::UnknownDependency { name, vr })?;
            if target.causality != Causality::Input {
                return Err(DescriptionError::DependencyNotInput { name, target: target.name });
            }
        }
        if (!var.depends_on.is_empty() || !var.initial_inputs().is_empty()) && var.causality != Causality::Output {
            return Err(DescriptionError::DependenciesOfNonOutput { name });
        }
    }
    Ok(())
}

fn start_attribute(var: &Var) -> Option<String> {
    match var.kind {
        Kind::Real { start, .. } => start.map(format_real),
        Kind::Integer { start, .. } => start.map(|s| s.to_string()),
        Kind::Enumeration { start, .. } => start.map(|s| s.to_string()),
        Kind::Boolean { start } => start.map(|s| s.to_string()),
        Kind::String { start } => start.map(str::to_string),
    }
}

/// The XML writer of a model description.
type XmlWriter = Writer<Vec<u8>>;

fn write(w: &mut XmlWriter, event: Event) {
    w.write_event(event).expect("writing to a Vec cannot fail");
}

fn render<M: Model>(guid: &str) -> String {
    let info = M::info();
    let table = M::Var::TABLE;
    let mut w = Writer::new_with_indent(Vec::new(), b' ', 2);
    write_header(&mut w, &info, guid);
    write_unit_definitions(&mut w, table);
    write_type_definitions(&mut w, table);
    write_log_categories(&mut w);
    write_default_experiment(&mut w, &info);
    write_model_variables(&mut w, table);
    write_model_structure(&mut w, table);
    write(&mut w, Event::End(BytesEnd::new("fmiModelDescription")));
    let mut text = String::from_utf8(w.into_inner()).expect("the writer emits UTF-8");
    text.push('\n');
    text
}

/// The declaration, the root element's attributes and the co-simulation capabilities.
fn write_header(w: &mut XmlWriter, info: &ModelInfo, guid: &str) {
    write(w, Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)));
    let mut root = BytesStart::new("fmiModelDescription");
    root.push_attribute(("fmiVersion", "2.0"));
    root.push_attribute(("modelName", info.model_name));
    root.push_attribute(("guid", guid));
    root.push_attribute(("description", info.description));
    root.push_attribute(("author", info.author));
    root.push_attribute(("version", info.version));
    root.push_attribute(("generationTool", GENERATION_TOOL));
    root.push_attribute(("variableNamingConvention", "structured"));
    root.push_attribute(("numberOfEventIndicators", "0"));
    write(w, Event::Start(root));

    let mut cs = BytesStart::new("CoSimulation");
    for (k, v) in [
        ("modelIdentifier", info.model_identifier),
        ("needsExecutionTool", "false"),
        ("canHandleVariableCommunicationStepSize", "true"),
        ("canInterpolateInputs", "false"),
        ("maxOutputDerivativeOrder", "0"),
        ("canRunAsynchronuously", "false"),
        ("canBeInstantiatedOnlyOncePerProcess", "false"),
        ("canNotUseMemoryManagementFunctions", "true"),
        ("canGetAndSetFMUstate", "true"),
        ("canSerializeFMUstate", "true"),
        ("providesDirectionalDerivative", "false"),
    ] {
        cs.push_attribute((k, v));
    }
    write(w, Event::Empty(cs));
}

/// The units the variables use, in order of first use.
fn write_unit_definitions(w: &mut XmlWriter, table: &[Var]) {
    let mut used: Vec<&str> = Vec::new();
    for var in table {
        if let Some(u) = var.unit() {
            if !used.contains(&u) {
                used.push(u);
            }
        }
    }
    if !used.is_empty() {
        write(w, Event::Start(BytesStart::new("UnitDefinitions")));
        for name in &used {
            let def = units::lookup(name).unwrap_or_else(|| panic!("unit '{name}' is not in units::UNITS"));
            let mut unit = BytesStart::new("Unit");
            unit.push_attribute(("name", def.name));
            write(w, Event::Start(unit));
            let mut base = BytesStart::new("BaseUnit");
            let exponents = [("kg", def.kg), ("m", def.m), ("s", def.s), ("A", def.a), ("rad", def.rad)];
            let exponent_texts: Vec<(&str, String)> =
                exponents.iter().filter(|(_, e)| *e != 0).map(|(k, e)| (*k, e.to_string())).collect();
            for (k, v) in &exponent_texts {
                base.push_attribute((*k, v.as_str()));
            }
            let factor = format_real(def.factor);
            if def.factor != 1.0 {
                base.push_attribute(("factor", factor.as_str()));
            }
            write(w, Event::Empty(base));
            write(w, Event::End(BytesEnd::new("Unit")));
        }
        write(w, Event::End(BytesEnd::new("UnitDefinitions")));
    }
}

/// The enumeration types the variables use, in order of first use.
fn write_type_definitions(w: &mut XmlWriter, table: &[Var]) {
    let mut enums: Vec<&crate::variables::EnumerationType> = Vec::new();
    for var in table {
        if let Kind::Enumeration { declared_type, .. } = var.kind {
            if !enums.iter().any(|e| e.name == declared_type.name) {
                enums.push(declared_type);
            }
        }
    }
    if !enums.is_empty() {
        write(w, Event::Start(BytesStart::new("TypeDefinitions")));
        for e in &enums {
            let mut st = BytesStart::new("SimpleType");
            st.push_attribute(("name", e.name));
            st.push_attribute(("description", e.description));
            write(w, Event::Start(st));
            write(w, Event::Start(BytesStart::new("Enumeration")));
            for (i, (name, description)) in e.items.iter().enumerate() {
                let mut item = BytesStart::new("Item");
                let value = (i + 1).to_string();
                item.push_attribute(("name", *name));
                item.push_attribute(("value", value.as_str()));
                item.push_attribute(("description", *description));
                write(w, Event::Empty(item));
            }
            write(w, Event::End(BytesEnd::new("Enumeration")));
            write(w, Event::End(BytesEnd::new("SimpleType")));
        }
        write(w, Event::End(BytesEnd::new("TypeDefinitions")));
    }
}

fn write_log_categories(w: &mut XmlWriter) {
    write(w, Event::Start(BytesStart::new("LogCategories")));
    for (name, description) in LOG_CATEGORIES {
        let mut cat = BytesStart::new("Category");
        cat.push_attribute(("name", *name));
        cat.push_attribute(("description", *description));
        write(w, Event::Empty(cat));
    }
    write(w, Event::End(BytesEnd::new("LogCategories")));
}

fn write_default_experiment(w: &mut XmlWriter, info: &ModelInfo) {
    let de = info.default_experiment;
    let mut experiment = BytesStart::new("DefaultExperiment");
    let (start, stop, step) = (format_real(de.start_time), format_real(de.stop_time), format_real(de.step_size));
    experiment.push_attribute(("startTime", start.as_str()));
    experiment.push_attribute(("stopTime", stop.as_str()));
    experiment.push_attribute(("stepSize", step.as_str()));
    write(w, Event::Empty(experiment));
}

/// One `ScalarVariable` per variable, in value-reference order.
fn write_model_variables(w: &mut XmlWriter, table: &[Var]) {
    write(w, Event::Start(BytesStart::new("ModelVariables")));
    for (i, var) in table.iter().enumerate() {
        let mut sv = BytesStart::new("ScalarVariable");
        let vr = i.to_string();
        sv.push_attribute(("name", var.name));
        sv.push_attribute(("valueReference", vr.as_str()));
        sv.push_attribute(("description", var.description));
        sv.push_attribute(("causality", var.causality.xml_name()));
        sv.push_attribute(("variability", var.variability.xml_name()));
        if let Some(initial) = var.initial {
            // For parameters "exact" is the default; writing it anyway is valid and explicit.
            sv.push_attribute(("initial", initial.xml_name()));
        }
        write(w, Event::Start(sv));
        write(w, Event::Empty(type_element(var)));
        write(w, Event::End(BytesEnd::new("ScalarVariable")));
    }
    write(w, Event::End(BytesEnd::new("ModelVariables")));
}

/// The type element of a `ScalarVariable` with its attributes.
fn type_element(var: &Var) -> BytesStart<'static> {
    let start = start_attribute(var);
    match var.kind {
        Kind::Real { unit, min, max, nominal, .. } => {
            let mut e = BytesStart::new("Real");
            e.push_attribute(("unit", unit));
            if let Some(s) = &start {
                e.push_attribute(("start", s.as_str()));
            }
            for (k, v) in [("min", min), ("max", max), ("nominal", nominal)] {
                if let Some(v) = v {
                    let text = format_real(v);
                    e.push_attribute((k, text.as_str()));
                }
            }
            e
        }
        Kind::Integer { min, max, .. } => {
            let mut e = BytesStart::new("Integer");
            if let Some(s) = &start {
                e.push_attribute(("start", s.as_str()));
            }
            for (k, v) in [("min", min), ("max", max)] {
                if let Some(v) = v {
                    let text = v.to_string();
                    e.push_attribute((k, text.as_str()));
                }
            }
            e
        }
        Kind::Enumeration { declared_type, .. } => {
            let mut e = BytesStart::new("Enumeration");
            e.push_attribute(("declaredType", declared_type.name));
            if let Some(s) = &start {
                e.push_attribute(("start", s.as_str()));
            }
            e
        }
        Kind::Boolean { .. } => {
            let mut e = BytesStart::new("Boolean");
            if let Some(s) = &start {
                e.push_attribute(("start", s.as_str()));
            }
            e
        }
        Kind::String { .. } => {
            let mut e = BytesStart::new("String");
            if let Some(s) = &start {
                e.push_attribute(("start", s.as_str()));
            }
            e
        }
    }
}

/// Outputs and initial unknowns; indices are 1-based positions in `ModelVariables`.
fn write_model_structure(w: &mut XmlWriter, table: &[Var]) {
    write(w, Event::Start(BytesStart::new("ModelStructure")));
    let outputs: Vec<(usize, &Var)> =
        table.iter().enumerate().filter(|(_, v)| v.causality == Causality::Output).collect();
    if !outputs.is_empty() {
        write(w, Event::Start(BytesStart::new("Outputs")));
        for (i, var) in &outputs {
            write(w, Event::Empty(unknown(*i, var.depends_on, &[])));
        }
        write(w, Event::End(BytesEnd::new("Outputs")));
    }
    let initial_unknowns: Vec<(usize, &Var)> = table
        .iter()
        .enumerate()
        .filter(|(_, v)| {
            v.causality == Causality::CalculatedParameter
                || (v.causality == Causality::Output
                    && matches!(
                        v.initial,
                        Some(crate::variables::Initial::Calculated) | Some(crate::variables::Initial::Approx)
                    ))
        })
        .collect();
    if !initial_unknowns.is_empty() {
        // The knowns of initialisation are the parameters and the inputs. Every initial unknown
        // is declared to depend on every parameter (a conservative statement: a parameter is
        // never connected, so it cannot make a loop) and on exactly the inputs its initial value
        // depends on, so that a master sees no loop that is not there (leaving `dependencies`
        // out would say "depends on all knowns", every input included).
        let parameters: Vec<u32> = table
            .iter()
            .enumerate()
            .filter(|(_, v)| v.causality == Causality::Parameter)
            .map(|(i, _)| i as u32)
            .collect();
        write(w, Event::Start(BytesStart::new("InitialUnknowns")));
        for (i, var) in &initial_unknowns {
            let inputs: &[u32] = if var.causality == Causality::Output { var.initial_inputs() } else { &[] };
            write(w, Event::Empty(unknown(*i, inputs, &parameters)));
        }
        write(w, Event::End(BytesEnd::new("InitialUnknowns")));
    }
    write(w, Event::End(BytesEnd::new("ModelStructure")));
}

/// One `Unknown` of the model structure: its index and the knowns it depends on (0-based
/// positions in the table, written 1-based and in ascending order, as the standard asks).
fn unknown(index: usize, inputs: &[u32], parameters: &[u32]) -> BytesStart<'static> {
    let mut e = BytesStart::new("Unknown");
    e.push_attribute(("index", (index + 1).to_string().as_str()));
    let mut knowns: Vec<u32> = inputs.iter().chain(parameters).copied().collect();
    knowns.sort_unstable();
    knowns.dedup();
    let deps: Vec<String> = knowns.iter().map(|d| (d + 1).to_string()).collect();
    e.push_attribute(("dependencies", deps.join(" ").as_str()));
    if !deps.is_empty() {
        let kinds = vec!["dependent"; deps.len()].join(" ");
        e.push_attribute(("dependenciesKind", kinds.as_str()));
    }
    e
}
