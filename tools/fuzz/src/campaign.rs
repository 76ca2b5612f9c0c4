//! Runs sequences in child processes, so that an abort or a crash of an FMU is observed rather
//! than suffered, with a timeout per sequence so that a hang is observed too; shrinks each
//! failing sequence to a minimal one and reports it with its seed.
//!
//! The child is this program itself (`fmu-fuzz child ...`): it opens one FMU, runs a range of
//! seeds and prints one line per sequence (`start <seed>`, then `ok <seed> <calls> <trace>` or
//! `fail <seed> <call> <message>`). The parent reads the lines with a deadline; a child that
//! ends without finishing its current sequence aborted on it, one that says nothing for the
//! timeout hangs on it. Either way the parent notes the seed and starts a new child after it.

use std::io::{BufRead, BufReader, Read, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use crate::runner::{run_with, Failure, Reached};
use crate::sequence::{generate, Call, Limits};
use crate::target::Target;

/// What a campaign runs.
#[derive(Debug, Clone)]
pub struct Config {
    /// This program (the child is `exe child ...`).
    pub exe: PathBuf,
    /// The FMUs, by name and packaged file.
    pub fmus: Vec<(String, PathBuf)>,
    /// The seeds of each FMU.
    pub seeds: Range<u64>,
    pub campaign_limits: bool,
    /// Longest silence of a child (it reports every call it makes) before it counts as hung:
    /// the time one call may take.
    pub timeout: Duration,
    /// Child processes at once.
    pub jobs: usize,
    /// Seeds per child process.
    pub chunk: u64,
    /// Every n-th seed also runs on two instances on two threads, compared with the serial run.
    pub threads_every: u64,
    /// A command the child runs under (valgrind and its options), if any.
    pub wrapper: Vec<String>,
    /// Shrink failing sequences (trials per failure).
    pub shrink_trials: usize,
}

/// How a sequence failed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Kind {
    /// A property or the oracle was violated.
    Property,
    /// The child process ended in the middle of the sequence.
    Abort,
    /// The child said nothing for the timeout.
    Hang,
    /// The wrapper (valgrind) reported an error.
    Valgrind,
}

/// One failure, reproducible by its FMU and seed.
#[derive(Debug, Clone)]
pub struct Report {
    pub fmu: String,
    pub seed: u64,
    pub kind: Kind,
    pub message: String,
    /// The smallest sequence found that still fails, as C calls.
    pub minimal: Vec<String>,
}

/// What a campaign found, per FMU.
#[derive(Debug, Clone, Default)]
pub struct FmuSummary {
    pub fmu: String,
    pub sequences: u64,
    pub calls: u64,
    /// Over all sequences: what they reached.
    pub reached: Reached,
    pub seconds: f64,
    pub failures: Vec<Report>,
}

/// One child's answer for one seed.
enum Outcome {
    Ok { calls: u64, reached: Reached },
    Failed(Kind, String),
}

/// Runs the campaign: every FMU, every seed, `jobs` children at a time.
pub fn run_campaign(config: &Config) -> anyhow::Result<Vec<FmuSummary>> {
    let mut work = Vec::new();
    for (index, _) in config.fmus.iter().enumerate() {
        let mut start = config.seeds.start;
        while start < config.seeds.end {
            let end = (start + config.chunk).min(config.seeds.end);
            work.push((index, start..end));
            start = end;
        }
    }
    let queue = std::sync::Mutex::new(work.into_iter());
    let results = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..config.jobs.max(1) {
            scope.spawn(|| loop {
                let next = queue.lock().expect("queue").next();
                let Some((index, seeds)) = next else { break };
                let started = Instant::now();
                let outcomes = run_chunk(config, index, seeds);
                results.lock().expect("results").push((index, started.elapsed().as_secs_f64(), outcomes));
            });
        }
    });
    let mut summaries: Vec<FmuSummary> =
        config.fmus.iter().map(|(name, _)| FmuSummary { fmu: name.clone(), ..FmuSummary::default() }).collect();
    let mut collected = results.into_inner().expect("results");
    collected.sort_by_key(|(index, _, outcomes)| (*index, outcomes.first().map_or(0, |(seed, _)| *seed)));
    for (index, seconds, outcomes) in collected {
        let summary = &mut summaries[index];
        summary.seconds += seconds;
        for (seed, outcome) in outcomes {
            summary.sequences += 1;
            match outcome {
                Outcome::Ok { calls, reached } => {
                    summary.calls += calls;
                    summary.reached.ok += reached.ok;
                    summary.reached.steps += reached.steps;
                    summary.reached.restores += reached.restores;
                    summary.reached.refused_states += reached.refused_states;
                }
                Outcome::Failed(kind, message) => {
                    let minimal = shrink(config, index, seed, &kind);
                    summary.failures.push(Report { fmu: summary.fmu.clone(), seed, kind, message, minimal });
                }
            }
        }
    }
    Ok(summaries)
}

/// Runs a range of seeds of one FMU through as many children as it takes.
fn run_chunk(config: &Config, fmu: usize, seeds: Range<u64>) -> Vec<(u64, Outcome)> {
    let mut outcomes = Vec::new();
    let mut next = seeds.start;
    while next < seeds.end {
        let batch = next..seeds.end;
        match run_child(config, fmu, batch.clone(), None) {
            Ok(mut answered) => {
                let last = answered.last().map(|(s, _)| *s);
                let done = answered.len() as u64;
                outcomes.append(&mut answered);
                next = match last {
                    Some(seed) => seed + 1,
                    None => next + 1,
                };
                if done == 0 {
                    outcomes
                        .push((batch.start, Outcome::Failed(Kind::Abort, "the child process did not start".into())));
                }
            }
            Err(error) => {
                outcomes.push((next, Outcome::Failed(Kind::Abort, format!("cannot run the child: {error}"))));
                next += 1;
            }
        }
    }
    outcomes
}

/// Starts a child for `seeds` (or one seed with only the calls `keep`).
fn spawn(config: &Config, fmu: usize, seeds: &Range<u64>, keep: Option<&[usize]>) -> std::io::Result<Child> {
    let mut args: Vec<String> = vec![
        "child".into(),
        "--fmu".into(),
        config.fmus[fmu].1.display().to_string(),
        "--first".into(),
        seeds.start.to_string(),
        "--count".into(),
        (seeds.end - seeds.start).to_string(),
        "--threads-every".into(),
        config.threads_every.to_string(),
    ];
    if config.campaign_limits {
        args.push("--campaign".into());
    }
    if let Some(keep) = keep {
        args.push("--keep".into());
        args.push(keep.iter().map(|k| k.to_string()).collect::<Vec<_>>().join(","));
    }
    let mut command = match config.wrapper.split_first() {
        Some((program, options)) => {
            let mut c = Command::new(program);
            c.args(options).arg(&config.exe);
            c
        }
        None => {
            // The child's address space is capped, so that an FMU that allocates without
            // bound fails in its own process (an abort the campaign reports) instead of
            // taking the machine's memory from everything else running on it.
            let mut c = Command::new("sh");
            c.arg("-c").arg(format!("ulimit -v {CHILD_MEMORY_KIB} && exec \"$0\" \"$@\"")).arg(&config.exe);
            c
        }
    };
    command.args(args).stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn()
}

/// Runs one child until it finishes, dies or hangs; returns the outcome of every seed it
/// started (the last one failed if the child died or hung on it).
fn run_child(
    config: &Config,
    fmu: usize,
    seeds: Range<u64>,
    keep: Option<&[usize]>,
) -> std::io::Result<Vec<(u64, Outcome)>> {
    let mut child = spawn(config, fmu, &seeds, keep)?;
    let stdout = child.stdout.take().expect("piped");
    let mut stderr = child.stderr.take().expect("piped");
    let (lines_tx, lines) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines() {
            if lines_tx.send(line.unwrap_or_default()).is_err() {
                break;
            }
        }
    });
    let errors = std::thread::spawn(move || {
        let mut text = String::new();
        let _ = stderr.read_to_string(&mut text);
        text
    });
    let mut outcomes = Vec::new();
    let mut current: Option<u64> = None;
    // Valgrind makes everything some fifty times slower.
    let timeout = if config.wrapper.is_empty() { config.timeout } else { config.timeout * 50 };
    loop {
        match lines.recv_timeout(timeout) {
            Ok(line) => {
                let mut words = line.splitn(4, ' ');
                let (tag, seed) = (words.next().unwrap_or(""), words.next().and_then(|s| s.parse::<u64>().ok()));
                match (tag, seed) {
                    ("start", Some(seed)) => current = Some(seed),
                    ("ok", Some(seed)) => {
                        let calls = words.next().and_then(|c| c.parse().ok()).unwrap_or(0);
                        let numbers: Vec<u64> =
                            words.next().unwrap_or("").split(' ').filter_map(|n| n.parse().ok()).collect();
                        let at = |k: usize| numbers.get(k).copied().unwrap_or(0);
                        let reached = Reached { ok: at(0), steps: at(1), restores: at(2), refused_states: at(3) };
                        outcomes.push((seed, Outcome::Ok { calls, reached }));
                        current = None;
                    }
                    ("fail", Some(seed)) => {
                        let call = words.next().unwrap_or("-");
                        let message = words.next().unwrap_or("").to_string();
                        outcomes.push((seed, Outcome::Failed(Kind::Property, format!("call {call}: {message}"))));
                        current = None;
                    }
                    _ => {}
                }
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {
                let _ = child.kill();
                let _ = child.wait();
                if let Some(seed) = current {
                    outcomes.push((seed, Outcome::Failed(Kind::Hang, format!("no answer within {timeout:?}"))));
                }
                return Ok(outcomes);
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        }
    }
    let status = child.wait()?;
    let stderr_text = errors.join().unwrap_or_default();
    if let Some(seed) = current {
        outcomes.push((
            seed,
            Outcome::Failed(
                Kind::Abort,
                format!("the process ended during the sequence ({status}): {}", tail(&stderr_text)),
            ),
        ));
    } else if !status.success() {
        let kind = if !config.wrapper.is_empty() && status.code() == Some(VALGRIND_ERROR_EXIT) {
            Kind::Valgrind
        } else {
            Kind::Abort
        };
        // Valgrind reports at exit: the batch failed as a whole; its first seed stands for it.
        let seed = outcomes.first().map_or(seeds.start, |(s, _)| *s);
        outcomes.retain(|(s, _)| *s != seed);
        outcomes.insert(
            0,
            (
                seed,
                Outcome::Failed(
                    kind,
                    format!("seeds {seeds:?}: the process exited with {status}: {}", tail(&stderr_text)),
                ),
            ),
        );
    }
    Ok(outcomes)
}

/// The address space a child may use, KiB (4 GiB): some hundred times what a sequence needs.
pub const CHILD_MEMORY_KIB: u64 = 4 * 1024 * 1024;

/// The exit code the campaign asks valgrind to use when it found an error.
pub const VALGRIND_ERROR_EXIT: i32 = 99;

fn tail(text: &str) -> String {
    let lines: Vec<&str> = text.lines().rev().take(12).collect();
    lines.into_iter().rev().collect::<Vec<_>>().join(" | ")
}

/// Removes calls from a failing sequence while it still fails the same way (in child
/// processes, so that aborts shrink too); returns the remaining calls as text.
fn shrink(config: &Config, fmu: usize, seed: u64, kind: &Kind) -> Vec<String> {
    let Ok(target) = Target::open(&config.fmus[fmu].1) else { return vec!["(the FMU could not be opened)".into()] };
    let limits = if config.campaign_limits { Limits::CAMPAIGN } else { Limits::QUICK };
    let calls = generate(&target, seed, limits);
    let mut keep: Vec<usize> = (0..calls.len()).collect();
    // Hangs cost a timeout per trial, and valgrind a minute: shrink those less.
    let mut budget = match kind {
        Kind::Property | Kind::Abort => config.shrink_trials,
        Kind::Hang | Kind::Valgrind => config.shrink_trials.min(8),
    };
    let mut chunk = keep.len().div_ceil(2).max(1);
    while chunk >= 1 && budget > 0 {
        let mut start = 0;
        let mut removed_any = false;
        while start < keep.len() && budget > 0 {
            let candidate: Vec<usize> =
                keep.iter().enumerate().filter(|(i, _)| *i < start || *i >= start + chunk).map(|(_, &c)| c).collect();
            budget -= 1;
            if still_fails(config, fmu, seed, &candidate, kind) {
                keep = candidate;
                removed_any = true;
            } else {
                start += chunk;
            }
        }
        if chunk == 1 && !removed_any {
            break;
        }
        chunk = if removed_any { chunk } else { chunk / 2 };
        if chunk == 0 {
            break;
        }
    }
    keep.iter().map(|&i| calls[i].to_string()).collect()
}

fn still_fails(config: &Config, fmu: usize, seed: u64, keep: &[usize], kind: &Kind) -> bool {
    let Ok(outcomes) = run_child(config, fmu, seed..seed + 1, Some(keep)) else { return false };
    outcomes.iter().any(|(_, o)| matches!(o, Outcome::Failed(k, _) if k == kind))
}

/// The child's side: runs `count` seeds from `first` on one FMU and prints a line per sequence.
pub fn child_main(
    fmu: &Path,
    first: u64,
    count: u64,
    campaign: bool,
    threads_every: u64,
    keep: Option<Vec<usize>>,
) -> anyhow::Result<()> {
    let target = Target::open(fmu)?;
    let limits = if campaign { Limits::CAMPAIGN } else { Limits::QUICK };
    let stdout = std::io::stdout();
    for seed in first..first + count {
        writeln!(stdout.lock(), "start {seed}")?;
        stdout.lock().flush()?;
        let mut calls = generate(&target, seed, limits);
        if let Some(keep) = &keep {
            calls = keep.iter().filter_map(|&i| calls.get(i).cloned()).collect();
        }
        let heartbeat = |index: usize| {
            let mut out = std::io::stdout().lock();
            let _ = writeln!(out, "call {seed} {index}");
            let _ = out.flush();
        };
        let threads = threads_every > 0 && seed % threads_every == 0;
        let line = match check_sequence_with(&target, &calls, threads, &heartbeat) {
            Ok(r) => format!("ok {seed} {} {} {} {} {}", calls.len(), r.ok, r.steps, r.restores, r.refused_states),
            Err(Failure { call, message }) => {
                let call = call.map_or("-".to_string(), |c| c.to_string());
                format!("fail {seed} {call} {}", message.replace('\n', " "))
            }
        };
        writeln!(stdout.lock(), "{line}")?;
        stdout.lock().flush()?;
    }
    Ok(())
}

/// Runs a sequence serially and, if asked, on two instances on two threads at once: the three
/// runs must answer identically.
pub fn check_sequence(target: &Target, calls: &[Call], threads: bool) -> Result<Reached, Failure> {
    check_sequence_with(target, calls, threads, &|_| {})
}

/// [`check_sequence`] with a report of each call made (see [`run_with`]).
pub fn check_sequence_with(
    target: &Target,
    calls: &[Call],
    threads: bool,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Reached, Failure> {
    let (serial, reached) = run_with(target, calls, "serial", progress)?;
    if threads {
        let (a, b) = std::thread::scope(|scope| {
            let a = scope.spawn(|| run_with(target, calls, "thread-a", progress));
            let b = scope.spawn(|| run_with(target, calls, "thread-b", progress));
            (a.join(), b.join())
        });
        for (name, result) in [("a", a), ("b", b)] {
            match result {
                Ok(Ok((trace, _))) if trace == serial => {}
                Ok(Ok(_)) => {
                    return Err(Failure {
                        call: None,
                        message: format!("thread {name} answered differently from the serial run"),
                    })
                }
                Ok(Err(failure)) => return Err(failure),
                Err(_) => return Err(Failure { call: None, message: format!("thread {name} panicked") }),
            }
        }
    }
    Ok(reached)
}
