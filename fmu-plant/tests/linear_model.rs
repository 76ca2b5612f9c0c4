//! The linear configuration against the paper's (corrected) Eq. 1, solved independently.
//!
//! The reference solutions come from `analytic`: the transfer functions of the paper's matrix
//! equation, inverted by partial fractions over the eigenvalues of a companion matrix. The
//! simulator uses a state-space model and a matrix exponential; the two share no code.

use fmu_plant::analytic::{current_loop, RationalFunction, TwoMassParameters};
use fmu_plant::{AzimuthInputs, AzimuthParams, AzimuthPlant, ElevationInputs, ElevationParams, ElevationPlant};

/// Largest error of `simulated` against `reference`, as a fraction of the reference's range.
fn error_relative_to_range(simulated: &[f64], reference: &[f64]) -> f64 {
    let max = reference.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let min = reference.iter().cloned().fold(f64::INFINITY, f64::min);
    let worst = simulated.iter().zip(reference).map(|(s, r)| (s - r).abs()).fold(0.0, f64::max);
    worst / (max - min)
}

/// Step responses of motor speed, load angle (motor side) and shaft torque per unit current.
struct Reference {
    motor_speed: RationalFunction,
    load_angle: RationalFunction,
    shaft_torque: RationalFunction,
}

fn reference(p: &TwoMassParameters, torque_per_amp: f64, bandwidth_hz: f64) -> Reference {
    let den = p.determinant();
    let loop_and_gain = current_loop(bandwidth_hz).scaled(torque_per_amp);
    // V_M/T_E = s (J_L s^2 + K_cv s + K_s) / D(s).
    let mut speed_num = vec![0.0];
    speed_num.extend(p.motor_position_numerator());
    let motor_speed = loop_and_gain.times(&RationalFunction::new(speed_num, den.clone()));
    let load_angle = loop_and_gain.times(&RationalFunction::new(p.load_position_numerator(), den.clone()));
    // Shaft torque T_L = (K_s + K_cv s)(P_M - P_L) = (K_s + K_cv s) J_L s^2 / D(s) per unit T_E.
    let torque_num = vec![0.0, 0.0, p.shaft_stiffness * p.load_inertia, p.cross_coupled_damping * p.load_inertia];
    let shaft_torque = loop_and_gain.times(&RationalFunction::new(torque_num, den));
    Reference { motor_speed, load_angle, shaft_torque }
}

#[test]
fn linear_azimuth_step_response_equals_the_analytic_solution_of_eq_1() {
    let params = AzimuthParams::linear();
    let mut plant = AzimuthPlant::new(params).unwrap();
    plant.set_initial_state(0.0).unwrap();
    let current = 2.0;
    let inputs = AzimuthInputs { current_command_a: [current; 2], disturbance_torque_nm: 0.0, elevation_deg: 37.3 };
    let h = 1e-3;
    let mut sim = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut times = Vec::new();
    for k in 1..=600 {
        plant.step(&inputs, h).unwrap();
        let out = plant.outputs();
        times.push(k as f64 * h);
        sim.0.push(out.motor_speed_rad_per_s[0]);
        sim.1.push(out.axis_position_deg.to_radians());
        sim.2.push(out.pinion_torque_nm[0] + out.pinion_torque_nm[1]);
        sim.3.push(out.motor_speed_rad_per_s[1]);
    }
    // Both motors together: torque 2 K_phi i into the doubled two-mass model of the cell in use.
    let two_mass = plant.two_mass_in_use();
    let motor = params.motors[0];
    let r = reference(&two_mass, 2.0 * motor.torque_constant_nm_per_a, motor.current_loop_bandwidth_hz);
    let n = params.gear_ratio;
    let speed = r.motor_speed.step_response().unwrap();
    let angle = r.load_angle.step_response().unwrap();
    let torque = r.shaft_torque.step_response().unwrap();
    let ref_speed: Vec<f64> = times.iter().map(|&t| current * speed.value_at(t)).collect();
    let ref_angle: Vec<f64> = times.iter().map(|&t| current * angle.value_at(t) / n).collect();
    let ref_torque: Vec<f64> = times.iter().map(|&t| current * torque.value_at(t) * n).collect();
    let errors = [
        error_relative_to_range(&sim.0, &ref_speed),
        error_relative_to_range(&sim.3, &ref_speed),
        error_relative_to_range(&sim.1, &ref_angle),
        error_relative_to_range(&sim.2, &ref_torque),
    ];
    println!("azimuth linear step: errors relative to range (speed 1, speed 2, axis angle, shaft torque) = {errors:?}");
    for e in errors {
        assert!(e < 1e-9, "error {e:e} of the range exceeds 1e-9");
    }
}

#[test]
fn linear_elevation_step_response_equals_the_analytic_solution_of_eq_1() {
    let params = ElevationParams::linear();
    let mut plant = ElevationPlant::new(params).unwrap();
    // Start at a cell centre so that the motion (about 0.1 deg) stays within the cell.
    let cell = params.numerics.parameter_grid_cell_deg;
    let start_deg = (45.0 / cell).floor() * cell + 0.5 * cell;
    plant.set_initial_state(start_deg.to_radians()).unwrap();
    let two_mass = plant.two_mass_in_use();
    let n = plant.outputs().transmission_ratio;
    let current = 1.0;
    let inputs = ElevationInputs { current_command_a: current, disturbance_torque_nm: 0.0 };
    let h = 1e-3;
    let (mut speed_sim, mut angle_sim, mut torque_sim, mut times) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for k in 1..=500 {
        plant.step(&inputs, h).unwrap();
        let out = plant.outputs();
        assert_eq!(out.transmission_ratio, n, "the motion left the parameter cell");
        times.push(k as f64 * h);
        speed_sim.push(out.motor_speed_rad_per_s);
        angle_sim.push((out.axis_position_deg - start_deg).to_radians());
        torque_sim.push(out.drive_torque_nm);
    }
    let r = reference(&two_mass, params.motor.torque_constant_nm_per_a, params.motor.current_loop_bandwidth_hz);
    let speed = r.motor_speed.step_response().unwrap();
    let angle = r.load_angle.step_response().unwrap();
    let torque = r.shaft_torque.step_response().unwrap();
    let ref_speed: Vec<f64> = times.iter().map(|&t| current * speed.value_at(t)).collect();
    let ref_angle: Vec<f64> = times.iter().map(|&t| current * angle.value_at(t) / n).collect();
    let ref_torque: Vec<f64> = times.iter().map(|&t| current * torque.value_at(t) * n).collect();
    let errors = [
        error_relative_to_range(&speed_sim, &ref_speed),
        error_relative_to_range(&angle_sim, &ref_angle),
        error_relative_to_range(&torque_sim, &ref_torque),
    ];
    println!("elevation linear step: errors relative to range (motor speed, axis angle, drive torque) = {errors:?}");
    for e in errors {
        assert!(e < 1e-9, "error {e:e} of the range exceeds 1e-9");
    }
}

/// A deterministic, piecewise-constant test signal that changes every millisecond.
fn command_at(step_ms: usize, seed: u64) -> f64 {
    let mut z = (step_ms as u64).wrapping_add(seed).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64 * 4.0 - 2.0
}

#[test]
fn linear_azimuth_results_do_not_depend_on_the_step_size() {
    let run = |substeps: usize| {
        let mut plant = AzimuthPlant::new(AzimuthParams::linear()).unwrap();
        plant.set_initial_state(0.3).unwrap();
        let mut samples = Vec::new();
        for ms in 0..500 {
            let inputs = AzimuthInputs {
                current_command_a: [command_at(ms, 1), command_at(ms, 2)],
                disturbance_torque_nm: 2e4 * command_at(ms, 3),
                elevation_deg: 60.0,
            };
            for _ in 0..substeps {
                plant.step(&inputs, 1e-3 / substeps as f64).unwrap();
            }
            let o = plant.outputs();
            samples.push([
                o.axis_position_deg,
                o.motor_speed_rad_per_s[0],
                o.motor_speed_rad_per_s[1],
                o.pinion_torque_nm[1],
            ]);
        }
        samples
    };
    let coarse = run(1);
    let fine = run(10);
    for signal in 0..4 {
        let a: Vec<f64> = coarse.iter().map(|s| s[signal]).collect();
        let b: Vec<f64> = fine.iter().map(|s| s[signal]).collect();
        let e = error_relative_to_range(&a, &b);
        println!("azimuth linear, 1 ms vs 0.1 ms, signal {signal}: {e:e} of range");
        assert!(e < 1e-11, "signal {signal}: 1 ms and 0.1 ms steps differ by {e:e} of the range");
    }
}

#[test]
fn linear_elevation_results_do_not_depend_on_the_step_size_within_a_cell() {
    let run = |substeps: usize| {
        let mut plant = ElevationPlant::new(ElevationParams::linear()).unwrap();
        plant.set_initial_state(30.125f64.to_radians()).unwrap();
        let mut samples = Vec::new();
        for ms in 0..500 {
            let inputs = ElevationInputs {
                current_command_a: 0.3 * command_at(ms, 7),
                disturbance_torque_nm: 1e4 * command_at(ms, 8),
            };
            for _ in 0..substeps {
                plant.step(&inputs, 1e-3 / substeps as f64).unwrap();
            }
            let o = plant.outputs();
            samples.push([o.axis_position_deg, o.motor_speed_rad_per_s, o.screw_force_n]);
        }
        samples
    };
    let coarse = run(1);
    let fine = run(10);
    for signal in 0..3 {
        let a: Vec<f64> = coarse.iter().map(|s| s[signal]).collect();
        let b: Vec<f64> = fine.iter().map(|s| s[signal]).collect();
        let e = error_relative_to_range(&a, &b);
        println!("elevation linear, 1 ms vs 0.1 ms, signal {signal}: {e:e} of range");
        assert!(e < 1e-11, "signal {signal}: 1 ms and 0.1 ms steps differ by {e:e} of the range");
    }
}
