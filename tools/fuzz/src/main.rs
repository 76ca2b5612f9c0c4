//! `fmu-fuzz`: random call sequences against the packaged FMUs, each in a child process, checked
//! against the FMI 2.0 state table and the robustness properties (docs/fmu-robustness.md).
//! Exit code 0 when every sequence passed, 1 when one failed, 2 on bad usage.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand};
use fmu_fuzz::campaign::{child_main, run_campaign, Config, VALGRIND_ERROR_EXIT};
use fmu_fuzz::{fmu_path, FMUS};

#[derive(Parser)]
#[command(version, about = "Random call sequences against the packaged FMUs through their C ABI")]
struct Cli {
    #[command(subcommand)]
    command: Option<Sub>,
    /// FMUs to fuzz (model identifiers); all six by default.
    #[arg(long = "fmu")]
    fmus: Vec<String>,
    /// First seed.
    #[arg(long, default_value_t = 0)]
    first: u64,
    /// Sequences per FMU.
    #[arg(long, default_value_t = 2000)]
    sequences: u64,
    /// Campaign limits: longer sequences and steps up to 10 s (default: the quick limits of the
    /// test command).
    #[arg(long)]
    campaign: bool,
    /// Child processes at once.
    #[arg(long, default_value_t = 2)]
    jobs: usize,
    /// Seconds one call may take before the sequence counts as hung.
    #[arg(long, default_value_t = 60)]
    timeout: u64,
    /// Run the sequences under valgrind (memcheck, --error-exitcode) instead.
    #[arg(long)]
    valgrind: bool,
    /// Every n-th seed also runs on two threads against the serial run (0: never).
    #[arg(long, default_value_t = 8)]
    threads_every: u64,
    /// Child runs spent shrinking each failing sequence (0: report the whole sequence).
    #[arg(long, default_value_t = 200)]
    shrink_trials: usize,
}

#[derive(Subcommand)]
enum Sub {
    /// Runs seeds in this process and prints a line per sequence (used by the parent).
    #[command(hide = true)]
    Child {
        #[arg(long)]
        fmu: PathBuf,
        #[arg(long)]
        first: u64,
        #[arg(long)]
        count: u64,
        #[arg(long)]
        campaign: bool,
        #[arg(long, default_value_t = 0)]
        threads_every: u64,
        #[arg(long, value_delimiter = ',')]
        keep: Option<Vec<usize>>,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if let Some(Sub::Child { fmu, first, count, campaign, threads_every, keep }) = cli.command {
        return match child_main(&fmu, first, count, campaign, threads_every, keep) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("fmu-fuzz: error: {e:#}");
                ExitCode::from(2)
            }
        };
    }
    match campaign(&cli) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(e) => {
            eprintln!("fmu-fuzz: error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn campaign(cli: &Cli) -> anyhow::Result<bool> {
    let names: Vec<String> =
        if cli.fmus.is_empty() { FMUS.iter().map(|s| s.to_string()).collect() } else { cli.fmus.clone() };
    let mut fmus = Vec::new();
    for name in names {
        let path = fmu_path(&name);
        anyhow::ensure!(path.is_file(), "{} not found: run `cargo xtask package` first", path.display());
        fmus.push((name, path));
    }
    let wrapper = if cli.valgrind {
        vec![
            "valgrind".to_string(),
            "--tool=memcheck".into(),
            "-q".into(),
            format!("--error-exitcode={VALGRIND_ERROR_EXIT}"),
            "--leak-check=no".into(),
        ]
    } else {
        Vec::new()
    };
    let config = Config {
        exe: std::env::current_exe()?,
        fmus,
        seeds: cli.first..cli.first + cli.sequences,
        campaign_limits: cli.campaign,
        timeout: Duration::from_secs(cli.timeout),
        jobs: cli.jobs,
        chunk: if cli.valgrind { 25 } else { 500 },
        threads_every: cli.threads_every,
        wrapper,
        shrink_trials: cli.shrink_trials,
    };
    let started = Instant::now();
    let summaries = run_campaign(&config)?;
    println!("| FMU | sequences | calls | answered OK | steps OK | states restored | damaged states refused | failures | child wall s |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut clean = true;
    for s in &summaries {
        let r = s.reached;
        println!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {:.1} |",
            s.fmu,
            s.sequences,
            s.calls,
            r.ok,
            r.steps,
            r.restores,
            r.refused_states,
            s.failures.len(),
            s.seconds
        );
    }
    for s in &summaries {
        for f in &s.failures {
            clean = false;
            println!("\nFAIL {} seed {} ({:?}): {}", f.fmu, f.seed, f.kind, f.message);
            println!(
                "  reproduce: fmu-fuzz --fmu {} --first {} --sequences 1{}",
                f.fmu,
                f.seed,
                if cli.campaign { " --campaign" } else { "" }
            );
            println!("  minimal sequence ({} calls):", f.minimal.len());
            for call in &f.minimal {
                println!("    {call}");
            }
        }
    }
    println!("\n{} in {:.1} s", if clean { "no failures" } else { "FAILURES" }, started.elapsed().as_secs_f64());
    Ok(clean)
}
