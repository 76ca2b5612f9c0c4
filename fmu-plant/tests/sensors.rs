//! The sensor model of both plants: with every error at zero the encoder reads exactly what the
//! plant read before the sensor model, and each error alone leaves its analytic signature in
//! `encoder_error_arcsec` (reading minus true angle).

use fmu_plant::{
    AzimuthInputs, AzimuthParams, AzimuthPlant, CountMode, ElevationInputs, ElevationParams, ElevationPlant,
    PeriodicError,
};

/// The encoder reading before the sensor model: the angle rounded down to whole counts.
fn truncated_reading_deg(angle_deg: f64, bits: u32) -> f64 {
    let count = std::f64::consts::TAU / (1u64 << bits) as f64;
    ((angle_deg.to_radians() / count).floor() * count).to_degrees()
}

/// A torque-biased azimuth run that reverses, with every output recorded.
fn azimuth_run(params: AzimuthParams, steps: usize, h: f64) -> Vec<fmu_plant::AzimuthOutputs> {
    let mut plant = AzimuthPlant::new(params).unwrap();
    plant.set_initial_state(10f64.to_radians()).unwrap();
    let mut out = vec![plant.outputs()];
    for k in 0..steps {
        let common = 3.0 * (k as f64 * h * 2.0).sin();
        let inputs = AzimuthInputs {
            current_command_a: [common + 1.0, common - 1.0],
            disturbance_torque_nm: 500.0,
            elevation_deg: 40.0,
        };
        plant.step(&inputs, h).unwrap();
        out.push(plant.outputs());
    }
    out
}

#[test]
fn with_every_error_at_zero_the_encoder_reads_the_truncated_true_angle_bit_for_bit() {
    let ideal = azimuth_run(AzimuthParams::default(), 3000, 1e-3);
    // Zero amplitudes with other harmonics, phases, seeds and sample periods change nothing.
    let mut zeroed = AzimuthParams::default();
    zeroed.sensors.encoder.graduation[0] =
        PeriodicError { amplitude_arcsec: 0.0, cycles_per_turn: 7.0, phase_deg: 33.0 };
    zeroed.sensors.encoder.eccentricity.phase_deg = 80.0;
    zeroed.sensors.seed = 99;
    zeroed.sensors.sample_period_s = 3e-4;
    let zeroed = azimuth_run(zeroed, 3000, 1e-3);
    let mut moved = 0.0f64;
    for (a, b) in ideal.iter().zip(&zeroed) {
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
        assert_eq!(a.encoder_position_deg.to_bits(), truncated_reading_deg(a.axis_position_deg, 25).to_bits());
        let error = (a.encoder_position_deg - a.axis_position_deg) * 3600.0;
        assert!((a.encoder_error_arcsec - error).abs() < 1e-6, "{a:?}");
        moved = moved.max((a.axis_position_deg - 10.0).abs());
    }
    assert!(moved > 1e-3, "the axis must move through many counts: {moved} deg");
}

#[test]
fn elevation_encoder_with_every_error_at_zero_reads_the_truncated_true_angle() {
    let mut plant = ElevationPlant::new(ElevationParams::default()).unwrap();
    plant.set_initial_state(45f64.to_radians()).unwrap();
    for k in 0..2000 {
        let inputs = ElevationInputs { current_command_a: 2.0 * (k as f64 * 2e-3).sin(), disturbance_torque_nm: 0.0 };
        plant.step(&inputs, 1e-3).unwrap();
        let o = plant.outputs();
        assert_eq!(o.encoder_position_deg.to_bits(), truncated_reading_deg(o.axis_position_deg, 25).to_bits());
    }
}

/// The encoder error of an azimuth plant put at rest at each angle of a uniform grid over one
/// turn, unquantised or with the default 25 bits.
fn error_over_a_turn(params: AzimuthParams, points: usize) -> Vec<(f64, f64)> {
    let mut plant = AzimuthPlant::new(params).unwrap();
    (0..points)
        .map(|j| {
            let angle = std::f64::consts::TAU * j as f64 / points as f64;
            plant.set_initial_state(angle).unwrap();
            (angle, plant.outputs().encoder_error_arcsec)
        })
        .collect()
}

/// Amplitude and phase (deg) of the harmonic `cycles` per turn in a uniformly sampled turn, as
/// `A sin(c theta + phi)`.
fn harmonic(samples: &[(f64, f64)], cycles: f64) -> (f64, f64) {
    let n = samples.len() as f64;
    let (mut s, mut c) = (0.0, 0.0);
    for &(angle, e) in samples {
        s += e * (cycles * angle).sin();
        c += e * (cycles * angle).cos();
    }
    let (a_sin, a_cos) = (2.0 * s / n, 2.0 * c / n);
    (a_sin.hypot(a_cos), a_cos.atan2(a_sin).to_degrees())
}

#[test]
fn a_graduation_harmonic_alone_appears_at_its_angle_period_with_its_amplitude_and_phase() {
    let mut params = AzimuthParams::default();
    params.sensors.encoder.graduation[1] =
        PeriodicError { amplitude_arcsec: 1.5, cycles_per_turn: 3.0, phase_deg: 40.0 };
    let samples = error_over_a_turn(params, 7200);
    let (amplitude, phase) = harmonic(&samples, 3.0);
    assert!((amplitude - 1.5).abs() < 0.015, "amplitude {amplitude}");
    assert!((phase - 40.0).abs() < 1.0, "phase {phase}");
    // Nothing at the neighbouring harmonics: the period is 120 deg, not 90 or 180.
    for other in [1.0, 2.0, 4.0] {
        assert!(harmonic(&samples, other).0 < 0.01, "harmonic {other}: {:?}", harmonic(&samples, other));
    }
}

#[test]
fn eccentricity_alone_is_a_once_per_revolution_sinusoid() {
    let mut params = AzimuthParams { encoder_bits: 0, ..AzimuthParams::default() };
    params.sensors.encoder.eccentricity =
        PeriodicError { amplitude_arcsec: 2.0, cycles_per_turn: 1.0, phase_deg: 30.0 };
    let samples = error_over_a_turn(params, 3600);
    let (amplitude, phase) = harmonic(&samples, 1.0);
    assert!((amplitude - 2.0).abs() < 0.02 && (phase - 30.0).abs() < 0.5, "{amplitude} {phase}");
    for &(angle, e) in &samples {
        assert!((e - 2.0 * (angle + 30f64.to_radians()).sin()).abs() < 1e-6, "at {angle}: {e}");
    }
}

#[test]
fn interpolation_error_repeats_with_the_signal_period() {
    // 32768 signal periods per turn: one period is 39.55 arcsec. Sample two periods finely.
    let mut params = AzimuthParams { encoder_bits: 0, ..AzimuthParams::default() };
    params.sensors.encoder.interpolation[0].amplitude_arcsec = 0.4;
    let period = std::f64::consts::TAU / 32768.0;
    let mut plant = AzimuthPlant::new(params).unwrap();
    let points = 400;
    let samples: Vec<(f64, f64)> = (0..points)
        .map(|j| {
            let angle = 1.0 + 2.0 * period * j as f64 / points as f64;
            plant.set_initial_state(angle).unwrap();
            (angle, plant.outputs().encoder_error_arcsec)
        })
        .collect();
    let (amplitude, _) = harmonic(&samples.iter().map(|&(a, e)| (a - 1.0, e)).collect::<Vec<_>>(), 32768.0);
    assert!((amplitude - 0.4).abs() < 0.004, "amplitude {amplitude}");
    for j in 0..points / 2 {
        assert!((samples[j].1 - samples[j + points / 2].1).abs() < 1e-6, "not periodic at {j}");
    }
}

/// Mean encoder error over a slow sweep of many counts, arcsec, with a count of `bits`.
fn mean_error_over_a_sweep(bits: u32, mode: CountMode) -> f64 {
    let mut params = AzimuthParams { encoder_bits: bits, ..AzimuthParams::default() };
    params.sensors.encoder.count_mode = mode;
    let samples = error_over_a_turn(params, 100_003);
    samples.iter().map(|s| s.1).sum::<f64>() / samples.len() as f64
}

#[test]
fn rounding_has_zero_mean_error_where_truncation_has_minus_half_a_count() {
    let bits = 20;
    let count_arcsec = 360.0 * 3600.0 / f64::from(1u32 << bits);
    let truncated = mean_error_over_a_sweep(bits, CountMode::Truncate);
    let rounded = mean_error_over_a_sweep(bits, CountMode::Round);
    assert!((truncated + 0.5 * count_arcsec).abs() < 0.02 * count_arcsec, "truncate: {truncated} arcsec");
    assert!(rounded.abs() < 0.02 * count_arcsec, "round: {rounded} arcsec");
}

/// The encoder error and the motor 1 speed signal of an azimuth plant at rest, with noise, read
/// at every communication point of a run of `h`-second steps over `duration` seconds.
fn noise_at_rest(seed: u64, h: f64, duration: f64) -> Vec<(f64, f64, f64)> {
    let mut params = AzimuthParams { encoder_bits: 0, ..AzimuthParams::default() };
    params.sensors.encoder.noise_rms_arcsec = 0.5;
    params.sensors.motor_speed_noise_rms_rad_per_s = [0.05, 0.05];
    params.sensors.seed = seed;
    let mut plant = AzimuthPlant::new(params).unwrap();
    plant.set_initial_state(0.3).unwrap();
    let steps = (duration / h).round() as usize;
    let mut out = Vec::with_capacity(steps + 1);
    let o = plant.outputs();
    out.push((0.0, o.encoder_error_arcsec, o.motor_speed_rad_per_s[0]));
    for k in 1..=steps {
        plant.step(&AzimuthInputs { elevation_deg: 45.0, ..AzimuthInputs::default() }, h).unwrap();
        let o = plant.outputs();
        out.push((k as f64 * h, o.encoder_error_arcsec, o.motor_speed_rad_per_s[0]));
    }
    out
}

#[test]
fn reading_noise_has_its_rms_is_reproducible_and_does_not_depend_on_the_communication_step() {
    let millisecond = noise_at_rest(5, 1e-3, 20.0);
    let n = millisecond.len() as f64;
    let rms = (millisecond.iter().map(|s| s.1 * s.1).sum::<f64>() / n).sqrt();
    let speed_rms = (millisecond.iter().map(|s| s.2 * s.2).sum::<f64>() / n).sqrt();
    // 20001 independent samples: the sample RMS has a relative standard error 1/sqrt(2 n) = 0.5 %;
    // the bound is four of them.
    assert!((rms / 0.5 - 1.0).abs() < 4.0 / (2.0 * n).sqrt(), "encoder noise rms {rms}");
    assert!((speed_rms / 0.05 - 1.0).abs() < 4.0 / (2.0 * n).sqrt(), "speed noise rms {speed_rms}");
    // Same seed, same values; another seed, other values.
    assert_eq!(format!("{millisecond:?}"), format!("{:?}", noise_at_rest(5, 1e-3, 20.0)));
    let other = noise_at_rest(6, 1e-3, 20.0);
    assert!(millisecond.iter().zip(&other).all(|(a, b)| a.1 != b.1 && a.2 != b.2));
    // 0.5 ms and 2 ms steps read the same samples at the common instants; between two sample
    // instants the sample is held.
    let half = noise_at_rest(5, 0.5e-3, 20.0);
    let double = noise_at_rest(5, 2e-3, 20.0);
    for (k, m) in millisecond.iter().enumerate() {
        assert!((half[2 * k].1 - m.1).abs() < 1e-9 && half[2 * k].2 == m.2, "0.5 ms at {} s", m.0);
        if k + 1 < millisecond.len() {
            assert!((half[2 * k + 1].1 - m.1).abs() < 1e-9, "held over the sample period at {} s", m.0);
        }
        if k % 2 == 0 {
            assert!((double[k / 2].1 - m.1).abs() < 1e-9 && double[k / 2].2 == m.2, "2 ms at {} s", m.0);
        }
    }
    // Neighbouring samples are uncorrelated (white at the sample rate).
    let lag1 = millisecond.windows(2).map(|w| w[0].1 * w[1].1).sum::<f64>() / (n * rms * rms);
    assert!(lag1.abs() < 4.0 / n.sqrt(), "lag-1 correlation {lag1}");
}

#[test]
fn a_restored_state_replays_the_same_noise() {
    let mut params = ElevationParams::default();
    params.sensors.encoder.noise_rms_arcsec = 1.0;
    params.sensors.motor_speed_noise_rms_rad_per_s = [0.1];
    let mut plant = ElevationPlant::new(params).unwrap();
    plant.set_initial_state(45f64.to_radians()).unwrap();
    let inputs = ElevationInputs { current_command_a: 0.5, disturbance_torque_nm: 0.0 };
    for _ in 0..100 {
        plant.step(&inputs, 1e-3).unwrap();
    }
    let saved = plant.save_state();
    let run = |plant: &mut ElevationPlant| -> Vec<(u64, u64)> {
        (0..50)
            .map(|_| {
                plant.step(&inputs, 0.7e-3).unwrap();
                let o = plant.outputs();
                (o.encoder_position_deg.to_bits(), o.motor_speed_rad_per_s.to_bits())
            })
            .collect()
    };
    let first = run(&mut plant);
    let mut other = ElevationPlant::new(params).unwrap();
    other.load_state(saved).unwrap();
    assert_eq!(first, run(&mut other));
}

#[test]
fn azimuth_and_elevation_noise_differ_for_the_same_seed() {
    let mut az = AzimuthParams::default();
    az.sensors.encoder.noise_rms_arcsec = 1.0;
    let mut el = ElevationParams::default();
    el.sensors.encoder.noise_rms_arcsec = 1.0;
    let (mut a, mut e) = (AzimuthPlant::new(az).unwrap(), ElevationPlant::new(el).unwrap());
    a.set_initial_state(0.0).unwrap();
    e.set_initial_state(0.0).unwrap();
    let (ea, ee) = (a.outputs().encoder_error_arcsec, e.outputs().encoder_error_arcsec);
    assert!(ea != 0.0 && ee != 0.0 && (ea - ee).abs() > 1e-6, "{ea} {ee}");
}
