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

use std::path::Path;

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal, Uniform};

use crate::suite::{truth_text, CaseTruth};
use crate::Effect;

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
    /// A rigid linear carriage of 95 kg on a direct drive instead of the rotary two-mass
    /// drive: positions in metres, one encoder, no injected excitation, the published EMPS
    /// benchmark's numbers as its plant (see [`Plant::carriage`]).
    pub carriage: bool,
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
            carriage: false,
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
    /// One body: the load moves with the motor (no path).
    rigid: bool,
    /// The torque noise of the current sensor (N m or N, axis side), the unit of the effect
    /// sizes.
    torque_sigma: f64,
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
            rigid: false,
            torque_sigma: TORQUE_SIGMA,
        }
    }

    /// A carriage with the numbers Janot, Gautier and Brunot (2019) publish for the EMPS
    /// benchmark: 95.1 kg, 203.5 N s/m viscous and 20.4 N Coulomb friction, an offset of
    /// -3.4 N, a force constant of 35.15 N per ampere (per volt of command there), as a linear
    /// axis of unit radius and gear ratio 1. No Stribeck hump (the published model has none);
    /// bristles reaching 10 micrometres at the Coulomb level; the force noise (0.5 N) an
    /// estimate.
    fn carriage() -> Plant {
        let (mass, coulomb) = (95.1, 20.4);
        let bristle_stiffness = coulomb / 1e-5;
        Plant {
            gear: 1.0,
            motor_inertia: mass,
            load_inertia: 0.0,
            stiffness: 0.0,
            damping: 0.0,
            viscous: 203.5,
            coulomb,
            breakaway: coulomb,
            stribeck_velocity: 0.01,
            bristle_stiffness,
            bristle_damping: (bristle_stiffness * mass).sqrt(),
            torque_constant: 35.15,
            torque_constant_scale: 1.0,
            offset: -3.4,
            unbalance: 0.0,
            unbalance_phase: 0.0,
            delay: 0.0,
            backlash: 0.0,
            cogging: 0.0,
            cogging_period: 0.02,
            cogging_phase: 0.0,
            asymmetry: 0.0,
            rigid: true,
            torque_sigma: 0.5,
        }
    }

    /// The plant with the effect added at 10 times the torque noise (or the like).
    fn with(mut self, effect: SecondEffect, delay: f64) -> Plant {
        let p = &mut self;
        let size = 10.0 * p.torque_sigma;
        match effect {
            SecondEffect::Clean => {}
            SecondEffect::Coulomb => {
                p.coulomb += size;
                p.breakaway += size;
            }
            SecondEffect::Stribeck => p.breakaway += 2.0 * size,
            SecondEffect::Offset => p.offset += size,
            SecondEffect::Unbalance => {
                p.unbalance = size;
                p.unbalance_phase = 0.3;
            }
            SecondEffect::Inertia if p.rigid => p.motor_inertia *= 1.45,
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
        self
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

/// Why `secondgen` cannot write a log as asked.
#[derive(Debug, thiserror::Error)]
pub enum SecondError {
    #[error("the carriage is one rigid body on a straight line: it has no {0} (use the rotary drive)")]
    NotOnACarriage(&'static str),
    #[error("cannot write {path}: {source}")]
    Write { path: std::path::PathBuf, source: std::io::Error },
}

/// The kinds of a suite of the rotary drive, each with the truth generator's name for it and
/// the truth the scoring (`crate::scoring`) compares the found change with.
fn suite_truths(effect: SecondEffect, delay: f64) -> Vec<(String, f64, Effect)> {
    let p = Plant::nominal().with(effect, delay);
    let nominal = Plant::nominal();
    let size = 10.0;
    let one = |kind: &str, e: Effect| vec![(kind.to_string(), size, e)];
    match effect {
        SecondEffect::Clean => vec![],
        SecondEffect::Coulomb => one("coulomb", Effect::Coulomb(p.coulomb - nominal.coulomb)),
        SecondEffect::Stribeck => one("stribeck", Effect::Stribeck(p.breakaway - nominal.breakaway)),
        SecondEffect::Offset => one("torque_offset", Effect::TorqueOffset(p.offset)),
        SecondEffect::Unbalance => {
            one("unbalance", Effect::Unbalance { amplitude: p.unbalance, phase: p.unbalance_phase })
        }
        SecondEffect::Inertia => one("inertia", Effect::InertiaFactor(p.load_inertia / nominal.load_inertia)),
        SecondEffect::TorqueConstant => one("torque_constant", Effect::TorqueConstantScale(p.torque_constant_scale)),
        SecondEffect::Delay => one("delay", Effect::Delay(p.delay)),
        SecondEffect::Backlash => one("backlash", Effect::Backlash(p.backlash)),
        SecondEffect::Stiffness => one("stiffness", Effect::StiffnessFactor(p.stiffness / nominal.stiffness)),
        SecondEffect::Cogging => {
            one("cogging", Effect::Cogging { amplitude: p.cogging, period: p.cogging_period, phase: p.cogging_phase })
        }
        // The friction's sliding level moves by the asymmetry times it, either way.
        SecondEffect::Asymmetry => one("asymmetry", Effect::Asymmetry(p.asymmetry * p.coulomb)),
        SecondEffect::CoulombUnbalance => vec![
            ("coulomb".to_string(), size, Effect::Coulomb(p.coulomb - nominal.coulomb)),
            ("unbalance".to_string(), size, Effect::Unbalance { amplitude: p.unbalance, phase: p.unbalance_phase }),
        ],
    }
}

/// Writes a suite of the rotary drive in the truth generator's layout (`log_NNN.csv` with a
/// `.truth` sidecar, and `start.params`), which `validate suite DIR` scores as it scores
/// that generator's: per seed a clean log, every single effect and the Coulomb-unbalance
/// pair, in an order shuffled by the seeds, each with `base`'s length, rate, delay and
/// sensors (its effect and seed are the suite's). The effect sizes stay against the current
/// noise of the default sensor (`TORQUE_SIGMA`), also with a noiseless current. Returns the
/// logs written.
pub fn write_suite(dir: &Path, seeds: &[u64], base: &SecondOptions) -> Result<usize, SecondError> {
    if base.carriage {
        return Err(SecondError::NotOnACarriage("suite (unbalance and drive path)"));
    }
    let write = |path: std::path::PathBuf, text: &str| {
        std::fs::write(&path, text).map_err(|source| SecondError::Write { path, source })
    };
    std::fs::create_dir_all(dir).map_err(|source| SecondError::Write { path: dir.to_path_buf(), source })?;
    let mut cases: Vec<(u64, SecondEffect)> = seeds
        .iter()
        .flat_map(|&seed| <SecondEffect as clap::ValueEnum>::value_variants().iter().map(move |&effect| (seed, effect)))
        .collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(
        seeds.iter().fold(0x5EC0u64, |a, s| a.wrapping_mul(31).wrapping_add(*s)),
    );
    cases.shuffle(&mut rng);
    for (index, &(seed, effect)) in cases.iter().enumerate() {
        let name = format!("log_{:03}", index + 1);
        let options = SecondOptions { effect, seed, ..base.clone() };
        let truth = CaseTruth {
            log_file: format!("{name}.csv"),
            seed,
            effects: suite_truths(effect, options.delay),
            torque_sigma: TORQUE_SIGMA,
            // The motor encoder carries half the load encoder's white noise (`generate`).
            twist_sigma: Drive::for_plant(&Plant::nominal()).encoder_noise * 1.25f64.sqrt(),
            sample_interval: 1.0 / options.rate,
            conditions: suite_conditions(&options),
        };
        write(dir.join(format!("{name}.csv")), &generate(&options)?)?;
        write(dir.join(format!("{name}.truth")), &truth_text(&truth))?;
    }
    write(dir.join("start.params"), &start_params(false))?;
    Ok(cases.len())
}

/// The `.truth` sidecar's conditions of a suite log: the generator, and each option that
/// differs from the default (for the report, and the skew for the scoring).
fn suite_conditions(options: &SecondOptions) -> std::collections::BTreeMap<String, String> {
    let default = SecondOptions::default();
    let mut conditions = std::collections::BTreeMap::from([("generator".to_string(), "secondgen".to_string())]);
    let mut differs = |name: &str, value: String, default_value: String| {
        if value != default_value {
            conditions.insert(name.to_string(), value);
        }
    };
    differs("duration_s", options.duration.to_string(), default.duration.to_string());
    differs("rate_hz", options.rate.to_string(), default.rate.to_string());
    differs("noiseless_current", options.noiseless_current.to_string(), default.noiseless_current.to_string());
    // The scoring's name and sign: the instant the load encoder is read less the motor
    // encoder's, so that a skew `validate` finds is right where the log has one. This
    // generator's load encoder reads the angle `load_skew` old: read that much earlier.
    differs("load_encoder_skew", (-options.load_skew).to_string(), (-default.load_skew).to_string());
    differs("static_friction", options.static_friction.to_string(), default.static_friction.to_string());
    conditions
}

/// The controller, the motion and the sensors of a drive, from its nominal plant.
struct Drive {
    /// Speed-loop gain (N m s/rad), its integral's (N m/rad), the position loop's (1/s).
    speed_gain: f64,
    integral_gain: f64,
    position_gain: f64,
    /// The encoder speed's first-order filter (Hz).
    speed_filter_hz: f64,
    /// RMS of the multisine torque added to the speed loop's output (N m).
    injection_rms: f64,
    /// The encoders' quanta and white noise (rad or m, axis side).
    motor_quantum: f64,
    load_quantum: f64,
    encoder_noise: f64,
}

impl Drive {
    /// The rotary drive: a 2.5 Hz speed loop with its integral at 0.4 Hz, a 0.6 Hz position
    /// loop on the load encoder, a 60 Hz speed filter, 200 N m of multisine; an 18-bit motor
    /// encoder and a 25-bit load encoder with 0.1 microradian of noise. The carriage (EMPS-like):
    /// a 20 Hz speed loop with its integral at 4 Hz, a 3 Hz position loop on the one encoder,
    /// a 200 Hz filter, no injected excitation (the benchmark's logs have none), 0.1 micrometre
    /// steps and 20 nm of noise.
    fn for_plant(p: &Plant) -> Drive {
        // (speed loop, its integral, position loop, speed filter: Hz; multisine RMS: N m;
        // motor and load encoder quanta and white noise: rad or m, axis side)
        let (speed_hz, integral_hz, position_hz, filter_hz, injection_rms, motor_quantum, load_quantum, noise) =
            if p.rigid {
                (20.0, 4.0, 3.0, 200.0, 0.0, 1e-7, 1e-7, 2e-8)
            } else {
                let motor = 2.0 * PI / (f64::from(1u32 << 18) * p.gear);
                (2.5, 0.4, 0.6, 60.0, 200.0, motor, 2.0 * PI / f64::from(1u32 << 25), 1e-7)
            };
        let speed_gain = (p.motor_inertia + p.load_inertia) * 2.0 * PI * speed_hz;
        Drive {
            speed_gain,
            integral_gain: speed_gain * 2.0 * PI * integral_hz,
            position_gain: 2.0 * PI * position_hz,
            speed_filter_hz: filter_hz,
            injection_rms,
            motor_quantum,
            load_quantum,
            encoder_noise: noise,
        }
    }
}

/// A log as CSV text (`docs/measured-log-format.md`), with the truth as comment lines.
pub fn generate(options: &SecondOptions) -> Result<String, SecondError> {
    let nominal = if options.carriage { Plant::carriage() } else { Plant::nominal() };
    if nominal.rigid {
        match options.effect {
            SecondEffect::Unbalance | SecondEffect::CoulombUnbalance => {
                return Err(SecondError::NotOnACarriage("unbalance"))
            }
            SecondEffect::Backlash | SecondEffect::Stiffness => return Err(SecondError::NotOnACarriage("drive path")),
            _ if options.load_skew != 0.0 => return Err(SecondError::NotOnACarriage("load encoder")),
            _ => {}
        }
    }
    let p = nominal.clone().with(options.effect, options.delay);
    let drive = Drive::for_plant(&nominal);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(options.seed);
    let dt_control = 1.0 / options.rate;
    let substeps = (20_000.0 / options.rate).round().max(1.0) as usize;
    let dt = dt_control / substeps as f64;
    let steps = (options.duration * options.rate) as usize;
    let reference =
        if p.rigid { carriage_reference(steps, dt_control, &mut rng) } else { reference(steps, dt_control, &mut rng) };
    let phases: Vec<(f64, f64)> = (0..60)
        .map(|j| {
            (
                0.3 * (40.0f64 / 0.3).powf(f64::from(j) / 59.0),
                2.0 * PI * Uniform::new(0.0, 1.0).expect("range").sample(&mut rng),
            )
        })
        .collect();
    let injection_amplitude = drive.injection_rms * (2.0f64 / 60.0).sqrt();
    let filter = 1.0 - (-2.0 * PI * drive.speed_filter_hz * dt_control).exp();
    let (loop_frequency, loop_damping) = (2.0 * PI * 250.0, 0.7);
    let encoder_noise = Normal::new(0.0, drive.encoder_noise).expect("a valid deviation");
    let current_sigma = if options.noiseless_current { 0.0 } else { p.torque_sigma / (p.gear * p.torque_constant) };
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
    let delay_steps = (p.delay / dt).round() as usize;
    let mut delayed = History::new(0.0, delay_steps + 1);
    // The load encoder's reading `load_skew` old at each log instant.
    let skew_steps = (options.load_skew / dt).round() as usize;
    let mut skewed = History::new(start, skew_steps);
    let mut integral = p.offset + p.unbalance * (start + p.unbalance_phase).cos();
    let mut previous_motor = quantise(start, drive.motor_quantum);
    let mut speed_estimate = 0.0;
    let mut text = header(options, &p);
    for (k, &(ref_pos, ref_speed)) in reference.iter().enumerate() {
        let t = k as f64 * dt_control;
        let motor = quantise(s.motor + 0.5 * encoder_noise.sample(&mut rng), drive.motor_quantum);
        let load = quantise(skewed.ago(skew_steps) + encoder_noise.sample(&mut rng), drive.load_quantum);
        let current = quantise(s.current + current_noise.sample(&mut rng), 1e-3);
        let _ = if p.rigid {
            writeln!(text, "{t:.6},{ref_pos:.9},{current:.4},{motor:.9}")
        } else {
            writeln!(
                text,
                "{t:.6},{:.10},{current:.4},{:.10},{:.10}",
                ref_pos.to_degrees(),
                motor.to_degrees(),
                load.to_degrees()
            )
        };
        speed_estimate += filter * ((motor - previous_motor) / dt_control - speed_estimate);
        previous_motor = motor;
        // The rotary drive's position loop closes on the load encoder, the carriage's on its one.
        let position = if p.rigid { motor } else { load };
        let error = ref_speed + drive.position_gain * (ref_pos - position) - speed_estimate;
        integral += drive.integral_gain * error * dt_control;
        let injection: f64 =
            phases.iter().map(|(f, phase)| injection_amplitude * (2.0 * PI * f * t + phase).sin()).sum();
        let command = (drive.speed_gain * error + integral + injection) / (nominal.gear * nominal.torque_constant);
        for _ in 0..substeps {
            let acceleration = loop_frequency * loop_frequency * (command - s.current)
                - 2.0 * loop_damping * loop_frequency * s.current_rate;
            s.current_rate += acceleration * dt;
            s.current += s.current_rate * dt;
            delayed.push(s.current);
            let applied = 0.5 * (delayed.ago(delay_steps) + delayed.ago(delay_steps + 1));
            substep(&p, &mut s, applied, dt, options.static_friction);
            skewed.push(s.load);
        }
    }
    Ok(text)
}

/// The last values of a signal sampled every substep, for reading it a fixed number of
/// substeps late (a delayed current, a late load encoder).
struct History {
    values: Vec<f64>,
    /// Where the next value goes: the oldest one held.
    next: usize,
}

impl History {
    /// Holds `longest` substeps of history besides the newest value, all `initial` at first.
    fn new(initial: f64, longest: usize) -> History {
        History { values: vec![initial; longest + 1], next: 0 }
    }

    fn push(&mut self, value: f64) {
        self.values[self.next] = value;
        self.next = (self.next + 1) % self.values.len();
    }

    /// The value pushed `substeps` pushes before the newest (0: the newest), at most the
    /// history's length.
    fn ago(&self, substeps: usize) -> f64 {
        let len = self.values.len();
        self.values[(self.next + len - 1 - substeps.min(len - 1)) % len]
    }
}

/// The carriage's motion, as the benchmark's: moves between points of its 0.2 m stroke with
/// trapezoidal speed (0.1 to 0.4 m/s, 1.5 m/s^2), each followed by a rest of 0.3 to 1 s.
fn carriage_reference(steps: usize, dt: f64, rng: &mut rand_chacha::ChaCha8Rng) -> Vec<(f64, f64)> {
    let unit = Uniform::new(0.0f64, 1.0).expect("a valid range");
    let mut out = Vec::with_capacity(steps);
    let mut pos = 0.1;
    while out.len() < steps {
        let target = 0.2 * unit.sample(rng);
        let top = 0.1 + 0.3 * unit.sample(rng);
        if (target - pos).abs() > 1e-3 {
            pos = slew(&mut out, pos, target, top, 1.5, dt);
        }
        for _ in 0..((0.3 + 0.7 * unit.sample(rng)) / dt) as usize {
            out.push((pos, 0.0));
        }
    }
    out.truncate(steps);
    out
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
        // The bristles' damping fades with speed as exp(-(v/vs)^2) (Canudas de Wit et al.
        // 1995): constant, it adds sigma1 v to every start of a motion, spikes of tens of
        // newtons on the carriage that no real drive's log shows.
        let damping = p.bristle_damping * (-(v / p.stribeck_velocity).powi(2)).exp();
        p.bristle_stiffness * s.bristle + damping * bristle_rate + p.viscous * v
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
    if p.rigid {
        s.motor_speed += (motor_torque - friction - cogging - load_torque) / p.motor_inertia * dt;
        s.load_speed = s.motor_speed;
    } else {
        s.motor_speed += (motor_torque - shaft - friction - cogging) / p.motor_inertia * dt;
        s.load_speed += (shaft - load_torque) / p.load_inertia * dt;
    }
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
    // Axis-side units: a rotary drive's, or the carriage's (N for N m, m for rad, kg for kg m^2).
    let _ = writeln!(
        text,
        "# truth ({}): coulomb {}, breakaway {}, offset {}, unbalance {} at {}, motor inertia {} (axis side), load inertia {}, torque constant scale {}, backlash {}, stiffness {}, cogging {} over {} at {}, asymmetry {}",
        if p.rigid { "N, m, kg" } else { "N m, rad, kg m^2" },
        p.coulomb, p.breakaway, p.offset, p.unbalance, p.unbalance_phase, p.motor_inertia, p.load_inertia, p.torque_constant_scale, p.backlash, p.stiffness, p.cogging, p.cogging_period, p.cogging_phase, p.asymmetry
    );
    let columns = if p.rigid {
        "time_s,ref_pos_m,motor_current_A,motor_pos_m"
    } else {
        "time_s,ref_pos_deg,motor_current_A,motor_pos_deg,load_pos_deg"
    };
    let _ = writeln!(text, "{columns}");
    text
}

/// The starting parameter set: the nominal plant in `validate`'s parameter-file form (the
/// carriage's in its linear units).
pub fn start_params(carriage: bool) -> String {
    let p = if carriage { Plant::carriage() } else { Plant::nominal() };
    let rows: Vec<(&str, f64, &str)> = if carriage {
        vec![
            ("gear.ratio", 1.0, "-, a direct drive"),
            ("motor.inertia", p.motor_inertia, "kg, the carriage"),
            ("motor.torque_constant", p.torque_constant, "N/A, the force per ampere"),
            ("friction.viscous", p.viscous, "N s/m"),
            ("friction.coulomb", p.coulomb, "N"),
            ("friction.static", p.breakaway, "N"),
            ("friction.stribeck_velocity", p.stribeck_velocity, "m/s"),
            ("effect.torque_offset", p.offset, "N"),
        ]
    } else {
        vec![
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
        ]
    };
    let mut text = String::from("# The second generator's nominal plant (tools/truth/src/second.rs).\n");
    for (name, value, unit) in rows {
        let _ = writeln!(text, "{name:<28} = {value:e}  # {unit}");
    }
    text
}

#[cfg(test)]
mod tests {
    use super::History;

    #[test]
    fn a_history_reads_the_value_pushed_that_many_substeps_before_the_newest() {
        let mut history = History::new(-1.0, 20);
        assert_eq!(history.ago(20), -1.0);
        for k in 0..100 {
            history.push(f64::from(k));
        }
        assert_eq!(history.ago(0), 99.0);
        // A 1 ms late encoder at 50 us substeps reads the value of 20 substeps before.
        assert_eq!(history.ago(20), 79.0);
    }
}
