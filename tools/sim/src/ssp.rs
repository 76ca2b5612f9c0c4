//! The coupled antenna as SSP 1.0 archives (System Structure and Parameterization, `.ssp`), for
//! co-simulation engines other than ours: `SystemStructure.ssd` with the six FMUs as components
//! (`resources/<Name>.fmu`) and the connections exactly as the Rust master makes them
//! (`coupled.rs`), each component's parameters as an SSV parameter set (`resources/<Name>.ssv`,
//! with the units the FMU declares), and the step in an annotation that OSP's engines read.
//!
//! What the Rust master sets before a run is read back from an antenna it builds for the
//! scenario, so the archive holds the very values the master uses: its overrides, the start
//! pose, the loads the structure starts under and the plants' load inertias less what the
//! structure's modes carry. The command is the controllers' start values (`command.position`,
//! `command.velocity`): the whole command of a hold; any other goes with its table in
//! `resources/commands.csv`, and the engine's user sets those four inputs from it at every step,
//! since SSP 1.0 defines no signal source (and libcosim and ecos refuse connections to a
//! system's own connectors, the standard's way to leave inputs open). The archive without the
//! controllers is the plant for a controller of one's own: its motor current commands are left
//! unconnected, for that controller's outputs.
//!
//! The archive is written deterministically (entries sorted, fixed timestamps): the same
//! scenario and FMUs give the same bytes.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, Event};
use quick_xml::Writer;
use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, DateTime, ZipWriter};

use fmu_import::{AttributeError, DescriptionError, Fmu, ImportError, Instance, ModelDescription};

use crate::command::CommandTable;
use crate::coupled::{carried_inertia_split, AntennaConfig, CoupledAntenna, CouplingError, FmuSet, ParameterValue};
use crate::scenario::Scenario;

const SSC: &str = "http://ssp-standard.org/SSP1/SystemStructureCommon";
const SSD: &str = "http://ssp-standard.org/SSP1/SystemStructureDescription";
const SSV: &str = "http://ssp-standard.org/SSP1/SystemStructureParameterValues";
const OSP: &str = "http://opensimulationplatform.com/SSP/OSPAnnotations";

/// What can go wrong writing an archive.
#[derive(Debug, thiserror::Error)]
pub enum SspError {
    #[error(transparent)]
    Import(#[from] ImportError),
    #[error(transparent)]
    Coupling(#[from] CouplingError),
    /// An FMU's model description whose unit declarations do not read.
    #[error("{model}: modelDescription.xml: {source}")]
    Description { model: String, source: DescriptionError },
    #[error("{0}")]
    Io(#[from] std::io::Error),
    #[error("cannot write the archive: {0}")]
    Zip(#[from] zip::result::ZipError),
}

/// Which antenna an archive holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Extent {
    /// The whole antenna: plants, controllers, wind and structure.
    Antenna,
    /// The antenna without its controllers: the plant for a controller of one's own.
    Plant,
}

/// A value bound to a component before its initialisation.
#[derive(Debug, Clone, PartialEq)]
struct Binding {
    name: String,
    value: ParameterValue,
}

/// One FMU of the system and what is bound to it.
struct Component<'a> {
    name: &'static str,
    fmu: &'a Fmu,
    bindings: Vec<Binding>,
}

/// One end of a connection: an element and its connector.
type End = (&'static str, String);

/// A connection and the factor its value is multiplied by on the way (`None`: none).
struct Connection {
    from: End,
    to: End,
    factor: Option<f64>,
}

/// The system an archive describes.
struct System<'a> {
    components: Vec<Component<'a>>,
    connections: Vec<Connection>,
}

/// The archive of `scenario` run with `config` (its wind is the scenario's): the bytes of the
/// `.ssp` file. `fmu_dir` holds the packaged FMUs that `fmus` were opened from.
pub fn archive(
    fmus: &FmuSet,
    fmu_dir: &Path,
    config: &AntennaConfig,
    scenario: &Scenario,
    extent: Extent,
) -> Result<Vec<u8>, SspError> {
    let config = AntennaConfig { wind: scenario.wind.clone(), ..config.clone() };
    let system = system(fmus, &config, &scenario.table, extent)?;
    let mut entries: BTreeMap<String, Vec<u8>> = BTreeMap::new();
    let (start_s, _) = scenario.table.time_span();
    let name = system_name(&scenario.name, extent);
    entries
        .insert("SystemStructure.ssd".into(), ssd_text(&system, &name, start_s, scenario.end_s, config.step_s)?.into());
    for component in &system.components {
        let fmu_path = fmu_dir.join(format!("{}.fmu", component.name));
        entries.insert(format!("resources/{}.fmu", component.name), std::fs::read(&fmu_path)?);
        entries.insert(format!("resources/{}.ssv", component.name), ssv_text(component, &name)?.into());
    }
    // SSP 1.0 has no signal source: a command that changes goes with the table that gives it.
    if extent == Extent::Antenna && !constant_command(&scenario.table) {
        entries.insert("resources/commands.csv".into(), scenario.table.to_csv().into());
    }
    zip_deterministically(&entries)
}

/// The name of the archive's system description and of its parameter sets: the scenario's, as an
/// identifier (`hold-el45-normal-wind` gives `hold_el45_normal_wind`), since OMSimulator takes it
/// for the name of the model, which must be one; `_plant` added for the antenna without its
/// controllers.
pub fn system_name(scenario: &str, extent: Extent) -> String {
    let mut name: String = scenario.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '_' }).collect();
    if !name.starts_with(|c: char| c.is_ascii_alphabetic()) {
        name.insert(0, 's');
    }
    match extent {
        Extent::Antenna => name,
        Extent::Plant => name + "_plant",
    }
}

/// The archive's entries as a zip: sorted by name, each with the zip format's earliest time, so
/// that the same entries give the same bytes.
fn zip_deterministically(entries: &BTreeMap<String, Vec<u8>>) -> Result<Vec<u8>, SspError> {
    let mut zip = ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options = SimpleFileOptions::default().last_modified_time(DateTime::default()).unix_permissions(0o644);
    for (name, bytes) in entries {
        // The FMUs are zips already: stored as they are, they are not compressed twice.
        let method = if name.ends_with(".fmu") { CompressionMethod::Stored } else { CompressionMethod::Deflated };
        zip.start_file(name.as_str(), options.compression_method(method))?;
        zip.write_all(bytes)?;
    }
    Ok(zip.finish()?.into_inner())
}

/// Whether the command of `table` is constant over the run (positions and rates).
fn constant_command(table: &CommandTable) -> bool {
    let points = table.points();
    points.iter().all(|p| p.azimuth_deg == points[0].azimuth_deg && p.elevation_deg == points[0].elevation_deg)
}

/// The components, their bindings and the connections of the antenna as the Rust master couples
/// it for `config` and `table`.
fn system<'a>(
    fmus: &'a FmuSet,
    config: &AntennaConfig,
    table: &CommandTable,
    extent: Extent,
) -> Result<System<'a>, SspError> {
    let mut antenna = CoupledAntenna::new(fmus, config, table)?;
    let start = table.at(table.time_span().0);
    let structure_feedback = config.structure.is_some() && config.structure_feedback;
    let carried = match antenna.structure.as_mut() {
        Some(structure) if structure_feedback => modal_inertias(structure, &fmus.structure.description)?,
        _ => [[0.0; 2]; 2],
    };
    let carried_names = |axis: usize| -> Result<Vec<String>, CouplingError> {
        Ok(carried_inertia_split(axis, carried[0][axis], carried[1][axis])?
            .into_iter()
            .map(|(name, _)| name.to_string())
            .collect())
    };
    let names = |set: &[(String, ParameterValue)]| set.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    let mut components = Vec::new();
    let mut wanted = vec!["initial_position".to_string(), "elevation".to_string()];
    wanted.extend(names(&config.azimuth_plant));
    wanted.extend(carried_names(0)?);
    let bindings =
        read_back(&mut antenna.azimuth_plant, &fmus.azimuth_plant.description, &wanted, &config.azimuth_plant)?;
    components.push(Component { name: "AzimuthPlant", fmu: &fmus.azimuth_plant, bindings });
    let mut wanted = vec!["initial_position".to_string()];
    wanted.extend(names(&config.elevation_plant));
    wanted.extend(carried_names(1)?);
    let bindings =
        read_back(&mut antenna.elevation_plant, &fmus.elevation_plant.description, &wanted, &config.elevation_plant)?;
    components.push(Component { name: "ElevationPlant", fmu: &fmus.elevation_plant, bindings });
    if extent == Extent::Antenna {
        for (name, fmu, instance, overrides, command) in [
            (
                "AzimuthController",
                &fmus.azimuth_controller,
                &mut antenna.azimuth_controller,
                &config.azimuth_controller,
                (start.azimuth_deg, start.azimuth_rate_deg_per_s),
            ),
            (
                "ElevationController",
                &fmus.elevation_controller,
                &mut antenna.elevation_controller,
                &config.elevation_controller,
                (start.elevation_deg, start.elevation_rate_deg_per_s),
            ),
        ] {
            let mut wanted = vec!["command.position".to_string(), "measured.position".to_string()];
            wanted.extend(names(overrides));
            let mut bindings = read_back(instance, &fmu.description, &wanted, overrides)?;
            // The master sets the command at every step: its value at the start is the start
            // value, the whole command of a hold.
            set_binding(&mut bindings, "command.position", ParameterValue::Real(command.0));
            set_binding(&mut bindings, "command.velocity", ParameterValue::Real(command.1));
            components.push(Component { name, fmu, bindings });
        }
    }
    let mut wanted = ["wind.mean_speed", "wind.roughness_length", "wind.direction", "seed", "spectrum"]
        .into_iter()
        .chain(["antenna.azimuth", "antenna.elevation"])
        .map(str::to_string)
        .collect::<Vec<_>>();
    wanted.extend(names(&config.wind_unit));
    let bindings = read_back(&mut antenna.wind, &fmus.wind.description, &wanted, &config.wind_unit)?;
    components.push(Component { name: "Wind", fmu: &fmus.wind, bindings });
    let mut takes = Vec::new();
    if let (Some(overrides), Some(structure)) = (&config.structure, antenna.structure.as_mut()) {
        let description = &fmus.structure.description;
        let mut wanted = names(overrides);
        wanted.extend(structure_start_inputs(&fmus.wind.description, description));
        let bindings = read_back(structure, description, &wanted, overrides)?;
        components.push(Component { name: "Structure", fmu: &fmus.structure, bindings });
        takes = structure_inputs_taken(structure, &fmus.wind.description, description)?;
    }
    let wind_factor = if config.wind.mean_speed_m_s <= 0.0 { 0.0 } else { config.wind_load_scale };
    let connections = connections(extent, &takes, structure_feedback, wind_factor);
    Ok(System { components, connections })
}

/// Puts `value` for `name` in `bindings`, in place of any value it had.
fn set_binding(bindings: &mut Vec<Binding>, name: &str, value: ParameterValue) {
    bindings.retain(|b| b.name != name);
    bindings.push(Binding { name: name.to_string(), value });
}

/// The inertia the structure's modes carry about azimuth and elevation at the zenith (`[0]`) and
/// the horizon (`[1]`), as the Rust master reads them.
fn modal_inertias(structure: &mut Instance, description: &ModelDescription) -> Result<[[f64; 2]; 2], ImportError> {
    let mut carried = [[0.0; 2]; 2];
    let zenith = [description.vr("modal_inertia.azimuth")?, description.vr("modal_inertia.elevation")?];
    structure.get_real(&zenith, &mut carried[0])?;
    carried[1] = carried[0];
    if let (Ok(az), Ok(el)) =
        (description.vr("modal_inertia.azimuth_horizon"), description.vr("modal_inertia.elevation_horizon"))
    {
        structure.get_real(&[az, el], &mut carried[1])?;
    }
    Ok(carried)
}

/// The structure inputs the Rust master gives a start value: the wind's loads (those both
/// units have) and the elevation.
fn structure_start_inputs(wind: &ModelDescription, structure: &ModelDescription) -> Vec<String> {
    let mut inputs: Vec<String> = ["torque.azimuth", "torque.elevation", "force.dish"].map(String::from).to_vec();
    for (output, input) in &WIND_FORCES[1..] {
        if wind.vr(output).is_ok() && structure.vr(input).is_ok() {
            inputs.push(input.to_string());
        }
    }
    if structure.vr("axis.elevation").is_ok() {
        inputs.push("axis.elevation".into());
    }
    inputs
}

/// The wind unit's forces, each with the structure input it drives (`coupled.rs`'s table).
const WIND_FORCES: [(&str, &str); 4] = [
    ("force.drag", "force.dish"),
    ("force.axial", "force.axial"),
    ("force.lateral", "force.lateral"),
    ("force.lift", "force.lift"),
];

/// Where a structure input comes from.
#[derive(Debug, Clone, PartialEq)]
enum Source {
    /// A wind unit output, scaled by the load scale.
    Wind(&'static str),
    /// A plant output, unscaled.
    Plant(&'static str, &'static str),
}

/// The structure inputs the Rust master sends at every step, with their sources: those the
/// structure has and takes (its `takes.<input>` calculated parameters; one without takes all).
fn structure_inputs_taken(
    structure: &mut Instance,
    wind: &ModelDescription,
    description: &ModelDescription,
) -> Result<Vec<(&'static str, Source)>, ImportError> {
    let mut inputs = vec![
        ("torque.azimuth", Source::Wind("torque.azimuth")),
        ("torque.elevation", Source::Wind("torque.elevation")),
        ("force.dish", Source::Wind("force.drag")),
    ];
    if description.vr("axis.azimuth_speed").is_ok() && description.vr("axis.elevation_speed").is_ok() {
        inputs.push(("axis.azimuth_speed", Source::Plant("AzimuthPlant", "axis.speed")));
        inputs.push(("axis.elevation_speed", Source::Plant("ElevationPlant", "axis.speed")));
    }
    if description.vr("axis.elevation").is_ok() {
        inputs.push(("axis.elevation", Source::Plant("ElevationPlant", "axis.position")));
    }
    for (output, input) in &WIND_FORCES[1..] {
        if wind.vr(output).is_ok() && description.vr(input).is_ok() {
            inputs.push((input, Source::Wind(output)));
        }
    }
    let mut taken = Vec::new();
    for (input, source) in inputs {
        let takes = match description.vr(&format!("takes.{input}")) {
            Ok(vr) => {
                let mut value = [true];
                structure.get_boolean(&[vr], &mut value)?;
                value[0]
            }
            Err(_) => true,
        };
        if takes {
            taken.push((input, source));
        }
    }
    Ok(taken)
}

/// The connections of the Rust master (`coupled.rs`): the axes' positions to the wind unit and
/// the elevation to the azimuth plant; the controllers' current commands to the plants and the
/// encoders and motor speeds back (none without controllers); the
/// wind's loads, scaled by `wind_factor`, to the structure and, where its modes push back on
/// the drives (`structure_feedback`), the structure's drive torques to the plants, else the
/// wind's torques. `structure_inputs` is empty without a structure.
fn connections(
    extent: Extent,
    structure_inputs: &[(&'static str, Source)],
    structure_feedback: bool,
    wind_factor: f64,
) -> Vec<Connection> {
    let element = |e: &'static str, c: &str| (e, c.to_string());
    let plain = |from: End, to: End| Connection { from, to, factor: None };
    let scaled = |from: End, to: End| Connection { from, to, factor: (wind_factor != 1.0).then_some(wind_factor) };
    let mut out = vec![
        plain(element("AzimuthPlant", "axis.position"), element("Wind", "antenna.azimuth")),
        plain(element("ElevationPlant", "axis.position"), element("Wind", "antenna.elevation")),
        plain(element("ElevationPlant", "axis.position"), element("AzimuthPlant", "elevation")),
    ];
    let controller_links = [
        ("AzimuthController", "motor1.current_command", "AzimuthPlant", "motor1.current_command"),
        ("AzimuthController", "motor2.current_command", "AzimuthPlant", "motor2.current_command"),
        ("ElevationController", "motor.current_command", "ElevationPlant", "motor.current_command"),
    ];
    let measurement_links = [
        ("AzimuthPlant", "axis.encoder_position", "AzimuthController", "measured.position"),
        ("AzimuthPlant", "motor1.speed", "AzimuthController", "measured.motor1_speed"),
        ("AzimuthPlant", "motor2.speed", "AzimuthController", "measured.motor2_speed"),
        ("ElevationPlant", "axis.encoder_position", "ElevationController", "measured.position"),
        ("ElevationPlant", "motor.speed", "ElevationController", "measured.motor_speed"),
    ];
    if extent == Extent::Antenna {
        for (a, x, b, y) in controller_links.iter().chain(&measurement_links) {
            out.push(plain(element(a, x), element(b, y)));
        }
    }
    for (input, source) in structure_inputs {
        match source {
            Source::Wind(output) => out.push(scaled(element("Wind", output), element("Structure", input))),
            Source::Plant(plant, output) => out.push(plain(element(plant, output), element("Structure", input))),
        }
    }
    let drives = [("azimuth", "AzimuthPlant"), ("elevation", "ElevationPlant")];
    for (axis, plant) in drives {
        let to = element(plant, "load.disturbance_torque");
        if structure_feedback {
            out.push(plain(element("Structure", &format!("drive_torque.{axis}")), to));
        } else {
            out.push(scaled(element("Wind", &format!("torque.{axis}")), to));
        }
    }
    out
}

/// The values of the variables `names` (first mention kept, repeats dropped) as the instance
/// holds them after its initialisation, which are what the Rust master set; strings, which an
/// FMU may hold differently, come from `overrides`.
fn read_back(
    instance: &mut Instance,
    description: &ModelDescription,
    names: &[String],
    overrides: &[(String, ParameterValue)],
) -> Result<Vec<Binding>, ImportError> {
    let mut bindings: Vec<Binding> = Vec::new();
    for name in names {
        if bindings.iter().any(|b| &b.name == name) {
            continue;
        }
        let variable = description.variable(name)?;
        let vr = [variable.value_reference];
        let value = match variable.type_name.as_str() {
            "Real" => {
                let mut v = [0.0];
                instance.get_real(&vr, &mut v)?;
                ParameterValue::Real(v[0])
            }
            "Integer" | "Enumeration" => {
                let mut v = [0];
                instance.get_integer(&vr, &mut v)?;
                ParameterValue::Integer(v[0])
            }
            "Boolean" => {
                let mut v = [false];
                instance.get_boolean(&vr, &mut v)?;
                ParameterValue::Boolean(v[0])
            }
            _ => match overrides.iter().rev().find(|(n, _)| n == name) {
                Some((_, value)) => value.clone(),
                None => ParameterValue::Text(instance.get_string(&vr)?.remove(0)),
            },
        };
        // Engines that ignore enumerations (libcosim, ecos) would lose this setting: where the
        // FMU offers the same choice as an Integer, `<name>_number`, it is bound too.
        let twin = format!("{name}_number");
        if variable.type_name == "Enumeration" && description.variable(&twin).is_ok_and(|t| t.type_name == "Integer") {
            bindings.push(Binding { name: twin, value: value.clone() });
        }
        bindings.push(Binding { name: name.clone(), value });
    }
    Ok(bindings)
}

/// What an FMU's model description declares beyond its variables: its units, with the attributes
/// of their `BaseUnit`.
#[derive(Debug, Default)]
struct Declarations {
    units: BTreeMap<String, Vec<(String, String)>>,
}

/// Reads the declarations of the FMU unpacked in `fmu.directory`.
fn declarations(fmu: &Fmu) -> Result<Declarations, SspError> {
    let text = std::fs::read_to_string(fmu.directory.join("modelDescription.xml"))?;
    let bad = |source: DescriptionError| SspError::Description { model: fmu.description.model_name.clone(), source };
    let mut reader = quick_xml::Reader::from_str(&text);
    let mut out = Declarations::default();
    // The unit being read.
    let mut unit = String::new();
    loop {
        let event = reader
            .read_event()
            .map_err(|source| bad(DescriptionError::Xml { position: reader.buffer_position(), source }))?;
        let element = match &event {
            Event::Start(e) | Event::Empty(e) => e.clone(),
            Event::Eof => break,
            _ => continue,
        };
        let mut attributes = Vec::new();
        for attribute in element.attributes() {
            let attribute = attribute.map_err(|e| bad(AttributeError::Syntax(e).into()))?;
            let value = attribute
                .normalized_value(quick_xml::XmlVersion::Explicit1_0)
                .map_err(|e| bad(AttributeError::Value(e).into()))?
                .to_string();
            attributes.push((attribute.key.into_inner().to_string(), value));
        }
        let get = |key: &str| attributes.iter().find(|(k, _)| k == key).map(|(_, v)| v.clone()).unwrap_or_default();
        match element.name().into_inner() {
            "Unit" => unit = get("name"),
            "BaseUnit" => {
                out.units.insert(unit.clone(), attributes.clone());
            }
            _ => {}
        }
    }
    Ok(out)
}

/// An f64 as XML Schema's `xs:double` reads it back exactly (Rust's shortest round-trip form).
fn xml_double(x: f64) -> String {
    match x {
        f64::INFINITY => "INF".into(),
        f64::NEG_INFINITY => "-INF".into(),
        _ if x.is_nan() => "NaN".into(),
        _ => format!("{x:?}"),
    }
}

/// How a value is written in an SSV parameter set: the name of the parameter, the element
/// (`Real`, `Integer`, `Boolean` or `String`) and its attributes. The one place that decides how
/// each FMU variable is given its value, so that another route (an Integer alias of an
/// enumeration, for engines that ignore enumerations) changes only here.
///
/// An enumeration's value goes as the integer it is (FMI 2.0 sets enumerations with
/// `fmi2SetInteger`), under its own name, not as an `ssv:Enumeration` item: libcosim aborts on
/// those, and libcosim and ecos ignore enumeration variables whatever the value's form.
fn ssv_parameter(
    variable: &fmu_import::ScalarVariable,
    value: &ParameterValue,
) -> (String, &'static str, Vec<(&'static str, String)>) {
    let (kind, attributes) = match value {
        ParameterValue::Real(x) => {
            let mut attributes = vec![("value", xml_double(*x))];
            if let Some(unit) = &variable.unit {
                attributes.push(("unit", unit.clone()));
            }
            ("Real", attributes)
        }
        ParameterValue::Integer(i) => ("Integer", vec![("value", i.to_string())]),
        ParameterValue::Boolean(b) => ("Boolean", vec![("value", b.to_string())]),
        ParameterValue::Text(t) => ("String", vec![("value", t.clone())]),
    };
    (variable.name.clone(), kind, attributes)
}

type XmlWriter = Writer<Vec<u8>>;

fn start(w: &mut XmlWriter, name: &str, attributes: &[(&str, &str)]) -> Result<(), SspError> {
    let mut element = BytesStart::new(name);
    element.extend_attributes(attributes.iter().copied());
    w.write_event(Event::Start(element))?;
    Ok(())
}

fn empty(w: &mut XmlWriter, name: &str, attributes: &[(&str, &str)]) -> Result<(), SspError> {
    let mut element = BytesStart::new(name);
    element.extend_attributes(attributes.iter().copied());
    w.write_event(Event::Empty(element))?;
    Ok(())
}

fn end(w: &mut XmlWriter, name: &str) -> Result<(), SspError> {
    w.write_event(Event::End(BytesEnd::new(name)))?;
    Ok(())
}

fn new_document() -> Result<XmlWriter, SspError> {
    let mut w = Writer::new_with_indent(Vec::new(), b' ', 2);
    w.write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))?;
    Ok(w)
}

fn finish(w: XmlWriter) -> String {
    let mut text = String::from_utf8(w.into_inner()).expect("the writer emits UTF-8");
    text.push('\n');
    text
}

/// The units (`prefix`: `ssc`) named in `used`, as the FMUs declare them.
fn write_units(
    w: &mut XmlWriter,
    element: &str,
    used: &BTreeMap<String, Vec<(String, String)>>,
) -> Result<(), SspError> {
    if used.is_empty() {
        return Ok(());
    }
    start(w, element, &[])?;
    for (name, base) in used {
        start(w, "ssc:Unit", &[("name", name)])?;
        let attributes: Vec<(&str, &str)> = base.iter().map(|(k, v)| (k.as_str(), v.as_str())).collect();
        empty(w, "ssc:BaseUnit", &attributes)?;
        end(w, "ssc:Unit")?;
    }
    end(w, element)
}

/// A component's parameter set, named `set_name`: every binding with its unit, and the units
/// they use. Every component's set has the same name, the archive's: ecos
/// applies the sets of one name to all components at once (libcosim the first set of each).
fn ssv_text(component: &Component, set_name: &str) -> Result<String, SspError> {
    let declarations = declarations(component.fmu)?;
    let description = &component.fmu.description;
    let mut w = new_document()?;
    start(
        &mut w,
        "ssv:ParameterSet",
        &[("xmlns:ssc", SSC), ("xmlns:ssv", SSV), ("version", "1.0"), ("name", set_name)],
    )?;
    start(&mut w, "ssv:Parameters", &[])?;
    let mut units = BTreeMap::new();
    for binding in &component.bindings {
        let variable = description.variable(&binding.name)?;
        let (name, kind, attributes) = ssv_parameter(variable, &binding.value);
        start(&mut w, "ssv:Parameter", &[("name", &name)])?;
        let attributes: Vec<(&str, &str)> = attributes.iter().map(|(k, v)| (*k, v.as_str())).collect();
        empty(&mut w, &format!("ssv:{kind}"), &attributes)?;
        end(&mut w, "ssv:Parameter")?;
        for (_, unit) in attributes.iter().filter(|(key, _)| *key == "unit") {
            units.insert(unit.to_string(), declarations.units.get(*unit).cloned().unwrap_or_default());
        }
    }
    end(&mut w, "ssv:Parameters")?;
    write_units(&mut w, "ssv:Units", &units)?;
    end(&mut w, "ssv:ParameterSet")?;
    Ok(finish(w))
}

/// The kind of connector an FMU variable is in SSP's terms.
fn connector_kind(variable: &fmu_import::ScalarVariable) -> &'static str {
    match variable.causality.as_str() {
        "input" => "input",
        "output" => "output",
        "calculatedParameter" => "calculatedParameter",
        _ => "parameter",
    }
}

/// A connector with its type (and unit) for a variable that is no enumeration.
fn write_connector(
    w: &mut XmlWriter,
    name: &str,
    kind: &str,
    variable: &fmu_import::ScalarVariable,
    declarations: &Declarations,
    units: &mut BTreeMap<String, Vec<(String, String)>>,
) -> Result<(), SspError> {
    start(w, "ssd:Connector", &[("name", name), ("kind", kind)])?;
    match variable.type_name.as_str() {
        "Real" => match &variable.unit {
            Some(unit) => {
                empty(w, "ssc:Real", &[("unit", unit)])?;
                units.insert(unit.clone(), declarations.units.get(unit).cloned().unwrap_or_default());
            }
            None => empty(w, "ssc:Real", &[])?,
        },
        other => empty(w, &format!("ssc:{other}"), &[])?,
    }
    end(w, "ssd:Connector")
}

/// `SystemStructure.ssd`: the system `name` with its components, their connectors, parameter
/// bindings and connections, the units used, and the run's start, end and step.
fn ssd_text(system: &System, name: &str, start_s: f64, end_s: f64, step_s: f64) -> Result<String, SspError> {
    let mut w = new_document()?;
    start(
        &mut w,
        "ssd:SystemStructureDescription",
        &[
            ("xmlns:ssc", SSC),
            ("xmlns:ssd", SSD),
            ("xmlns:ssv", SSV),
            ("xmlns:osp", OSP),
            ("version", "1.0"),
            ("name", name),
            ("generationTool", "antenna --ssp (antenna-sim)"),
        ],
    )?;
    start(&mut w, "ssd:System", &[("name", "antenna")])?;
    let mut units = BTreeMap::new();
    let mut all_declarations = BTreeMap::new();
    for component in &system.components {
        all_declarations.insert(component.name, declarations(component.fmu)?);
    }
    start(&mut w, "ssd:Elements", &[])?;
    for component in &system.components {
        let source = format!("resources/{}.fmu", component.name);
        start(
            &mut w,
            "ssd:Component",
            &[("name", component.name), ("type", "application/x-fmu-sharedlibrary"), ("source", &source)],
        )?;
        // Every input and output is a connector, connected or not (the plant's open current
        // commands among them), and every variable bound, in the FMU's order; but no
        // enumeration: libcosim aborts on an enumeration connector (while the standard lets a
        // binding name a variable without one).
        let used = |v: &fmu_import::ScalarVariable| {
            matches!(v.causality.as_str(), "input" | "output") || component.bindings.iter().any(|b| b.name == v.name)
        };
        start(&mut w, "ssd:Connectors", &[])?;
        for variable in component.fmu.description.variables.iter().filter(|v| used(v) && v.type_name != "Enumeration") {
            let declarations = &all_declarations[component.name];
            write_connector(&mut w, &variable.name, connector_kind(variable), variable, declarations, &mut units)?;
        }
        end(&mut w, "ssd:Connectors")?;
        start(&mut w, "ssd:ParameterBindings", &[])?;
        empty(&mut w, "ssd:ParameterBinding", &[("source", &format!("resources/{}.ssv", component.name))])?;
        end(&mut w, "ssd:ParameterBindings")?;
        end(&mut w, "ssd:Component")?;
    }
    end(&mut w, "ssd:Elements")?;
    start(&mut w, "ssd:Connections", &[])?;
    for connection in &system.connections {
        let mut attributes = Vec::new();
        attributes.push(("startElement", connection.from.0));
        attributes.push(("startConnector", connection.from.1.as_str()));
        attributes.push(("endElement", connection.to.0));
        attributes.push(("endConnector", connection.to.1.as_str()));
        match connection.factor {
            Some(factor) => {
                start(&mut w, "ssd:Connection", &attributes)?;
                empty(&mut w, "ssc:LinearTransformation", &[("factor", &xml_double(factor)), ("offset", "0")])?;
                end(&mut w, "ssd:Connection")?;
            }
            None => empty(&mut w, "ssd:Connection", &attributes)?,
        }
    }
    end(&mut w, "ssd:Connections")?;
    end(&mut w, "ssd:System")?;
    write_units(&mut w, "ssd:Units", &units)?;
    write_default_experiment(&mut w, start_s, end_s, step_s)?;
    end(&mut w, "ssd:SystemStructureDescription")?;
    Ok(finish(w))
}

/// The run's start and end and, in an annotation, its step.
fn write_default_experiment(w: &mut XmlWriter, start_s: f64, end_s: f64, step_s: f64) -> Result<(), SspError> {
    start(w, "ssd:DefaultExperiment", &[("startTime", &xml_double(start_s)), ("stopTime", &xml_double(end_s))])?;
    // SSP 1.0 leaves the step to the engine; OSP's engines (libcosim, ecos) read it here, and
    // libcosim only where the OSP namespace is declared on the root element.
    start(w, "ssd:Annotations", &[])?;
    start(w, "ssc:Annotation", &[("type", "com.opensimulationplatform")])?;
    start(w, "osp:Algorithm", &[])?;
    empty(w, "osp:FixedStepAlgorithm", &[("baseStepSize", &xml_double(step_s))])?;
    end(w, "osp:Algorithm")?;
    end(w, "ssc:Annotation")?;
    end(w, "ssd:Annotations")?;
    end(w, "ssd:DefaultExperiment")?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ends(connections: &[Connection]) -> Vec<(String, String)> {
        let show = |(element, connector): &End| format!("{element}.{connector}");
        connections.iter().map(|c| (show(&c.from), show(&c.to))).collect()
    }

    #[test]
    fn the_plant_archive_has_no_controller_and_leaves_the_current_commands_open() {
        let inputs = [("torque.azimuth", Source::Wind("torque.azimuth"))];
        let plant = ends(&connections(Extent::Plant, &inputs, true, 1.0));
        assert!(plant.iter().all(|(a, b)| !a.contains("Controller") && !b.contains("Controller")), "{plant:?}");
        assert!(plant.iter().all(|(_, b)| !b.ends_with("current_command")), "{plant:?}");
        let antenna = ends(&connections(Extent::Antenna, &inputs, true, 1.0));
        let current = ("AzimuthController.motor1.current_command".into(), "AzimuthPlant.motor1.current_command".into());
        assert!(antenna.contains(&current), "{antenna:?}");
        assert_eq!(antenna.len(), plant.len() + 8);
    }

    #[test]
    fn only_the_winds_loads_are_scaled_and_only_when_the_scale_is_not_one() {
        let inputs = [
            ("torque.azimuth", Source::Wind("torque.azimuth")),
            ("axis.azimuth_speed", Source::Plant("AzimuthPlant", "axis.speed")),
        ];
        let calm = connections(Extent::Antenna, &inputs, false, 0.0);
        let scaled: Vec<_> = calm.iter().filter(|c| c.factor.is_some()).map(|c| c.from.1.clone()).collect();
        assert_eq!(scaled, ["torque.azimuth", "torque.azimuth", "torque.elevation"]);
        assert!(connections(Extent::Antenna, &inputs, false, 1.0).iter().all(|c| c.factor.is_none()));
    }

    #[test]
    fn system_names_are_identifiers() {
        assert_eq!(system_name("track-0.04-el45-normal-wind", Extent::Antenna), "track_0_04_el45_normal_wind");
        assert_eq!(system_name("4deg", Extent::Plant), "s4deg_plant");
    }

    #[test]
    fn doubles_are_written_so_that_they_read_back_exactly() {
        for x in [0.1, 1e-3, 30.0, 4.84813681109536e-6, 1e300, -2.5e-310] {
            assert_eq!(xml_double(x).parse::<f64>(), Ok(x));
        }
        assert_eq!(xml_double(f64::INFINITY), "INF");
    }
}
