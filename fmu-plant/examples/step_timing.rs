//! Wall-clock cost of one 1 ms plant step, for the performance budget (the coupled antenna must
//! run at least 2000 times real time at 1 kHz). Each axis runs under a simple velocity PI loop
//! on motor speed (a few nanoseconds of the figure), so the scenarios stay where they belong.
//!
//! Run with `cargo run --release -p fmu-plant --example step_timing`.

use std::hint::black_box;
use std::time::Instant;

use fmu_plant::{AzimuthInputs, AzimuthParams, AzimuthPlant, ElevationInputs, ElevationParams, ElevationPlant};

const H: f64 = 1e-3;

/// Nanoseconds this thread has spent on a CPU (Linux), or wall-clock nanoseconds elsewhere.
/// On a shared machine the CPU time is the fairer measure: it leaves out time spent waiting
/// for a core.
struct Clock {
    wall: Instant,
    cpu: Option<u64>,
}

fn cpu_ns() -> Option<u64> {
    std::fs::read_to_string("/proc/thread-self/schedstat").ok()?.split_whitespace().next()?.parse().ok()
}

impl Clock {
    fn start() -> Self {
        Self { wall: Instant::now(), cpu: cpu_ns() }
    }

    /// (CPU ns, wall ns) per step.
    fn per_step(&self, steps: usize) -> (f64, f64) {
        let wall = self.wall.elapsed().as_nanos() as f64 / steps as f64;
        let cpu = match (self.cpu, cpu_ns()) {
            (Some(a), Some(b)) => (b - a) as f64 / steps as f64,
            _ => wall,
        };
        (cpu, wall)
    }
}

struct VelocityLoop {
    kp: f64,
    ki: f64,
    integrator: f64,
}

impl VelocityLoop {
    fn new(inertia: f64, torque_per_amp: f64, bandwidth_hz: f64) -> Self {
        let kp = inertia * std::f64::consts::TAU * bandwidth_hz / torque_per_amp;
        Self { kp, ki: kp * std::f64::consts::TAU * bandwidth_hz / 5.0, integrator: 0.0 }
    }

    fn current(&mut self, reference: f64, measured: f64) -> f64 {
        let error = reference - measured;
        self.integrator += self.ki * error * H;
        self.kp * error + self.integrator
    }
}

/// Azimuth at a constant axis speed with a 2 A torque bias; returns ns per step.
fn azimuth(name: &str, params: AzimuthParams, speed_deg_per_s: f64, steps: usize) {
    let mut plant = AzimuthPlant::new(params).unwrap();
    plant.set_initial_state(0.0).unwrap();
    let t = params.two_mass_at(45.0);
    let mut control =
        VelocityLoop::new(t.motor_inertia + t.load_inertia, 2.0 * params.motors[0].torque_constant_nm_per_a, 8.0);
    let reference = speed_deg_per_s.to_radians() * params.gear_ratio;
    let mut run = |plant: &mut AzimuthPlant, n: usize| {
        for _ in 0..n {
            let o = plant.outputs();
            let i = control.current(reference, 0.5 * (o.motor_speed_rad_per_s[0] + o.motor_speed_rad_per_s[1]));
            let inputs = AzimuthInputs {
                current_command_a: [i + 2.0, i - 2.0],
                disturbance_torque_nm: 0.0,
                elevation_deg: 45.0,
            };
            plant.step(black_box(&inputs), H).unwrap();
        }
    };
    run(&mut plant, 20_000);
    let before = plant.numerics_statistics();
    let clock = Clock::start();
    run(&mut plant, steps);
    let (ns, wall) = clock.per_step(steps);
    let after = plant.numerics_statistics();
    println!(
        "azimuth   {name:<46} {ns:7.1} ns/step CPU ({wall:7.1} wall)   ({} events, {} exponentials while timed)",
        after.events - before.events,
        after.discretisations_computed - before.discretisations_computed
    );
}

fn elevation(name: &str, params: ElevationParams, speed_deg_per_s: f64, steps: usize) {
    let mut plant = ElevationPlant::new(params).unwrap();
    plant.set_initial_state(45f64.to_radians()).unwrap();
    let t = params.two_mass_at(45.0);
    let mut control = VelocityLoop::new(t.motor_inertia + t.load_inertia, params.motor.torque_constant_nm_per_a, 8.0);
    let mut run = |plant: &mut ElevationPlant, n: usize| {
        for _ in 0..n {
            let o = plant.outputs();
            let i = control.current(speed_deg_per_s.to_radians() * o.transmission_ratio, o.motor_speed_rad_per_s);
            plant.step(black_box(&ElevationInputs { current_command_a: i, disturbance_torque_nm: 0.0 }), H).unwrap();
        }
    };
    run(&mut plant, 20_000);
    let before = plant.numerics_statistics();
    let clock = Clock::start();
    run(&mut plant, steps);
    let (ns, wall) = clock.per_step(steps);
    let after = plant.numerics_statistics();
    println!(
        "elevation {name:<46} {ns:7.1} ns/step CPU ({wall:7.1} wall)   ({} events, {} exponentials while timed)",
        after.events - before.events,
        after.discretisations_computed - before.discretisations_computed
    );
}

/// Both axes slewing across the elevation range: azimuth at 2 deg/s while elevation goes from
/// 15 to 85 deg at 1 deg/s. Every parameter-grid cell is new, so this is the worst common case.
fn slew() {
    let (az_params, el_params) = (AzimuthParams::default(), ElevationParams::default());
    let mut az = AzimuthPlant::new(az_params).unwrap();
    let mut el = ElevationPlant::new(el_params).unwrap();
    az.set_initial_state(0.0).unwrap();
    el.set_initial_state(15f64.to_radians()).unwrap();
    let (ta, te) = (az_params.two_mass_at(45.0), el_params.two_mass_at(45.0));
    let mut az_loop = VelocityLoop::new(ta.motor_inertia + ta.load_inertia, 1.6, 8.0);
    let mut el_loop = VelocityLoop::new(te.motor_inertia + te.load_inertia, 0.8, 8.0);
    let steps = 70_000;
    let clock = Clock::start();
    for k in 0..steps {
        let ramp = (k as f64 * H).min(1.0);
        let (ao, eo) = (az.outputs(), el.outputs());
        let i = az_loop.current(
            2f64.to_radians() * ramp * az_params.gear_ratio,
            0.5 * (ao.motor_speed_rad_per_s[0] + ao.motor_speed_rad_per_s[1]),
        );
        let az_inputs = AzimuthInputs {
            current_command_a: [i + 2.0, i - 2.0],
            disturbance_torque_nm: 0.0,
            elevation_deg: eo.axis_position_deg,
        };
        az.step(&az_inputs, H).unwrap();
        let j = el_loop.current(1f64.to_radians() * ramp * eo.transmission_ratio, eo.motor_speed_rad_per_s);
        el.step(&ElevationInputs { current_command_a: j, disturbance_torque_nm: 0.0 }, H).unwrap();
    }
    let (ns, wall) = clock.per_step(steps);
    println!(
        "slew: both axes, az 2 deg/s, el 15 -> {:.0} deg at 1 deg/s: {ns:7.1} ns CPU ({wall:.1} wall) per 1 ms step of both plants\n  azimuth   {:?}\n  elevation {:?}",
        el.outputs().axis_position_deg,
        az.numerics_statistics(),
        el.numerics_statistics()
    );
}

fn main() {
    let steps = 2_000_000;
    let sidereal = 0.004;
    azimuth("default, biased, tracking 4 mdeg/s", AzimuthParams::default(), sidereal, steps);
    azimuth("default, biased, holding still", AzimuthParams::default(), 0.0, steps);
    azimuth("linear (Eq. 1), tracking 4 mdeg/s", AzimuthParams::linear(), sidereal, steps);
    let mut effects = AzimuthParams::default();
    for m in effects.motors.iter_mut() {
        m.cogging.amplitude_nm = 0.02;
        m.friction.stribeck_velocity_rad_per_s = 2.0;
    }
    azimuth("default + cogging + Stribeck (10 sub-steps)", effects, sidereal, steps / 10);
    elevation("default, tracking 4 mdeg/s", ElevationParams::default(), sidereal, steps);
    elevation("default, holding still", ElevationParams::default(), 0.0, steps);
    elevation("linear (Eq. 1, frozen geometry), tracking", ElevationParams::linear(), sidereal, steps);
    slew();
}
