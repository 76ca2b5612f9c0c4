//! The one table of uncertain parameters (docs/parameters.csv) against the FMUs it describes:
//! every variable it names exists, its start value is the table's `paper` value (the plants'
//! defaults are the paper's model) or its `default` (the wind unit's defaults are the realistic
//! antenna's), its default and range lie within the variable's declared minimum and maximum,
//! and the structure's defaults are the shipped modes file's.

use antenna_fmus::model_description_directory;
use antenna_fmus::parameters::{parameters, Target};
use antenna_sim::configuration::{INERTIA_SHARE, SHARED_INERTIAS};
use fmu_import::ModelDescription;
use fmu_structure::modes::{parse_modes, DEFAULT_MODES, DEFAULT_MODES_FILE};

fn description(model_identifier: &str) -> ModelDescription {
    let path = model_description_directory().join(format!("{model_identifier}.xml"));
    let xml = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    ModelDescription::parse(&xml).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn every_variable_the_table_names_exists_with_the_papers_value_as_its_start_and_the_range_inside_its_bounds() {
    let mut checked = 0;
    for p in parameters() {
        for target in &p.targets {
            let Target::Variable { model_identifier, name } = target else { continue };
            let d = description(model_identifier);
            let v = d.variable(name).unwrap_or_else(|e| panic!("{}: {model_identifier}.{name}: {e}", p.name));
            let start: f64 = v
                .start
                .as_deref()
                .unwrap_or_else(|| panic!("{}: {model_identifier}.{name} has no start value", p.name))
                .parse()
                .unwrap_or_else(|e| panic!("{}: start of {name}: {e}", p.name));
            let paper = p.paper.unwrap_or_else(|| panic!("{}: an FMU variable needs its paper value", p.name));
            assert!(
                start == paper || start == p.default,
                "{}: {model_identifier}.{name} starts at {start}, neither the paper's {paper} nor the default {}",
                p.name,
                p.default
            );
            let bound = |text: &Option<String>| text.as_deref().map(|t| t.parse::<f64>().unwrap());
            let (min, max) = (bound(&v.min), bound(&v.max));
            for value in [p.default, p.low, p.high] {
                assert!(
                    min.is_none_or(|m| value >= m) && max.is_none_or(|m| value <= m),
                    "{}: {value} lies outside {model_identifier}.{name}'s bounds {min:?}..{max:?}",
                    p.name
                );
            }
            checked += 1;
        }
    }
    assert!(checked >= 40, "only {checked} variables checked");
}

#[test]
fn the_structures_defaults_are_the_shipped_modes_files_values() {
    let modes = parse_modes(DEFAULT_MODES, DEFAULT_MODES_FILE).unwrap();
    let mut checked = 0;
    for p in parameters() {
        for target in &p.targets {
            let Target::StructureMode { field } = target else { continue };
            let (mode, name) = field.strip_prefix("mode").and_then(|f| f.split_once('.')).unwrap();
            let index: usize = mode.parse().unwrap();
            if field.ends_with(INERTIA_SHARE) {
                // The share of its axis's inertia that the shipped mode carries: K / w^2 over
                // the default of the inertia it is a share of, to the table's five digits.
                let mode = &modes[index - 1];
                let (_, inertia_name) = SHARED_INERTIAS.iter().find(|(m, _)| field.starts_with(m)).unwrap();
                let inertia = parameters().into_iter().find(|q| q.name == *inertia_name).unwrap().default;
                let carried = mode.stiffness / (mode.omega() * mode.omega());
                assert!(
                    (p.default * inertia / carried - 1.0).abs() < 1e-4,
                    "{}: {} x {inertia} against the shipped mode's {carried} kg m^2",
                    p.name,
                    p.default
                );
                checked += 1;
                continue;
            }
            let shipped = modes[index - 1].field(name).unwrap_or_else(|| panic!("{}: no field {name}", p.name));
            assert_eq!(p.default, shipped, "{}: default against the shipped {field}", p.name);
            assert!(p.paper.is_none(), "{}: the paper's model has no structure", p.name);
            checked += 1;
        }
    }
    assert!(checked >= 6, "only {checked} mode fields checked");
}
