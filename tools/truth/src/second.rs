//! A second, separately written log generator: a check that `validate` is not shaped by the
//! truth generator of this crate (`lib.rs`), whose code it shares none of.
//!
//! It was written from the physics alone, with other choices wherever a choice exists: the
//! controller is a 1 kHz (or log-rate) cascade closed on the load encoder and a filtered
//! motor-encoder speed, the excitation a logarithmic multisine torque of 60 lines from 0.3 to
//! 40 Hz added to the speed loop's output, the motion a random sequence of trapezoidal slews,
//! slow tracking in either direction and sine scans, the friction LuGre with its bristle state
//! relaxed exactly over each substep (or a static curve), the current loop of second order at
//! 250 Hz, the integration at 20 kHz (speeds by Euler, positions by the trapezoid). Everything is on the axis side; the
//! nominal plant is `start.params`, and an effect is added to the truth only.

use std::f64::consts::PI;
use std::fmt::Write as _;

use rand::SeedableRng;
use rand_distr::{Distribution, Normal, Uniform};

/// The torque noise the effect sizes are measured in (axis side, N m): the current sensor's
/// noise times the torque constant and the gear ratio.
pub const TORQUE_SIGMA: f64 = 30.0;

/// The effects the generator can add, each at `SIZE` times the torque noise or its like.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SecondEffect {
    Clean,
    Coulomb,
    Stribeck,
    Offset,
    Unbalance,
    Inertia,
    TorqueConstant,
    Delay,
    Backlash,
    Stiffness,
    Cogging,
    Asymmetry,
    /// A Coulomb change and an unbalance together.
    CoulombUnbalance,
}

/// What to generate.
#[derive(Debug, Clone)]
pub struct SecondOptions {
    pub effect: SecondEffect,
    pub seed: u64,
    pub duration: f64,
    /// The controller's and the log's rate (Hz).
    pub rate: f64,
    /// The delay of the delay effect (s).
    pub delay: f64,
    /// A current sensor without noise (rounded to 1 mA).
    pub noiseless_current: bool,
    /// The load encoder read this long after the motor encoder and the current (s).
    pub load_skew: f64,
    /// A static friction curve instead of LuGre's bristles.
    pub static_friction: bool,
}

impl Default for SecondOptions {
    fn default() -> Self {
        SecondOptions {
            effect: SecondEffect::Clean,
            seed: 1,
            duration: 60.0,
            rate: 1000.0,
            delay: 4e-3,
            noiseless_current: false,
            load_skew: 0.0,
            static_friction: false,
        }
    }
}

/// The plant, axis side (SI: rad, N m, kg m^2).
#[derive(Debug, Clone)]
struct Plant {
    gear: f64,
    motor_inertia: f64,
    load_inertia: f64,
    stiffness: f64,
    damping: f64,
    viscous: f64,
    coulomb: f64,
    breakaway: f64,
    stribeck_velocity: f64,
    bristle_stiffness: f64,
    bristle_damping: f64,
    torque_constant: f64,
    torque_constant_scale: f64,
    offset: f64,
    unbalance: f64,
    unbalance_phase: f64,
    delay: f64,
    backlash: f64,
    cogging: f64,
    cogging_period: f64,
    cogging_phase: f64,
    asymmetry: f64,
}

impl Plant {
    /// The nominal plant: the numbers of `start.params`, with LuGre bristles whose presliding
    /// reach at the Coulomb level is 1 microradian at the axis (0.2 arcsec).
    fn nominal() -> Plant {
        let gear = 1200.0;
        Plant {
            gear,
            motor_inertia: 0.02 * gear * gear,
            load_inertia: 6e4,
            stiffness: 3.79e7,
            damping: 1.2e5,
            viscous: 2e4,
            coulomb: 3000.0,
            breakaway: 4000.0,
            stribeck_velocity: 2e-3,
            bristle_stiffness: 3e9,
            bristle_damping: 9e6,
            torque_constant: 2.0,
            torque_constant_scale: 1.0,
            offset: 0.0,
            unbalance: 0.0,
            unbalance_phase: 0.0,
            delay: 0.0,
            backlash: 0.0,
            cogging: 0.0,
            cogging_period: 2.0 * PI / (gear * 4.0),
            cogging_phase: 0.0,
            asymmetry: 0.0,
        }
    }

    /// The nominal plant with the effect added at 10 times the torque noise (or the like).
    fn with(effect: SecondEffect, delay: f64) -> Plant {
        let mut p = Plant::nominal();
        let size = 10.0 * TORQUE_SIGMA;
        match effect {
            SecondEffect::Clean => {}
            SecondEffect::Coulomb => {
                p.coulomb += size;
                p.breakaway += size;
            }
            SecondEffect::Stribeck => p.breakaway += 2.0 * size,
            SecondEffect::Offset => p.offset = size,
            SecondEffect::Unbalance => {
                p.unbalance = size;
                p.unbalance_phase = 0.3;
            }
            SecondEffect::Inertia => p.load_inertia *= 1.45,
            SecondEffect::TorqueConstant => p.torque_constant_scale = 0.93,
            SecondEffect::Delay => p.delay = delay,
            SecondEffect::Backlash => p.backlash = 2.3e-6,
            SecondEffect::Stiffness => p.stiffness *= 0.93,
            SecondEffect::Cogging => {
                p.cogging = 1.3 * size;
                p.cogging_phase = 0.7;
            }
            SecondEffect::Asymmetry => p.asymmetry = 0.1,
            SecondEffect::CoulombUnbalance => {
                p.coulomb += size;
                p.breakaway += size;
                p.unbalance = size;
            }
        }
        p
    }

    /// The friction level at speed `v`: Coulomb plus the Stribeck hump, scaled by direction.
    fn friction_level(&self, v: f64) -> f64 {
        let scale = if v >= 0.0 { 1.0 + self.asymmetry } else { 1.0 - self.asymmetry };
        scale * (self.coulomb + (self.breakaway - self.coulomb) * (-(v / self.stribeck_velocity).powi(2)).exp())
    }
}

/// The motion asked of the axis: position and speed at each control step.
fn reference(steps: usize, dt: f64, rng: &mut rand_chacha::ChaCha8Rng) -> Vec<(f64, f64)> {
    let unit = Uniform::new(0.0f64, 1.0).expect("a valid range");
    let mut draw = || -> f64 { unit.sample(rng) };
    let mut out = Vec::with_capacity(steps);
    let mut pos = (30.0 + 40.0 * draw()).to_radians();
    while out.len() < steps {
        let choice = draw();
        if choice < 0.4 {
            let target = pos + (draw() - 0.5) * 16f64.to_radians();
            let top = (0.3 + 1.2 * draw()).to_radians();
            pos = slew(&mut out, pos, target, top, 0.5f64.to_radians(), dt);
        } else if choice < 0.7 {
            let rate = (draw() - 0.5) * 0.03f64.to_radians();
            for _ in 0..(3000.0 + 4000.0 * draw()) as usize {
                pos += rate * dt;
                out.push((pos, rate));
            }
        } else {
            let amplitude = (0.2 + 0.8 * draw()).to_radians();
            let w = 2.0 * PI * (0.1 + 0.2 * draw());
            for j in 0..(2.0 * 2.0 * PI / w / dt) as usize {
                let t = j as f64 * dt;
                out.push((pos + amplitude * (w * t).sin(), amplitude * w * (w * t).cos()));
            }
        }
    }
    out.truncate(steps);
    out
}

/// A trapezoidal slew from `from` to `to`; returns where it ends.
fn slew(out: &mut Vec<(f64, f64)>, from: f64, to: f64, top: f64, acceleration: f64, dt: f64) -> f64 {
    let direction = (to - from).signum();
    let (mut x, mut v) = (from, 0.0f64);
    loop {
        let remaining = direction * (to - x);
        if remaining <= 0.0 {
            out.push((to, 0.0));
            return to;
        }
        let braking = v * v / (2.0 * acceleration) >= remaining;
        let a = if braking {
            -acceleration
        } else if v < top {
            acceleration
        } else {
            0.0
        };
        v = (v + a * dt).clamp(0.0, top);
        if braking && v == 0.0 {
            v = (remaining / dt).min(acceleration * dt);
        }
        x += direction * v * dt;
        out.push((x, direction * v));
    }
}

/// The state of the simulation between control steps.
struct State {
    motor: f64,
    load: f64,
    motor_speed: f64,
    load_speed: f64,
    bristle: f64,
    current: f64,
    current_rate: f64,
}

/// Rounds to a quantum.
fn quantise(x: f64, quantum: f64) -> f64 {
    (x / quantum).round() * quantum
}

/// A log as CSV text (`docs/measured-log-format.md`), with the truth as comment lines.
pub fn generate(options: &SecondOptions) -> String {
    let p = Plant::with(options.effect, options.delay);
    let nominal = Plant::nominal();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(options.seed);
    let dt_control = 1.0 / options.rate;
    let substeps = (20_000.0 / options.rate).round().max(1.0) as usize;
    let dt = dt_control / substeps as f64;
    let steps = (options.duration * options.rate) as usize;
    let reference = reference(steps, dt_control, &mut rng);
    let phases: Vec<(f64, f64)> = (0..60)
        .map(|j| {
            (
                0.3 * (40.0f64 / 0.3).powf(f64::from(j) / 59.0),
                2.0 * PI * Uniform::new(0.0, 1.0).expect("range").sample(&mut rng),
            )
        })
        .collect();
    let injection_amplitude = 200.0 * (2.0f64 / 60.0).sqrt();
    // The cascade's gains from the nominal plant: a 2.5 Hz speed loop with its integral at 0.4
    // Hz, a 0.6 Hz position loop, a 60 Hz first-order filter on the encoder's speed.
    let total_inertia = nominal.motor_inertia + nominal.load_inertia;
    let speed_gain = total_inertia * 2.0 * PI * 2.5;
    let integral_gain = speed_gain * 2.0 * PI * 0.4;
    let position_gain = 2.0 * PI * 0.6;
    let filter = 1.0 - (-2.0 * PI * 60.0 * dt_control).exp();
    let (loop_frequency, loop_damping) = (2.0 * PI * 250.0, 0.7);
    let load_quantum = 2.0 * PI / f64::from(1u32 << 25);
    let motor_quantum = 2.0 * PI / (f64::from(1u32 << 18) * p.gear);
    let encoder_noise = Normal::new(0.0, 1e-7).expect("a valid deviation");
    let current_sigma = if options.noiseless_current { 0.0 } else { TORQUE_SIGMA / (p.gear * p.torque_constant) };
    let current_noise = Normal::new(0.0, current_sigma).expect("a valid deviation");
    let start = reference[0].0;
    let mut s = State {
        motor: start,
        load: start,
        motor_speed: 0.0,
        load_speed: 0.0,
        bristle: 0.0,
        current: 0.0,
        current_rate: 0.0,
    };
    // The applied current is the logged one `delay` earlier, taken at the middle of each
    // substep (the mean of the two values around it), so that the torque acts when the
    // current says and a clean log has no delay of its own.
    let mut delayed = vec![0.0; (p.delay / dt).round() as usize + 2];
    let mut skewed = vec![start; (options.load_skew / dt).round() as usize + 1];
    let (mut at, mut skew_at) = (0usize, 0usize);
    let mut integral = p.offset + p.unbalance * (start + p.unbalance_phase).cos();
    let mut previous_motor = quantise(start, motor_quantum);
    let mut speed_estimate = 0.0;
    let mut text = header(options, &p);
    for (k, &(ref_pos, ref_speed)) in reference.iter().enumerate() {
        let t = k as f64 * dt_control;
        let motor = quantise(s.motor + 0.5 * encoder_noise.sample(&mut rng), motor_quantum);
        let load = quantise(skewed[(skew_at + 1) % skewed.len()] + encoder_noise.sample(&mut rng), load_quantum);
        let current = quantise(s.current + current_noise.sample(&mut rng), 1e-3);
        let _ = writeln!(
            text,
            "{t:.6},{:.10},{current:.4},{:.10},{:.10}",
            ref_pos.to_degrees(),
            motor.to_degrees(),
            load.to_degrees()
        );
        speed_estimate += filter * ((motor - previous_motor) / dt_control - speed_estimate);
        previous_motor = motor;
        let error = ref_speed + position_gain * (ref_pos - load) - speed_estimate;
        integral += integral_gain * error * dt_control;
        let injection: f64 =
            phases.iter().map(|(f, phase)| injection_amplitude * (2.0 * PI * f * t + phase).sin()).sum();
        let command = (speed_gain * error + integral + injection) / (nominal.gear * nominal.torque_constant);
        for _ in 0..substeps {
            let acceleration = loop_frequency * loop_frequency * (command - s.current)
                - 2.0 * loop_damping * loop_frequency * s.current_rate;
            s.current_rate += acceleration * dt;
            s.current += s.current_rate * dt;
            delayed[at] = s.current;
            let applied = 0.5 * (delayed[(at + 1) % delayed.len()] + delayed[(at + 2) % delayed.len()]);
            at = (at + 1) % delayed.len();
            substep(&p, &mut s, applied, dt, options.static_friction);
            skewed[skew_at] = s.load;
            skew_at = (skew_at + 1) % skewed.len();
        }
    }
    text
}

/// One substep of the mechanics with the applied current.
fn substep(p: &Plant, s: &mut State, current: f64, dt: f64, static_friction: bool) {
    let v = s.motor_speed;
    let level = p.friction_level(v);
    let friction = if static_friction {
        level * (v / 1e-5).tanh() + p.viscous * v
    } else {
        // The bristle relaxes towards level/sigma0 at the rate sigma0 |v| / level: exact over
        // the substep for a constant speed, stable however stiff.
        let rate = p.bristle_stiffness * v.abs() / level;
        let steady = v.signum() * level / p.bristle_stiffness;
        let next = if rate > 0.0 { steady + (s.bristle - steady) * (-rate * dt).exp() } else { s.bristle };
        let bristle_rate = (next - s.bristle) / dt;
        s.bristle = next;
        p.bristle_stiffness * s.bristle + p.bristle_damping * bristle_rate + p.viscous * v
    };
    let twist = s.motor - s.load;
    let half = 0.5 * p.backlash;
    let shaft = if twist.abs() <= half {
        0.0
    } else {
        p.stiffness * (twist - half * twist.signum()) + p.damping * (s.motor_speed - s.load_speed)
    };
    let cogging = p.cogging * (2.0 * PI * s.motor / p.cogging_period + p.cogging_phase).sin();
    let motor_torque = p.gear * p.torque_constant * p.torque_constant_scale * current;
    let load_torque = p.offset + p.unbalance * (s.load + p.unbalance_phase).cos();
    // The positions move with the mean of the speeds before and after (trapezoidal), so that
    // the motion is centred on the substep as the torque is.
    let (motor_speed, load_speed) = (s.motor_speed, s.load_speed);
    s.motor_speed += (motor_torque - shaft - friction - cogging) / p.motor_inertia * dt;
    s.load_speed += (shaft - load_torque) / p.load_inertia * dt;
    s.motor += 0.5 * (motor_speed + s.motor_speed) * dt;
    s.load += 0.5 * (load_speed + s.load_speed) * dt;
}

/// The log's metadata and header lines, with the truth as comments.
fn header(options: &SecondOptions, p: &Plant) -> String {
    let mut text = String::new();
    let _ = writeln!(text, "# generated_by = secondgen (antenna-truth's second generator)");
    let _ = writeln!(
        text,
        "# truth: effect {:?}, seed {}, delay {} s, load skew {} s, noiseless current {}, static friction {}",
        options.effect, options.seed, p.delay, options.load_skew, options.noiseless_current, options.static_friction
    );
    let _ = writeln!(
        text,
        "# truth: coulomb {} N m, breakaway {} N m, offset {} N m, unbalance {} N m at {} rad, load inertia {} kg m^2, torque constant scale {}, backlash {} rad, stiffness {} N m/rad, cogging {} N m over {} rad at {} rad, asymmetry {}",
        p.coulomb, p.breakaway, p.offset, p.unbalance, p.unbalance_phase, p.load_inertia, p.torque_constant_scale, p.backlash, p.stiffness, p.cogging, p.cogging_period, p.cogging_phase, p.asymmetry
    );
    let _ = writeln!(text, "time_s,ref_pos_deg,motor_current_A,motor_pos_deg,load_pos_deg");
    text
}

/// The starting parameter set: the nominal plant in `validate`'s parameter-file form.
pub fn start_params() -> String {
    let p = Plant::nominal();
    let rows = [
        ("gear.ratio", p.gear, "-"),
        ("motor.inertia", p.motor_inertia / (p.gear * p.gear), "kg m^2, motor side"),
        ("motor.torque_constant", p.torque_constant, "N m/A"),
        ("load.inertia", p.load_inertia, "kg m^2"),
        ("path.stiffness", p.stiffness, "N m/rad"),
        ("path.damping", p.damping, "N m s/rad"),
        ("friction.viscous", p.viscous, "N m s/rad"),
        ("friction.coulomb", p.coulomb, "N m"),
        ("friction.static", p.breakaway, "N m"),
        ("friction.stribeck_velocity", p.stribeck_velocity, "rad/s"),
    ];
    let mut text = String::from("# The second generator's nominal plant (tools/truth/src/second.rs).\n");
    for (name, value, unit) in rows {
        let _ = writeln!(text, "{name:<28} = {value:e}  # {unit}");
    }
    text
}
