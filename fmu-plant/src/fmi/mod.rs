//! The FMI 2.0 face of the plant: two co-simulation FMUs, `AzimuthPlant` and
//! `ElevationPlant`, served by one shared library (crate `fmu-plant-cdylib`; the GUID chooses
//! the model). The axes differ
//! in their ports, and FMI 2.0 has no structural parameters, hence two FMUs.

pub mod azimuth;
mod common;
pub mod elevation;

pub use azimuth::{AzVar, AzimuthPlantModel};
pub use elevation::{ElVar, ElevationPlantModel};

use fmu_runtime::package::{default_parameter_file, FmuSpec};
use fmu_runtime::params::ParamsError;

use crate::error::PlantError;

/// Why a plant FMU refuses a call; logged with `fmi2Error`.
#[derive(Debug, thiserror::Error)]
pub enum PlantFmuError {
    /// The parameters, the initial position or a step's inputs do not describe a drive that
    /// can run.
    #[error(transparent)]
    Plant(#[from] PlantError),
    /// The parameter file named by `parameter_file` cannot be applied.
    #[error(transparent)]
    Parameters(#[from] ParamsError),
    /// A step before fmi2ExitInitializationMode built the plant.
    #[error("the plant is not initialised")]
    NotInitialised,
}

/// Files shipped in each plant FMU's `resources/` folder: the default parameter set (generated
/// from the variable table), the linear Eq. 1 configuration and the realistic sensors.
fn azimuth_resources() -> Vec<(String, Vec<u8>)> {
    vec![
        ("defaults.params".into(), default_parameter_file::<AzimuthPlantModel>().into_bytes()),
        ("linear.params".into(), LINEAR_PARAMS.as_bytes().to_vec()),
        ("realistic_sensors.params".into(), realistic_sensors(&["motor1", "motor2"]).into_bytes()),
    ]
}

fn elevation_resources() -> Vec<(String, Vec<u8>)> {
    vec![
        ("defaults.params".into(), default_parameter_file::<ElevationPlantModel>().into_bytes()),
        ("linear.params".into(), LINEAR_PARAMS.as_bytes().to_vec()),
        ("realistic_sensors.params".into(), realistic_sensors(&["motor"]).into_bytes()),
    ]
}

const LINEAR_PARAMS: &str = "# The paper's linear Eq. 1 configuration: friction (except the viscous B_M), backlash,\n# saturation, delay, cogging, extra torques and encoder quantisation are ignored; the elevation\n# geometry is frozen at geometry.frozen_elevation.\nlinear_configuration = true\n";

/// The encoder part of `realistic_sensors.params`: a Heidenhain-class ring encoder read by one
/// head. docs/plant-model.md (section "Sensors") gives each value's source or marks it an
/// estimate, with its range.
const REALISTIC_ENCODER: &str = "\
# Realistic sensors: a Heidenhain-class modular (ring) angle encoder with one read head, and the
# servo amplifier's motor speed signal. Sourced: graduation accuracy +/-1.5 arcsec (ECA 4000
# class), interpolation error about 1 % of the signal period, eccentricity 412 e/D arcsec.
# Estimates: the split of the graduation error over harmonics, all phases, the line count, the
# reading noise and the speed-signal noise. Ranges in docs/plant-model.md, section Sensors.
encoder.count_mode = \"round\"              # the pointing model's zero offset absorbs a truncating count's half count
encoder.graduation_error1_amplitude = 0.8   # arcsec; the three amplitudes add up to the +/-1.5 arcsec class
encoder.graduation_error1_harmonic = 2
encoder.graduation_error1_phase = 40        # deg, estimate
encoder.graduation_error2_amplitude = 0.45  # arcsec
encoder.graduation_error2_harmonic = 3
encoder.graduation_error2_phase = 110       # deg, estimate
encoder.graduation_error3_amplitude = 0.25  # arcsec
encoder.graduation_error3_harmonic = 4
encoder.graduation_error3_phase = 250       # deg, estimate
encoder.line_count = 32768                  # signal period 39.6 arcsec (estimate: RCN 8000 / ring class)
encoder.interpolation_error1_amplitude = 0.3  # arcsec; with the next, 1 % of the signal period (0.4 arcsec)
encoder.interpolation_error1_phase = 0
encoder.interpolation_error2_amplitude = 0.1  # arcsec
encoder.interpolation_error2_phase = 90
encoder.eccentricity_error_amplitude = 2.0  # arcsec: e = 2.4 um on a D = 500 mm ring (412 e/D)
encoder.eccentricity_error_phase = 30       # deg, estimate
encoder.noise_rms = 0.02                    # arcsec, estimate (0.005-0.1)
";

/// `realistic_sensors.params` for an axis whose motors are named `motors`.
fn realistic_sensors(motors: &[&str]) -> String {
    let mut text = REALISTIC_ENCODER.to_string();
    for motor in motors {
        text.push_str(&format!(
            "{motor}.speed_noise_rms = 0.052          # rad/s = 0.5 rpm at the motor, estimate (0.05-5 rpm)\n"
        ));
    }
    text
}

/// The FMUs this crate ships.
pub fn fmus() -> Vec<FmuSpec> {
    vec![
        FmuSpec::of::<AzimuthPlantModel>("fmu_plant_ffi", azimuth_resources),
        FmuSpec::of::<ElevationPlantModel>("fmu_plant_ffi", elevation_resources),
    ]
}

#[cfg(test)]
mod tests {
    use std::fmt::Debug;

    use fmu_runtime::variables::{Causality, Kind};
    use fmu_runtime::{Values, VariableSet};

    use super::azimuth::{azimuth_params, AzVar};
    use super::elevation::{elevation_params, ElVar};
    use crate::{AzimuthInputs, AzimuthParams, AzimuthPlant, ElevationInputs, ElevationParams, ElevationPlant};

    /// The fields in which two parameter sets differ, found line by line in their pretty
    /// `Debug` forms (one field, or array element, per line), with the line for orientation.
    fn differing_fields(built: &impl Debug, default: &impl Debug) -> Vec<String> {
        let (built, default) = (format!("{built:#?}"), format!("{default:#?}"));
        assert_eq!(built.lines().count(), default.lines().count(), "the two sets differ in shape:\n{built}\n{default}");
        built
            .lines()
            .zip(default.lines())
            .enumerate()
            .filter(|(_, (b, d))| b != d)
            .map(|(line, (b, d))| {
                format!("line {}: FMU start values give `{}`, the default is `{}`", line + 1, b.trim(), d.trim())
            })
            .collect()
    }

    #[test]
    fn azimuth_start_values_are_the_default_parameters_field_by_field() {
        // The variable table repeats AzimuthParams::default() as start values; this keeps the
        // two copies equal (the backlash is declared in arcsec and must convert back exactly).
        let built = azimuth_params(&Values::<AzVar>::at_start());
        let differences = differing_fields(&built, &AzimuthParams::default());
        assert!(differences.is_empty(), "{}", differences.join("\n"));
        assert_eq!(built, AzimuthParams::default());
    }

    #[test]
    fn elevation_start_values_are_the_default_parameters_field_by_field() {
        let built = elevation_params(&Values::<ElVar>::at_start());
        let differences = differing_fields(&built, &ElevationParams::default());
        assert!(differences.is_empty(), "{}", differences.join("\n"));
        assert_eq!(built, ElevationParams::default());
    }

    /// Every declared minimum and maximum of a Real parameter, with the variable.
    fn declared_bounds<V: VariableSet>() -> Vec<(V, f64)> {
        let mut bounds = Vec::new();
        for (index, var) in V::TABLE.iter().enumerate() {
            if let (Causality::Parameter, Kind::Real { min, max, .. }) = (var.causality, var.kind) {
                let typed = V::from_index(index).expect("index from the table");
                bounds.extend(min.into_iter().chain(max).map(|b| (typed, b)));
            }
        }
        bounds
    }

    /// Parameters whose bound is joint with others, so that a declared bound alone cannot be
    /// the truth: the jackscrew geometry must keep the lever arm and the nut on the screw over
    /// the travel (their descriptions say so).
    const JOINTLY_BOUNDED: [&str; 3] =
        ["jackscrew.dish_attachment_radius", "jackscrew.yoke_attachment_radius", "jackscrew.length_between_bearings"];

    /// The values of `values` with `var` at `bound`, and the partner that a documented joint
    /// rule ties to it moved where the rule holds: a breakaway friction of 0 needs a sliding
    /// friction of 0 ("at least the sliding friction"), a path damping of 0 needs no backlash
    /// ("with backlash it must be positive"), the shortest event check interval needs the
    /// finest event resolution ("at least numerics.event_time_resolution"). The description
    /// must state the rule.
    fn at_bound<V: VariableSet>(var: V, bound: f64) -> Values<V> {
        let mut values = Values::<V>::at_start();
        values.set_real(var, bound);
        let (name, description) = (var.var().name, var.var().description);
        let partner = if let Some(body) = name.strip_suffix(".static_friction") {
            assert!(description.contains("at least the sliding friction"), "{name}: the joint rule is not described");
            Some(format!("{body}.coulomb_friction"))
        } else if let Some(body) = name.strip_suffix(".coulomb_friction") {
            // The mirror of the rule above: a sliding friction at its maximum needs a breakaway
            // friction at least as large.
            let static_ = V::by_name(&format!("{body}.static_friction")).expect("the partner exists");
            assert!(
                static_.var().description.contains("at least the sliding friction"),
                "{name}: the joint rule is not described"
            );
            values.set_real(static_, values.real(static_).max(bound));
            None
        } else if let Some(path) = name.strip_suffix(".damping").filter(|p| p.starts_with("pinion")) {
            assert!(
                description.contains("With backlash it must be positive"),
                "{name}: the joint rule is not described"
            );
            Some(format!("{path}.backlash"))
        } else if name == "numerics.event_check_interval" {
            assert!(
                description.contains("at least numerics.event_time_resolution"),
                "{name}: the joint rule is not described"
            );
            let resolution = V::by_name("numerics.event_time_resolution").expect("the partner exists");
            values.set_real(resolution, values.real(resolution).min(bound));
            None
        } else {
            None
        };
        if let Some(partner) = partner.filter(|_| bound == 0.0) {
            values.set_real(V::by_name(&partner).expect("the partner exists"), 0.0);
        }
        values
    }

    /// The elevation geometry's angles and offsets, declared within physical limits (half a
    /// turn, a hundred metres) that do not know the other geometry parameters: only some
    /// combinations keep the lever arm and the nut on the screw, which construction checks.
    const GEOMETRY_BOUNDED: [&str; 6] = [
        "jackscrew.attachment_angle_at_zero_elevation",
        "jackscrew.nut_offset",
        "jackscrew.lead",
        "travel.min",
        "travel.max",
        "geometry.frozen_elevation",
    ];

    #[test]
    fn every_declared_bound_of_an_azimuth_parameter_is_a_value_the_plant_runs_with() {
        let bounds = declared_bounds::<AzVar>();
        assert!(bounds.len() > 40, "only {} bounds found", bounds.len());
        for (var, bound) in bounds {
            let name = var.var().name;
            let values = at_bound(var, bound);
            let mut plant =
                AzimuthPlant::new(azimuth_params(&values)).unwrap_or_else(|e| panic!("{name} = {bound}: {e}"));
            plant.set_initial_state(values.real(AzVar::InitialPosition).to_radians()).unwrap();
            // Torque-biased drive that reverses, so friction, backlash and saturation all act.
            for k in 0..300 {
                let common = if (k / 100) % 2 == 0 { 4.0 } else { -4.0 };
                let inputs = AzimuthInputs {
                    current_command_a: [common + 1.0, common - 1.0],
                    disturbance_torque_nm: 1e3,
                    elevation_deg: values.real(AzVar::Elevation),
                };
                plant.step(&inputs, 1e-3).unwrap_or_else(|e| panic!("{name} = {bound}, step {k}: {e}"));
            }
            let o = plant.outputs();
            assert!(
                o.axis_position_deg.is_finite() && o.pinion_torque_nm.iter().all(|t| t.is_finite()),
                "{name} = {bound}: {o:?}"
            );
        }
    }

    #[test]
    fn every_declared_bound_of_an_elevation_parameter_is_a_value_the_plant_runs_with() {
        let bounds = declared_bounds::<ElVar>();
        assert!(bounds.len() > 30, "only {} bounds found", bounds.len());
        for (var, bound) in bounds {
            let name = var.var().name;
            if JOINTLY_BOUNDED.contains(&name) {
                assert!(
                    var.var().description.contains("over the whole travel"),
                    "{name} must describe its joint bound"
                );
                continue;
            }
            let values = at_bound(var, bound);
            let built = ElevationPlant::new(elevation_params(&values));
            if GEOMETRY_BOUNDED.contains(&name) {
                // The geometry's parameters bound each other; at a declared bound the plant
                // runs or refuses at construction (initialisation), naming the geometry.
                if let Err(e) = &built {
                    let e = e.to_string();
                    assert!(e.contains("geometry") || e.contains("travel"), "{name} = {bound}: {e}");
                    continue;
                }
            }
            let mut plant = built.unwrap_or_else(|e| panic!("{name} = {bound}: {e}"));
            plant.set_initial_state(values.real(ElVar::InitialPosition).to_radians()).unwrap();
            for k in 0..300 {
                let inputs = ElevationInputs {
                    current_command_a: if (k / 100) % 2 == 0 { 3.0 } else { -3.0 },
                    disturbance_torque_nm: 1e3,
                };
                plant.step(&inputs, 1e-3).unwrap_or_else(|e| panic!("{name} = {bound}, step {k}: {e}"));
            }
            let o = plant.outputs();
            assert!(o.axis_position_deg.is_finite() && o.drive_torque_nm.is_finite(), "{name} = {bound}: {o:?}");
        }
    }
}
