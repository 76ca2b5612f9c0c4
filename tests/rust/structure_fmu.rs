//! The packaged structure FMU (`Structure.fmu`) through the C ABI, as a master sees it: a
//! constant load deflects the beam by load times the static compliance of the FMU's own modes
//! file (read here from the archive and summed by hand, not by the model crate); each mode
//! shows in the frequency response from load torque to beam offset, estimated from a white-noise
//! run, at its documented frequency; results do not depend on the communication step for
//! piecewise-constant loads; a bad modes file is an fmi2Error that names the file and the
//! cause; an FMU state replays the run bit for bit. The wind force resolved in the antenna's
//! frame (axial, lateral, lift) deflects the beam by force x participation / stiffness x beam
//! participation, an old modes file ignores it, and in the coupled antenna a mode that takes
//! only the lateral force sees none in a front wind and the drag's lateral part when the wind
//! turns.
//!
//! Figures for docs/structure-model.md: `cargo test --release -p antenna-tests --test
//! integration -- structure_fmu:: --nocapture`.

use std::io::Read;
use std::path::PathBuf;

use antenna_dsp::{transfer_function_h1, WelchConfig};
use antenna_sim::{CommandPoint, CommandTable, Configuration, CoupledAntenna, FmuSet, Lanes, Trace, WindCondition};
use antenna_tests::{expect_error, fmu_path, open, output_bits, reals, set_reals, test_signal};
use fmu_import::{Fmu, Instance};
use fmu_runtime::params::{self, ParameterValue};

const ARCSEC_PER_RAD: f64 = 180.0 / std::f64::consts::PI * 3600.0;
/// The structure's loads in the order of a mode's participations (docs/structure-model.md).
const LOADS: [&str; 6] =
    ["torque.azimuth", "torque.elevation", "force.dish", "force.axial", "force.lateral", "force.lift"];
const OFFSETS: [&str; 2] = ["beam.azimuth_offset", "beam.elevation_offset"];

/// One mode as the modes file documents it (docs/structure-model.md), read here independently
/// of the model crate.
#[derive(Debug, Clone)]
struct Mode {
    frequency_hz: f64,
    damping_ratio: f64,
    stiffness: f64,
    participation: [f64; 6],
    beam: [f64; 2],
    /// The beam's rotation about the azimuth axis per unit coordinate (optional, default 0).
    azimuth_rotation: f64,
}

/// Reads a modes file with the project's parameter parser: `mode<k>.<field> = value`.
fn parse_modes(text: &str) -> Vec<Mode> {
    let mut modes: Vec<Mode> = Vec::new();
    for a in params::parse(text, "modes").unwrap() {
        let ParameterValue::Number(value) = a.value else { panic!("{} is not a number", a.name) };
        let (mode, field) = a.name.strip_prefix("mode").and_then(|n| n.split_once('.')).unwrap();
        let index: usize = mode.parse::<usize>().unwrap() - 1;
        while modes.len() <= index {
            modes.push(Mode {
                frequency_hz: f64::NAN,
                damping_ratio: f64::NAN,
                stiffness: f64::NAN,
                // The resolved forces' participations are optional and default to zero.
                participation: [f64::NAN, f64::NAN, f64::NAN, 0.0, 0.0, 0.0],
                beam: [f64::NAN; 2],
                azimuth_rotation: 0.0,
            });
        }
        let m = &mut modes[index];
        match field {
            "frequency" => m.frequency_hz = value,
            "damping" => m.damping_ratio = value,
            "stiffness" => m.stiffness = value,
            "azimuth_torque" => m.participation[0] = value,
            "elevation_torque" => m.participation[1] = value,
            "dish_force" => m.participation[2] = value,
            "axial_force" => m.participation[3] = value,
            "lateral_force" => m.participation[4] = value,
            "lift_force" => m.participation[5] = value,
            "beam_azimuth" => m.beam[0] = value,
            "beam_elevation" => m.beam[1] = value,
            "beam_azimuth_rotation" => m.azimuth_rotation = value,
            other => panic!("unknown field {other}"),
        }
    }
    modes
}

/// The modes file shipped in the packaged FMU's resources.
fn shipped_modes() -> Vec<Mode> {
    let file = std::fs::File::open(fmu_path("Structure")).unwrap();
    let mut archive = zip::ZipArchive::new(file).unwrap();
    let mut text = String::new();
    archive.by_name("resources/structure_modes.params").unwrap().read_to_string(&mut text).unwrap();
    parse_modes(&text)
}

/// The elevation input's start value, deg: where an instance that is not told otherwise holds
/// the dish.
const START_ELEVATION_DEG: f64 = 45.0;

/// The static beam offset on the sky (arcsec; cross-elevation, elevation) under constant loads
/// (the first of [`LOADS`]; the rest zero) with the dish at the start elevation: the sum over
/// the modes of beam x participation / stiffness, times the load, a rotation about the azimuth
/// axis projected with cos(elevation).
fn static_offset(modes: &[Mode], loads: &[f64]) -> [f64; 2] {
    static_offset_at(modes, loads, START_ELEVATION_DEG)
}

fn static_offset_at(modes: &[Mode], loads: &[f64], elevation_deg: f64) -> [f64; 2] {
    let mut offset = [0.0; 2];
    for m in modes {
        let q: f64 = m.participation.iter().zip(loads).map(|(p, u)| p * u).sum::<f64>() / m.stiffness;
        let on_sky = [m.beam[0] + m.azimuth_rotation * elevation_deg.to_radians().cos(), m.beam[1]];
        for (o, b) in offset.iter_mut().zip(on_sky) {
            *o += b * q * ARCSEC_PER_RAD;
        }
    }
    offset
}

/// A folder of its own for the modes files a test writes.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("structure-fmu-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// An initialised instance, optionally with another modes file.
fn structure(fmu: &Fmu, name: &str, modes_file: Option<&str>) -> Instance {
    let mut instance = fmu.instantiate(name, false).unwrap();
    instance.setup_experiment(0.0, None).unwrap();
    if let Some(file) = modes_file {
        instance.set_string(&[fmu.description.vr("modes_file").unwrap()], &[file]).unwrap();
    }
    instance.enter_initialization_mode().unwrap();
    instance.exit_initialization_mode().unwrap();
    instance
}

/// Runs `steps` steps of `step` seconds from `start` with the loads `loads(time)` set before
/// each; returns the beam offsets after every step.
fn run<const N: usize>(
    fmu: &Fmu,
    instance: &mut Instance,
    start: f64,
    step: f64,
    steps: usize,
    loads: impl Fn(f64) -> [f64; N],
) -> Vec<[f64; 2]> {
    let load_vrs = fmu.description.vrs(&LOADS[..N]).unwrap();
    let offset_vrs = fmu.description.vrs(&OFFSETS).unwrap();
    let mut out = Vec::with_capacity(steps);
    let mut offset = [0.0; 2];
    for k in 0..steps {
        let t = start + k as f64 * step;
        instance.set_real(&load_vrs, &loads(t)).unwrap();
        instance.do_step(t, step).unwrap();
        instance.get_real(&offset_vrs, &mut offset).unwrap();
        out.push(offset);
    }
    out
}

/// A modes file of three coupled modes, each taking several loads and moving both beam axes.
const COUPLED_MODES: &str = "\
mode1.frequency = 4.5\nmode1.damping = 0.02\nmode1.stiffness = 3e8\nmode1.azimuth_torque = 1\nmode1.elevation_torque = 0.2\nmode1.dish_force = 0\nmode1.beam_azimuth = 1\nmode1.beam_elevation = 0.1\n\
mode2.frequency = 7.0\nmode2.damping = 0.01\nmode2.stiffness = 6e8\nmode2.azimuth_torque = -0.3\nmode2.elevation_torque = 1\nmode2.dish_force = 2.5\nmode2.beam_azimuth = 0.05\nmode2.beam_elevation = 1\n\
mode3.frequency = 11.0\nmode3.damping = 0.005\nmode3.stiffness = 1\nmode3.azimuth_torque = 1e-5\nmode3.elevation_torque = 2e-5\nmode3.dish_force = 4e-5\nmode3.beam_azimuth = 3e-5\nmode3.beam_elevation = -2e-5\n";

#[test]
fn a_constant_load_deflects_the_beam_by_load_times_the_compliance_of_its_own_modes() {
    let fmu = open("Structure");
    let dir = scratch("static");
    let coupled = dir.join("coupled.params");
    std::fs::write(&coupled, COUPLED_MODES).unwrap();
    let loads = [1.05e4, -8.0e3, 6.0e3];
    for (label, file, modes) in [
        ("shipped modes", None, shipped_modes()),
        ("three coupled modes", Some(coupled.to_str().unwrap()), parse_modes(COUPLED_MODES)),
    ] {
        let mut instance = structure(&fmu, label, file);
        // From rest, unloaded, a step load held for 40 s: the transient of the slowest-decaying
        // mode (11 Hz at 0.5 % in the coupled set) falls to exp(-zeta w 40 s) = exp(-13.8) =
        // 1e-6 of the step by the end.
        let offsets = run(&fmu, &mut instance, 0.0, 1e-3, 40_000, |_| loads);
        let end = offsets[offsets.len() - 1];
        let expected = static_offset(&modes, &loads);
        for axis in 0..2 {
            let error = (end[axis] - expected[axis]).abs() / expected[axis].abs();
            println!(
                "{label}: axis {axis}: {:.6} arcsec, load x compliance {:.6} arcsec, error {:.2e}",
                end[axis], expected[axis], error
            );
            assert!(error < 0.01, "{label}: axis {axis}: {} arcsec against {}", end[axis], expected[axis]);
        }
        let quasi_static =
            reals(&fmu, &mut instance, &["beam.azimuth_offset_static", "beam.elevation_offset_static"]).unwrap();
        for axis in 0..2 {
            assert!(
                (quasi_static[axis] / expected[axis] - 1.0).abs() < 1e-9,
                "{label}: static output {quasi_static:?}"
            );
        }
    }
    std::fs::remove_dir_all(&dir).ok();
    let shipped = static_offset(&shipped_modes(), &[1.05e4, 1.05e4, 0.0]);
    println!("shipped modes: 10.5 kN m (the largest mean wind torque at 9.8 m/s) gives {shipped:.2?} arcsec");
}

/// The shipped azimuth mode is a twist about the azimuth axis: on the sky it moves the beam by
/// the angle times cos(elevation). Checked against the hand calculation 20 kN m / 4e8 N m/rad =
/// 5e-5 rad = 10.313 arcsec of twist: at 0 deg all of it, at 60 deg half (5.157 arcsec), at 88
/// deg cos 88 = 0.0349 of it (0.360 arcsec), in the settled offset and the quasi-static output.
#[test]
fn the_azimuth_twist_moves_the_beam_on_the_sky_by_the_angle_times_cos_elevation() {
    let fmu = open("Structure");
    let twist_arcsec = 2e4 / 4e8 * ARCSEC_PER_RAD;
    for (elevation, cos_el) in [(0.0, 1.0), (60.0, 0.5), (88.0, 0.034_899_496_702_500_97)] {
        let mut instance = fmu.instantiate("twist", false).unwrap();
        let vrs = [fmu.description.vr("torque.azimuth").unwrap(), fmu.description.vr("axis.elevation").unwrap()];
        instance.initialize(0.0, &[(vrs[0], 2e4), (vrs[1], elevation)]).unwrap();
        let expected = twist_arcsec * cos_el;
        let at_start = reals(&fmu, &mut instance, &OFFSETS).unwrap();
        let held = run(&fmu, &mut instance, 0.0, 1e-3, 200, |_| [2e4, 0.0, 0.0]);
        let quasi_static = reals(&fmu, &mut instance, &["beam.azimuth_offset_static"]).unwrap()[0];
        println!("el {elevation} deg: beam {:.6} arcsec, hand {expected:.6} arcsec", held[199][0]);
        for value in [at_start[0], held[199][0], quasi_static] {
            assert!((value - expected).abs() <= 1e-9 * twist_arcsec, "el {elevation}: {value} against {expected}");
        }
        assert_eq!(held[199][1], 0.0, "a twist about the azimuth axis does not move the beam in elevation");
    }
}

#[test]
fn the_static_outputs_follow_the_loads_without_a_step_and_a_loaded_start_is_at_rest() {
    let fmu = open("Structure");
    let modes = shipped_modes();
    let mut instance = fmu.instantiate("loaded", false).unwrap();
    instance.initialize(0.0, &[(fmu.description.vr("torque.azimuth").unwrap(), 2e4)]).unwrap();
    let at_start = reals(&fmu, &mut instance, &OFFSETS).unwrap();
    let expected = static_offset(&modes, &[2e4, 0.0, 0.0]);
    assert!((at_start[0] / expected[0] - 1.0).abs() < 1e-12, "{at_start:?} against {expected:?}");
    let held = run(&fmu, &mut instance, 0.0, 1e-3, 100, |_| [2e4, 0.0, 0.0]);
    assert!((held[99][0] / expected[0] - 1.0).abs() < 1e-12, "a loaded start rings: {:?}", held[99]);
    set_reals(&fmu, &mut instance, &[("torque.elevation", -3e4)]);
    let quasi_static =
        reals(&fmu, &mut instance, &["beam.azimuth_offset_static", "beam.elevation_offset_static"]).unwrap();
    let expected = static_offset(&modes, &[2e4, -3e4, 0.0]);
    assert!((quasi_static[1] / expected[1] - 1.0).abs() < 1e-12, "{quasi_static:?} against {expected:?}");
}

/// Three modes that take the wind force resolved in the antenna's frame: one physical mode per
/// axis (lever arms in metres) and one in a finite-element scaling (`K = w^2`) that takes all
/// three forces and moves both beam axes.
const RESOLVED_MODES: &str = "\
mode1.frequency = 5.0\nmode1.damping = 0.02\nmode1.stiffness = 3e8\nmode1.azimuth_torque = 0\nmode1.elevation_torque = 0\nmode1.dish_force = 0\nmode1.lateral_force = 4.0\nmode1.beam_azimuth = 1\nmode1.beam_elevation = 0\n\
mode2.frequency = 7.0\nmode2.damping = 0.015\nmode2.stiffness = 5e8\nmode2.azimuth_torque = 0\nmode2.elevation_torque = 1\nmode2.dish_force = 0\nmode2.axial_force = 2.5\nmode2.lift_force = -1.5\nmode2.beam_azimuth = 0\nmode2.beam_elevation = 1\n\
mode3.frequency = 9.0\nmode3.damping = 0.01\nmode3.stiffness = 3197.75\nmode3.azimuth_torque = 0\nmode3.elevation_torque = 0\nmode3.dish_force = 0\nmode3.axial_force = -1e-3\nmode3.lateral_force = 5e-4\nmode3.lift_force = 2e-3\nmode3.beam_azimuth = 3e-3\nmode3.beam_elevation = 1e-3\n";

#[test]
fn a_constant_axial_lateral_or_lift_force_deflects_the_beam_by_force_times_participation_over_stiffness() {
    let fmu = open("Structure");
    let dir = scratch("resolved");
    let path = dir.join("resolved.params");
    std::fs::write(&path, RESOLVED_MODES).unwrap();
    let modes = parse_modes(RESOLVED_MODES);
    // About the mean drag and lift at 9.8 m/s (docs/wind-model.md): one force at a time, then
    // all three together.
    let cases: [(&str, [f64; 3]); 4] = [
        ("axial", [9.6e3, 0.0, 0.0]),
        ("lateral", [0.0, -4.8e3, 0.0]),
        ("lift", [0.0, 0.0, -2.2e3]),
        ("all three", [6.8e3, 3.4e3, -2.2e3]),
    ];
    for (label, forces) in cases {
        let mut instance = structure(&fmu, label, Some(path.to_str().unwrap()));
        let loads = [0.0, 0.0, 0.0, forces[0], forces[1], forces[2]];
        // From rest, unloaded, the forces held 40 s: the slowest transient (9 Hz at 1 %) falls
        // to exp(-0.01 x 2 pi 9 x 40) = 1.5e-10 of the step.
        let offsets = run(&fmu, &mut instance, 0.0, 1e-3, 40_000, |_| loads);
        let end = offsets[offsets.len() - 1];
        // force x participation / stiffness x beam participation, written out mode by mode.
        let mut expected = [0.0; 2];
        for m in &modes {
            let q = (m.participation[3] * forces[0] + m.participation[4] * forces[1] + m.participation[5] * forces[2])
                / m.stiffness;
            expected[0] += m.beam[0] * q * ARCSEC_PER_RAD;
            expected[1] += m.beam[1] * q * ARCSEC_PER_RAD;
        }
        for axis in 0..2 {
            let error = (end[axis] - expected[axis]).abs() / expected[axis].abs();
            println!(
                "resolved forces, {label}: axis {axis}: {:.6} arcsec, force x participation / stiffness x beam {:.6} arcsec, error {:.2e}",
                end[axis], expected[axis], error
            );
            assert!(error < 0.01, "{label}: axis {axis}: {} arcsec against {}", end[axis], expected[axis]);
        }
        let quasi_static =
            reals(&fmu, &mut instance, &["beam.azimuth_offset_static", "beam.elevation_offset_static"]).unwrap();
        for axis in 0..2 {
            assert!((quasi_static[axis] / expected[axis] - 1.0).abs() < 1e-9, "{label}: static {quasi_static:?}");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn modes_without_the_resolved_forces_ignore_them_bit_for_bit() {
    // The shipped modes and a file written before the resolved forces existed: setting
    // force.axial, force.lateral and force.lift changes no output by a bit.
    let fmu = open("Structure");
    let dir = scratch("old");
    let path = dir.join("coupled.params");
    std::fs::write(&path, COUPLED_MODES).unwrap();
    for file in [None, Some(path.to_str().unwrap())] {
        let loads = |t: f64| {
            let k = (t * 200.0) as u64;
            [1e4 * test_signal(k, 31), 1e4 * test_signal(k, 32), 5e3 * test_signal(k, 33)]
        };
        let mut without = structure(&fmu, "without", file);
        let a = run(&fmu, &mut without, 0.0, 1e-3, 3000, loads);
        let mut with = structure(&fmu, "with", file);
        let b = run(&fmu, &mut with, 0.0, 1e-3, 3000, |t| {
            let [az, el, dish] = loads(t);
            [az, el, dish, 7e3, -4e3 - t, 2e3]
        });
        let bits = |r: &[[f64; 2]]| r.iter().flat_map(|o| o.map(f64::to_bits)).collect::<Vec<_>>();
        assert!(bits(&a) == bits(&b), "{file:?}: the resolved forces moved a mode that does not take them");
        assert_eq!(output_bits(&fmu, &mut without), output_bits(&fmu, &mut with));
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_takes_parameters_say_which_wind_forces_the_modes_weigh() {
    // A master may leave unset the forces that no mode takes (the antenna master does, which
    // saves it a twentieth of a step): the shipped modes take none, the coupled modes only the
    // drag, the resolved-force modes the axial, lateral and lift forces but not the drag.
    let fmu = open("Structure");
    let dir = scratch("takes");
    let (coupled, resolved) = (dir.join("coupled.params"), dir.join("resolved.params"));
    std::fs::write(&coupled, COUPLED_MODES).unwrap();
    std::fs::write(&resolved, RESOLVED_MODES).unwrap();
    let names = ["takes.force.dish", "takes.force.axial", "takes.force.lateral", "takes.force.lift"];
    let vrs: Vec<u32> = names.iter().map(|name| fmu.description.vr(name).unwrap()).collect();
    let cases = [
        (None, [false; 4]),
        (Some(coupled.to_str().unwrap()), [true, false, false, false]),
        (Some(resolved.to_str().unwrap()), [false, true, true, true]),
    ];
    for (file, expected) in cases {
        let mut instance = structure(&fmu, "takes", file);
        let mut takes = [!expected[0]; 4];
        instance.get_boolean(&vrs, &mut takes).unwrap();
        assert_eq!(takes, expected, "{file:?}: {names:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A coupled run of the paper's drive model with the structure of `modes_file`, holding
/// azimuth 100 deg, elevation 30 deg in a steady 9.8 m/s wind from `direction` (no gust: the
/// static deflection is then exact); the trace and the wind unit's lateral force at the end.
fn coupled_hold(fmus: &FmuSet, modes_file: &str, direction: f64, lanes: Lanes) -> (Trace, f64) {
    let mut config = Configuration::Paper.antenna_config();
    config.structure = Some(vec![("modes_file".into(), antenna_sim::ParameterValue::Text(modes_file.into()))]);
    config.wind = WindCondition { mean_speed_m_s: 9.8, roughness_length_m: 0.0105, direction_deg: direction, seed: 1 };
    config.wind_unit.push(("spectrum".into(), antenna_sim::ParameterValue::Integer(3)));
    config.lanes = lanes;
    let table = CommandTable::new(vec![
        CommandPoint { time_s: 0.0, azimuth_deg: 100.0, elevation_deg: 30.0 },
        CommandPoint { time_s: 2.0, azimuth_deg: 100.0, elevation_deg: 30.0 },
    ])
    .unwrap();
    let mut antenna = CoupledAntenna::new(fmus, &config, &table).unwrap();
    let mut trace = Trace::default();
    antenna.run_steps(&table, 2000, Some(&mut trace), &mut |_| {}).unwrap();
    let lateral = {
        let mut value = [f64::NAN];
        antenna.wind.get_real(&[fmus.wind.description.vr("force.lateral").unwrap()], &mut value).unwrap();
        value[0]
    };
    (trace, lateral)
}

#[test]
fn in_the_coupled_antenna_a_lateral_force_mode_sees_none_in_front_wind_and_the_wind_forces_lateral_part_when_it_turns()
{
    let directory = antenna_fmus::fmu_directory();
    let fmus = FmuSet::open(&directory).unwrap();
    let dir = scratch("coupled-lateral");
    let path = dir.join("lateral.params");
    // The azimuth mode takes only the lateral force (a 5 m lever arm; physical scaling); the
    // elevation mode is the shipped one.
    let (p, k) = (5.0, 4e8);
    let modes = format!(
        "mode1.frequency = 6.0\nmode1.damping = 0.015\nmode1.stiffness = {k:e}\nmode1.azimuth_torque = 0\nmode1.elevation_torque = 0\nmode1.dish_force = 0\nmode1.lateral_force = {p}\nmode1.beam_azimuth = 1\nmode1.beam_elevation = 0\n\
         mode2.frequency = 6.0\nmode2.damping = 0.015\nmode2.stiffness = 4e8\nmode2.azimuth_torque = 0\nmode2.elevation_torque = 1\nmode2.dish_force = 0\nmode2.beam_azimuth = 0\nmode2.beam_elevation = 1\n"
    );
    std::fs::write(&path, modes).unwrap();
    let file = path.to_str().unwrap();
    // Drag and side force by hand (docs/wind-model.md): q A C_D0 |cos el cos yaw| and
    // q A C_L0 cos^2 el sin(2 yaw) at 9.8 m/s, el 30 deg.
    let q_a = 0.5 * 1.075 * 9.8 * 9.8 * std::f64::consts::PI * 13.5 * 13.5 / 4.0;
    let drag = |yaw: f64| q_a * 1.3 * (30f64.to_radians().cos() * yaw.to_radians().cos()).abs();
    let side = |yaw: f64| q_a * 0.3 * 30f64.to_radians().cos().powi(2) * (2.0 * yaw.to_radians()).sin();
    // Azimuth 100 deg: wind from 100 is yaw 0 (into the face); turned by 90 deg, from 55 and
    // from 145, yaw -45 and +45.
    let mut statics = Vec::new();
    for (direction, yaw) in [(100.0, 0.0_f64), (55.0, -45.0), (145.0, 45.0)] {
        let (trace, lateral) = coupled_hold(&fmus, file, direction, Lanes::One);
        let beam = trace.beam_offset_static_arcsec[trace.beam_offset_static_arcsec.len() - 1][0];
        let (sin, cos) = yaw.to_radians().sin_cos();
        let by_hand = (-drag(yaw) * sin + side(yaw) * cos) * p / k * ARCSEC_PER_RAD;
        let from_wind = lateral * p / k * ARCSEC_PER_RAD;
        println!(
            "wind from {direction} deg (yaw {yaw:+}): static beam azimuth offset {beam:+.6} arcsec; lateral force {lateral:+.1} N x {p} m / {k:e} N m = {from_wind:+.6}; by hand -drag sin(yaw) + side cos(yaw) {by_hand:+.6}"
        );
        assert!((beam - from_wind).abs() <= 1e-9 * from_wind.abs().max(1e-3), "{beam} against {from_wind}");
        if yaw == 0.0 {
            // Only the axis's servo error (arcseconds) turns the drag off the boresight: less
            // than 1e-4 of what the whole drag would give (a yaw of 1e-4 rad, 21 arcsec).
            let whole = drag(0.0) * p / k * ARCSEC_PER_RAD;
            assert!(beam.abs() < 1e-4 * whole, "front wind: {beam} arcsec against {whole} for the whole drag");
        } else {
            assert!((beam / by_hand - 1.0).abs() < 0.01, "yaw {yaw}: {beam} against {by_hand}");
        }
        statics.push(beam);
    }
    // Turning the wind from 55 to 145 deg mirrors the lateral push: the beam moves to the other side.
    assert!(statics[1] > 0.0 && statics[2] < 0.0 && (statics[1] + statics[2]).abs() < 1e-3 * statics[1]);
    // The same values cross between the threads of the two-lane master.
    let (one, _) = coupled_hold(&fmus, file, 145.0, Lanes::One);
    let (two, _) = coupled_hold(&fmus, file, 145.0, Lanes::Two);
    assert!(
        one.beam_offset_arcsec == two.beam_offset_arcsec
            && one.beam_offset_static_arcsec == two.beam_offset_static_arcsec
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The frequency of the largest |H1| between `low` and `high` Hz, refined by a parabola through
/// the peak bin and its neighbours (on the log magnitude).
fn peak_frequency(frequency_hz: &[f64], magnitude: &[f64], low: f64, high: f64) -> f64 {
    let (k, _) = frequency_hz
        .iter()
        .zip(magnitude)
        .enumerate()
        .filter(|(_, (f, _))| **f >= low && **f <= high)
        .max_by(|a, b| a.1 .1.total_cmp(b.1 .1))
        .unwrap();
    let (a, b, c) = (magnitude[k - 1].ln(), magnitude[k].ln(), magnitude[k + 1].ln());
    let shift = 0.5 * (a - c) / (a - 2.0 * b + c);
    frequency_hz[k] + shift * (frequency_hz[k + 1] - frequency_hz[k])
}

#[test]
fn each_mode_shows_in_the_frf_from_load_torque_to_beam_offset_at_its_documented_frequency() {
    let fmu = open("Structure");
    let modes = shipped_modes();
    let step = 2e-3;
    let steps = 600_000;
    let mut instance = structure(&fmu, "frf", None);
    // Independent white torques on the two axes, constant over each step.
    let torque = |t: f64, seed: u64| 1e4 * test_signal((t / step).round() as u64, seed);
    let offsets = run(&fmu, &mut instance, 0.0, step, steps, |t| [torque(t, 1), torque(t, 2), 0.0]);
    let config = WelchConfig::new(1 << 15);
    for (axis, mode) in modes.iter().enumerate() {
        let input: Vec<f64> = (0..steps).map(|k| torque(k as f64 * step, axis as u64 + 1)).collect();
        let output: Vec<f64> = offsets.iter().map(|o| o[axis]).collect();
        let estimate = transfer_function_h1(&input, &output, 1.0 / step, &config).unwrap();
        let magnitude: Vec<f64> = estimate.h1.iter().map(|h| h.norm()).collect();
        let peak = peak_frequency(&estimate.frequency_hz, &magnitude, 0.5, 50.0);
        let error = peak / mode.frequency_hz - 1.0;
        println!(
            "axis {axis}: FRF peak {peak:.4} Hz, documented {} Hz (damping {}), error {:.3} % (resolution {:.4} Hz)",
            mode.frequency_hz,
            mode.damping_ratio,
            100.0 * error,
            estimate.frequency_hz[1]
        );
        assert!(error.abs() < 0.02, "axis {axis}: peak at {peak} Hz, documented {} Hz", mode.frequency_hz);
        // Below the mode the FRF tends to the static compliance.
        let low = estimate.frequency_hz.iter().position(|f| *f >= 0.5).unwrap();
        let compliance = static_offset(&modes, &[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]][axis])[axis];
        assert!(
            (magnitude[low] / compliance - 1.0).abs() < 0.05,
            "axis {axis}: |H(0.5 Hz)| {} against {compliance}",
            magnitude[low]
        );
    }
}

#[test]
fn results_do_not_depend_on_the_communication_step_for_piecewise_constant_loads() {
    let fmu = open("Structure");
    let hold = 5e-3;
    let duration = 10.0;
    let loads = |t: f64| {
        let k = (t / hold + 1e-6).floor() as u64;
        [1e4 * test_signal(k, 11), 1e4 * test_signal(k, 12), 5e3 * test_signal(k, 13)]
    };
    let dir = scratch("steps");
    let coupled = dir.join("coupled.params");
    std::fs::write(&coupled, COUPLED_MODES).unwrap();
    for file in [None, Some(coupled.to_str().unwrap())] {
        let mut records = Vec::new();
        for step in [1e-3, 0.25e-3, 5e-3] {
            let mut instance = structure(&fmu, "steps", file);
            let every = (hold / step).round() as usize;
            let offsets = run(&fmu, &mut instance, 0.0, step, (duration / step).round() as usize, loads);
            records.push(offsets.into_iter().skip(every - 1).step_by(every).collect::<Vec<_>>());
        }
        for axis in 0..2 {
            let reference: Vec<f64> = records[0].iter().map(|o| o[axis]).collect();
            let range = reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (other, step) in records[1..].iter().zip(["0.25 ms", "5 ms"]) {
                assert_eq!(other.len(), reference.len());
                let worst = other.iter().zip(&reference).map(|(o, r)| (o[axis] - r).abs()).fold(0.0, f64::max);
                println!(
                    "{}: axis {axis}: {step} against 1 ms: largest difference {worst:.2e} arcsec, {:.1e} of the largest offset {range:.3} arcsec",
                    if file.is_some() { "coupled modes" } else { "shipped modes" },
                    worst / range
                );
                assert!(worst <= 1e-9 * range, "axis {axis}: {step} differs from 1 ms by {worst} arcsec");
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_bad_modes_file_is_an_fmi2_error_naming_the_file_and_the_cause() {
    let fmu = open("Structure");
    let dir = scratch("bad");
    let good = COUPLED_MODES;
    let cases = [
        (
            "negative_frequency",
            good.replace("mode2.frequency = 7.0", "mode2.frequency = -7.0"),
            "the frequency must be positive",
        ),
        ("typo", good.replace("mode1.stiffness", "mode1.stifness"), "`mode1.stifness` is not a mode field"),
        ("missing_field", good.replace("mode3.damping = 0.005\n", ""), "mode3.damping is missing"),
        ("gap", good.replace("mode2.", "mode4."), "mode 2 is missing"),
        ("not_a_number", good.replace("mode1.damping = 0.02", "mode1.damping = low"), "`low` is not a number"),
        ("empty", String::from("# no modes\n"), "no modes"),
        (
            "drag_twice",
            good.replace("mode2.dish_force = 2.5\n", "mode2.dish_force = 2.5\nmode2.lateral_force = 1\n"),
            "not both",
        ),
    ];
    for (name, text, cause) in cases {
        let path = dir.join(format!("{name}.params"));
        std::fs::write(&path, text).unwrap();
        let mut instance = fmu.instantiate(name, false).unwrap();
        instance.setup_experiment(0.0, None).unwrap();
        let result = instance.set_string(&[fmu.description.vr("modes_file").unwrap()], &[path.to_str().unwrap()]);
        let messages = expect_error(result, &instance, name).join("\n");
        println!("{name}: {messages}");
        assert!(messages.contains(path.to_str().unwrap()), "{name}: the message does not name the file: {messages}");
        assert!(messages.contains(cause), "{name}: expected {cause:?} in {messages}");
    }
    std::fs::remove_dir_all(&dir).ok();
    let mut instance = fmu.instantiate("missing", false).unwrap();
    instance.setup_experiment(0.0, None).unwrap();
    let result = instance.set_string(&[fmu.description.vr("modes_file").unwrap()], &["no_such_modes.params"]);
    let messages = expect_error(result, &instance, "missing").join("\n");
    assert!(messages.contains("cannot read modes file") && messages.contains("no_such_modes.params"), "{messages}");
}

#[test]
fn a_restored_fmu_state_replays_the_run_bitwise() {
    let fmu = open("Structure");
    let loads = |t: f64| [1e4 * test_signal((t * 100.0) as u64, 21), 1e4 * test_signal((t * 100.0) as u64, 22), 0.0];
    let mut original = structure(&fmu, "original", None);
    run(&fmu, &mut original, 0.0, 1e-3, 777, loads);
    let start = 0.777;
    let at_save = output_bits(&fmu, &mut original);
    let state = original.get_state().unwrap();
    // Mixed step sizes: the discretisation cache is not state and must not matter.
    let schedule = |instance: &mut Instance| {
        let mut t = start;
        let mut out = Vec::new();
        for k in 0..3000 {
            let h = [1e-3, 0.25e-3, 5e-3][k % 3];
            out.extend(run(&fmu, instance, t, h, 1, loads).into_iter().map(|o| o.map(f64::to_bits)));
            t += h;
        }
        out
    };
    let first = schedule(&mut original);
    original.set_state(&state).unwrap();
    assert_eq!(output_bits(&fmu, &mut original), at_save, "the restored outputs differ");
    assert!(schedule(&mut original) == first, "the run after fmi2SetFMUstate differs");
    let bytes = original.serialize_state(&state).unwrap();
    let mut fresh = fmu.instantiate("fresh", false).unwrap();
    let restored = fresh.deserialize_state(&bytes).unwrap();
    fresh.set_state(&restored).unwrap();
    assert_eq!(fresh.serialize_state(&restored).unwrap(), bytes, "deserialize then serialize is not the identity");
    assert!(schedule(&mut fresh) == first, "a deserialized state continues differently");
}

/// One lightly damped azimuth mode that changes with elevation: 6 Hz at the zenith, 7 Hz at the
/// horizon (a dish's inertia about the vertical axis is largest with its boresight vertical).
const ELEVATION_MODES: &str = "\
mode1.frequency = 6.0\nmode1.horizon_frequency = 7.0\nmode1.damping = 0.002\nmode1.stiffness = 4e8\nmode1.azimuth_torque = 1\nmode1.elevation_torque = 0\nmode1.dish_force = 0\nmode1.beam_azimuth = 1\nmode1.beam_elevation = 0\n";

/// The frequency of a ringing record (one value per `step` seconds) from its zero crossings,
/// interpolated linearly between samples, Hz.
fn ringing_frequency(record: &[f64], step: f64) -> f64 {
    let crossings: Vec<f64> = record
        .windows(2)
        .enumerate()
        .filter(|(_, w)| w[0] < 0.0 && w[1] >= 0.0)
        .map(|(k, w)| (k as f64 + w[0] / (w[0] - w[1])) * step)
        .collect();
    let (first, last) = (crossings[0], crossings[crossings.len() - 1]);
    (crossings.len() - 1) as f64 / (last - first)
}

#[test]
fn a_mode_with_a_horizon_frequency_rings_at_each_elevation_at_the_documented_frequency() {
    let fmu = open("Structure");
    let dir = scratch("elevation");
    let file = dir.join("elevation.params");
    std::fs::write(&file, ELEVATION_MODES).unwrap();
    let (zenith_hz, horizon_hz, damping, stiffness) = (6.0_f64, 7.0_f64, 0.002_f64, 4e8);
    let inertia = |f: f64| stiffness / (std::f64::consts::TAU * f).powi(2);
    let step = 1e-3;
    for elevation_deg in [0.0, 15.0, 45.0, 88.0] {
        let mut instance = fmu.instantiate("elevation", false).unwrap();
        instance.setup_experiment(0.0, None).unwrap();
        instance.set_string(&[fmu.description.vr("modes_file").unwrap()], &[file.to_str().unwrap()]).unwrap();
        set_reals(&fmu, &mut instance, &[("axis.elevation", elevation_deg)]);
        instance.enter_initialization_mode().unwrap();
        instance.exit_initialization_mode().unwrap();
        // docs/structure-model.md: 1 / f^2 = cos^2(el) / f_horizon^2 + sin^2(el) / f_zenith^2,
        // damped by sqrt(1 - zeta^2). The FMU holds each 0.25 deg cell at its centre's frequency,
        // within 0.03 % of the elevation's here.
        let (s, c) = elevation_deg.to_radians().sin_cos();
        let undamped = 1.0 / (c * c / (horizon_hz * horizon_hz) + s * s / (zenith_hz * zenith_hz)).sqrt();
        let expected = undamped * (1.0 - damping * damping).sqrt();
        // A torque held for one step, then 20 s of free ringing.
        let offsets = run(&fmu, &mut instance, 0.0, step, 20_000, |t| [if t < step / 2.0 { 1e5 } else { 0.0 }]);
        let record: Vec<f64> = offsets.iter().map(|o| o[0]).collect();
        let measured = ringing_frequency(&record, step);
        println!("elevation {elevation_deg} deg: rings at {measured:.4} Hz, documented {expected:.4} Hz");
        assert!((measured / expected - 1.0).abs() < 5e-4, "{elevation_deg} deg: {measured} Hz against {expected} Hz");
        let takes = fmu.description.vr("takes.axis.elevation").unwrap();
        let mut says = [false];
        instance.get_boolean(&[takes], &mut says).unwrap();
        assert!(says[0], "a mode with a horizon frequency takes the elevation");
        let carried = reals(&fmu, &mut instance, &["modal_inertia.azimuth", "modal_inertia.azimuth_horizon"]).unwrap();
        assert!((carried[0] / inertia(zenith_hz) - 1.0).abs() < 1e-12, "{carried:?}");
        assert!((carried[1] / inertia(horizon_hz) - 1.0).abs() < 1e-12, "{carried:?}");
    }
    // The shipped modes do not change with elevation: the two ends carry the same inertia. The
    // elevation input still matters, through the azimuth twist's projection on the sky.
    let mut shipped = structure(&fmu, "shipped", None);
    let takes = fmu.description.vr("takes.axis.elevation").unwrap();
    let mut says = [false];
    shipped.get_boolean(&[takes], &mut says).unwrap();
    assert!(says[0], "the shipped azimuth twist is projected with cos(elevation)");
    let ends = reals(
        &fmu,
        &mut shipped,
        &[
            "modal_inertia.azimuth",
            "modal_inertia.azimuth_horizon",
            "modal_inertia.elevation",
            "modal_inertia.elevation_horizon",
        ],
    )
    .unwrap();
    assert_eq!((ends[0], ends[2]), (ends[1], ends[3]));
    // Their frequencies do not change either: the elevation offset is the same bit for bit at
    // any elevation, and the azimuth twist reaches the sky times cos(elevation).
    let at = |elevation_deg: f64| {
        let mut instance = structure(&fmu, "shipped-elevation", None);
        set_reals(&fmu, &mut instance, &[("axis.elevation", elevation_deg)]);
        run(&fmu, &mut instance, 0.0, step, 2_000, |t| [1e4 * (7.0 * t).sin(), 5e3])
    };
    let (low, high) = (at(15.0), at(88.0));
    let ratio = 88f64.to_radians().cos() / 15f64.to_radians().cos();
    for (a, b) in low.iter().zip(&high) {
        assert_eq!(a[1].to_bits(), b[1].to_bits());
        assert!((b[0] - ratio * a[0]).abs() <= 1e-12 * a[0].abs().max(1e-9), "{a:?} {b:?}");
    }
}

#[test]
fn coupled_both_ways_the_azimuth_plant_keeps_its_inertia_less_the_modes_at_every_elevation() {
    use antenna_sim::coupled::leave_out_carried_inertia;
    // A mode that carries 2.814e5 kg m^2 at the zenith and 2.068e5 at the horizon (6 and 7 Hz at
    // 4e8 N m/rad), and one that carries more at the horizon: the plant's inertia plus the
    // modes', `horizon cos^2 + zenith sin^2`, is the plant's own at every elevation.
    let plant = open("AzimuthPlant");
    let inertia_at = |instance: &mut Instance, elevation_deg: f64| {
        set_reals(&plant, instance, &[("elevation", elevation_deg)]);
        reals(&plant, instance, &["load.inertia"]).unwrap()[0]
    };
    let initialised = |carried: Option<(f64, f64)>| {
        let mut instance = plant.instantiate("inertia", false).unwrap();
        instance.setup_experiment(0.0, None).unwrap();
        instance.enter_initialization_mode().unwrap();
        if let Some((zenith, horizon)) = carried {
            leave_out_carried_inertia(&mut instance, &plant.description, 0, zenith, horizon).unwrap();
        }
        instance.exit_initialization_mode().unwrap();
        instance
    };
    let mut whole = initialised(None);
    for (zenith, horizon) in [(2.814e5, 2.068e5), (2.068e5, 2.814e5), (2.814e5, 2.814e5)] {
        let mut rest = initialised(Some((zenith, horizon)));
        for elevation_deg in [0.0, 15.0, 45.0, 70.0, 90.0] {
            // The plant reports the inertia of its elevation cell's centre.
            let frozen = fmu_plant::AzimuthParams::default().frozen_elevation_deg(elevation_deg);
            let (s, c) = frozen.to_radians().sin_cos();
            let carried = horizon * c * c + zenith * s * s;
            let (own, kept) = (inertia_at(&mut whole, elevation_deg), inertia_at(&mut rest, elevation_deg));
            assert!(
                ((kept + carried) / own - 1.0).abs() < 1e-12,
                "zenith {zenith}, horizon {horizon}, {elevation_deg} deg: {kept} + {carried} against {own}"
            );
        }
    }
    // The elevation plant's inertia does not change with elevation: modes whose inertia about
    // that axis does cannot be coupled both ways to it.
    let elevation_plant = open("ElevationPlant");
    let mut instance = elevation_plant.instantiate("inertia", false).unwrap();
    instance.setup_experiment(0.0, None).unwrap();
    instance.enter_initialization_mode().unwrap();
    let error = leave_out_carried_inertia(&mut instance, &elevation_plant.description, 1, 2.0e5, 1.5e5).unwrap_err();
    assert!(error.to_string().contains("cannot be coupled both ways"), "{error}");
}
