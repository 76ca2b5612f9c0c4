//! Runs a sweep's samples on all cores: every (sample, scenario) pair is one task, taken in
//! order from a shared counter by a fixed set of worker threads, each coupled run on its own FMU
//! instances. Finished rows go back to the calling thread, which writes them in task order; at
//! most one task per worker is in flight, so memory stays bounded (one trace per worker, dropped
//! as soon as its figure is taken) however long the sweep.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;

use antenna_fmus::parameters::UncertainParameter;

use super::rows::Row;
use super::{Plan, Sweep};
use crate::configuration::AntennaSetup;
use crate::coupled::{AntennaConfig, FmuSet};
use crate::report::{run_scenario, Outcome};
use crate::scenario::Scenario;

/// Why a sweep stopped.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("cannot start {0} worker threads")]
    Threads(usize, #[source] rayon::ThreadPoolBuildError),
    #[error("cannot write the rows")]
    Sink(#[source] Box<dyn std::error::Error + Send + Sync>),
    #[error("sample {sample}")]
    Setup { sample: u64, source: crate::configuration::SetupError },
    #[error(transparent)]
    Report(#[from] crate::report::ReportError),
    #[error("sample {sample} is outside the sweep's {len} samples")]
    SampleOutOfRange { sample: u64, len: u64 },
    #[error("cannot create the folder {path}")]
    Folder { path: String, source: std::io::Error },
}

/// What a finished run measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSummary {
    pub samples: u64,
    pub rows: u64,
    pub threads: usize,
    pub wall_s: f64,
    /// Simulated time of all runs, s.
    pub simulated_s: f64,
}

/// The values of every parameter in one sample: what [`Sweep::values`] returns, from the parts
/// the worker threads share.
pub(super) struct Draw<'a> {
    parameters: &'a [UncertainParameter],
    varied: &'a [usize],
    base: &'a [Option<f64>],
    plan: Plan,
}

impl Draw<'_> {
    pub(super) fn values(&self, index: u64) -> Vec<(UncertainParameter, Option<f64>)> {
        let point = self.plan.point(index);
        let mut values: Vec<(UncertainParameter, Option<f64>)> =
            self.parameters.iter().cloned().zip(self.base.iter().copied()).collect();
        for (&i, u) in self.varied.iter().zip(point) {
            values[i].1 = Some(self.parameters[i].value_at(u));
        }
        values
    }
}

impl Sweep {
    pub(super) fn draw(&self) -> Draw<'_> {
        Draw { parameters: &self.parameters, varied: &self.varied, base: &self.base, plan: self.plan }
    }
}

/// The number of worker threads for `threads` (0: one per core).
pub fn worker_threads(threads: usize) -> usize {
    if threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        threads
    }
}

/// Runs the samples `samples` of the sweep on `threads` workers (0: all cores) and hands every
/// row to `sink` in (sample, scenario) order. `progress` is told the rows done and the total.
/// A coupled run that fails is a row with its error, not the end of the sweep; a sink that fails
/// stops it.
pub fn run_samples<E>(
    sweep: &Sweep,
    fmus: &FmuSet,
    samples: Range<u64>,
    threads: usize,
    sink: &mut dyn FnMut(Row) -> Result<(), E>,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<RunSummary, RunError>
where
    E: std::error::Error + Send + Sync + 'static,
{
    let threads = worker_threads(threads);
    let pool =
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().map_err(|e| RunError::Threads(threads, e))?;
    let per_sample = sweep.scenarios.len() as u64;
    let total = (samples.end - samples.start) * per_sample;
    let next_task = AtomicU64::new(0);
    let stop = AtomicBool::new(false);
    let draw = sweep.draw();
    let started = std::time::Instant::now();
    let (sender, receiver) = mpsc::channel::<(u64, Row)>();
    let mut sink_error = None;
    pool.in_place_scope(|scope| {
        for _ in 0..threads {
            let sender = sender.clone();
            // A command table caches its last look-up and is not Sync: each worker has its own.
            let scenarios = sweep.scenarios.clone();
            let (next_task, stop, draw) = (&next_task, &stop, &draw);
            scope.spawn(move |_| loop {
                let task = next_task.fetch_add(1, Ordering::Relaxed);
                if task >= total || stop.load(Ordering::Relaxed) {
                    break;
                }
                let sample = samples.start + task / per_sample;
                let scenario = &scenarios[(task % per_sample) as usize];
                let row = run_task(draw, fmus, sample, scenario);
                if sender.send((task, row)).is_err() {
                    break;
                }
            });
        }
        drop(sender);
        // Rows arrive in the order they finish; they leave in task order.
        let mut pending = BTreeMap::new();
        let mut written = 0;
        for (task, row) in receiver.iter() {
            pending.insert(task, row);
            while let Some(row) = pending.remove(&written) {
                if let Err(e) = sink(row) {
                    stop.store(true, Ordering::Relaxed);
                    sink_error = Some(e);
                    return;
                }
                written += 1;
                progress(written, total);
            }
        }
    });
    if let Some(e) = sink_error {
        return Err(RunError::Sink(Box::new(e)));
    }
    let simulated_s = sweep.scenarios.iter().map(|s| s.end_s).sum::<f64>() * (samples.end - samples.start) as f64;
    Ok(RunSummary {
        samples: samples.end - samples.start,
        rows: total,
        threads,
        wall_s: started.elapsed().as_secs_f64(),
        simulated_s,
    })
}

/// One coupled run of one sample, as a row; its trace is dropped here.
fn run_task(draw: &Draw, fmus: &FmuSet, sample: u64, scenario: &Scenario) -> Row {
    let values = draw.values(sample);
    let folder = private_folder(&format!("{sample}-{}", scenario.name));
    let outcome = (|| -> Result<Outcome, String> {
        std::fs::create_dir_all(&folder).map_err(|e| format!("cannot create {}: {e}", folder.display()))?;
        let setup = AntennaSetup::from_values(&values, Some(&folder)).map_err(|e| error_text(&e))?;
        let scenario = setup.scenario.apply(scenario);
        run_scenario(fmus, &setup.config, &scenario, &mut |_| {}).map_err(|e| error_text(&e))
    })();
    let _ = std::fs::remove_dir_all(&folder);
    let requirement = scenario.requirement;
    let (figure, passed, error) = match outcome {
        Ok(o) => (o.figure, o.passed, String::new()),
        Err(e) => (f64::NAN, false, e),
    };
    Row {
        sample,
        scenario: scenario.name.clone(),
        requirement: requirement.label().to_string(),
        elevation_deg: scenario.elevation_deg,
        figure,
        unit: requirement.unit().to_string(),
        limit: requirement.limit(),
        passed,
        error,
        values: values.into_iter().map(|(_, v)| v).collect(),
    }
}

/// A temporary folder of this run alone: unique within the process (two sweeps may run the same
/// sample at once, in tests) and across processes.
pub(super) fn private_folder(label: &str) -> std::path::PathBuf {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let unique = NEXT.fetch_add(1, Ordering::Relaxed);
    std::env::temp_dir().join(format!("antenna-sweep-{}-{unique}-{label}", std::process::id()))
}

/// An error with its causes, on one line.
fn error_text(error: &dyn std::error::Error) -> String {
    let mut text = error.to_string();
    let mut source = error.source();
    while let Some(cause) = source {
        text.push_str(": ");
        text.push_str(&cause.to_string());
        source = cause.source();
    }
    text
}

/// Runs one sample's scenarios with their traces (to look at one sample closely), on all cores.
/// The varied structure's modes file is written into `folder`, which the returned configuration
/// names, so the runs can be repeated from the trace export.
pub fn run_one_sample(
    sweep: &Sweep,
    fmus: &FmuSet,
    sample: u64,
    folder: &Path,
) -> Result<(AntennaConfig, Vec<Outcome>), RunError> {
    use rayon::prelude::*;
    if sample >= sweep.len() {
        return Err(RunError::SampleOutOfRange { sample, len: sweep.len() });
    }
    std::fs::create_dir_all(folder)
        .map_err(|source| RunError::Folder { path: folder.display().to_string(), source })?;
    let setup = AntennaSetup::from_values(&sweep.values(sample), Some(folder))
        .map_err(|source| RunError::Setup { sample, source })?;
    let scenarios: Vec<Scenario> = sweep.scenarios.iter().map(|s| setup.scenario.apply(s)).collect();
    let outcomes = scenarios
        .into_par_iter()
        .map(|scenario| run_scenario(fmus, &setup.config, &scenario, &mut |_| {}))
        .collect::<Result<Vec<Outcome>, _>>()?;
    Ok((setup.config, outcomes))
}

/// The peak resident memory of this process so far, bytes (Linux; `None` elsewhere).
pub fn peak_resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Runs the samples `samples` and writes their rows, header first, to the CSV file `path`.
pub fn write_rows_file(
    sweep: &Sweep,
    fmus: &FmuSet,
    samples: Range<u64>,
    threads: usize,
    path: &Path,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<RunSummary, RunError> {
    let file =
        std::fs::File::create(path).map_err(|source| RunError::Folder { path: path.display().to_string(), source })?;
    let mut writer = super::rows::RowWriter::new(std::io::BufWriter::new(file), &sweep.parameters)
        .map_err(|e| RunError::Sink(Box::new(e)))?;
    let summary = run_samples(sweep, fmus, samples, threads, &mut |row| writer.write(&row), progress)?;
    writer.flush().map_err(|e| RunError::Sink(Box::new(e)))?;
    Ok(summary)
}
