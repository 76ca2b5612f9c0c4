//! Measured errors of the numerical scheme, each against a finer reference run of the same
//! model: the elevation grid on which angle-dependent parameters are frozen, the sub-step over
//! which non-piecewise-linear torques are held, and the step-size dependence that event
//! localisation leaves when the nonlinear effects are on. Each test prints what it measured
//! (run with `--nocapture`; the numbers are quoted in docs/plant-model.md) and fails if the
//! error exceeds the bound documented there.

use fmu_plant::{AzimuthInputs, AzimuthParams, AzimuthPlant, ElevationInputs, ElevationParams, ElevationPlant};

const ARCSEC_PER_DEG: f64 = 3600.0;

/// A velocity PI loop on motor speed, run at 1 kHz, the same in every run it is compared in.
struct VelocityLoop {
    proportional: f64,
    integral: f64,
    integrator: f64,
}

impl VelocityLoop {
    /// Gains for a loop of `bandwidth_hz` on a motor-side inertia `inertia` driven by `torque_per_amp`.
    fn new(inertia: f64, torque_per_amp: f64, bandwidth_hz: f64) -> Self {
        let kp = inertia * std::f64::consts::TAU * bandwidth_hz / torque_per_amp;
        Self { proportional: kp, integral: kp * std::f64::consts::TAU * bandwidth_hz / 5.0, integrator: 0.0 }
    }

    fn current(&mut self, reference: f64, measured: f64, h: f64) -> f64 {
        let error = reference - measured;
        self.integrator += self.integral * error * h;
        self.proportional * error + self.integrator
    }
}

/// A slew reference: ramp up at `accel` to `speed`, hold, ramp down, in deg/s.
fn slew_speed(t: f64, speed: f64, accel: f64, duration: f64) -> f64 {
    let ramp = speed / accel;
    if t < ramp {
        accel * t
    } else if t < duration - ramp {
        speed
    } else if t < duration {
        accel * (duration - t)
    } else {
        0.0
    }
}

#[derive(Default, Clone, Copy)]
struct Sample {
    position_deg: f64,
    current_a: f64,
    torque_nm: f64,
}

fn max_difference(a: &[Sample], b: &[Sample], f: impl Fn(&Sample) -> f64) -> f64 {
    a.iter().zip(b).map(|(x, y)| (f(x) - f(y)).abs()).fold(0.0, f64::max)
}

fn range(a: &[Sample], f: impl Fn(&Sample) -> f64) -> f64 {
    let max = a.iter().map(&f).fold(f64::NEG_INFINITY, f64::max);
    let min = a.iter().map(&f).fold(f64::INFINITY, f64::min);
    max - min
}

/// Elevation slew from 15 to about 85 deg at 1 deg/s under the velocity loop, sampled at 1 kHz.
fn elevation_slew(params: ElevationParams, substeps: usize, seconds: f64) -> Vec<Sample> {
    let mut plant = ElevationPlant::new(params).unwrap();
    plant.set_initial_state(15f64.to_radians()).unwrap();
    let mid = params.two_mass_at(50.0);
    let mut control =
        VelocityLoop::new(mid.motor_inertia + mid.load_inertia, params.motor.torque_constant_nm_per_a, 8.0);
    let mut samples = Vec::new();
    let h = 1e-3;
    for k in 0..(seconds / h) as usize {
        let out = plant.outputs();
        let reference =
            slew_speed(k as f64 * h, 1.0, 1.0, seconds - 1.0).to_radians() * params.ratio_at(out.axis_position_deg);
        let current = control.current(reference, out.motor_speed_rad_per_s, h);
        let inputs = ElevationInputs { current_command_a: current, disturbance_torque_nm: 0.0 };
        for _ in 0..substeps {
            plant.step(&inputs, h / substeps as f64).unwrap();
        }
        let o = plant.outputs();
        samples.push(Sample {
            position_deg: o.axis_position_deg,
            current_a: o.motor_current_a,
            torque_nm: o.drive_torque_nm,
        });
    }
    samples
}

/// Azimuth slew at 2 deg/s with torque bias while the elevation input sweeps 15 to 85 deg.
fn azimuth_slew(params: AzimuthParams, substeps: usize, seconds: f64) -> Vec<Sample> {
    let mut plant = AzimuthPlant::new(params).unwrap();
    plant.set_initial_state(0.0).unwrap();
    let mid = params.two_mass_at(50.0);
    let torque_per_amp = 2.0 * params.motors[0].torque_constant_nm_per_a;
    let mut control = VelocityLoop::new(mid.motor_inertia + mid.load_inertia, torque_per_amp, 8.0);
    let bias = 2.0;
    let mut samples = Vec::new();
    let h = 1e-3;
    for k in 0..(seconds / h) as usize {
        let t = k as f64 * h;
        let out = plant.outputs();
        let reference = slew_speed(t, 2.0, 1.0, seconds - 1.0).to_radians() * params.gear_ratio;
        let mean_speed = 0.5 * (out.motor_speed_rad_per_s[0] + out.motor_speed_rad_per_s[1]);
        let current = control.current(reference, mean_speed, h);
        let inputs = AzimuthInputs {
            current_command_a: [current + bias, current - bias],
            disturbance_torque_nm: 0.0,
            elevation_deg: 15.0 + 70.0 * t / seconds,
        };
        for _ in 0..substeps {
            plant.step(&inputs, h / substeps as f64).unwrap();
        }
        let o = plant.outputs();
        samples.push(Sample {
            position_deg: o.axis_position_deg,
            current_a: o.motor_current_a[0],
            torque_nm: o.pinion_torque_nm[0] + o.pinion_torque_nm[1],
        });
    }
    samples
}

/// Bounds quoted in docs/plant-model.md: position error in arcsec, current and torque errors
/// as fractions of the reference's range.
struct Bound {
    position_arcsec: f64,
    current: f64,
    torque: f64,
}

fn report(name: &str, run: &[Sample], reference: &[Sample]) -> (f64, f64, f64) {
    let position_arcsec = max_difference(run, reference, |s| s.position_deg) * ARCSEC_PER_DEG;
    let current_abs = max_difference(run, reference, |s| s.current_a);
    let torque_abs = max_difference(run, reference, |s| s.torque_nm);
    let (current_range, torque_range) = (range(reference, |s| s.current_a), range(reference, |s| s.torque_nm));
    let (current, torque) = (current_abs / current_range, torque_abs / torque_range);
    println!(
        "{name}: max errors: position {position_arcsec:.2e} arcsec; current {current_abs:.2e} A ({current:.1e} of its \
         {current_range:.2} A range); torque {torque_abs:.2e} N m ({torque:.1e} of its {torque_range:.3e} N m range)"
    );
    (position_arcsec, current, torque)
}

fn check(measured: (f64, f64, f64), bound: &Bound) {
    assert!(measured.0 < bound.position_arcsec, "position error {} arcsec", measured.0);
    assert!(measured.1 < bound.current, "current error {} of range", measured.1);
    assert!(measured.2 < bound.torque, "torque error {} of range", measured.2);
}

const GRID_BOUND: Bound = Bound { position_arcsec: 0.05, current: 1e-2, torque: 1e-2 };
const SUBSTEP_BOUND: Bound = Bound { position_arcsec: 5e-3, current: 2e-3, torque: 5e-3 };
const STEP_SIZE_BOUND: Bound = Bound { position_arcsec: 5e-3, current: 2e-3, torque: 5e-3 };

#[test]
fn elevation_parameter_grid_error_is_within_the_documented_bound() {
    let seconds = 72.0;
    // The linear drive with the angle-dependent geometry, so that only the grid differs.
    let varying = ElevationParams { geometry_frozen: false, ..ElevationParams::linear() };
    let mut fine = varying;
    fine.numerics.parameter_grid_cell_deg = 0.01;
    let reference = elevation_slew(fine, 1, seconds);
    assert!(reference.last().unwrap().position_deg > 80.0, "the slew must cross most of the travel");
    for cell in [0.25, 1.0] {
        let mut params = varying;
        params.numerics.parameter_grid_cell_deg = cell;
        let run = elevation_slew(params, 1, seconds);
        let measured = report(&format!("elevation grid {cell} deg vs 0.01 deg"), &run, &reference);
        if cell == 0.25 {
            check(measured, &GRID_BOUND);
        }
    }
}

#[test]
fn azimuth_parameter_grid_error_is_within_the_documented_bound() {
    let seconds = 70.0;
    let mut fine = AzimuthParams::linear();
    fine.numerics.parameter_grid_cell_deg = 0.01;
    let reference = azimuth_slew(fine, 1, seconds);
    for cell in [0.25, 1.0] {
        let mut params = AzimuthParams::linear();
        params.numerics.parameter_grid_cell_deg = cell;
        let run = azimuth_slew(params, 1, seconds);
        let measured = report(&format!("azimuth grid {cell} deg vs 0.01 deg"), &run, &reference);
        if cell == 0.25 {
            check(measured, &GRID_BOUND);
        }
    }
}

#[test]
fn frozen_parameters_stay_within_the_documented_fraction_of_their_exact_values() {
    let el = ElevationParams::default();
    let az = AzimuthParams::default();
    let cell = el.numerics.parameter_grid_cell_deg;
    let (mut stiffness, mut ratio, mut inertia, mut f_el, mut f_az) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut angle = el.travel_min_deg;
    while angle <= el.travel_max_deg {
        let centre = ((angle / cell).floor() + 0.5) * cell;
        let exact = el.two_mass_at(angle);
        let frozen = el.two_mass_at(centre);
        stiffness = stiffness.max((frozen.shaft_stiffness / exact.shaft_stiffness - 1.0).abs());
        ratio = ratio.max((el.ratio_at(centre) / el.ratio_at(angle) - 1.0).abs());
        f_el = f_el.max((frozen.anti_resonance_hz() / exact.anti_resonance_hz() - 1.0).abs());
        inertia = inertia.max((az.axis_inertia_kg_m2(centre) / az.axis_inertia_kg_m2(angle) - 1.0).abs());
        f_az = f_az.max((az.anti_resonance_hz(centre) / az.anti_resonance_hz(angle) - 1.0).abs());
        angle += 0.001;
    }
    println!(
        "grid {cell} deg: elevation K_s {stiffness:.2e}, ratio {ratio:.2e}, f_AR {f_el:.2e}; \
         azimuth J_L {inertia:.2e}, f_AR {f_az:.2e} (largest relative deviation from the exact value)"
    );
    assert!(stiffness < 5e-3 && ratio < 2e-3 && f_el < 1e-3 && inertia < 1e-3 && f_az < 1e-3);
}

/// Elevation tracking near the static friction limit with every non-piecewise-linear effect on.
fn elevation_tracking_with_effects(substep: f64, substeps_per_ms: usize) -> Vec<Sample> {
    let mut params = ElevationParams::default();
    params.numerics.nonlinear_substep_s = substep;
    params.motor.friction.stribeck_velocity_rad_per_s = 2.0;
    params.jackscrew.screw_friction.stribeck_velocity_rad_per_s = 2.0 / params.jackscrew.gearbox_ratio;
    params.motor.cogging =
        fmu_plant::CoggingParams { amplitude_nm: 0.03, period_motor_revolutions: 1.0 / 48.0, phase_deg: 0.0 };
    params.unbalance_moment_nm = 3e3;
    params.periodic_torque = fmu_plant::PeriodicTorqueParams { amplitude_nm: 200.0, period_deg: 0.5, phase_deg: 0.0 };
    let mut plant = ElevationPlant::new(params).unwrap();
    plant.set_initial_state(40f64.to_radians()).unwrap();
    let mid = params.two_mass_at(40.0);
    let mut control =
        VelocityLoop::new(mid.motor_inertia + mid.load_inertia, params.motor.torque_constant_nm_per_a, 8.0);
    let mut samples = Vec::new();
    let h = 1e-3;
    for k in 0..20_000 {
        let t = k as f64 * h;
        let out = plant.outputs();
        // Sidereal-like rate with slow reversals, so the drive passes through zero speed.
        let speed = 0.004 * (std::f64::consts::TAU * t / 8.0).sin();
        let current =
            control.current(speed.to_radians() * params.ratio_at(out.axis_position_deg), out.motor_speed_rad_per_s, h);
        let inputs = ElevationInputs { current_command_a: current, disturbance_torque_nm: 0.0 };
        for _ in 0..substeps_per_ms {
            plant.step(&inputs, h / substeps_per_ms as f64).unwrap();
        }
        let o = plant.outputs();
        samples.push(Sample {
            position_deg: o.axis_position_deg,
            current_a: o.motor_current_a,
            torque_nm: o.drive_torque_nm,
        });
    }
    samples
}

#[test]
fn nonlinear_substep_error_is_within_the_documented_bound() {
    let reference = elevation_tracking_with_effects(1e-6, 1);
    for substep in [1e-4, 1e-3] {
        let run = elevation_tracking_with_effects(substep, 1);
        let measured = report(&format!("sub-step {substep:e} s vs 1e-6 s"), &run, &reference);
        if substep == 1e-4 {
            check(measured, &SUBSTEP_BOUND);
        }
    }
}

/// Default azimuth (friction, backlash, saturation) under the velocity loop with torque bias,
/// reversing slowly so that bodies stick and pinions change flanks; inputs change every 1 ms.
/// Returns the samples and the number of mode switches the plant handled.
fn azimuth_reversals(params: AzimuthParams, substeps_per_ms: usize) -> (Vec<Sample>, u64) {
    let mut plant = AzimuthPlant::new(params).unwrap();
    plant.set_initial_state(0.0).unwrap();
    let mid = params.two_mass_at(45.0);
    let torque_per_amp = 2.0 * params.motors[0].torque_constant_nm_per_a;
    let mut control = VelocityLoop::new(mid.motor_inertia + mid.load_inertia, torque_per_amp, 8.0);
    let mut samples = Vec::new();
    let h = 1e-3;
    for k in 0..10_000 {
        let t = k as f64 * h;
        let out = plant.outputs();
        let speed = 0.05 * (std::f64::consts::TAU * t / 4.0).sin();
        let mean = 0.5 * (out.motor_speed_rad_per_s[0] + out.motor_speed_rad_per_s[1]);
        let current = control.current(speed.to_radians() * params.gear_ratio, mean, h);
        let bias = 1.0;
        let inputs = AzimuthInputs {
            current_command_a: [current + bias, current - bias],
            disturbance_torque_nm: 3e3 * (std::f64::consts::TAU * t / 1.3).sin(),
            elevation_deg: 45.0,
        };
        for _ in 0..substeps_per_ms {
            plant.step(&inputs, h / substeps_per_ms as f64).unwrap();
        }
        let o = plant.outputs();
        samples.push(Sample {
            position_deg: o.axis_position_deg,
            current_a: o.motor_current_a[0],
            torque_nm: o.pinion_torque_nm[0],
        });
    }
    (samples, plant.numerics_statistics().events)
}

#[test]
fn azimuth_step_size_dependence_with_the_nonlinear_effects_on_is_within_the_documented_bound() {
    let params = AzimuthParams::default();
    let mut fine_events = params;
    fine_events.numerics.event_time_resolution_s = 1e-8;
    let (reference, events) = azimuth_reversals(fine_events, 10);
    println!("azimuth reversals: {events} mode switches in 10 s");
    assert!(events > 20, "the scenario must exercise sticking, slipping and flank changes");
    for substeps in [1, 10] {
        let (run, _) = azimuth_reversals(params, substeps);
        let step = 1e-3 / substeps as f64;
        let name = format!("azimuth, default effects, step {step:e} s vs 1e-4 s with 1e-8 s event resolution");
        check(report(&name, &run, &reference), &STEP_SIZE_BOUND);
    }
}

/// Elevation with the default effects and the angle-dependent geometry: a slew across grid
/// cells followed by slow reversals through zero speed.
fn elevation_slew_and_reversals(params: ElevationParams, substeps_per_ms: usize) -> (Vec<Sample>, u64) {
    let mut plant = ElevationPlant::new(params).unwrap();
    plant.set_initial_state(30f64.to_radians()).unwrap();
    let mid = params.two_mass_at(40.0);
    let mut control =
        VelocityLoop::new(mid.motor_inertia + mid.load_inertia, params.motor.torque_constant_nm_per_a, 8.0);
    let mut samples = Vec::new();
    let h = 1e-3;
    for k in 0..20_000 {
        let t = k as f64 * h;
        let out = plant.outputs();
        let speed = if t < 8.0 { slew_speed(t, 1.0, 1.0, 8.0) } else { 0.01 * (std::f64::consts::TAU * t / 3.0).sin() };
        let current =
            control.current(speed.to_radians() * params.ratio_at(out.axis_position_deg), out.motor_speed_rad_per_s, h);
        let inputs = ElevationInputs {
            current_command_a: current,
            disturbance_torque_nm: 2e3 * (std::f64::consts::TAU * t / 0.7).sin(),
        };
        for _ in 0..substeps_per_ms {
            plant.step(&inputs, h / substeps_per_ms as f64).unwrap();
        }
        let o = plant.outputs();
        samples.push(Sample {
            position_deg: o.axis_position_deg,
            current_a: o.motor_current_a,
            torque_nm: o.drive_torque_nm,
        });
    }
    (samples, plant.numerics_statistics().events)
}

#[test]
fn elevation_step_size_dependence_with_the_nonlinear_effects_on_is_within_the_documented_bound() {
    let params = ElevationParams::default();
    let mut fine_events = params;
    fine_events.numerics.event_time_resolution_s = 1e-8;
    let (reference, events) = elevation_slew_and_reversals(fine_events, 10);
    println!("elevation slew and reversals: {events} mode switches in 20 s");
    assert!(events > 10, "the scenario must exercise sticking and slipping");
    for substeps in [1, 10] {
        let (run, _) = elevation_slew_and_reversals(params, substeps);
        let step = 1e-3 / substeps as f64;
        let name = format!("elevation, default effects, step {step:e} s vs 1e-4 s with 1e-8 s event resolution");
        check(report(&name, &run, &reference), &STEP_SIZE_BOUND);
    }
    // The linear drive with the varying geometry: only the curvature term, held per step,
    // depends on the step.
    let linear = ElevationParams { geometry_frozen: false, ..ElevationParams::linear() };
    let (coarse, _) = elevation_slew_and_reversals(linear, 1);
    let (fine, _) = elevation_slew_and_reversals(linear, 10);
    check(
        report("elevation, linear drive with varying geometry, step 1e-3 s vs 1e-4 s", &coarse, &fine),
        &STEP_SIZE_BOUND,
    );
}
