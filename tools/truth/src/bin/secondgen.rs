//! `secondgen`: writes a log of the second, separately written generator
//! (`antenna_truth::second`) and, beside it, the starting parameter set it is validated from.

use std::path::PathBuf;

use antenna_truth::second::{self, SecondEffect, SecondOptions};
use anyhow::Context;
use clap::Parser;

/// Writes one drive log of the second generator (LuGre friction, a second-order current loop,
/// a multisine-excited cascade) with one effect the starting set lacks, and `start.params`.
#[derive(Parser)]
#[command(version)]
struct Cli {
    /// The effect the truth adds to the nominal plant, at about 10 times the torque noise.
    #[arg(long, value_enum, default_value_t = SecondEffect::Clean)]
    effect: SecondEffect,
    /// The seed of the motion, the excitation's phases and the sensors' noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The log's length (s).
    #[arg(long, default_value_t = 60.0)]
    duration: f64,
    /// The controller's and the log's rate (Hz), 100 to 20000.
    #[arg(long, default_value_t = 1000.0)]
    rate: f64,
    /// The delay of `--effect delay` (s).
    #[arg(long, default_value_t = 4e-3)]
    delay: f64,
    /// A current sensor without noise (still rounded to 1 mA).
    #[arg(long)]
    noiseless_current: bool,
    /// The load encoder read this long after the motor encoder and the current (s).
    #[arg(long, default_value_t = 0.0)]
    load_skew: f64,
    /// A static friction curve instead of LuGre's bristles.
    #[arg(long)]
    static_friction: bool,
    /// A rigid 95 kg linear carriage with the EMPS benchmark's published numbers instead of
    /// the rotary two-mass drive (positions in metres, one encoder).
    #[arg(long)]
    carriage: bool,
    /// The log to write; `start.params` goes into the same folder.
    #[arg(long, required_unless_present = "suite")]
    out: Option<PathBuf>,
    /// Write a scored suite into this folder instead of one log: per seed a clean log, every
    /// effect and the Coulomb-unbalance pair (with --duration, --rate, --delay and the sensor
    /// options), for `validate suite DIR`.
    #[arg(long, value_name = "DIR", conflicts_with = "out")]
    suite: Option<PathBuf>,
    /// The seeds of `--suite`.
    #[arg(long, value_delimiter = ',', default_values_t = [11, 12])]
    seeds: Vec<u64>,
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    anyhow::ensure!((100.0..=20_000.0).contains(&cli.rate), "--rate must be 100 to 20000 Hz");
    anyhow::ensure!(cli.duration > 1.0 && cli.duration <= 3600.0, "--duration must be over 1 s and at most 3600 s");
    anyhow::ensure!((0.0..=0.05).contains(&cli.delay), "--delay must be 0 to 0.05 s");
    anyhow::ensure!((0.0..=0.05).contains(&cli.load_skew), "--load-skew must be 0 to 0.05 s");
    let options = SecondOptions {
        effect: cli.effect,
        seed: cli.seed,
        duration: cli.duration,
        rate: cli.rate,
        delay: cli.delay,
        noiseless_current: cli.noiseless_current,
        load_skew: cli.load_skew,
        static_friction: cli.static_friction,
        carriage: cli.carriage,
    };
    if let Some(dir) = &cli.suite {
        let logs = second::write_suite(dir, &cli.seeds, &options)?;
        println!("wrote {logs} logs with their .truth files and start.params into {}", dir.display());
        return Ok(());
    }
    let out = cli.out.clone().context("--out or --suite is needed")?;
    std::fs::write(&out, second::generate(&options)?).with_context(|| format!("cannot write {}", out.display()))?;
    let start = out.parent().unwrap_or(std::path::Path::new(".")).join("start.params");
    std::fs::write(&start, second::start_params(cli.carriage))
        .with_context(|| format!("cannot write {}", start.display()))?;
    println!("wrote {} and {}", out.display(), start.display());
    Ok(())
}
