//! Parameter and wind sweeps of the coupled antenna: N samples drawn over the ranges of the one
//! parameter table (`docs/parameters.csv`, optionally overridden by a sweep file), each run
//! through a set of the requirement scenarios, one CSV row per sample and scenario, and a
//! report of the answers (pass probabilities with confidence intervals, percentiles, the worst
//! samples, a sensitivity ranking, figures). See docs/sweeps.md.
//!
//! A sample's values depend only on the sweep's definition and the sample's index
//! ([`sampling`]), and each sample runs on its own FMU instances, so the rows are the same
//! whatever the number of threads ([`run`]) or of batches and machines (`--batch i/n`, the
//! distributed engine in `tools/sweep_distributed/`).

pub mod analysis;
pub mod distributed;
mod joe_kuo;
pub mod report;
pub mod rows;
pub mod run;
pub mod sampling;

use std::path::{Path, PathBuf};

use antenna_fmus::parameters::{parameters, parse_parameters, ParameterTableError, Target, UncertainParameter};

use crate::configuration::{AntennaSetup, SetupError};
use crate::scenario::{requirement_scenarios, Scenario};
pub use sampling::{Method, Plan, SamplingError};

/// What a sweep draws and runs, as given on the command line.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepSpec {
    /// Samples to draw (for a grid: points per axis).
    pub samples: u64,
    pub seed: u64,
    pub method: Method,
    /// Run the requirement scenarios whose name contains any of these (all if empty).
    pub scenarios: Vec<String>,
    /// Vary only these parameters: full names, or a group such as `wind` or `encoder` (the part
    /// before the first dot). All of the table if empty.
    pub vary: Vec<String>,
    /// Hold these parameters at a value.
    pub fix: Vec<(String, f64)>,
    /// A table in the format of docs/parameters.csv whose rows replace the committed rows of
    /// the same name (other ranges, scales or defaults) or add new ones.
    pub sweep_file: Option<PathBuf>,
}

impl SweepSpec {
    /// The command-line arguments that define this sweep (after `antenna sweep`), in a fixed
    /// order: what a batch, a worker or a rerun of one sample is given.
    pub fn to_args(&self) -> Vec<String> {
        let mut args = vec![
            "--samples".to_string(),
            self.samples.to_string(),
            "--seed".to_string(),
            self.seed.to_string(),
            "--method".to_string(),
            self.method.name().to_string(),
        ];
        for part in &self.scenarios {
            args.extend(["--scenarios".to_string(), part.clone()]);
        }
        for name in &self.vary {
            args.extend(["--vary".to_string(), name.clone()]);
        }
        for (name, value) in &self.fix {
            args.extend(["--fix".to_string(), format!("{name}={value:e}")]);
        }
        if let Some(path) = &self.sweep_file {
            args.extend(["--sweep-file".to_string(), path.display().to_string()]);
        }
        args
    }

    /// The arguments as one shell-quoted line.
    pub fn command_line(&self) -> String {
        self.to_args().iter().map(|a| shell_quote(a)).collect::<Vec<_>>().join(" ")
    }
}

/// `text` quoted for a POSIX shell where it needs quoting.
pub fn shell_quote(text: &str) -> String {
    if !text.is_empty() && text.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=:+,@".contains(c)) {
        text.to_string()
    } else {
        format!("'{}'", text.replace('\'', "'\\''"))
    }
}

/// Why a sweep cannot be set up.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    #[error("cannot read the sweep file {path}: {reason}")]
    ReadSweepFile { path: String, reason: fmu_runtime::files::FileError },
    #[error(transparent)]
    Table(#[from] ParameterTableError),
    #[error("--{option} {name}: no parameter of the table has this name or group; the parameters are: {known}")]
    UnknownParameter { option: &'static str, name: String, known: String },
    #[error("--scenarios {part}: no scenario name contains it; the scenarios are: {known}")]
    UnknownScenario { part: String, known: String },
    #[error("nothing to vary: every parameter is fixed")]
    NothingVaried,
    #[error(transparent)]
    Sampling(#[from] SamplingError),
    #[error("the parameter table cannot be applied")]
    Setup(#[from] SetupError),
    #[error("--batch {0}: give i/n with 0 <= i < n")]
    Batch(String),
}

/// A sweep ready to run: the parameter table it draws from, which parameters vary, the values
/// of the others, the sampling plan and the scenarios.
#[derive(Debug, Clone)]
pub struct Sweep {
    pub spec: SweepSpec,
    /// The committed table with the sweep file's rows applied, in table order.
    pub parameters: Vec<UncertainParameter>,
    /// Indices into `parameters` of the varied ones, in table order: sampling dimension `d` is
    /// parameter `varied[d]`.
    pub varied: Vec<usize>,
    /// The value of each parameter when it is not varied: the fixed value, its default, or
    /// `None` for the wind seed, which then stays each scenario's own (as in the report).
    pub base: Vec<Option<f64>>,
    pub plan: Plan,
    pub scenarios: Vec<Scenario>,
}

impl Sweep {
    /// Resolves a sweep's definition against the parameter table and the scenarios.
    pub fn new(spec: SweepSpec) -> Result<Sweep, SweepError> {
        let parameters = table_with_overrides(spec.sweep_file.as_deref())?;
        let known = || parameters.iter().map(|p| p.name.as_str()).collect::<Vec<_>>().join(", ");
        let matches =
            |pattern: &str, p: &UncertainParameter| p.name == pattern || p.name.split('.').next() == Some(pattern);
        let mut base: Vec<Option<f64>> =
            parameters.iter().map(|p| if keeps_scenario_seed(p) { None } else { Some(p.default) }).collect();
        let mut fixed = vec![false; parameters.len()];
        for (name, value) in &spec.fix {
            let index = parameters
                .iter()
                .position(|p| &p.name == name)
                .ok_or_else(|| SweepError::UnknownParameter { option: "fix", name: name.clone(), known: known() })?;
            base[index] = Some(*value);
            fixed[index] = true;
        }
        for pattern in &spec.vary {
            if !parameters.iter().any(|p| matches(pattern, p)) {
                return Err(SweepError::UnknownParameter { option: "vary", name: pattern.clone(), known: known() });
            }
        }
        let varied: Vec<usize> = (0..parameters.len())
            .filter(|&i| !fixed[i] && (spec.vary.is_empty() || spec.vary.iter().any(|v| matches(v, &parameters[i]))))
            .collect();
        if varied.is_empty() {
            return Err(SweepError::NothingVaried);
        }
        let plan = Plan::new(spec.method, spec.seed, spec.samples, varied.len())?;
        let scenarios = select_scenarios(&spec.scenarios)?;
        let sweep = Sweep { spec, parameters, varied, base, plan, scenarios };
        // Every target must be known to the master before hours of runs start.
        let folder = run::private_folder("check");
        std::fs::create_dir_all(&folder)
            .map_err(|source| SetupError::WriteModes { path: folder.display().to_string(), source })?;
        let checked = AntennaSetup::from_values(&sweep.values(0), Some(&folder));
        let _ = std::fs::remove_dir_all(&folder);
        checked?;
        Ok(sweep)
    }

    /// The number of samples (a grid: its points).
    pub fn len(&self) -> u64 {
        self.plan.len()
    }

    /// Whether the sweep has no samples (never, once built).
    pub fn is_empty(&self) -> bool {
        self.plan.is_empty()
    }

    /// Every parameter with its value in sample `index`.
    pub fn values(&self, index: u64) -> Vec<(UncertainParameter, Option<f64>)> {
        self.draw().values(index)
    }

    /// The samples of batch `i` of `n` (`"i/n"`): consecutive, nearly equal ranges.
    pub fn batch(&self, text: &str) -> Result<std::ops::Range<u64>, SweepError> {
        let bad = || SweepError::Batch(text.to_string());
        let (i, n) = text.split_once('/').ok_or_else(bad)?;
        let (i, n): (u64, u64) = (i.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
        if n == 0 || i >= n {
            return Err(bad());
        }
        let len = self.len() as u128;
        let start = (len * i as u128 / n as u128) as u64;
        let end = (len * (i as u128 + 1) / n as u128) as u64;
        Ok(start..end)
    }
}

/// The committed table, with a sweep file's rows replacing those of the same name or added.
fn table_with_overrides(sweep_file: Option<&Path>) -> Result<Vec<UncertainParameter>, SweepError> {
    let mut table = parameters();
    if let Some(path) = sweep_file {
        let text =
            fmu_runtime::files::read_regular_file(path, fmu_runtime::files::MAX_PARAMETER_FILE_BYTES, "sweep file")
                .map_err(|reason| SweepError::ReadSweepFile { path: path.display().to_string(), reason })?;
        for row in parse_parameters(&text, &path.display().to_string())? {
            match table.iter_mut().find(|p| p.name == row.name) {
                Some(existing) => *existing = row,
                None => table.push(row),
            }
        }
    }
    Ok(table)
}

/// Whether a parameter is the wind's seed, which stays each scenario's own unless varied or
/// fixed (as in the requirement report).
fn keeps_scenario_seed(p: &UncertainParameter) -> bool {
    p.targets.iter().any(|t| matches!(t, Target::Scenario { name } if name == "wind.seed"))
}

/// The requirement scenarios whose names contain any of `parts` (all if empty).
pub fn select_scenarios(parts: &[String]) -> Result<Vec<Scenario>, SweepError> {
    let all = requirement_scenarios();
    let known = || all.iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(", ");
    for part in parts {
        if !all.iter().any(|s| s.name.contains(part.as_str())) {
            return Err(SweepError::UnknownScenario { part: part.clone(), known: known() });
        }
    }
    Ok(all.iter().filter(|s| parts.is_empty() || parts.iter().any(|p| s.name.contains(p.as_str()))).cloned().collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> SweepSpec {
        SweepSpec {
            samples: 8,
            seed: 1,
            method: Method::Lhs,
            scenarios: vec!["step-30arcmin".into()],
            vary: Vec::new(),
            fix: Vec::new(),
            sweep_file: None,
        }
    }

    #[test]
    fn a_sweep_varies_every_row_of_the_table_within_its_range() {
        let sweep = Sweep::new(spec()).unwrap();
        assert_eq!(sweep.varied.len(), parameters().len());
        for index in 0..sweep.len() {
            for (p, value) in sweep.values(index) {
                let value = value.unwrap();
                assert!((p.low..=p.high).contains(&value), "{} = {value}", p.name);
            }
        }
        assert_eq!(sweep.scenarios.len(), 3);
    }

    #[test]
    fn vary_takes_names_and_groups_and_fix_holds_a_value() {
        let sweep = Sweep::new(SweepSpec {
            vary: vec!["wind".into(), "structure.damping".into()],
            fix: vec![("wind.yaw".into(), 90.0)],
            ..spec()
        })
        .unwrap();
        let names: Vec<&str> = sweep.varied.iter().map(|&i| sweep.parameters[i].name.as_str()).collect();
        assert!(names.contains(&"structure.damping") && names.contains(&"wind.seed"));
        assert!(!names.contains(&"wind.yaw") && !names.contains(&"structure.stiffness"));
        let values = sweep.values(3);
        assert_eq!(values.iter().find(|(p, _)| p.name == "wind.yaw").unwrap().1, Some(90.0));
        let stiffness = values.iter().find(|(p, _)| p.name == "structure.stiffness").unwrap();
        assert_eq!(stiffness.1, Some(stiffness.0.default));
    }

    #[test]
    fn unknown_names_are_refused_with_the_known_ones() {
        let error = Sweep::new(SweepSpec { vary: vec!["nonsense".into()], ..spec() }).unwrap_err();
        assert!(error.to_string().contains("wind.yaw"), "{error}");
        let error = Sweep::new(SweepSpec { scenarios: vec!["nonsense".into()], ..spec() }).unwrap_err();
        assert!(error.to_string().contains("slew-90deg-el45"), "{error}");
    }

    #[test]
    fn batches_cover_the_samples_once_in_order() {
        let sweep = Sweep::new(SweepSpec { samples: 10, ..spec() }).unwrap();
        let ranges: Vec<_> = (0..3).map(|i| sweep.batch(&format!("{i}/3")).unwrap()).collect();
        assert_eq!(ranges, vec![0..3, 3..6, 6..10]);
        assert!(sweep.batch("3/3").is_err() && sweep.batch("x").is_err());
    }

    #[test]
    fn a_sweep_file_replaces_a_range() {
        let folder = std::env::temp_dir().join(format!("antenna-sweep-file-{}", std::process::id()));
        std::fs::create_dir_all(&folder).unwrap();
        let path = folder.join("narrow.csv");
        let header = "name,unit,paper,default,low,high,scale,targets,basis,source";
        let row = "wind.yaw,deg,130,130,120,140,linear,scenario:wind.yaw,estimate,a narrower range";
        std::fs::write(&path, format!("{header}\n{row}\n")).unwrap();
        let sweep = Sweep::new(SweepSpec { sweep_file: Some(path), vary: vec!["wind.yaw".into()], ..spec() }).unwrap();
        std::fs::remove_dir_all(&folder).unwrap();
        for index in 0..sweep.len() {
            let value = sweep.values(index).into_iter().find(|(p, _)| p.name == "wind.yaw").unwrap().1.unwrap();
            assert!((120.0..=140.0).contains(&value));
        }
    }

    #[test]
    fn the_command_line_reads_back_as_the_same_sweep() {
        let spec = SweepSpec { fix: vec![("wind.yaw".into(), 0.1)], vary: vec!["wind".into()], ..spec() };
        assert_eq!(
            spec.command_line(),
            "--samples 8 --seed 1 --method lhs --scenarios step-30arcmin --vary wind --fix wind.yaw=1e-1"
        );
    }
}
