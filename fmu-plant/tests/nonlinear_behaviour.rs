//! The effects the paper's control architecture exists for, and the validation effects that are
//! off by default, each checked against what the physics says they must do.

use fmu_plant::{
    AzimuthInputs, AzimuthParams, AzimuthPlant, CoggingParams, ElevationInputs, ElevationParams, ElevationPlant,
    FrictionParams,
};

fn elevation_at(params: ElevationParams, elevation_deg: f64) -> ElevationPlant {
    let mut plant = ElevationPlant::new(params).unwrap();
    plant.set_initial_state(elevation_deg.to_radians()).unwrap();
    plant
}

fn run_elevation(plant: &mut ElevationPlant, current: f64, disturbance: f64, seconds: f64, h: f64) {
    let inputs = ElevationInputs { current_command_a: current, disturbance_torque_nm: disturbance };
    for _ in 0..(seconds / h).round() as usize {
        plant.step(&inputs, h).unwrap();
    }
}

/// Breakaway torque of the elevation motor-side body: motor plus jackscrew referred through the gearbox.
fn elevation_motor_breakaway(p: &ElevationParams, direction: f64) -> f64 {
    let screw = p.jackscrew.screw_friction;
    (1.0 + direction * p.motor.friction.asymmetry) * p.motor.friction.static_nm
        + (1.0 + direction * screw.asymmetry) * screw.static_nm / p.jackscrew.gearbox_ratio
}

#[test]
fn static_friction_holds_the_elevation_drive_until_the_breakaway_torque_is_exceeded() {
    let params = ElevationParams::default();
    let breakaway_current = elevation_motor_breakaway(&params, 1.0) / params.motor.torque_constant_nm_per_a;
    let mut plant = elevation_at(params, 40.0);
    let start = plant.outputs();
    run_elevation(&mut plant, 0.95 * breakaway_current, 0.0, 1.0, 1e-3);
    let held = plant.outputs();
    assert_eq!(held.axis_position_deg, start.axis_position_deg, "the axis crept below breakaway");
    assert_eq!(held.motor_speed_rad_per_s, 0.0);
    run_elevation(&mut plant, 1.05 * breakaway_current, 0.0, 1.0, 1e-3);
    let moving = plant.outputs();
    assert!(moving.motor_speed_rad_per_s > 0.0 && moving.axis_position_deg > start.axis_position_deg);
}

#[test]
fn coulomb_friction_brings_a_coasting_axis_to_rest_where_it_then_sticks() {
    let mut plant = elevation_at(ElevationParams::default(), 40.0);
    run_elevation(&mut plant, 5.0, 0.0, 0.5, 1e-3);
    assert!(plant.outputs().axis_speed_deg_per_s > 0.01);
    run_elevation(&mut plant, 0.0, 0.0, 3.0, 1e-3);
    let rest = plant.outputs();
    assert_eq!(rest.motor_speed_rad_per_s, 0.0, "the motor did not stick");
    assert_eq!(rest.axis_speed_deg_per_s, 0.0, "the load did not stick");
    run_elevation(&mut plant, 0.0, 0.0, 1.0, 1e-3);
    assert_eq!(plant.outputs().axis_position_deg, rest.axis_position_deg, "a stuck axis moved");
}

#[test]
fn asymmetric_friction_breaks_away_at_different_torques_in_each_direction() {
    let mut params = ElevationParams::default();
    params.motor.friction.asymmetry = 0.3;
    params.jackscrew.screw_friction.asymmetry = 0.3;
    let up = elevation_motor_breakaway(&params, 1.0);
    let down = elevation_motor_breakaway(&params, -1.0);
    let between = 0.5 * (up + down) / params.motor.torque_constant_nm_per_a;
    let mut positive = elevation_at(params, 40.0);
    run_elevation(&mut positive, between, 0.0, 0.5, 1e-3);
    assert_eq!(positive.outputs().motor_speed_rad_per_s, 0.0, "moved up below its breakaway torque");
    let mut negative = elevation_at(params, 40.0);
    run_elevation(&mut negative, -between, 0.0, 0.5, 1e-3);
    assert!(negative.outputs().motor_speed_rad_per_s < 0.0, "did not move down above its breakaway torque");
}

#[test]
fn stribeck_friction_holds_the_breakaway_level_at_low_speed_and_falls_to_coulomb_when_fast() {
    let plain = ElevationParams::default();
    let mut stribeck = plain;
    stribeck.motor.friction.stribeck_velocity_rad_per_s = 5.0;
    stribeck.jackscrew.screw_friction.stribeck_velocity_rad_per_s = 5.0 / plain.jackscrew.gearbox_ratio;
    let current = 1.2 * elevation_motor_breakaway(&plain, 1.0) / plain.motor.torque_constant_nm_per_a;
    let mut a = elevation_at(plain, 40.0);
    let mut b = elevation_at(stribeck, 40.0);
    let mut slower_early = false;
    for k in 0..4000 {
        run_elevation(&mut a, current, 0.0, 1e-3, 1e-3);
        run_elevation(&mut b, current, 0.0, 1e-3, 1e-3);
        let (va, vb) = (a.outputs().motor_speed_rad_per_s, b.outputs().motor_speed_rad_per_s);
        if k == 50 {
            slower_early = vb < 0.8 * va;
        }
        assert!(vb <= va + 1e-9, "Stribeck friction can only add friction, step {k}: {vb} > {va}");
    }
    assert!(slower_early, "the Stribeck excess did not slow the start");
    // Far above the Stribeck velocity the two agree: the excess has decayed away.
    let (va, vb) = (a.outputs().motor_speed_rad_per_s, b.outputs().motor_speed_rad_per_s);
    assert!(va > 10.0 * 5.0, "the test must reach speeds far above the Stribeck velocity");
    assert!(((va - vb) / va).abs() < 0.05, "fast speeds differ: {va} vs {vb}");
}

fn azimuth_at(params: AzimuthParams) -> AzimuthPlant {
    let mut plant = AzimuthPlant::new(params).unwrap();
    plant.set_initial_state(0.0).unwrap();
    plant
}

#[test]
fn backlash_lets_a_lone_motor_cross_the_gap_before_its_pinion_pushes_the_load() {
    let params = AzimuthParams::default();
    let mut plant = azimuth_at(params);
    let start = plant.outputs();
    assert_eq!(start.pinion_flank, [0, 0], "pinions start centred in their backlash");
    let inputs = AzimuthInputs { current_command_a: [3.0, 0.0], disturbance_torque_nm: 0.0, elevation_deg: 45.0 };
    let mut motor_travel = 0.0;
    let mut contact_after = None;
    for k in 0..400 {
        let before = plant.outputs().motor_speed_rad_per_s[0];
        plant.step(&inputs, 1e-3).unwrap();
        let out = plant.outputs();
        motor_travel += 0.5 * (before + out.motor_speed_rad_per_s[0]) * 1e-3;
        if contact_after.is_none() && out.pinion_flank[0] == 0 {
            assert_eq!(
                out.axis_position_deg, start.axis_position_deg,
                "the load moved before the pinion reached a flank"
            );
            assert_eq!(out.pinion_torque_nm[0], 0.0);
        } else if contact_after.is_none() {
            contact_after = Some(k);
            assert_eq!(out.pinion_flank[0], 1, "a positive current closes the positive flank");
            // Half the free play, reflected to the motor, must have been crossed.
            let half_gap_at_motor = 0.5 * params.pinion_backlash_rad[0] * params.gear_ratio;
            assert!(
                (motor_travel - half_gap_at_motor).abs() < 0.05 * half_gap_at_motor,
                "motor turned {motor_travel} rad through a half gap of {half_gap_at_motor} rad"
            );
        }
    }
    assert!(contact_after.is_some(), "the pinion never reached the flank");
    assert_eq!(plant.outputs().pinion_flank[1], 0, "the idle pinion stays in its gap");
    assert!(plant.outputs().axis_position_deg > start.axis_position_deg);
}

#[test]
fn torque_bias_takes_up_the_backlash_on_opposite_flanks_and_holds_the_axis() {
    let params = AzimuthParams::default();
    let mut plant = azimuth_at(params);
    let bias = 3.0;
    let inputs = AzimuthInputs { current_command_a: [bias, -bias], disturbance_torque_nm: 0.0, elevation_deg: 45.0 };
    for _ in 0..2000 {
        plant.step(&inputs, 1e-3).unwrap();
    }
    let out = plant.outputs();
    assert_eq!(out.pinion_flank, [1, -1]);
    assert_eq!(out.axis_speed_deg_per_s, 0.0, "equal and opposite bias must not move the axis");
    // Each pinion carries the bias torque, less what the sticking motor friction absorbs.
    let motor = params.motors[0];
    let bias_torque = motor.torque_constant_nm_per_a * bias * params.gear_ratio;
    let friction_allowance = motor.friction.static_nm * params.gear_ratio;
    for (k, sign) in [(0, 1.0), (1, -1.0)] {
        let t = sign * out.pinion_torque_nm[k];
        assert!(t > bias_torque - friction_allowance && t <= bias_torque + 1e-6 * bias_torque, "pinion {k}: {t} N m");
    }
}

#[test]
fn current_saturation_limits_the_motor_torque() {
    let params = AzimuthParams::default();
    let mut plant = azimuth_at(params);
    let inputs = AzimuthInputs { current_command_a: [100.0, -100.0], disturbance_torque_nm: 0.0, elevation_deg: 45.0 };
    let limit = params.motors[0].current_limit_a;
    for _ in 0..100 {
        plant.step(&inputs, 1e-3).unwrap();
        let out = plant.outputs();
        // The lag approaches the clamped command from inside; allow only rounding beyond it.
        assert!(out.motor_current_a[0] <= limit * (1.0 + 1e-12) && out.motor_current_a[1] >= -limit * (1.0 + 1e-12));
    }
    let out = plant.outputs();
    assert!((out.motor_current_a[0] - limit).abs() < 1e-6 * limit);
    let torque_limit = params.motors[0].torque_constant_nm_per_a * limit;
    assert!((out.motor_torque_nm[0] - torque_limit).abs() < 1e-6 * torque_limit);
}

#[test]
fn encoder_reports_whole_counts_at_or_below_the_true_angle() {
    let params = AzimuthParams::default();
    let mut plant = azimuth_at(params);
    plant.set_initial_state(1.2345).unwrap();
    let count_deg = 360.0 / (1u64 << params.encoder_bits) as f64;
    let inputs = AzimuthInputs { current_command_a: [6.0, 2.0], disturbance_torque_nm: 0.0, elevation_deg: 45.0 };
    let mut distinct = std::collections::BTreeSet::new();
    for _ in 0..300 {
        plant.step(&inputs, 1e-3).unwrap();
        let out = plant.outputs();
        let counts = out.encoder_position_deg / count_deg;
        assert!((counts - counts.round()).abs() < 1e-6, "not a whole number of counts: {counts}");
        assert!(out.encoder_position_deg <= out.axis_position_deg);
        assert!(out.axis_position_deg - out.encoder_position_deg < count_deg * (1.0 + 1e-9));
        distinct.insert(counts.round() as i64);
    }
    assert!(distinct.len() > 10, "the axis must move across many counts");
}

#[test]
fn a_positive_disturbance_torque_accelerates_the_axis_positively() {
    let mut az = azimuth_at(AzimuthParams::linear());
    let inputs = AzimuthInputs { current_command_a: [0.0; 2], disturbance_torque_nm: 1e4, elevation_deg: 30.0 };
    for _ in 0..100 {
        az.step(&inputs, 1e-3).unwrap();
    }
    assert!(az.outputs().axis_speed_deg_per_s > 0.0);
    let mut el = elevation_at(ElevationParams::linear(), 50.0);
    run_elevation(&mut el, 0.0, -1e4, 0.1, 1e-3);
    assert!(el.outputs().axis_speed_deg_per_s < 0.0);
}

#[test]
fn elevation_unbalance_torque_is_minus_m_g_r_cos_of_elevation_plus_phase() {
    for (phase_deg, elevation_deg) in [(0.0, 30.0), (0.0, 70.0), (-90.0, 45.0)] {
        let mut params = ElevationParams::linear();
        params.unbalance_moment_nm = 2e4;
        params.unbalance_phase_deg = phase_deg;
        let mut plant = elevation_at(params, elevation_deg);
        let seconds = 0.5;
        run_elevation(&mut plant, 0.0, 0.0, seconds, 1e-3);
        // Rigid-body estimate: the drive follows the dish, so the whole reflected inertia moves
        // against the motor's viscous friction; the angle changes too little to alter the torque.
        let two_mass = plant.two_mass_in_use();
        let n = plant.outputs().transmission_ratio;
        let inertia = (two_mass.motor_inertia + two_mass.load_inertia) * n * n;
        let viscous = two_mass.motor_friction * n * n;
        let torque = -2e4 * (elevation_deg + phase_deg).to_radians().cos();
        let expected_speed = (torque / viscous * (1.0 - (-viscous * seconds / inertia).exp())).to_degrees();
        let speed = plant.outputs().axis_speed_deg_per_s;
        assert!(
            (speed - expected_speed).abs() < 0.01 * expected_speed.abs(),
            "phase {phase_deg}, el {elevation_deg}: speed {speed} deg/s, rigid-body estimate {expected_speed}"
        );
    }
}

#[test]
fn a_balanced_dish_without_input_stays_where_it_is() {
    let mut plant = elevation_at(ElevationParams::linear(), 60.0);
    run_elevation(&mut plant, 0.0, 0.0, 1.0, 1e-3);
    assert_eq!(plant.outputs().axis_speed_deg_per_s, 0.0);
    assert_eq!(plant.outputs().axis_position_deg, 60.0f64.to_radians().to_degrees());
}

#[test]
fn a_command_delay_of_whole_steps_shifts_the_response_exactly() {
    let delayed_params = ElevationParams {
        motor: fmu_plant::MotorParams { current_command_delay_s: 3e-3, ..ElevationParams::linear().motor },
        ..ElevationParams::linear()
    };
    let mut delayed = elevation_at(delayed_params, 45.1);
    let mut shifted = elevation_at(ElevationParams::linear(), 45.1);
    let command = |k: usize| if k >= 10 { ((k as f64) * 0.37).sin() } else { 0.0 };
    for k in 0..300 {
        delayed.step(&ElevationInputs { current_command_a: command(k), disturbance_torque_nm: 0.0 }, 1e-3).unwrap();
        let earlier = if k >= 3 { command(k - 3) } else { 0.0 };
        shifted.step(&ElevationInputs { current_command_a: earlier, disturbance_torque_nm: 0.0 }, 1e-3).unwrap();
        assert_eq!(delayed.outputs(), shifted.outputs(), "step {k}");
    }
}

#[test]
fn a_command_delay_that_is_not_a_whole_step_splits_the_step_exactly() {
    // A 2.5 ms delay stepped at 1 ms must match the undelayed plant stepped at 0.5 ms with the
    // command shifted by five half-steps.
    let delayed_params = ElevationParams {
        motor: fmu_plant::MotorParams { current_command_delay_s: 2.5e-3, ..ElevationParams::linear().motor },
        ..ElevationParams::linear()
    };
    let mut delayed = elevation_at(delayed_params, 45.1);
    let mut shifted = elevation_at(ElevationParams::linear(), 45.1);
    let command = |ms: usize| ((ms as f64) * 0.61).cos();
    let range = 1e-2_f64;
    for ms in 0..200 {
        delayed.step(&ElevationInputs { current_command_a: command(ms), disturbance_torque_nm: 0.0 }, 1e-3).unwrap();
        for half in 0..2 {
            let t_half = 2 * ms + half;
            let earlier = if t_half >= 5 { command((t_half - 5) / 2) } else { 0.0 };
            shifted.step(&ElevationInputs { current_command_a: earlier, disturbance_torque_nm: 0.0 }, 0.5e-3).unwrap();
        }
        let (a, b) = (delayed.outputs(), shifted.outputs());
        assert!(
            (a.motor_speed_rad_per_s - b.motor_speed_rad_per_s).abs()
                < 1e-11 * range.max(a.motor_speed_rad_per_s.abs())
        );
        assert!((a.motor_current_a - b.motor_current_a).abs() < 1e-12);
    }
}

#[test]
fn torque_constant_scale_scales_the_produced_torque() {
    let mut params = AzimuthParams::linear();
    params.motors[1].torque_constant_scale = 0.9;
    let mut plant = azimuth_at(params);
    let inputs = AzimuthInputs { current_command_a: [4.0, 4.0], disturbance_torque_nm: 0.0, elevation_deg: 30.0 };
    for _ in 0..50 {
        plant.step(&inputs, 1e-3).unwrap();
    }
    let out = plant.outputs();
    assert_eq!(out.motor_current_a[0], out.motor_current_a[1]);
    let ratio = out.motor_torque_nm[1] / out.motor_torque_nm[0];
    assert!((ratio - 0.9).abs() < 1e-12, "torque ratio {ratio}");
}

#[test]
fn cogging_torque_accelerates_a_free_motor_from_rest_by_amplitude_times_sine_of_phase() {
    let mut params = ElevationParams::linear();
    params.motor.cogging = CoggingParams { amplitude_nm: 0.05, period_motor_revolutions: 1.0 / 48.0, phase_deg: 60.0 };
    // At 0 deg elevation the motor angle is zero by definition; the travel is widened to keep
    // the geometry valid there.
    params.travel_min_deg = 0.0;
    let mut plant = elevation_at(params, 0.0);
    let h = params.numerics.nonlinear_substep_s;
    run_elevation(&mut plant, 0.0, 0.0, h, h);
    // Over a time short against the shaft resonance the motor accelerates alone.
    let expected = 0.05 * 60f64.to_radians().sin() / params.motor.inertia_kg_m2 * h;
    let speed = plant.outputs().motor_speed_rad_per_s;
    assert!((speed - expected).abs() < 0.01 * expected, "motor speed {speed}, expected {expected}");
}

#[test]
fn a_saved_azimuth_state_reproduces_the_future_bitwise() {
    let mut params = AzimuthParams::default();
    params.motors[0].current_command_delay_s = 2e-3;
    let mut plant = azimuth_at(params);
    let inputs = |k: usize| AzimuthInputs {
        current_command_a: [2.0 + 6.0 * (k as f64 * 0.01).sin(), -2.0 + 6.0 * (k as f64 * 0.01).sin()],
        disturbance_torque_nm: 3e3 * (k as f64 * 0.05).cos(),
        elevation_deg: 20.0 + 0.05 * k as f64,
    };
    for k in 0..700 {
        plant.step(&inputs(k), 1e-3).unwrap();
    }
    let state = plant.save_state();
    let mut expected = Vec::new();
    for k in 700..1400 {
        plant.step(&inputs(k), 1e-3).unwrap();
        expected.push(plant.outputs());
    }
    let mut restored = AzimuthPlant::new(params).unwrap();
    restored.load_state(state.clone()).unwrap();
    for (i, k) in (700..1400).enumerate() {
        restored.step(&inputs(k), 1e-3).unwrap();
        assert_eq!(restored.outputs(), expected[i], "step {k}");
    }
    // A state that does not fit the plant is refused and changes nothing.
    let mut short = state.clone();
    short.x.pop();
    let mut presliding = state.clone();
    presliding.paths[1].anchor = Some(0.0);
    for wrong in [short, presliding] {
        let mut fresh = AzimuthPlant::new(params).unwrap();
        let untouched = fresh.save_state();
        assert!(fresh.load_state(wrong).is_err());
        assert_eq!(fresh.save_state(), untouched);
    }
}

#[test]
fn a_saved_elevation_state_reproduces_the_future_bitwise_across_grid_cells() {
    let params = ElevationParams::default();
    let mut plant = elevation_at(params, 30.0);
    let inputs = |k: usize| ElevationInputs {
        current_command_a: 3.0 * (k as f64 * 0.004).sin() + 1.0,
        disturbance_torque_nm: 0.0,
    };
    for k in 0..1500 {
        plant.step(&inputs(k), 1e-3).unwrap();
    }
    let state = plant.save_state();
    let before = plant.outputs().axis_position_deg;
    let mut expected = Vec::new();
    for k in 1500..4000 {
        plant.step(&inputs(k), 1e-3).unwrap();
        expected.push(plant.outputs());
    }
    let cell = params.numerics.parameter_grid_cell_deg;
    assert!((plant.outputs().axis_position_deg - before).abs() > 2.0 * cell, "the run must cross parameter cells");
    let mut restored = ElevationPlant::new(params).unwrap();
    restored.load_state(state).unwrap();
    for (i, k) in (1500..4000).enumerate() {
        restored.step(&inputs(k), 1e-3).unwrap();
        assert_eq!(restored.outputs(), expected[i], "step {k}");
    }
}

#[test]
fn invalid_parameters_are_rejected_with_the_offending_field_named() {
    let mut az = AzimuthParams { gear_ratio: -1.0, ..AzimuthParams::default() };
    az.motors[1].friction = FrictionParams { coulomb_nm: 1.0, static_nm: 0.5, ..FrictionParams::NONE };
    let message = AzimuthPlant::new(az).unwrap_err().to_string();
    assert!(message.contains("gear_ratio") && message.contains("motors[1].friction.static_nm"), "{message}");
    let mut el = ElevationParams::default();
    el.jackscrew.nut_offset_m = 0.0;
    let message = ElevationPlant::new(el).unwrap_err().to_string();
    assert!(message.contains("nut"), "{message}");
    let mut el = ElevationParams::default();
    el.jackscrew.axial_backlash_m = 1e-4;
    el.jackscrew.axial_damping_n_s_per_m = 0.0;
    assert!(ElevationPlant::new(el).unwrap_err().to_string().contains("axial_damping"));
}

#[test]
fn non_finite_inputs_and_step_sizes_are_errors_that_leave_the_state_alone() {
    let mut plant = azimuth_at(AzimuthParams::default());
    let before = plant.outputs();
    let bad = AzimuthInputs { current_command_a: [f64::NAN, 0.0], disturbance_torque_nm: 0.0, elevation_deg: 45.0 };
    assert!(plant.step(&bad, 1e-3).is_err());
    assert!(plant.step(&AzimuthInputs::default(), 0.0).is_err());
    assert!(plant.step(&AzimuthInputs::default(), f64::INFINITY).is_err());
    assert_eq!(plant.outputs(), before);
    assert_eq!(plant.time_s(), 0.0);
}

#[test]
fn the_discretisation_cache_stays_bounded_when_the_master_varies_its_step() {
    let params = AzimuthParams::default();
    let mut plant = azimuth_at(params);
    for k in 0..3000 {
        let h = 1e-4 * (1.0 + (k as f64 * 0.7).sin().abs());
        let inputs = AzimuthInputs {
            current_command_a: [3.0 + 5.0 * (k as f64 * 0.02).sin(), -3.0 + 5.0 * (k as f64 * 0.02).sin()],
            disturbance_torque_nm: 0.0,
            elevation_deg: 15.0 + k as f64 * 0.02,
        };
        plant.step(&inputs, h).unwrap();
        assert!(plant.cached_discretisations() <= 2 * params.numerics.cache_capacity);
    }
}

#[test]
fn a_long_communication_step_gives_the_same_motion_as_many_short_ones() {
    // A 20 ms master step is checked for events every millisecond inside, so friction and
    // backlash events are caught as they are with 1 ms steps.
    let params = AzimuthParams::default();
    let run = |h: f64| {
        let mut plant = azimuth_at(params);
        let mut positions = Vec::new();
        for k in 0..100 {
            let t = k as f64 * 0.02;
            let current = 6.0 * (std::f64::consts::TAU * t / 1.5).sin();
            let inputs = AzimuthInputs {
                current_command_a: [current + 1.0, current - 1.0],
                disturbance_torque_nm: 0.0,
                elevation_deg: 45.0,
            };
            for _ in 0..(0.02 / h).round() as usize {
                plant.step(&inputs, h).unwrap();
            }
            positions.push(plant.outputs().axis_position_deg);
        }
        (positions, plant.numerics_statistics().events)
    };
    let (long, events) = run(0.02);
    let (short, _) = run(0.001);
    assert!(events > 5, "the scenario must produce events");
    let worst = long.iter().zip(&short).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) * 3600.0;
    println!("20 ms vs 1 ms steps: {worst:.2e} arcsec, {events} events");
    assert!(worst < 1e-3, "20 ms and 1 ms steps differ by {worst} arcsec");
}

/// The motor side of the azimuth drive: both motors commanded with `current` for `seconds`,
/// the pinions without backlash and the load held by a bearing friction far above what the
/// motors can apply (`held`), or the default one.
fn held_azimuth(presliding: f64, current: f64, seconds: f64, held: bool) -> fmu_plant::AzimuthOutputs {
    let mut params = AzimuthParams { pinion_backlash_rad: [0.0; 2], ..AzimuthParams::default() };
    if held {
        params.bearing_friction = FrictionParams::coulomb_and_static(1e7, 1e7);
    }
    for m in params.motors.iter_mut() {
        m.presliding_stiffness_nm_per_rad = presliding;
        m.presliding_damping_nm_s_per_rad = 2.0 * (presliding * m.inertia_kg_m2).sqrt();
    }
    let mut plant = azimuth_at(params);
    let inputs = AzimuthInputs { current_command_a: [current; 2], disturbance_torque_nm: 0.0, elevation_deg: 45.0 };
    for _ in 0..(seconds * 1e3).round() as usize {
        plant.step(&inputs, 1e-3).unwrap();
    }
    plant.outputs()
}

#[test]
fn a_presliding_motor_yields_elastically_below_breakaway_where_a_rigid_stick_does_not_move() {
    // 0.25 A gives 0.2 N m per motor, half the 0.4 N m breakaway: a rigid stick holds the motor
    // exactly (no twist reaches the pinion); a bristle of stiffness sigma lets it turn until the
    // bristle and the path (K / N^2 at the motor) share the torque, so the pinion carries the
    // fraction K' / (sigma + K') of it (the load held).
    let params = AzimuthParams::default();
    let path_at_motor = params.path_stiffness_nm_per_rad[0] / (params.gear_ratio * params.gear_ratio);
    let rigid = held_azimuth(0.0, 0.25, 0.5, true);
    assert_eq!(rigid.motor_speed_rad_per_s, [0.0; 2]);
    assert_eq!(rigid.pinion_torque_nm, [0.0; 2]);
    let sigma = 10.0;
    let yielding = held_azimuth(sigma, 0.25, 0.5, true);
    let motor_torque = yielding.motor_torque_nm[0];
    let expected = motor_torque * path_at_motor / (sigma + path_at_motor) * params.gear_ratio;
    for k in 0..2 {
        assert!(yielding.motor_speed_rad_per_s[k].abs() < 1e-6, "settled: {:?}", yielding.motor_speed_rad_per_s);
        let relative = (yielding.pinion_torque_nm[k] - expected).abs() / expected;
        assert!(relative < 1e-3, "pinion {k}: {} N m against {expected} N m", yielding.pinion_torque_nm[k]);
    }
}

#[test]
fn a_presliding_motor_slips_once_its_bristle_torque_passes_breakaway() {
    // 6 A gives 4.8 N m per motor: the bristle's share sigma / (sigma + K') of it passes the
    // 0.4 N m breakaway, so the motor slides and the axis turns, with or without the bristle.
    let sliding = held_azimuth(10.0, 6.0, 0.3, false);
    assert!(sliding.motor_speed_rad_per_s.iter().all(|v| *v > 1.0), "{:?}", sliding.motor_speed_rad_per_s);
    let rigid = held_azimuth(0.0, 6.0, 0.3, false);
    let relative = (sliding.axis_speed_deg_per_s - rigid.axis_speed_deg_per_s).abs() / rigid.axis_speed_deg_per_s.abs();
    assert!(
        relative < 0.05,
        "sliding axis speed {} against {} with a rigid stick",
        sliding.axis_speed_deg_per_s,
        rigid.axis_speed_deg_per_s
    );
}

#[test]
fn a_saved_azimuth_state_with_presliding_motors_reproduces_the_future_bitwise() {
    // The friction anchors are part of the state: a restored plant continues exactly, through
    // stick phases (the commands reverse) where the bristles hold the motors.
    let mut params = AzimuthParams::default();
    for m in params.motors.iter_mut() {
        m.presliding_stiffness_nm_per_rad = 20.0;
        m.presliding_damping_nm_s_per_rad = 0.5;
    }
    let mut plant = azimuth_at(params);
    let inputs = |k: usize| AzimuthInputs {
        current_command_a: [0.6 * (k as f64 * 0.01).sin(), 0.6 * (k as f64 * 0.013).sin()],
        disturbance_torque_nm: 0.0,
        elevation_deg: 45.0,
    };
    for k in 0..700 {
        plant.step(&inputs(k), 1e-3).unwrap();
    }
    let state = plant.save_state();
    let mut expected = Vec::new();
    for k in 700..2000 {
        plant.step(&inputs(k), 1e-3).unwrap();
        expected.push(plant.outputs());
    }
    assert!(expected.iter().any(|o| o.motor_speed_rad_per_s[0] != 0.0), "the motors must move");
    let mut restored = AzimuthPlant::new(params).unwrap();
    restored.load_state(state.clone()).unwrap();
    for (i, k) in (700..2000).enumerate() {
        restored.step(&inputs(k), 1e-3).unwrap();
        assert_eq!(restored.outputs(), expected[i], "step {k}");
    }
}
