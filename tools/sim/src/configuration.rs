//! The antenna configurations the master runs, built from the one parameter table
//! (`docs/parameters.csv`, read through `antenna_fmus::parameters`): the `paper` configuration
//! (the seed paper's drive-only model: the FMUs' start values, a coherent gust, no structure),
//! the `realistic` default (every parameter at its default: structure, sensors, friction at
//! sidereal rates, aerodynamic admittance), and any point of a sweep.

use std::path::Path;

use antenna_fmus::parameters::{parameters, Scale, Target, UncertainParameter};
use fmu_structure::modes::{parse_modes, write_modes, DEFAULT_MODES, DEFAULT_MODES_FILE};

use super::coupled::{AntennaConfig, Overrides, ParameterValue};
use super::scenario::{wind_direction_deg, Scenario, WIND_YAW_DEG};

/// The plants' sub-step while Stribeck friction is on: one value for the master and the
/// packaged `realistic.params`.
pub use antenna_fmus::parameters::STRIBECK_SUBSTEP_S;

/// A named configuration of the whole antenna.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Configuration {
    /// The paper's model: reproduces the report of the drive-only model.
    Paper,
    /// The realistic antenna: the default.
    Realistic,
}

impl Configuration {
    /// Every parameter of the table with its value in this configuration (`None` where the
    /// paper's model lacks the part).
    pub fn values(self) -> Vec<(UncertainParameter, Option<f64>)> {
        parameters()
            .into_iter()
            .map(|p| {
                // Both configurations keep each scenario's own gust seed; a sweep draws one.
                let keeps_scenario_seed =
                    p.targets.iter().any(|t| matches!(t, Target::Scenario { name } if name == "wind.seed"));
                let value = match self {
                    _ if keeps_scenario_seed => None,
                    Configuration::Paper => p.paper,
                    Configuration::Realistic => Some(p.default),
                };
                (p, value)
            })
            .collect()
    }

    /// [`Configuration::values`] with the parameters named in `set` held at their values.
    pub fn values_with(self, set: &[(String, f64)]) -> Result<Vec<(UncertainParameter, Option<f64>)>, SetupError> {
        let mut values = self.values();
        for (name, value) in set {
            let Some((_, slot)) = values.iter_mut().find(|(p, _)| p.name == *name) else {
                let known: Vec<String> = values.iter().map(|(p, _)| p.name.clone()).collect();
                return Err(SetupError::UnknownParameter { name: name.clone(), known: known.join(", ") });
            };
            *slot = Some(*value);
        }
        Ok(values)
    }

    /// The coupled master's configuration (the wind condition is the scenario's).
    pub fn antenna_config(self) -> AntennaConfig {
        let point = self.values();
        let setup = AntennaSetup::from_values(&point, None).expect("the committed table's values are consistent");
        setup.config
    }

    /// The settings the master applies to a scenario's wind.
    pub fn scenario_settings(self) -> ScenarioSettings {
        let point = self.values();
        AntennaSetup::from_values(&point, None).expect("the committed table's values are consistent").scenario
    }
}

/// The realistic antenna (here rather than beside the type, so that the master's module does
/// not reach back into the configurations built on it).
impl Default for AntennaConfig {
    fn default() -> Self {
        Configuration::Realistic.antenna_config()
    }
}

/// How a point of the table changes a requirement scenario's wind.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScenarioSettings {
    /// Multiplies the condition's mean wind speed.
    pub mean_speed_factor: f64,
    /// Where the wind comes from relative to the antenna's azimuth at the start, deg.
    pub yaw_deg: f64,
    /// Multiplies the condition's roughness length.
    pub roughness_factor: f64,
    /// Replaces the scenario's gust seed.
    pub seed: Option<i32>,
}

impl Default for ScenarioSettings {
    fn default() -> Self {
        ScenarioSettings { mean_speed_factor: 1.0, yaw_deg: WIND_YAW_DEG, roughness_factor: 1.0, seed: None }
    }
}

impl ScenarioSettings {
    /// The scenario with these settings applied to its wind. The defaults leave it unchanged,
    /// to the bit.
    pub fn apply(&self, scenario: &Scenario) -> Scenario {
        let mut scenario = scenario.clone();
        let wind = &mut scenario.wind;
        if wind.mean_speed_m_s > 0.0 {
            // The scenarios' wind comes from WIND_YAW_DEG to the right of the start azimuth.
            let azimuth = wind.direction_deg - WIND_YAW_DEG;
            wind.mean_speed_m_s *= self.mean_speed_factor;
            wind.roughness_length_m *= self.roughness_factor;
            if self.yaw_deg != WIND_YAW_DEG {
                wind.direction_deg = wind_direction_deg(azimuth, self.yaw_deg);
            }
            if let Some(seed) = self.seed {
                wind.seed = seed;
            }
        }
        scenario
    }
}

/// A point of the table turned into what the master needs.
#[derive(Debug, Clone, PartialEq)]
pub struct AntennaSetup {
    pub config: AntennaConfig,
    pub scenario: ScenarioSettings,
}

/// Why a point of the table cannot be set up.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    #[error("`{name}` is not a parameter of docs/parameters.csv; they are: {known}")]
    UnknownParameter { name: String, known: String },
    #[error("{parameter}: target `{target}` is unknown to the master")]
    UnknownTarget { parameter: String, target: String },
    #[error("{parameter}: `{field}` is not a field of mode {mode} of the shipped modes")]
    UnknownModeField { parameter: String, mode: String, field: String },
    #[error("the structure's modes differ from the shipped ones, and no folder was given to write them to")]
    NoFolderForModes,
    #[error("cannot write the modes file {path}")]
    WriteModes { path: String, source: std::io::Error },
}

impl AntennaSetup {
    /// The configuration for `values` (a value for each parameter, `None` where the part is
    /// absent, as the paper's structure). A structure whose modes differ from the shipped file
    /// is written as `structure_modes.params` into `modes_folder`.
    pub fn from_values(
        values: &[(UncertainParameter, Option<f64>)],
        modes_folder: Option<&Path>,
    ) -> Result<AntennaSetup, SetupError> {
        let mut config = AntennaConfig::bare();
        let mut scenario = ScenarioSettings::default();
        let shipped = parse_modes(DEFAULT_MODES, DEFAULT_MODES_FILE).expect("the shipped modes file is valid");
        let mut modes = shipped.clone();
        let mut structure_present = false;
        // The modes' inertia shares (field, default, value): they set the modes' frequencies
        // once the stiffnesses and the axes' inertias are known.
        let mut shares = Vec::new();
        for (parameter, value) in values {
            let Some(value) = *value else { continue };
            for target in &parameter.targets {
                match target {
                    Target::Variable { model_identifier, name } => {
                        let overrides =
                            unit_overrides(&mut config, model_identifier).ok_or_else(|| SetupError::UnknownTarget {
                                parameter: parameter.name.clone(),
                                target: format!("{model_identifier}:{name}"),
                            })?;
                        let value = match parameter.scale {
                            Scale::Integer => ParameterValue::Integer(value as i32),
                            Scale::Linear | Scale::Log | Scale::Circular => ParameterValue::Real(value),
                        };
                        overrides.push((name.clone(), value));
                    }
                    Target::StructureMode { field } if field.ends_with(INERTIA_SHARE) => {
                        structure_present = true;
                        shares.push((field.clone(), parameter.default, value));
                    }
                    Target::StructureMode { field } => {
                        structure_present = true;
                        set_mode_field(&mut modes, &parameter.name, field, value)?;
                    }
                    Target::Scenario { name } => {
                        apply_scenario_setting(&mut config, &mut scenario, &parameter.name, name, value)?
                    }
                }
            }
        }
        for (field, default, share) in shares {
            set_frequency_from_share(&mut modes, &shipped, values, &field, default, share)?;
        }
        if structure_present {
            config.structure = Some(structure_overrides(&modes, &shipped, modes_folder)?);
        }
        // Numerics, not physics: the sub-step only matters where Stribeck friction or
        // position-dependent torques are on, and is set before the parameters so that a
        // sweep's own value would win.
        for plant in [&mut config.azimuth_plant, &mut config.elevation_plant] {
            plant.insert(0, ("numerics.nonlinear_substep".to_string(), ParameterValue::Real(STRIBECK_SUBSTEP_S)));
        }
        Ok(AntennaSetup { config, scenario })
    }
}

fn unit_overrides<'a>(config: &'a mut AntennaConfig, model_identifier: &str) -> Option<&'a mut Overrides> {
    Some(match model_identifier {
        "AzimuthPlant" => &mut config.azimuth_plant,
        "ElevationPlant" => &mut config.elevation_plant,
        "AzimuthController" => &mut config.azimuth_controller,
        "ElevationController" => &mut config.elevation_controller,
        "Wind" => &mut config.wind_unit,
        _ => return None,
    })
}

fn set_mode_field(
    modes: &mut [fmu_structure::modes::Mode],
    parameter: &str,
    field: &str,
    value: f64,
) -> Result<(), SetupError> {
    let unknown = || SetupError::UnknownModeField {
        parameter: parameter.to_string(),
        mode: field.split('.').next().unwrap_or("").to_string(),
        field: field.to_string(),
    };
    let (mode, name) = field.strip_prefix("mode").and_then(|f| f.split_once('.')).ok_or_else(unknown)?;
    let index: usize = mode.parse().map_err(|_| unknown())?;
    let mode = modes.get_mut(index.wrapping_sub(1)).ok_or_else(unknown)?;
    if mode.set_field(name, value) {
        Ok(())
    } else {
        Err(unknown())
    }
}

/// The suffix of a mode's pseudo-field that the table draws instead of its frequency: the share
/// of an axis's load inertia that the mode's moving part carries.
pub const INERTIA_SHARE: &str = ".inertia_share";

/// For each mode with an inertia share, the table's parameter whose inertia the share is of (the
/// part of the axis's load inertia the master takes the mode's out of, when the modes push back
/// on the drives).
pub const SHARED_INERTIAS: [(&str, &str); 2] =
    [("mode1", "azimuth.turning_head_inertia"), ("mode2", "elevation.load_inertia")];

/// Sets a mode's frequency from the share of an axis's inertia that it carries: the mode's
/// inertia is `K / w^2 = share J`, so `w = sqrt(K / (share J))`. Written as a scaling of the
/// shipped mode, `f = f0 sqrt((K / K0) (share0 J0) / (share J))` with the table's defaults
/// `share0`, `J0`, so that the defaults give the shipped frequency to the bit.
fn set_frequency_from_share(
    modes: &mut [fmu_structure::modes::Mode],
    shipped: &[fmu_structure::modes::Mode],
    values: &[(UncertainParameter, Option<f64>)],
    field: &str,
    default_share: f64,
    share: f64,
) -> Result<(), SetupError> {
    let mode_name = field.trim_end_matches(INERTIA_SHARE);
    let unknown = || SetupError::UnknownModeField {
        parameter: field.to_string(),
        mode: mode_name.to_string(),
        field: field.to_string(),
    };
    let (_, inertia_name) = SHARED_INERTIAS.iter().find(|(mode, _)| *mode == mode_name).ok_or_else(unknown)?;
    let index: usize = mode_name.trim_start_matches("mode").parse().map_err(|_| unknown())?;
    let (Some(mode), Some(shipped)) = (modes.get_mut(index.wrapping_sub(1)), shipped.get(index.wrapping_sub(1))) else {
        return Err(unknown());
    };
    let (inertia_default, inertia) = values
        .iter()
        .find(|(p, _)| p.name == *inertia_name)
        .map(|(p, value)| (p.default, value.unwrap_or(p.default)))
        .ok_or_else(unknown)?;
    let ratio = (mode.stiffness / shipped.stiffness) * (default_share * inertia_default) / (share * inertia);
    mode.frequency_hz = shipped.frequency_hz * ratio.sqrt();
    Ok(())
}

fn apply_scenario_setting(
    config: &mut AntennaConfig,
    scenario: &mut ScenarioSettings,
    parameter: &str,
    name: &str,
    value: f64,
) -> Result<(), SetupError> {
    match name {
        "wind.mean_speed_factor" => scenario.mean_speed_factor = value,
        "wind.yaw" => scenario.yaw_deg = value,
        "wind.roughness_factor" => scenario.roughness_factor = value,
        "wind.torque_coefficient_scale" => config.wind_load_scale = value,
        "wind.seed" => scenario.seed = Some(value as i32),
        _ => {
            return Err(SetupError::UnknownTarget {
                parameter: parameter.to_string(),
                target: format!("scenario:{name}"),
            })
        }
    }
    Ok(())
}

/// The structure's overrides: none for the shipped modes, else a written modes file.
fn structure_overrides(
    modes: &[fmu_structure::modes::Mode],
    shipped: &[fmu_structure::modes::Mode],
    folder: Option<&Path>,
) -> Result<Overrides, SetupError> {
    if modes == shipped {
        return Ok(Vec::new());
    }
    let folder = folder.ok_or(SetupError::NoFolderForModes)?;
    let path = folder.join("structure_modes.params");
    let text =
        write_modes(modes, "Structure modes of one point of docs/parameters.csv, written by the coupled master.");
    std::fs::write(&path, text)
        .map_err(|source| SetupError::WriteModes { path: path.display().to_string(), source })?;
    Ok(vec![("modes_file".to_string(), ParameterValue::Text(path.display().to_string()))])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::requirement_scenarios;

    #[test]
    fn a_value_set_by_name_replaces_the_configurations_and_an_unknown_name_is_refused() {
        let set = [("structure.stiffness".to_string(), 2e8)];
        let values = Configuration::Realistic.values_with(&set).unwrap();
        for ((parameter, value), (_, realistic)) in values.iter().zip(Configuration::Realistic.values()) {
            let expected = if parameter.name == "structure.stiffness" { Some(2e8) } else { realistic };
            assert_eq!(*value, expected, "{}", parameter.name);
        }
        // The paper's model lacks the structure; setting one of its values adds it.
        let paper = Configuration::Paper.values_with(&set).unwrap();
        assert!(paper.iter().any(|(p, v)| p.name == "structure.stiffness" && *v == Some(2e8)));
        let error = Configuration::Realistic.values_with(&[("structure.stifness".into(), 1.0)]).unwrap_err();
        assert!(error.to_string().contains("structure.stiffness"), "{error}");
    }

    #[test]
    fn the_paper_configuration_sets_nothing_but_the_papers_values_and_has_no_structure() {
        let config = Configuration::Paper.antenna_config();
        assert_eq!(config.structure, None);
        assert_eq!(config.wind_load_scale, 1.0);
        let settings = Configuration::Paper.scenario_settings();
        for scenario in requirement_scenarios() {
            let applied = settings.apply(&scenario);
            assert_eq!(applied.wind, scenario.wind, "{}", scenario.name);
        }
    }

    #[test]
    fn the_realistic_configuration_couples_the_shipped_structure_and_keeps_the_scenario_winds() {
        let config = Configuration::Realistic.antenna_config();
        assert_eq!(config.structure, Some(Vec::new()), "the default modes are the shipped file's");
        assert!(config.azimuth_plant.iter().any(|(name, _)| name == "encoder.eccentricity_error_amplitude"));
        let settings = Configuration::Realistic.scenario_settings();
        for scenario in requirement_scenarios() {
            assert_eq!(settings.apply(&scenario).wind, scenario.wind, "{}", scenario.name);
        }
    }

    #[test]
    fn a_varied_structure_is_written_to_a_modes_file_that_reads_back() {
        let mut values = Configuration::Realistic.values();
        // A quarter of the share at the same stiffness: twice the frequency.
        let share = values.iter_mut().find(|(p, _)| p.name == "structure.azimuth_mode_inertia_share").unwrap();
        share.1 = Some(share.0.default / 4.0);
        assert!(matches!(AntennaSetup::from_values(&values, None), Err(SetupError::NoFolderForModes)));
        let folder = std::env::temp_dir().join(format!("antenna-sim-modes-{}", std::process::id()));
        std::fs::create_dir_all(&folder).unwrap();
        let setup = AntennaSetup::from_values(&values, Some(&folder)).unwrap();
        let Some(overrides) = setup.config.structure else { panic!("no structure") };
        let ParameterValue::Text(path) = &overrides[0].1 else { panic!("{overrides:?}") };
        let modes = fmu_structure::modes::read_modes(Path::new(path)).unwrap();
        assert!((modes[0].frequency_hz / 12.0 - 1.0).abs() < 1e-12, "{}", modes[0].frequency_hz);
        assert_eq!(modes[1].frequency_hz, 6.0);
        // The mode's inertia is the share of the turning head's.
        let inertia = modes[0].stiffness / (modes[0].omega() * modes[0].omega());
        assert!((inertia / (0.5117 / 4.0 * 5.5e5) - 1.0).abs() < 1e-4, "{inertia}");
        std::fs::remove_dir_all(&folder).unwrap();
    }

    #[test]
    fn scenario_settings_move_the_wind_as_the_table_says() {
        let scenario = requirement_scenarios().into_iter().find(|s| s.wind.mean_speed_m_s > 5.0).unwrap();
        let settings = ScenarioSettings { mean_speed_factor: 0.5, yaw_deg: 10.0, roughness_factor: 2.0, seed: Some(9) };
        let applied = settings.apply(&scenario);
        assert_eq!(applied.wind.mean_speed_m_s, 0.5 * scenario.wind.mean_speed_m_s);
        assert_eq!(applied.wind.roughness_length_m, 2.0 * scenario.wind.roughness_length_m);
        assert!((applied.wind.direction_deg - (scenario.wind.direction_deg - WIND_YAW_DEG + 10.0)).abs() < 1e-12);
        // A direction past north wraps into the wind unit's range.
        let around = ScenarioSettings { yaw_deg: 350.0, ..settings }.apply(&scenario);
        assert!((0.0..360.0).contains(&around.wind.direction_deg), "{}", around.wind.direction_deg);
        assert_eq!(applied.wind.seed, 9);
    }
}
