//! The plants' sensor model through the packaged FMUs, as a master sees it: the default
//! encoder reads the truncated true angle bit for bit (so every earlier result stands), the
//! eccentricity error shows as a once-per-revolution sinusoid, the noise has its RMS, follows
//! its seed and does not depend on the communication step, and the shipped
//! `realistic_sensors.params` loads into both plants.
//!
//! Run with `cargo test --release -p antenna-tests --test integration -- plant_sensors::`.

use antenna_tests::{open, real, reals, set_reals, PLANTS};
use fmu_import::{Fmu, Instance};

/// An initialised plant with Real, Integer and String parameters set before initialisation.
fn configured(fmu: &Fmu, reals: &[(&str, f64)], integers: &[(&str, i32)], file: Option<&str>) -> Instance {
    let md = &fmu.description;
    let mut instance = fmu.instantiate("sensors", false).unwrap();
    instance.setup_experiment(0.0, None).unwrap();
    instance.enter_initialization_mode().unwrap();
    if let Some(file) = file {
        instance.set_string(&[md.vr("parameter_file").unwrap()], &[file]).unwrap();
    }
    set_reals(fmu, &mut instance, reals);
    for (name, value) in integers {
        instance.set_integer(&[md.vr(name).unwrap()], &[*value]).unwrap();
    }
    instance.exit_initialization_mode().unwrap();
    instance
}

fn current_inputs(identifier: &str) -> Vec<&'static str> {
    if identifier == "AzimuthPlant" {
        vec!["motor1.current_command", "motor2.current_command"]
    } else {
        vec!["motor.current_command"]
    }
}

#[test]
fn the_default_encoder_reads_the_truncated_true_angle_bit_for_bit_in_both_fmus() {
    let count_deg = 360.0 / f64::from(1u32 << 25);
    for identifier in PLANTS {
        let fmu = open(identifier);
        let mut instance = configured(&fmu, &[], &[], None);
        let inputs = current_inputs(identifier);
        let mut travelled_counts = 0.0f64;
        let start = real(&fmu, &mut instance, "axis.position");
        for k in 0..2000 {
            let common = 2.0 * (k as f64 * 3e-3).sin();
            let values: Vec<(&str, f64)> = if inputs.len() == 2 {
                vec![(inputs[0], common + 1.0), (inputs[1], common - 1.0)]
            } else {
                vec![(inputs[0], common)]
            };
            set_reals(&fmu, &mut instance, &values);
            instance.do_step(k as f64 * 1e-3, 1e-3).unwrap();
            let v =
                reals(&fmu, &mut instance, &["axis.encoder_position", "axis.position", "axis.encoder_error"]).unwrap();
            let truncated =
                ((v[1].to_radians() / count_deg.to_radians()).floor() * count_deg.to_radians()).to_degrees();
            assert_eq!(v[0].to_bits(), truncated.to_bits(), "{identifier} step {k}: {v:?}");
            assert!((v[2] - (v[0] - v[1]) * 3600.0).abs() < 1e-6, "{identifier} step {k}: {v:?}");
            assert!(v[2] <= 0.0 && v[2] > -count_deg * 3600.0 * (1.0 + 1e-9), "{identifier}: {v:?}");
            travelled_counts = travelled_counts.max((v[1] - start).abs() / count_deg);
        }
        assert!(travelled_counts > 100.0, "{identifier} moved only {travelled_counts} counts");
    }
}

#[test]
fn eccentricity_through_the_fmu_is_a_once_per_revolution_sinusoid_of_its_amplitude() {
    let fmu = open("AzimuthPlant");
    let points = 72;
    let (mut s, mut c) = (0.0, 0.0);
    for j in 0..points {
        // The travel is -185 to 275 deg: one turn from -180 deg.
        let angle_deg = -180.0 + 360.0 * j as f64 / points as f64;
        let mut instance = configured(
            &fmu,
            &[
                ("initial_position", angle_deg),
                ("encoder.eccentricity_error_amplitude", 2.0),
                ("encoder.eccentricity_error_phase", 30.0),
            ],
            &[("encoder.bits", 0)],
            None,
        );
        let error = real(&fmu, &mut instance, "axis.encoder_error");
        let angle = angle_deg.to_radians();
        assert!((error - 2.0 * (angle + 30f64.to_radians()).sin()).abs() < 1e-6, "at {angle_deg} deg: {error}");
        s += error * angle.sin();
        c += error * angle.cos();
    }
    let (a_sin, a_cos) = (2.0 * s / points as f64, 2.0 * c / points as f64);
    let amplitude = a_sin.hypot(a_cos);
    assert!((amplitude - 2.0).abs() < 0.02, "amplitude {amplitude}");
}

/// Encoder error and motor speed signal of a plant at rest with noise on, at every
/// communication point of `h`-second steps over `duration` seconds.
fn noise_record(identifier: &str, seed: i32, h: f64, duration: f64) -> Vec<(f64, f64)> {
    let fmu = open(identifier);
    let speed = if identifier == "AzimuthPlant" { "motor1" } else { "motor" };
    let noise_name = format!("{speed}.speed_noise_rms");
    let mut instance = configured(
        &fmu,
        &[("encoder.noise_rms", 0.5), (noise_name.as_str(), 0.05)],
        &[("sensors.seed", seed), ("encoder.bits", 0)],
        None,
    );
    let names = ["axis.encoder_error".to_string(), format!("{speed}.speed")];
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let steps = (duration / h).round() as usize;
    let mut record = Vec::with_capacity(steps + 1);
    let v = reals(&fmu, &mut instance, &names).unwrap();
    record.push((v[0], v[1]));
    for k in 0..steps {
        instance.do_step(k as f64 * h, h).unwrap();
        let v = reals(&fmu, &mut instance, &names).unwrap();
        record.push((v[0], v[1]));
    }
    record
}

#[test]
fn sensor_noise_through_the_fmu_has_its_rms_follows_its_seed_and_not_the_communication_step() {
    for identifier in PLANTS {
        let millisecond = noise_record(identifier, 3, 1e-3, 10.0);
        let n = millisecond.len() as f64;
        let rms = (millisecond.iter().map(|s| s.0 * s.0).sum::<f64>() / n).sqrt();
        let speed_rms = (millisecond.iter().map(|s| s.1 * s.1).sum::<f64>() / n).sqrt();
        // Relative standard error of a sample RMS: 1/sqrt(2 n); the bound is four of them.
        let bound = 4.0 / (2.0 * n).sqrt();
        assert!((rms / 0.5 - 1.0).abs() < bound, "{identifier}: encoder noise rms {rms}");
        assert!((speed_rms / 0.05 - 1.0).abs() < bound, "{identifier}: speed noise rms {speed_rms}");
        assert_eq!(millisecond, noise_record(identifier, 3, 1e-3, 10.0), "{identifier}: same seed");
        let other = noise_record(identifier, 4, 1e-3, 10.0);
        assert!(millisecond.iter().zip(&other).all(|(a, b)| a.0 != b.0), "{identifier}: another seed");
        let half = noise_record(identifier, 3, 0.5e-3, 10.0);
        let double = noise_record(identifier, 3, 2e-3, 10.0);
        for (k, m) in millisecond.iter().enumerate() {
            assert!((half[2 * k].0 - m.0).abs() < 1e-9 && half[2 * k].1 == m.1, "{identifier} 0.5 ms, sample {k}");
            if k % 2 == 0 {
                assert!(
                    (double[k / 2].0 - m.0).abs() < 1e-9 && double[k / 2].1 == m.1,
                    "{identifier} 2 ms, sample {k}"
                );
            }
        }
    }
}

#[test]
fn the_shipped_realistic_sensor_set_loads_and_gives_arcsecond_encoder_errors() {
    for identifier in PLANTS {
        let fmu = open(identifier);
        let mut instance = configured(&fmu, &[], &[], Some("realistic_sensors.params"));
        let mut worst = 0.0f64;
        for k in 0..500 {
            instance.do_step(k as f64 * 1e-3, 1e-3).unwrap();
            worst = worst.max(real(&fmu, &mut instance, "axis.encoder_error").abs());
        }
        // Graduation 1.5 + interpolation 0.4 + eccentricity 2 arcsec at most, noise 0.02 RMS,
        // half a count of rounding.
        assert!(worst > 0.01 && worst < 4.0, "{identifier}: worst encoder error {worst} arcsec");
    }
}
