//! truthgen: writes measured logs from the independent truth simulation.
//!
//! `suite` writes `log_NNN.csv` logs with a hidden `log_NNN.truth` beside each and the starting
//! parameter set `start.params`; `one` writes a single log (and FILE.truth); `start` the
//! starting parameter set. Sizes are the RMS of what the effect adds to its channel divided by
//! that channel's sensor noise. Exit codes: 0 ok, 2 bad usage or bad input.

use antenna_truth::suite::{self, SuiteConfig};
use antenna_truth::{CurrentLog, MotorSensor, SpeedSensor, ThreeMass, TruthConfig};
use anyhow::{bail, Context};
use clap::{ArgMatches, Args, CommandFactory, FromArgMatches, Parser, Subcommand};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::ExitCode;

/// Writes measured logs with hidden effects from the independent truth simulation of a drive
/// axis, to test `validate` on data whose truth is known.
#[derive(Parser)]
#[command(version, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// A suite: every kind at every size and seed, pairs, clean logs, in a shuffled order.
    Suite {
        /// The suite folder.
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        /// Seeds of the effect logs.
        #[arg(long, value_delimiter = ',', default_values_t = [11u64, 12])]
        seeds: Vec<u64>,
        /// Effect sizes, times the channel's noise.
        #[arg(long, value_delimiter = ',', default_values_t = [0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0])]
        sizes: Vec<f64>,
        /// Number of clean logs (seeds 101, 102, ...).
        #[arg(long, value_name = "COUNT", default_value_t = 10)]
        clean: u64,
        /// Effect kinds (default: all of them).
        #[arg(long, value_delimiter = ',')]
        kinds: Option<Vec<String>>,
        /// No two-effect logs.
        #[arg(long)]
        no_pairs: bool,
        #[command(flatten)]
        truth: TruthArgs,
    },
    /// One log, with its truth in FILE.truth.
    One {
        /// The log file.
        #[arg(long, value_name = "FILE.csv")]
        out: PathBuf,
        /// An effect kind; repeat for several. Each takes the --size after it (default 10).
        #[arg(long = "effect", value_name = "KIND")]
        effects: Vec<String>,
        /// Size of the effect before it, times the channel's noise.
        #[arg(long = "size", value_name = "RATIO")]
        sizes: Vec<f64>,
        /// Seed of the noise, the excitation and the effect's random parts.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        #[command(flatten)]
        truth: TruthArgs,
    },
    /// The starting parameter set: the truth's nominal plant.
    Start {
        /// The parameter file.
        #[arg(long, value_name = "FILE.params")]
        out: PathBuf,
        #[command(flatten)]
        truth: TruthArgs,
    },
}

/// The truth's plant, sensors and run, where they differ from the suite's.
#[derive(Args)]
struct TruthArgs {
    /// A seed of the sensor noise alone, apart from --seed's excitation (trajectory and
    /// injected torque): the same excitation with another noise draw (default: --seed's).
    #[arg(long, value_name = "SEED")]
    noise_seed: Option<u64>,
    /// Length of each log (s).
    #[arg(long, value_name = "SECONDS")]
    duration: Option<f64>,
    /// The truth's LuGre bristle deflection at breakaway (axis rad, default 1e-7), for studies
    /// of the friction-model-form floor.
    #[arg(long, value_name = "RAD")]
    presliding: Option<f64>,
    /// The RK4 base rate (default 20 kHz; steps are cut into substeps while the bristles relax
    /// faster than that).
    #[arg(long, value_name = "HZ")]
    internal_rate: Option<f64>,
    /// The log rate (default 500 Hz).
    #[arg(long, value_name = "HZ")]
    log_rate: Option<f64>,
    /// Current and load-encoder noise times X.
    #[arg(long, value_name = "X")]
    noise_scale: Option<f64>,
    /// The nominal path stiffness set for this locked-motor anti-resonance (damping ratio kept).
    #[arg(long, value_name = "HZ")]
    anti_resonance: Option<f64>,
    /// The load inertia (the anti-resonance kept).
    #[arg(long, value_name = "KGM2")]
    load_inertia: Option<f64>,
    /// Log a motor speed signal (noise, bias, scale error) instead of the motor encoder.
    #[arg(long, conflicts_with = "no_motor_sensor")]
    motor_speed: bool,
    /// Log no motor sensor: the load encoder is the only position.
    #[arg(long)]
    no_motor_sensor: bool,
    /// Motors whose currents are logged in columns of their own (1 or 2).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=2))]
    motors: Option<u64>,
    /// With two motors, amperes added to motor 1's current and taken from motor 2's.
    #[arg(long, value_name = "A")]
    current_bias: Option<f64>,
    /// Bits per revolution of the load encoder (default 25).
    #[arg(long, value_name = "BITS")]
    load_encoder_bits: Option<u32>,
    /// White noise of the current sensor (A, default 0.0125); 0 is a noiseless sensor.
    #[arg(long, value_name = "A")]
    current_noise: Option<f64>,
    /// Log the current loop's command instead of the current (no sensor noise).
    #[arg(long)]
    current_command: bool,
    /// Log the axis as a linear one (positions in mm).
    #[arg(long)]
    linear: bool,
    /// The trajectory's stroke: from 40 deg over this many degrees (default 15 to 85 deg).
    #[arg(long, value_name = "DEG")]
    stroke: Option<f64>,
    /// The controller's sample rate (default 2 kHz); the log rate may not exceed it and the
    /// internal rate must be at least it.
    #[arg(long, value_name = "HZ")]
    controller_rate: Option<f64>,
    /// Effect sizes measured against this current noise (A) instead of the log's own (with
    /// --current-noise or --current-command: the suite's 0.0125 A).
    #[arg(long, value_name = "A")]
    size_current_noise: Option<f64>,
    /// Graduation and eccentricity error of the load encoder: RMS over a revolution (arcsec,
    /// default 0: none), summed over the harmonics of --load-encoder-harmonics with amplitudes
    /// and phases drawn from the seed. The controller reads it too.
    #[arg(long, value_name = "ARCSEC")]
    load_encoder_error: Option<f64>,
    /// Orders of the load encoder's error harmonics, cycles per load revolution (default
    /// 1,2,4,8,16,36: eccentricity and graduation).
    #[arg(long, value_name = "K,...", value_delimiter = ',', requires = "load_encoder_error")]
    load_encoder_harmonics: Option<Vec<u32>>,
    /// Read the load encoder this much later than the motor encoder (s, default 0; negative is
    /// earlier): a row stamped t holds the load angle at t + skew.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    load_encoder_skew: Option<f64>,
    /// Read the current this much later than the encoders (s, default 0; negative is earlier).
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    current_skew: Option<f64>,
    /// With --motor-speed: a drift of the speed signal's bias, a random walk with this RMS over
    /// the log (axis side, default 0: none).
    #[arg(long, value_name = "RAD_PER_S", requires = "motor_speed")]
    tacho_drift: Option<f64>,
    /// With --motor-speed: the speed signal's scale error (default 0.005).
    #[arg(long, value_name = "X", requires = "motor_speed", allow_negative_numbers = true)]
    tacho_scale_error: Option<f64>,
    /// Cogging cycles per motor revolution (e.g. 2p or 6p for p pole pairs): a cogging
    /// effect's period is then 2 pi / (N K) at the axis (default: drawn, 0.2 to 2 deg).
    #[arg(long, value_name = "K")]
    cogging_per_motor_rev: Option<u32>,
    /// A three-mass drive: an intermediate inertia between the gearbox compliance and a second
    /// compliance, whose own mode (motor and load held) is at this frequency (default: the
    /// two-mass drive).
    #[arg(long, value_name = "HZ")]
    three_mass: Option<f64>,
    /// The three-mass drive's intermediate inertia as a fraction of the load inertia (default
    /// 0.2; the load keeps the rest).
    #[arg(long, value_name = "FRACTION", requires = "three_mass")]
    three_mass_fraction: Option<f64>,
}

/// A positive finite number, or an error naming the option.
fn positive(value: f64, flag: &str) -> anyhow::Result<f64> {
    if value > 0.0 && value.is_finite() {
        Ok(value)
    } else {
        bail!("{flag} needs a positive number, not {value}")
    }
}

impl TruthArgs {
    /// The truth configuration: the suite's, changed by the options given.
    fn config(&self) -> anyhow::Result<TruthConfig> {
        let mut base = TruthConfig { noise_seed: self.noise_seed, ..TruthConfig::default() };
        if let Some(rate) = self.controller_rate {
            base.controller_rate = positive(rate, "--controller-rate")?;
            if base.controller_rate > base.internal_rate && self.internal_rate.is_none() {
                bail!("--controller-rate must not exceed the internal rate");
            }
            if self.log_rate.is_none() && base.log_rate > base.controller_rate {
                bail!("--controller-rate must be at least the log rate");
            }
        }
        if let Some(displacement) = self.presliding {
            base.plant.presliding_displacement = positive(displacement, "--presliding")?;
        }
        if let Some(rate) = self.internal_rate {
            // Written so that NaN is refused too.
            let fast_enough = rate >= base.controller_rate;
            if !fast_enough {
                bail!("--internal-rate must be at least the controller rate");
            }
            base.internal_rate = rate;
        }
        if let Some(rate) = self.log_rate {
            base.log_rate = positive(rate, "--log-rate")?;
            if base.log_rate > base.controller_rate {
                bail!("--log-rate must not exceed the controller rate");
            }
        }
        if let Some(scale) = self.noise_scale {
            let scale = positive(scale, "--noise-scale")?;
            base.noise.current_sigma *= scale;
            base.noise.load_encoder_sigma *= scale;
        }
        if let Some(hz) = self.anti_resonance {
            base.plant.set_anti_resonance(positive(hz, "--anti-resonance")?);
        }
        if let Some(inertia) = self.load_inertia {
            let hz = base.plant.anti_resonance();
            base.plant.load_inertia = positive(inertia, "--load-inertia")?;
            base.plant.set_anti_resonance(hz);
        }
        if self.motor_speed {
            base.noise.motor_sensor = MotorSensor::Speed(SpeedSensor::default());
        }
        if self.no_motor_sensor {
            base.noise.motor_sensor = MotorSensor::None;
        }
        if let Some(motors) = self.motors {
            base.noise.motors = motors as usize;
        }
        if let Some(bias) = self.current_bias {
            base.noise.current_bias = bias;
        }
        if let Some(bits) = self.load_encoder_bits {
            base.noise.load_encoder_counts = 2f64.powi(bits as i32);
        }
        let suite_current_sigma = base.noise.current_sigma;
        if let Some(sigma) = self.current_noise {
            if !(sigma >= 0.0 && sigma.is_finite()) {
                bail!("--current-noise needs a number at least 0, not {sigma}");
            }
            base.noise.current_sigma = sigma;
            base.noise.size_current_sigma = Some(suite_current_sigma);
        }
        if self.current_command {
            base.noise.current_log = CurrentLog::Command;
            base.noise.current_sigma = 0.0;
            base.noise.size_current_sigma = Some(suite_current_sigma);
        }
        base.linear = self.linear;
        if let Some(stroke) = self.stroke {
            base.trajectory.min_position = 40f64.to_radians();
            base.trajectory.max_position = (40.0 + positive(stroke, "--stroke")?).to_radians();
        }
        if let Some(duration) = self.duration {
            base.duration = duration;
        }
        self.hidden_log_options(&mut base)?;
        Ok(base)
    }

    /// The options of what hidden logs from other generators had: encoder error, skews, a
    /// drifting tacho, motor-pole cogging, a three-mass drive, the size reference.
    fn hidden_log_options(&self, base: &mut TruthConfig) -> anyhow::Result<()> {
        if let Some(sigma) = self.size_current_noise {
            base.noise.size_current_sigma = Some(positive(sigma, "--size-current-noise")?);
        }
        if let Some(arcsec) = self.load_encoder_error {
            base.noise.load_encoder_error.rms = positive(arcsec, "--load-encoder-error")?.to_radians() / 3600.0;
        }
        if let Some(orders) = &self.load_encoder_harmonics {
            if orders.is_empty() || orders.contains(&0) {
                bail!("--load-encoder-harmonics needs orders of at least 1");
            }
            base.noise.load_encoder_error.harmonics = orders.clone();
        }
        for (skew, flag, slot) in [
            (self.load_encoder_skew, "--load-encoder-skew", &mut base.noise.load_encoder_skew),
            (self.current_skew, "--current-skew", &mut base.noise.current_skew),
        ] {
            if let Some(skew) = skew {
                // A skew longer than a second would be a broken log, not a skew.
                let plausible = skew.abs() < 1.0;
                if !plausible {
                    bail!("{flag} needs a number of seconds between -1 and 1, not {skew}");
                }
                *slot = skew;
            }
        }
        if let MotorSensor::Speed(sensor) = &mut base.noise.motor_sensor {
            if let Some(drift) = self.tacho_drift {
                sensor.drift = positive(drift, "--tacho-drift")?;
            }
            if let Some(scale) = self.tacho_scale_error {
                let plausible = scale.abs() < 0.5;
                if !plausible {
                    bail!("--tacho-scale-error needs a number between -0.5 and 0.5, not {scale}");
                }
                sensor.scale_error = scale;
            }
        }
        if let Some(k) = self.cogging_per_motor_rev {
            if k == 0 {
                bail!("--cogging-per-motor-rev needs at least 1");
            }
            base.plant.cogging_per_motor_rev = Some(k);
        }
        if let Some(hz) = self.three_mass {
            let fraction = self.three_mass_fraction.unwrap_or(DEFAULT_THREE_MASS_FRACTION);
            base.plant.three_mass =
                Some(ThreeMass::with_second_mode(&base.plant, fraction, positive(hz, "--three-mass")?)?);
        }
        Ok(())
    }
}

/// The three-mass drive's intermediate inertia when `--three-mass-fraction` is not given: a
/// fifth of the load's, as a gearbox output stage, pinions and bull gear with part of the
/// structure are beside the reflector.
const DEFAULT_THREE_MASS_FRACTION: f64 = 0.2;

/// Each `--size` sets the size of the `--effect` given last before it (10 without one), by the
/// options' positions on the command line.
fn pair_sizes(matches: Option<&ArgMatches>, effects: Vec<String>, sizes: &[f64]) -> anyhow::Result<Vec<(String, f64)>> {
    let positions =
        |id: &str| -> Vec<usize> { matches.and_then(|m| m.indices_of(id)).map(|i| i.collect()).unwrap_or_default() };
    let (effect_at, size_at) = (positions("effects"), positions("sizes"));
    let mut paired: Vec<(String, f64)> = effects.into_iter().map(|kind| (kind, 10.0)).collect();
    for (size, at) in sizes.iter().zip(&size_at) {
        let Some(last) = effect_at.iter().rposition(|e| e < at) else { bail!("--size must follow --effect") };
        paired[last].1 = *size;
    }
    Ok(paired)
}

fn main() -> ExitCode {
    let matches = Cli::command().get_matches();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    match run(cli, &matches) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("truthgen: error: {error:#}");
            ExitCode::from(2)
        }
    }
}

fn run(cli: Cli, matches: &ArgMatches) -> anyhow::Result<()> {
    match cli.command {
        Command::Suite { out, seeds, sizes, clean, kinds, no_pairs, truth } => {
            let mut config =
                SuiteConfig { seeds, sizes, clean_seeds: (101..101 + clean).collect(), ..SuiteConfig::default() };
            if let Some(kinds) = kinds {
                config.kinds = kinds;
            }
            if no_pairs {
                config.pairs.clear();
            }
            config.base = truth.config()?;
            let truths = suite::write_suite(&out, &config, &mut |line| println!("{line}"))?;
            println!("wrote {} logs to {}", truths.len(), out.display());
        }
        Command::One { out, effects, sizes, seed, truth } => {
            let effects = pair_sizes(matches.subcommand_matches("one"), effects, &sizes)?;
            let name = out.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
            let (text, truth) = suite::generate_case(&truth.config()?, seed, &effects, &name, &mut BTreeMap::new())?;
            std::fs::write(&out, text).with_context(|| format!("cannot write {}", out.display()))?;
            let truth_path = out.with_extension("truth");
            std::fs::write(&truth_path, suite::truth_text(&truth))
                .with_context(|| format!("cannot write {}", truth_path.display()))?;
            println!("{}: {}", out.display(), suite::describe(&truth));
        }
        Command::Start { out, truth } => {
            truth
                .config()?
                .starting_parameters()
                .write(&out, "Starting parameter set: the truth generator's nominal plant.")?;
        }
    }
    Ok(())
}
