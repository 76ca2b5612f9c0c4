//! The generated test suite: logs with one or two undeclared effects at several sizes relative
//! to the sensor noise, several seeds, and clean logs.
//!
//! The size of an effect is the RMS of what it adds to the channel where it shows (the axis
//! torque for most, the measured twist for stiffness and backlash) divided by that channel's
//! sensor noise. It is set from a clean run with the same seed, so "10 times the noise" means
//! the same thing for every effect. Each log gets an opaque name and a sidecar `.truth` file
//! for scoring; the log itself declares nothing.

use super::{
    simulate, CleanSignals, CurrentLog, Effect, EncoderError, MotorSensor, SpeedSensor, ThreeMass, TruthConfig,
};
use antenna_validate::parameters::ParameterError;
use rand::{RngExt, SeedableRng};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Why a case could not be generated, a suite could not be written or a truth file not read.
#[derive(Debug, thiserror::Error)]
pub enum SuiteError {
    /// No delay up to the searched maximum changes the torque by the requested multiple of the
    /// noise.
    #[error("a delay of {max_delay} s does not reach {ratio} times the noise")]
    DelayUnreachable { max_delay: f64, ratio: f64 },
    /// The effect kind is none of [`EFFECT_KINDS`].
    #[error("unknown effect kind '{kind}' (known: {})", EFFECT_KINDS.join(", "))]
    UnknownEffectKind { kind: String },
    /// The truth simulation with the effects produced a non-finite value.
    #[error("the closed loop is unstable with this effect (the truth simulation diverged)")]
    Diverged,
    /// A file or folder of the suite could not be created, read, written or removed.
    #[error("cannot {action} {}: {source}", path.display())]
    Io { action: &'static str, path: PathBuf, source: std::io::Error },
    /// The worker threads could not be started.
    #[error("cannot start {threads} threads: {source}")]
    Threads { threads: usize, source: rayon::ThreadPoolBuildError },
    /// The starting parameter set could not be written.
    #[error(transparent)]
    Parameters(#[from] ParameterError),
    /// A line of a truth file is not `key = value`.
    #[error("bad truth line '{line}'")]
    TruthLine { line: String },
    /// A truth file lacks a key.
    #[error("truth file lacks '{key}'")]
    TruthKeyMissing { key: String },
    /// A truth file's value is not a number.
    #[error("truth '{key}' is not a number, got '{value}'")]
    TruthNotANumber { key: String, value: String },
    /// An effect in a truth file has fewer values than its kind needs.
    #[error("effect{index} ({kind}) has too few values: {found}")]
    TruthTooFewValues { index: usize, kind: String, found: usize },
}

/// The [`SuiteError::Io`] of `action` on `path`.
fn io_error<'a>(action: &'static str, path: &'a Path) -> impl FnOnce(std::io::Error) -> SuiteError + 'a {
    move |source| SuiteError::Io { action, path: path.to_path_buf(), source }
}

/// Every effect kind the generator knows, in table order.
pub const EFFECT_KINDS: [&str; 11] = [
    "coulomb",
    "stribeck",
    "asymmetry",
    "torque_offset",
    "backlash",
    "stiffness",
    "inertia",
    "unbalance",
    "delay",
    "torque_constant",
    "cogging",
];

/// What a suite contains.
#[derive(Debug, Clone)]
pub struct SuiteConfig {
    pub kinds: Vec<String>,
    pub sizes: Vec<f64>,
    pub seeds: Vec<u64>,
    /// Seeds of the clean logs.
    pub clean_seeds: Vec<u64>,
    /// Pairs of kinds generated together at `pair_size`.
    pub pairs: Vec<(String, String)>,
    pub pair_size: f64,
    pub base: TruthConfig,
}

impl Default for SuiteConfig {
    fn default() -> Self {
        SuiteConfig {
            kinds: EFFECT_KINDS.iter().map(|s| s.to_string()).collect(),
            sizes: vec![0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0],
            seeds: vec![11, 12],
            clean_seeds: (101..=110).collect(),
            pairs: vec![
                ("coulomb".into(), "unbalance".into()),
                ("stiffness".into(), "delay".into()),
                ("cogging".into(), "torque_offset".into()),
                ("inertia".into(), "backlash".into()),
            ],
            pair_size: 20.0,
            base: TruthConfig::default(),
        }
    }
}

/// Suites unlike the main one, to check that `validate` is not tuned to it: other log rates,
/// noise levels, drive resonances and inertias, new seeds, every effect kind at 10 and 20
/// times the noise and four clean logs each. (name, what differs, suite)
pub fn holdout_suites() -> Vec<(&'static str, &'static str, SuiteConfig)> {
    let holdout = |seeds: Vec<u64>,
                   clean_seeds: Vec<u64>,
                   log_rate: f64,
                   noise_scale: f64,
                   anti_resonance: f64,
                   load_inertia: f64| {
        let mut base = TruthConfig { log_rate, ..TruthConfig::default() };
        base.noise.current_sigma *= noise_scale;
        base.noise.load_encoder_sigma *= noise_scale;
        base.plant.load_inertia = load_inertia;
        base.plant.set_anti_resonance(anti_resonance);
        SuiteConfig { sizes: vec![10.0, 20.0], seeds, clean_seeds, pairs: Vec::new(), base, ..SuiteConfig::default() }
    };
    let sensors = |seeds: Vec<u64>, clean_seeds: Vec<u64>, motor_sensor: MotorSensor, motors: usize| {
        let mut base = TruthConfig::default();
        base.noise.motor_sensor = motor_sensor;
        base.noise.motors = motors;
        SuiteConfig { sizes: vec![10.0, 20.0], seeds, clean_seeds, pairs: Vec::new(), base, ..SuiteConfig::default() }
    };
    let variant = |seeds: Vec<u64>, clean_seeds: Vec<u64>, change: &dyn Fn(&mut TruthConfig)| {
        let mut base = TruthConfig::default();
        change(&mut base);
        SuiteConfig { sizes: vec![10.0, 20.0], seeds, clean_seeds, pairs: Vec::new(), base, ..SuiteConfig::default() }
    };
    // Effect sizes of the noiseless-current variants are measured against the main suite's
    // current noise: "ten times no noise" is no size.
    let suite_current_sigma = TruthConfig::default().noise.current_sigma;
    let mut short_stroke = variant(vec![37, 38], (233..=236).collect(), &|base| {
        base.trajectory.min_position = 40f64.to_radians();
        base.trajectory.max_position = 46f64.to_radians();
    });
    short_stroke.kinds.retain(|k| k != "unbalance");
    // A linear axis has no angle: gravity on it is a constant force (an offset, which the suite
    // covers), and `validate` does not search an unbalance there. The generator's unbalance, a
    // torque periodic in the axis angle, has no linear counterpart to be named as.
    let mut linear_axis = variant(vec![35, 36], (229..=232).collect(), &|base| base.linear = true);
    linear_axis.kinds.retain(|k| k != "unbalance");
    vec![
        (
            "coarse-load-encoder",
            "a 22-bit load encoder (0.31 arcsec per count) on a stiffer drive (anti-resonance 18 Hz), whose twist spreads over 0.23 arcsec RMS: the load encoder is coarser than the twist",
            variant(vec![29, 30], (217..=220).collect(), &|base| {
                base.noise.load_encoder_counts = 2f64.powi(22);
                base.plant.set_anti_resonance(18.0);
            }),
        ),
        (
            "current-command",
            "the current loop's command logged instead of the current (no sensor noise, rounded to 1 mA, leading the current by the 100 Hz loop; the bandwidth is in the starting set); sizes against the suite's current noise",
            variant(vec![31, 32], (221..=224).collect(), &|base| {
                base.noise.current_log = CurrentLog::Command;
                base.noise.current_sigma = 0.0;
                base.noise.size_current_sigma = Some(suite_current_sigma);
            }),
        ),
        (
            "noiseless-current",
            "a current sensor without noise (rounded to 1 mA); sizes against the suite's current noise",
            variant(vec![33, 34], (225..=228).collect(), &|base| {
                base.noise.current_sigma = 0.0;
                base.noise.size_current_sigma = Some(suite_current_sigma);
            }),
        ),
        (
            "linear-axis",
            "the drive logged as a linear axis (positions in mm, an axis of unit radius: the numbers are the rotary drive's); every effect kind but an unbalance, which a linear axis does not have",
            linear_axis,
        ),
        (
            "short-stroke",
            "no unbalance in the truth and a log that covers a 6 deg stroke (40 to 46 deg), where an offset and an unbalance look alike; every other effect kind",
            short_stroke,
        ),
        (
            "speed-sensor",
            "a motor speed signal (noise 2e-6 rad/s, bias 2e-7 rad/s, scale error 0.5 %, axis side) instead of the motor encoder, and two motors' currents in columns of their own, as an antenna's azimuth drive logs them; the suite's drive",
            sensors(vec![25, 26], (209..=212).collect(), MotorSensor::Speed(SpeedSensor::default()), 2),
        ),
        (
            "load-encoder-only",
            "the load encoder is the only position (no motor encoder or speed), as the paper's closed-loop logs; the suite's drive",
            sensors(vec![27, 28], (213..=216).collect(), MotorSensor::None, 1),
        ),
        (
            "fast-stiff",
            "logged at 1 kHz, twice the sensor noise, a stiffer and lighter drive (anti-resonance 6 Hz, load inertia 3e4 kg m^2)",
            holdout(vec![21, 22], (201..=204).collect(), 1000.0, 2.0, 6.0, 3.0e4),
        ),
        (
            "slow-soft",
            "logged at 250 Hz, half the sensor noise, a softer and heavier drive (anti-resonance 2.5 Hz, load inertia 1.2e5 kg m^2)",
            holdout(vec![23, 24], (205..=208).collect(), 250.0, 0.5, 2.5, 1.2e5),
        ),
    ]
    .into_iter()
    .chain(hidden_log_suites())
    .collect()
}

/// The holdout suites with what hidden logs from another generator had: a load encoder with
/// graduation and eccentricity error, skewed signals, a drifting tacho, cogging at the motor's
/// pole period, a three-mass drive, and 2 kHz logs of a noiseless current. (name, what
/// differs, suite)
fn hidden_log_suites() -> Vec<(&'static str, &'static str, SuiteConfig)> {
    let variant = |seeds: Vec<u64>, clean_seeds: Vec<u64>, change: &dyn Fn(&mut TruthConfig)| {
        let mut base = TruthConfig::default();
        change(&mut base);
        SuiteConfig { sizes: vec![10.0, 20.0], seeds, clean_seeds, pairs: Vec::new(), base, ..SuiteConfig::default() }
    };
    let suite_current_sigma = TruthConfig::default().noise.current_sigma;
    vec![
        (
            "load-encoder-error",
            "a load encoder with 1 arcsec RMS of eccentricity and graduation error (harmonics 1, 2, 4, 8, 16 and 36 per revolution), which the controller reads too",
            variant(vec![39, 40], (237..=240).collect(), &|base| {
                base.noise.load_encoder_error = EncoderError { rms: 1f64.to_radians() / 3600.0, ..EncoderError::default() };
            }),
        ),
        (
            "skews",
            "the load encoder read 1 ms after the motor encoder and the current 0.5 ms before the encoders",
            variant(vec![41, 42], (241..=244).collect(), &|base| {
                base.noise.load_encoder_skew = 1.0e-3;
                base.noise.current_skew = -0.5e-3;
            }),
        ),
        (
            "drifting-tacho",
            "a motor speed signal instead of the motor encoder whose bias drifts as a random walk of 1e-6 rad/s RMS (half its white noise); one motor",
            variant(vec![43, 44], (245..=248).collect(), &|base| {
                base.noise.motor_sensor = MotorSensor::Speed(SpeedSensor { drift: 1.0e-6, ..SpeedSensor::default() });
            }),
        ),
        (
            "motor-pole-cogging",
            "cogging at 5 cycles per motor revolution, a period of 2 pi/(1200 x 5) = 1.05e-3 rad (0.06 deg) at the axis instead of one between 0.2 and 2 deg",
            variant(vec![45, 46], (249..=252).collect(), &|base| base.plant.cogging_per_motor_rev = Some(5)),
        ),
        (
            "three-mass",
            "a three-mass drive: a fifth of the load inertia between the gearbox compliance and a second one, with its own mode at 30 Hz; the two in series are the suite's path",
            variant(vec![47, 48], (253..=256).collect(), &|base| {
                base.plant.three_mass = ThreeMass::with_second_mode(&base.plant, 0.2, 30.0).ok();
            }),
        ),
        (
            "2khz-noiseless-current",
            "logged at 2 kHz, the controller's rate, with a current sensor without noise (rounded to 1 mA); sizes against the suite's current noise",
            variant(vec![49, 50], (257..=260).collect(), &|base| {
                base.log_rate = 2000.0;
                base.noise.current_sigma = 0.0;
                base.noise.size_current_sigma = Some(suite_current_sigma);
            }),
        ),
    ]
}

/// The hidden truth of one generated log.
#[derive(Debug, Clone, PartialEq)]
pub struct CaseTruth {
    pub log_file: String,
    pub seed: u64,
    /// (kind, size relative to noise, effect) per effect; empty for a clean log.
    pub effects: Vec<(String, f64, Effect)>,
    /// Sensor noise of the torque channel (axis side, N m) and of the twist (rad).
    pub torque_sigma: f64,
    pub twist_sigma: f64,
    pub sample_interval: f64,
    /// The log's hidden conditions beyond its effects (`TruthConfig::hidden_conditions`:
    /// encoder error, skews, tacho drift, cogging per motor revolution, three masses), by key;
    /// empty for the suite's own logs.
    pub conditions: BTreeMap<String, String>,
}

/// Sizes an effect of `kind` so that it adds `ratio` times the channel noise, from a clean run.
pub fn sized_effect(
    kind: &str,
    ratio: f64,
    clean: &CleanSignals,
    config: &TruthConfig,
    rng: &mut impl rand::Rng,
) -> Result<Effect, SuiteError> {
    let plant = &config.plant;
    let sigma_torque = config.noise.size_torque_sigma(plant);
    let sigma_twist = config.noise.twist_sigma(plant);
    let vs = plant.stribeck_velocity;
    let rms = |values: &mut dyn Iterator<Item = f64>| {
        let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
        (sum / n.max(1) as f64).sqrt()
    };
    let sign = |rng: &mut dyn rand::Rng| if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    let target = ratio * sigma_torque;
    Ok(match kind {
        "coulomb" => {
            let unit = rms(&mut clean.motor_vel.iter().map(|v| (v / (0.05 * vs)).tanh()));
            Effect::Coulomb(target / unit)
        }
        "stribeck" => {
            let unit = rms(&mut clean.motor_vel.iter().map(|v| (-(v / vs).powi(2)).exp() * (v / (0.05 * vs)).tanh()));
            Effect::Stribeck(target / unit)
        }
        "asymmetry" => {
            let unit = rms(&mut clean.motor_vel.iter().map(|v| (v / (0.1 * vs)).tanh()));
            Effect::Asymmetry(sign(rng) * target / unit)
        }
        "torque_offset" => Effect::TorqueOffset(sign(rng) * target),
        "backlash" => Effect::Backlash(2.0 * ratio * sigma_twist),
        "stiffness" => {
            // A softer path than quoted, as the paper found: the twist grows by the factor
            // 1/f - 1, which must add `ratio` times the twist noise.
            let unit = rms(&mut clean.shaft_torque.iter().map(|t| t / plant.stiffness));
            Effect::StiffnessFactor(1.0 / (1.0 + ratio * sigma_twist / unit))
        }
        "inertia" => {
            let unit = rms(&mut clean.load_acc.iter().map(|a| plant.load_inertia * a));
            let relative = target / unit;
            let s = if relative > 0.8 { 1.0 } else { sign(rng) };
            Effect::InertiaFactor(1.0 + s * relative)
        }
        "unbalance" => {
            let phase = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
            let unit = rms(&mut clean.load_pos.iter().map(|q| (q + phase).cos()));
            Effect::Unbalance { amplitude: target / unit, phase }
        }
        "delay" => {
            // Bisection on the RMS change of the applied torque when it is shifted by the delay.
            let torque = &clean.applied_torque_fine;
            let change = |delay: f64| {
                let shift = delay / clean.fine_dt;
                let whole = shift.floor() as usize;
                let frac = shift - whole as f64;
                let mut sum = 0.0;
                let mut n = 0usize;
                for i in whole + 1..torque.len() {
                    let delayed = (1.0 - frac) * torque[i - whole] + frac * torque[i - whole - 1];
                    sum += (torque[i] - delayed).powi(2);
                    n += 1;
                }
                (sum / n.max(1) as f64).sqrt()
            };
            let (mut lo, mut hi) = (0.0, 0.2);
            if change(hi) < target {
                return Err(SuiteError::DelayUnreachable { max_delay: hi, ratio });
            }
            for _ in 0..50 {
                let mid = 0.5 * (lo + hi);
                if change(mid) < target {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            Effect::Delay(0.5 * (lo + hi))
        }
        "torque_constant" => {
            let unit = rms(&mut clean.applied_torque.iter().copied());
            let relative = target / unit;
            // The logged current changes by 1/s - 1 relative; keep s positive and plausible.
            let s = if relative > 0.5 { 1.0 } else { sign(rng) };
            Effect::TorqueConstantScale(1.0 / (1.0 + s * relative))
        }
        "cogging" => {
            // The motor's poles set the period when the plant says how many cycles a motor
            // revolution has; otherwise it is drawn between 0.2 and 2 deg at the axis.
            let period = match plant.cogging_period() {
                Some(period) => period,
                None => rng.random_range(0.2f64.ln()..2f64.ln()).exp().to_radians(),
            };
            let phase = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
            Effect::Cogging { amplitude: target * std::f64::consts::SQRT_2, period, phase }
        }
        other => return Err(SuiteError::UnknownEffectKind { kind: other.to_string() }),
    })
}

/// An effect of `kind` set by the change of the parameter `validate` reports for it (the
/// leading parameter of its detection limit, `antenna_validate::candidates::size_change`, in
/// the same units): N m for friction, offsets, an unbalance's amplitude and a cogging's
/// amplitude, rad for a backlash's width, N m/rad for the stiffness (a softer path), kg m^2 for
/// the load inertia, s for a delay, and the torque-constant scale's change. Signs, phases and
/// a cogging's period are drawn from `rng` as [`sized_effect`] draws them; the magnitude of
/// `change` is used.
pub fn changed_effect(
    kind: &str,
    change: f64,
    config: &TruthConfig,
    rng: &mut impl rand::Rng,
) -> Result<Effect, SuiteError> {
    let plant = &config.plant;
    let change = change.abs();
    let sign = |rng: &mut dyn rand::Rng| if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    Ok(match kind {
        "coulomb" => Effect::Coulomb(change),
        "stribeck" => Effect::Stribeck(change),
        "asymmetry" => Effect::Asymmetry(sign(rng) * change),
        "torque_offset" => Effect::TorqueOffset(sign(rng) * change),
        "backlash" => Effect::Backlash(change),
        // A softer path than quoted, as the suite's stiffness effects are.
        "stiffness" => Effect::StiffnessFactor((1.0 - change / plant.stiffness).max(0.05)),
        "inertia" => Effect::InertiaFactor(1.0 + sign(rng) * change / plant.load_inertia),
        "unbalance" => Effect::Unbalance {
            amplitude: change,
            phase: rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
        },
        "delay" => Effect::Delay(change),
        "torque_constant" => Effect::TorqueConstantScale(1.0 + sign(rng) * change),
        "cogging" => {
            let period = match plant.cogging_period() {
                Some(period) => period,
                None => rng.random_range(0.2f64.ln()..2f64.ln()).exp().to_radians(),
            };
            let phase = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
            Effect::Cogging { amplitude: change, period, phase }
        }
        other => return Err(SuiteError::UnknownEffectKind { kind: other.to_string() }),
    })
}

/// Generates one log with the given kinds and sizes, returning its text and truth.
pub fn generate_case(
    base: &TruthConfig,
    seed: u64,
    kinds: &[(String, f64)],
    log_file: &str,
    clean_cache: &mut BTreeMap<u64, CleanSignals>,
) -> Result<(String, CaseTruth), SuiteError> {
    let mut config = base.clone();
    config.seed = seed;
    config.effects.clear();
    let clean = match clean_cache.get(&seed) {
        Some(c) => c.clone(),
        None => {
            let run = simulate(&config);
            clean_cache.insert(seed, run.clean.clone());
            run.clean
        }
    };
    let mut rng =
        rand_chacha::ChaCha8Rng::seed_from_u64(seed.wrapping_mul(0x9e37_79b9).wrapping_add(kinds.len() as u64));
    let mut effects = Vec::new();
    for (kind, ratio) in kinds {
        let effect = sized_effect(kind, *ratio, &clean, &config, &mut rng)?;
        effects.push((kind.clone(), *ratio, effect));
    }
    simulate_case(config, seed, effects, log_file)
}

/// Generates one log of `base` with the given effects, set directly rather than sized against
/// the noise; each effect's size relative to the noise in the truth is NaN (not measured).
pub fn generate_with_effects(
    base: &TruthConfig,
    seed: u64,
    effects: &[Effect],
    log_file: &str,
) -> Result<(String, CaseTruth), SuiteError> {
    let mut config = base.clone();
    config.seed = seed;
    let effects = effects.iter().map(|e| (e.kind().to_string(), f64::NAN, *e)).collect();
    simulate_case(config, seed, effects, log_file)
}

/// Simulates `config` (its seed set) with `effects` and returns the log's text and truth.
fn simulate_case(
    mut config: TruthConfig,
    seed: u64,
    effects: Vec<(String, f64, Effect)>,
    log_file: &str,
) -> Result<(String, CaseTruth), SuiteError> {
    config.effects = effects.iter().map(|e| e.2).collect();
    let run = simulate(&config);
    if run.log.channels.iter().any(|c| c.values.iter().any(|v| !v.is_finite())) {
        return Err(SuiteError::Diverged);
    }
    let text = run.log.to_csv(config.log_units());
    let truth = CaseTruth {
        log_file: log_file.to_string(),
        seed,
        effects,
        torque_sigma: config.noise.size_torque_sigma(&config.plant),
        twist_sigma: config.noise.twist_sigma(&config.plant),
        sample_interval: 1.0 / config.log_rate,
        conditions: config.hidden_conditions().into_iter().collect(),
    };
    Ok((text, truth))
}

/// The suite's cases (seed, kinds with sizes) in their shuffled file order.
fn suite_cases(suite: &SuiteConfig) -> Vec<(u64, Vec<(String, f64)>)> {
    let mut cases: Vec<(u64, Vec<(String, f64)>)> = Vec::new();
    for kind in &suite.kinds {
        for &size in &suite.sizes {
            for &seed in &suite.seeds {
                cases.push((seed, vec![(kind.clone(), size)]));
            }
        }
    }
    for (a, b) in &suite.pairs {
        for &seed in &suite.seeds {
            cases.push((seed, vec![(a.clone(), suite.pair_size), (b.clone(), suite.pair_size)]));
        }
    }
    for &seed in &suite.clean_seeds {
        cases.push((seed, Vec::new()));
    }
    // Shuffle the order deterministically so that the numbering says nothing about the effect.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x5eed);
    for i in (1..cases.len()).rev() {
        let j = rng.random_range(0..=i);
        cases.swap(i, j);
    }
    cases
}

/// Writes the suite: `log_NNN.csv` with `log_NNN.truth` beside it, and `start.params`.
pub fn write_suite(
    dir: &Path,
    suite: &SuiteConfig,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<CaseTruth>, SuiteError> {
    std::fs::create_dir_all(dir).map_err(io_error("create", dir))?;
    let cases = suite_cases(suite);
    let mut clean_cache = BTreeMap::new();
    let mut truths = Vec::new();
    for (index, (seed, kinds)) in cases.iter().enumerate() {
        let name = format!("log_{:03}", index + 1);
        // An effect size the plant cannot produce (a delay so long that the torque it shifts
        // decorrelates completely) is skipped with a note, not an error.
        let (text, truth) = match generate_case(&suite.base, *seed, kinds, &format!("{name}.csv"), &mut clean_cache) {
            Ok(case) => case,
            Err(message) => {
                progress(&format!("{name}: skipped: {message}"));
                continue;
            }
        };
        let log_path = dir.join(format!("{name}.csv"));
        std::fs::write(&log_path, text).map_err(io_error("write", &log_path))?;
        let truth_path = dir.join(format!("{name}.truth"));
        std::fs::write(&truth_path, truth_text(&truth)).map_err(io_error("write", &truth_path))?;
        progress(&format!("{name}: {}", describe(&truth)));
        truths.push(truth);
    }
    suite.base.starting_parameters().write(
        &dir.join("start.params"),
        "Starting parameter set of the generated suite: the truth's nominal plant, no effects.",
    )?;
    Ok(truths)
}

/// Writes the suite like [`write_suite`], generating the logs on `threads` threads (each with
/// its own cache of clean runs), after removing the logs and truths of an earlier suite in
/// `dir`. The files are the same as [`write_suite`]'s: every case depends only on its seed.
/// The truths come back in case order, whatever the thread count.
pub fn write_suite_parallel(
    dir: &Path,
    suite: &SuiteConfig,
    threads: usize,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Vec<CaseTruth>, SuiteError> {
    std::fs::create_dir_all(dir).map_err(io_error("create", dir))?;
    for entry in std::fs::read_dir(dir).map_err(io_error("read", dir))?.flatten() {
        let name = entry.file_name().to_string_lossy().to_string();
        if name.starts_with("log_") && (name.ends_with(".csv") || name.ends_with(".truth")) {
            let path = entry.path();
            std::fs::remove_file(&path).map_err(io_error("remove", &path))?;
        }
    }
    let cases = suite_cases(suite);
    let bar = crate::progress_bar(cases.len(), "generating logs");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
        .map_err(|source| SuiteError::Threads { threads, source })?;
    // Each worker keeps its own cache of clean runs; a case depends only on its seed and
    // effects, so the files are the same whichever worker generates it.
    let generated: Vec<Result<Option<CaseTruth>, SuiteError>> = pool.install(|| {
        cases
            .par_iter()
            .enumerate()
            .map_init(BTreeMap::new, |clean_cache, (index, (seed, kinds))| {
                let name = format!("log_{:03}", index + 1);
                let outcome = match generate_case(&suite.base, *seed, kinds, &format!("{name}.csv"), clean_cache) {
                    Ok((text, truth)) => {
                        let log_path = dir.join(format!("{name}.csv"));
                        std::fs::write(&log_path, text).map_err(io_error("write", &log_path))?;
                        let truth_path = dir.join(format!("{name}.truth"));
                        std::fs::write(&truth_path, truth_text(&truth)).map_err(io_error("write", &truth_path))?;
                        bar.suspend(|| progress(&format!("{name}: {}", describe(&truth))));
                        Some(truth)
                    }
                    // An effect size the plant cannot produce is skipped with a note.
                    Err(message) => {
                        bar.suspend(|| progress(&format!("{name}: skipped: {message}")));
                        None
                    }
                };
                bar.inc(1);
                Ok(outcome)
            })
            .collect()
    });
    bar.finish_and_clear();
    let truths: Vec<CaseTruth> = generated.into_iter().collect::<Result<Vec<_>, _>>()?.into_iter().flatten().collect();
    suite.base.starting_parameters().write(
        &dir.join("start.params"),
        "Starting parameter set of the generated suite: the truth's nominal plant, no effects.",
    )?;
    Ok(truths)
}

/// A one-line description of a case, for progress output and tables.
pub fn describe(truth: &CaseTruth) -> String {
    if truth.effects.is_empty() {
        return "clean".to_string();
    }
    truth.effects.iter().map(|(kind, ratio, _)| format!("{kind} x{ratio}")).collect::<Vec<_>>().join(" + ")
}

/// The sidecar text: `key = value` lines.
pub fn truth_text(truth: &CaseTruth) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "# Hidden truth of {} (for scoring only; the log declares nothing).", truth.log_file);
    let _ = writeln!(out, "log = {}", truth.log_file);
    let _ = writeln!(out, "seed = {}", truth.seed);
    let _ = writeln!(out, "torque_sigma = {:e}", truth.torque_sigma);
    let _ = writeln!(out, "twist_sigma = {:e}", truth.twist_sigma);
    let _ = writeln!(out, "sample_interval = {:e}", truth.sample_interval);
    let _ = writeln!(out, "effects = {}", truth.effects.len());
    for (i, (kind, ratio, effect)) in truth.effects.iter().enumerate() {
        let _ = writeln!(out, "effect{i}.kind = {kind}");
        let _ = writeln!(out, "effect{i}.size = {ratio}");
        let values: Vec<f64> = match *effect {
            Effect::Coulomb(x)
            | Effect::Stribeck(x)
            | Effect::Asymmetry(x)
            | Effect::TorqueOffset(x)
            | Effect::Backlash(x) => vec![x],
            Effect::StiffnessFactor(x)
            | Effect::InertiaFactor(x)
            | Effect::Delay(x)
            | Effect::TorqueConstantScale(x) => vec![x],
            Effect::Unbalance { amplitude, phase } => vec![amplitude, phase],
            Effect::Cogging { amplitude, period, phase } => vec![amplitude, period, phase],
        };
        let _ = writeln!(
            out,
            "effect{i}.values = {}",
            values.iter().map(|v| format!("{v:e}")).collect::<Vec<_>>().join(" ")
        );
    }
    for (key, value) in &truth.conditions {
        let _ = writeln!(out, "condition.{key} = {value}");
    }
    out
}

/// Reads a sidecar back.
pub fn parse_truth(text: &str) -> Result<CaseTruth, SuiteError> {
    let mut map = BTreeMap::new();
    for line in text.lines() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (k, v) = line.split_once('=').ok_or_else(|| SuiteError::TruthLine { line: line.to_string() })?;
        map.insert(k.trim().to_string(), v.trim().to_string());
    }
    let get = |k: &str| map.get(k).cloned().ok_or_else(|| SuiteError::TruthKeyMissing { key: k.to_string() });
    let num = |k: &str| -> Result<f64, SuiteError> {
        let value = get(k)?;
        value.parse::<f64>().map_err(|_| SuiteError::TruthNotANumber { key: k.to_string(), value })
    };
    let count = num("effects")? as usize;
    let mut effects = Vec::new();
    for i in 0..count {
        let kind = get(&format!("effect{i}.kind"))?;
        let size = num(&format!("effect{i}.size"))?;
        let values: Vec<f64> =
            get(&format!("effect{i}.values"))?.split_whitespace().filter_map(|v| v.parse().ok()).collect();
        let v = |j: usize| {
            values.get(j).copied().ok_or_else(|| SuiteError::TruthTooFewValues {
                index: i,
                kind: kind.clone(),
                found: values.len(),
            })
        };
        let effect = match kind.as_str() {
            "coulomb" => Effect::Coulomb(v(0)?),
            "stribeck" => Effect::Stribeck(v(0)?),
            "asymmetry" => Effect::Asymmetry(v(0)?),
            "torque_offset" => Effect::TorqueOffset(v(0)?),
            "backlash" => Effect::Backlash(v(0)?),
            "stiffness" => Effect::StiffnessFactor(v(0)?),
            "inertia" => Effect::InertiaFactor(v(0)?),
            "unbalance" => Effect::Unbalance { amplitude: v(0)?, phase: v(1)? },
            "delay" => Effect::Delay(v(0)?),
            "torque_constant" => Effect::TorqueConstantScale(v(0)?),
            "cogging" => Effect::Cogging { amplitude: v(0)?, period: v(1)?, phase: v(2)? },
            other => return Err(SuiteError::UnknownEffectKind { kind: other.to_string() }),
        };
        effects.push((kind, size, effect));
    }
    Ok(CaseTruth {
        log_file: get("log")?,
        seed: num("seed")? as u64,
        effects,
        torque_sigma: num("torque_sigma")?,
        twist_sigma: num("twist_sigma")?,
        sample_interval: num("sample_interval")?,
        conditions: map
            .iter()
            .filter_map(|(k, v)| k.strip_prefix("condition.").map(|key| (key.to_string(), v.clone())))
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truth_sidecar_round_trips() {
        let truth = CaseTruth {
            log_file: "log_001.csv".into(),
            seed: 4,
            effects: vec![
                ("cogging".into(), 10.0, Effect::Cogging { amplitude: 3.0, period: 0.01, phase: -1.0 }),
                ("delay".into(), 2.0, Effect::Delay(0.003)),
            ],
            torque_sigma: 30.0,
            twist_sigma: 1e-7,
            sample_interval: 0.002,
            conditions: [("cogging_per_motor_rev".to_string(), "5".to_string())].into_iter().collect(),
        };
        assert_eq!(parse_truth(&truth_text(&truth)).unwrap(), truth);
    }

    #[test]
    fn changed_effect_sets_the_parameter_change_validate_reports() {
        let config = TruthConfig::default();
        let plant = &config.plant;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut effect = |kind: &str, change: f64| changed_effect(kind, change, &config, &mut rng).unwrap();
        assert_eq!(effect("coulomb", 5.0), Effect::Coulomb(5.0));
        assert_eq!(effect("delay", 2e-3), Effect::Delay(2e-3));
        assert_eq!(effect("backlash", 1e-6), Effect::Backlash(1e-6));
        let Effect::TorqueOffset(offset) = effect("torque_offset", 4.0) else { panic!() };
        assert_eq!(offset.abs(), 4.0);
        let Effect::StiffnessFactor(factor) = effect("stiffness", 1e6) else { panic!() };
        assert!((plant.stiffness * (factor - 1.0) + 1e6).abs() < 1e-6 * 1e6);
        let Effect::InertiaFactor(factor) = effect("inertia", 600.0) else { panic!() };
        assert!(((plant.load_inertia * (factor - 1.0)).abs() - 600.0).abs() < 1e-9 * 600.0);
        let Effect::TorqueConstantScale(scale) = effect("torque_constant", 0.01) else { panic!() };
        assert!(((scale - 1.0).abs() - 0.01).abs() < 1e-12);
        let Effect::Unbalance { amplitude, .. } = effect("unbalance", 7.0) else { panic!() };
        assert_eq!(amplitude, 7.0);
        let Effect::Cogging { amplitude, period, .. } = effect("cogging", 9.0) else { panic!() };
        assert_eq!(amplitude, 9.0);
        assert!(period > 0.0);
        assert!(changed_effect("warp_drive", 1.0, &config, &mut rng).is_err());
    }

    #[test]
    fn sized_effect_adds_the_requested_multiple_of_the_noise() {
        let config = TruthConfig { duration: 6.0, ..TruthConfig::default() };
        let clean = simulate(&config).clean;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let sigma = config.noise.torque_sigma(&config.plant);
        let Effect::TorqueOffset(offset) = sized_effect("torque_offset", 7.0, &clean, &config, &mut rng).unwrap()
        else {
            panic!()
        };
        assert!((offset.abs() - 7.0 * sigma).abs() < 1e-9);
        let Effect::Cogging { amplitude, .. } = sized_effect("cogging", 7.0, &clean, &config, &mut rng).unwrap() else {
            panic!()
        };
        assert!((amplitude / std::f64::consts::SQRT_2 - 7.0 * sigma).abs() < 1e-9);
        assert!(sized_effect("warp_drive", 1.0, &clean, &config, &mut rng).is_err());
    }

    #[test]
    fn holdout_suites_share_no_seed_and_differ_from_the_main_suite() {
        let main = SuiteConfig::default();
        for (name, _, holdout) in holdout_suites() {
            assert!(
                holdout
                    .seeds
                    .iter()
                    .chain(&holdout.clean_seeds)
                    .all(|s| !main.seeds.contains(s) && !main.clean_seeds.contains(s)),
                "{name}"
            );
            let (h, m) = (&holdout.base, &main.base);
            let other_log = h.log_rate != m.log_rate && h.noise.current_sigma != m.noise.current_sigma;
            let other_drive =
                h.plant.anti_resonance() != m.plant.anti_resonance() && h.plant.load_inertia != m.plant.load_inertia;
            let other_sensors = h.noise.motor_sensor != m.noise.motor_sensor
                || h.noise.load_encoder_counts != m.noise.load_encoder_counts
                || h.noise.current_log != m.noise.current_log
                || h.noise.current_sigma != m.noise.current_sigma
                || h.noise.load_encoder_error != m.noise.load_encoder_error
                || h.noise.load_encoder_skew != m.noise.load_encoder_skew
                || h.noise.current_skew != m.noise.current_skew
                || h.linear != m.linear;
            let other_physics = h.plant.cogging_per_motor_rev != m.plant.cogging_per_motor_rev
                || h.plant.three_mass != m.plant.three_mass;
            let other_motion = h.trajectory.max_position - h.trajectory.min_position
                != m.trajectory.max_position - m.trajectory.min_position;
            assert!(
                other_log && other_drive || other_sensors || other_motion || other_physics,
                "{name}: the same log rate, noise, drive, sensors and motion as the main suite"
            );
            // Every effect kind, except an unbalance where the suite is about its absence or
            // the axis is linear (no angle for it to depend on).
            let expected: Vec<&str> =
                EFFECT_KINDS.iter().copied().filter(|k| !((other_motion || h.linear) && *k == "unbalance")).collect();
            assert_eq!(holdout.kinds, expected, "{name}: every effect kind");
        }
    }

    #[test]
    fn holdout_suites_share_no_seed_with_each_other() {
        let suites = holdout_suites();
        let mut seen = std::collections::BTreeSet::new();
        for (name, _, suite) in &suites {
            for seed in suite.seeds.iter().chain(&suite.clean_seeds) {
                assert!(seen.insert(*seed), "{name} reuses seed {seed}");
            }
        }
        let names: Vec<&str> = suites.iter().map(|s| s.0).collect();
        for name in [
            "load-encoder-error",
            "skews",
            "drifting-tacho",
            "motor-pole-cogging",
            "three-mass",
            "2khz-noiseless-current",
        ] {
            assert!(names.contains(&name), "{name}");
        }
        // Each hidden-log suite has its option on and the options it is not about off.
        let base = |name: &str| suites.iter().find(|s| s.0 == name).map(|s| s.2.base.clone()).unwrap();
        assert!(base("load-encoder-error").noise.load_encoder_error.is_on());
        assert!(base("skews").noise.load_encoder_skew > 0.0 && base("skews").noise.current_skew < 0.0);
        assert!(
            matches!(base("drifting-tacho").noise.motor_sensor, MotorSensor::Speed(SpeedSensor { drift, .. }) if drift > 0.0)
        );
        assert_eq!(base("motor-pole-cogging").plant.cogging_per_motor_rev, Some(5));
        assert!(base("three-mass").plant.three_mass.is_some());
        let fast = base("2khz-noiseless-current");
        assert!(fast.log_rate == 2000.0 && fast.noise.current_sigma == 0.0 && fast.noise.size_current_sigma.is_some());
        assert!(!base("three-mass").noise.load_encoder_error.is_on() && base("skews").plant.three_mass.is_none());
    }
}
