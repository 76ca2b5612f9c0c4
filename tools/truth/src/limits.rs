//! Detection limits checked by injection (issue 34): a clean log of each sensor variant states
//! the smallest change of each effect kind its search would claim; logs with that kind's effect
//! at a multiple of the stated limit (1.5 by default) must have it named in at least 90 % of
//! the injections, or the limit does not hold.
//!
//! A limit is a property of the log it is stated for: of its excitation (the trajectory and
//! the injected torque) and its noise level. The verdict's logs therefore share the clean
//! log's excitation and draw other sensor noise (`TruthConfig::noise_seed`). Logs of other
//! excitations (other seeds) are counted beside it with their own clean logs' limits, which
//! says how far a limit transfers to another trajectory.
//!
//! The rule for "named": the injected kind is among the found effects, or the report says the
//! data cannot tell it from a found effect ("X or Y: the data cannot tell"): the report then
//! names it as one of what it cannot separate. The table counts such injections separately.

use crate::suite::{self, changed_effect, generate_with_effects, SuiteError};
use crate::TruthConfig;
use antenna_validate::measured_log::parse_str;
use antenna_validate::output_error::PlantSimulator;
use antenna_validate::plant_fmu::FmuSimulator;
use antenna_validate::report::{limit_size_text, limit_text};
use antenna_validate::selection::DetectionLimit;
use antenna_validate::{validate_with, ValidateOptions, Validation};
use rand::SeedableRng;
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::Path;

/// Why the injection check could not run.
#[derive(Debug, thiserror::Error)]
pub enum LimitsError {
    /// A variant name is neither "suite" nor a holdout suite's.
    #[error("unknown variant '{name}' (known: {known})")]
    UnknownVariant { name: String, known: String },
    /// A log could not be generated.
    #[error(transparent)]
    Suite(#[from] SuiteError),
    /// The worker threads could not be started.
    #[error("cannot start {threads} threads: {source}")]
    Threads { threads: usize, source: rayon::ThreadPoolBuildError },
    /// The plant FMU could not be opened.
    #[error("the plant FMU: {0}")]
    Fmu(#[from] antenna_validate::plant_fmu::PlantFmuError),
    /// A clean log could not be validated: no limit to check.
    #[error("the clean log of {variant} could not be validated: {message}")]
    Clean { variant: String, message: String },
}

/// What the check runs.
#[derive(Debug, Clone)]
pub struct LimitsConfig {
    /// Sensor variants: "suite" (the suite's own sensors) and holdout suites by name.
    pub variants: Vec<String>,
    /// Effect kinds, as the truth generator names them ([`suite::EFFECT_KINDS`]).
    pub kinds: Vec<String>,
    /// Injected logs per variant and kind.
    pub injections: usize,
    /// The injected change over the stated limit.
    pub factor: f64,
    /// Seed of the clean log that states the limits.
    pub clean_seed: u64,
    /// Seed of the first injected log; the others follow.
    pub first_seed: u64,
    /// The share of injections that must name the effect for the limit to hold.
    pub required: f64,
    /// Also inject into logs of other excitations (the seeds from `first_seed`), each beside
    /// its own clean log's limit.
    pub other_excitations: bool,
}

impl Default for LimitsConfig {
    fn default() -> Self {
        LimitsConfig {
            variants: vec!["suite".into(), "noiseless-current".into()],
            kinds: ["coulomb", "unbalance", "torque_offset", "delay", "cogging", "backlash"]
                .iter()
                .map(|k| k.to_string())
                .collect(),
            injections: 10,
            factor: 1.5,
            clean_seed: 301,
            first_seed: 311,
            required: 0.9,
            other_excitations: true,
        }
    }
}

/// Every variant the check knows: the suite's own sensors and the holdout suites' truths.
pub fn variants() -> Vec<(String, TruthConfig)> {
    std::iter::once(("suite".to_string(), TruthConfig::default()))
        .chain(suite::holdout_suites().into_iter().map(|(name, _, config)| (name.to_string(), config.base)))
        .collect()
}

/// One injected log's outcome.
#[derive(Debug, Clone)]
pub struct Injection {
    /// The seed of the excitation (and of the noise without `noise_seed`).
    pub seed: u64,
    /// The seed of the sensor noise, for a log of the clean log's excitation.
    pub noise_seed: Option<u64>,
    /// The limit the clean log of this excitation states for the kind, for a log of another
    /// excitation than the clean log's (`None` where it states none).
    pub own_limit: Option<f64>,
    /// The injected change of the limit's parameter.
    pub change: f64,
    /// The kind is among the found effects.
    pub named: bool,
    /// The kind is not found but listed as one the data cannot tell from a found effect.
    pub cannot_tell: bool,
    pub found: Vec<String>,
    /// The validation's error, if it failed.
    pub error: Option<String>,
}

impl Injection {
    /// Named by the rule of this module: found, or listed as indistinguishable from a found one.
    pub fn counts(&self) -> bool {
        self.named || self.cannot_tell
    }
}

/// One variant and kind: the stated limit and its injections.
#[derive(Debug, Clone)]
pub struct LimitRow {
    pub variant: String,
    pub kind: String,
    /// The stated limit, or why the clean log states none for the kind.
    pub stated: Result<DetectionLimit, String>,
    /// Whether the variant logs a linear axis (for the limit's display units).
    pub linear: bool,
    /// Injections into the clean log's excitation with other noise: the verdict's.
    pub injections: Vec<Injection>,
    /// Injections into other excitations (empty unless asked for).
    pub other: Vec<Injection>,
}

impl LimitRow {
    /// Injections that name the kind ([`Injection::counts`]).
    pub fn named(&self) -> usize {
        self.injections.iter().filter(|i| i.counts()).count()
    }

    /// Whether the limit holds: at least `required` of the injections name the kind.
    pub fn holds(&self, required: f64) -> Option<bool> {
        (!self.injections.is_empty()).then(|| self.named() as f64 >= required * self.injections.len() as f64)
    }

    /// Injections into other excitations that name the kind.
    pub fn other_named(&self) -> usize {
        self.other.iter().filter(|i| i.counts()).count()
    }

    /// Injections into other excitations that missed the kind where that excitation's own
    /// clean log states a limit above the injected change: misses the log's own limit foretells.
    pub fn other_missed_below_own_limit(&self) -> usize {
        self.other.iter().filter(|i| !i.counts() && i.own_limit.is_some_and(|own| own >= i.change.abs())).count()
    }
}

/// The validate tool's name of a generator kind (an asymmetry and an offset are both offsets).
fn family(kind: &str) -> &str {
    match kind {
        "torque_offset" | "asymmetry" => "offset",
        other => other,
    }
}

/// What the clean validation states for `kind`: its limit, or why there is none.
fn stated_limit(validation: &Validation, kind: &str) -> Result<DetectionLimit, String> {
    let name = family(kind);
    if validation.selection.found.iter().any(|f| f.kind.name() == name) {
        return Err("found on the clean log".into());
    }
    if let Some((_, reason)) = validation.selection.unobservable().into_iter().find(|(k, _)| k.name() == name) {
        return Err(format!("not observable: {reason}"));
    }
    validation
        .selection
        .detection_limits()
        .into_iter()
        .find(|(k, _)| k.name() == name)
        .map(|(_, limit)| limit)
        .ok_or_else(|| "no limit stated".into())
}

/// Whether `kind` is named in `validation`: (among the found effects, listed as one the data
/// cannot tell from a found effect), and the found effects' names.
fn naming(validation: &Validation, kind: &str) -> (bool, bool, Vec<String>) {
    let name = family(kind);
    let found: Vec<String> = validation.selection.found.iter().map(|f| f.kind.name().to_string()).collect();
    let named = found.iter().any(|f| f == name);
    let cannot_tell = !named
        && validation.selection.found.iter().any(|f| {
            validation.selection.equally_consistent(f.kind).iter().any(|k| k.name() == name)
                || validation.indistinct.iter().any(|a| a.found == f.kind && a.alternative.name() == name)
        });
    (named, cannot_tell, found)
}

/// Validates a generated log's text with the variant's starting set.
fn validate_text(
    text: &str,
    config: &TruthConfig,
    options: &ValidateOptions,
    simulator: Option<&mut dyn PlantSimulator>,
) -> Result<Validation, String> {
    let log = parse_str(text).map_err(|e| e.to_string())?;
    validate_with(&log, &config.starting_parameters(), options, simulator).map_err(|e| e.to_string())
}

/// One unit of work on a worker: a clean log (no kind) or an injection.
struct Job<'a> {
    variant: usize,
    kind: Option<&'a str>,
    seed: u64,
    noise_seed: Option<u64>,
    change: f64,
}

/// A clean log's limit of each kind asked for, or why it states none.
type KindLimits = Vec<Result<DetectionLimit, String>>;

/// What a job gave: the clean validation's limits per kind, or an injection.
enum Outcome {
    Clean(KindLimits, bool),
    Injected(Injection),
}

/// The noise seed of the clean log of excitation `seed`: the clean log that states the
/// limits draws its sensor noise from a seed of its own (the clean seed), as the verdict's
/// injections do from theirs, since only then do they share its excitation. The truth draws
/// the injected torque from the excitation's stream, and without a noise seed the sensor noise
/// comes from that stream too, so a log without one has another injected torque than the logs
/// with one (on the 2 kHz noiseless current the clean log's torque residual was 16.2 N m RMS,
/// every injection's 22.6 N m). The clean logs of other excitations have no noise seed, as
/// their injections have none.
fn clean_noise_seed(config: &LimitsConfig, seed: u64) -> Option<u64> {
    (seed == config.clean_seed).then_some(seed)
}

/// Runs the check: the clean logs first (one per variant, on the workers), then every
/// injection. `progress` is called with each finished injection's line.
pub fn run(
    config: &LimitsConfig,
    options: &ValidateOptions,
    fmu: Option<&Path>,
    threads: usize,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Vec<LimitRow>, LimitsError> {
    let known = variants();
    let mut chosen = Vec::new();
    for name in &config.variants {
        let found = known.iter().find(|(n, _)| n == name).ok_or_else(|| LimitsError::UnknownVariant {
            name: name.clone(),
            known: known.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>().join(", "),
        })?;
        chosen.push(found.clone());
    }
    for kind in &config.kinds {
        if !suite::EFFECT_KINDS.contains(&kind.as_str()) {
            return Err(SuiteError::UnknownEffectKind { kind: kind.clone() }.into());
        }
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
        .map_err(|source| LimitsError::Threads { threads, source })?;
    // The clean logs: the one that states the limits, then (if asked) one per other excitation,
    // each stating its own limits.
    let other_seeds: Vec<u64> = if config.other_excitations {
        (0..config.injections).map(|i| config.first_seed + i as u64).collect()
    } else {
        Vec::new()
    };
    let clean_seeds: Vec<u64> = std::iter::once(config.clean_seed).chain(other_seeds.iter().copied()).collect();
    let clean_jobs: Vec<Job> = (0..chosen.len())
        .flat_map(|variant| {
            clean_seeds.iter().map(move |&seed| Job {
                variant,
                kind: None,
                seed,
                noise_seed: clean_noise_seed(config, seed),
                change: 0.0,
            })
        })
        .collect();
    let per_kind = config.injections * if config.other_excitations { 2 } else { 1 };
    let bar = crate::progress_bar(clean_jobs.len() + chosen.len() * config.kinds.len() * per_kind, "injection check");
    let clean = run_jobs(&pool, &clean_jobs, &chosen, &config.kinds, options, fmu, &bar, progress)?;
    let own: Vec<(usize, u64, KindLimits, bool)> = clean_jobs
        .iter()
        .zip(clean)
        .filter_map(|(job, outcome)| match outcome {
            Outcome::Clean(limits, linear) => Some((job.variant, job.seed, limits, linear)),
            Outcome::Injected(_) => None,
        })
        .collect();
    let mut rows = Vec::new();
    let mut injection_jobs = Vec::new();
    for (variant, _, limits, linear) in own.iter().filter(|(_, seed, _, _)| *seed == config.clean_seed) {
        for (kind, stated) in config.kinds.iter().zip(limits) {
            if let Ok(limit) = stated {
                let change = config.factor * limit.size;
                for i in 0..config.injections {
                    let noise_seed = Some(config.first_seed + i as u64);
                    injection_jobs.push(Job {
                        variant: *variant,
                        kind: Some(kind),
                        seed: config.clean_seed,
                        noise_seed,
                        change,
                    });
                }
                for &seed in &other_seeds {
                    injection_jobs.push(Job { variant: *variant, kind: Some(kind), seed, noise_seed: None, change });
                }
            } else {
                bar.inc(per_kind as u64);
            }
            rows.push(LimitRow {
                variant: chosen[*variant].0.clone(),
                kind: kind.clone(),
                stated: stated.clone(),
                linear: *linear,
                injections: Vec::new(),
                other: Vec::new(),
            });
        }
    }
    let injected = run_jobs(&pool, &injection_jobs, &chosen, &config.kinds, options, fmu, &bar, progress)?;
    bar.finish_and_clear();
    for (job, outcome) in injection_jobs.iter().zip(injected) {
        let (Outcome::Injected(mut injection), Some(kind)) = (outcome, job.kind) else { continue };
        let variant = &chosen[job.variant].0;
        let Some(row) = rows.iter_mut().find(|r| &r.variant == variant && r.kind == kind) else { continue };
        if job.noise_seed.is_some() {
            row.injections.push(injection);
        } else {
            let k = config.kinds.iter().position(|k| k == kind);
            injection.own_limit = own
                .iter()
                .find(|(v, seed, _, _)| *v == job.variant && *seed == job.seed)
                .and_then(|(_, _, limits, _)| limits.get(k?)?.as_ref().ok())
                .map(|limit| limit.size);
            row.other.push(injection);
        }
    }
    Ok(rows)
}

/// Runs `jobs` on the pool's workers, each with its own plant FMU instance; the outcomes come
/// back in job order.
#[allow(clippy::too_many_arguments)]
fn run_jobs(
    pool: &rayon::ThreadPool,
    jobs: &[Job],
    variants: &[(String, TruthConfig)],
    kinds: &[String],
    options: &ValidateOptions,
    fmu: Option<&Path>,
    bar: &indicatif::ProgressBar,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Vec<Outcome>, LimitsError> {
    let results: Vec<Result<Outcome, LimitsError>> = pool.install(|| {
        jobs.par_iter()
            .map_init(
                || fmu.map(FmuSimulator::open).transpose(),
                |simulator, job| {
                    let simulator = simulator.as_mut().map_err(|e| LimitsError::Fmu(e.clone()))?;
                    let simulator = simulator.as_mut().map(|s| s as &mut dyn PlantSimulator);
                    let outcome = run_job(job, variants, kinds, options, simulator)?;
                    if let Outcome::Injected(i) = &outcome {
                        let line = format!(
                            "{} {} seed {}{}: change {:.3e} -> {}{}",
                            variants[job.variant].0,
                            job.kind.unwrap_or("-"),
                            i.seed,
                            i.noise_seed.map(|n| format!(" noise {n}")).unwrap_or_default(),
                            i.change,
                            if i.found.is_empty() { "none".into() } else { i.found.join(", ") },
                            i.error.as_ref().map(|e| format!(" (error: {e})")).unwrap_or_default()
                        );
                        bar.suspend(|| progress(&line));
                    }
                    bar.inc(1);
                    Ok(outcome)
                },
            )
            .collect()
    });
    results.into_iter().collect()
}

/// One job: a clean log's limits or one injection.
fn run_job(
    job: &Job,
    variants: &[(String, TruthConfig)],
    kinds: &[String],
    options: &ValidateOptions,
    simulator: Option<&mut dyn PlantSimulator>,
) -> Result<Outcome, LimitsError> {
    let (variant, config) = &variants[job.variant];
    let config = &TruthConfig { noise_seed: job.noise_seed, ..config.clone() };
    let Some(kind) = job.kind else {
        let (text, _) = generate_with_effects(config, job.seed, &[], "clean.csv")?;
        let validation = validate_text(&text, config, options, simulator)
            .map_err(|message| LimitsError::Clean { variant: variant.clone(), message })?;
        let limits = kinds.iter().map(|kind| stated_limit(&validation, kind)).collect();
        return Ok(Outcome::Clean(limits, validation.data.linear));
    };
    // The effect's sign and phase follow the noise seed on the clean log's excitation, so the
    // injections into it do not all share one.
    let draw = job.noise_seed.unwrap_or(job.seed);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(draw.wrapping_mul(0x9e37_79b9).wrapping_add(0x11));
    let effect = changed_effect(kind, job.change, config, &mut rng)?;
    let (text, _) = generate_with_effects(config, job.seed, &[effect], "injected.csv")?;
    let injection = match validate_text(&text, config, options, simulator) {
        Ok(validation) => {
            let (named, cannot_tell, found) = naming(&validation, kind);
            Injection {
                seed: job.seed,
                noise_seed: job.noise_seed,
                own_limit: None,
                change: job.change,
                named,
                cannot_tell,
                found,
                error: None,
            }
        }
        Err(message) => Injection {
            seed: job.seed,
            noise_seed: job.noise_seed,
            own_limit: None,
            change: job.change,
            named: false,
            cannot_tell: false,
            found: Vec::new(),
            error: Some(message),
        },
    };
    Ok(Outcome::Injected(injection))
}

/// The table: variant, kind, stated limit (with its unit, what set it and the searched
/// range), named k/N in the clean log's excitation with other noise (of which as "cannot
/// tell"), verdict; and, with other excitations, named k/N there and how many of their misses
/// their own clean log's limit foretold.
pub fn markdown(rows: &[LimitRow], config: &LimitsConfig) -> String {
    let mut out = format!(
        "| variant | kind | stated limit (clean seed {}) | injected at {} x | named k/N, same excitation, other noise (as \"cannot tell\") | holds (>= {:.0} %) | other excitations: named k/N (misses where the log's own limit is at or above the injected change) |\n|---|---|---|---|---|---|---|\n",
        config.clean_seed,
        config.factor,
        config.required * 100.0
    );
    for row in rows {
        let (stated, injected) = match &row.stated {
            Ok(limit) => (
                format!("{} {}", limit.parameter, limit_text(limit, row.linear)),
                limit_size_text(&DetectionLimit { size: config.factor * limit.size, ..limit.clone() }, row.linear),
            ),
            Err(why) => (format!("none: {why}"), "-".into()),
        };
        let cannot_tell = row.injections.iter().filter(|i| i.cannot_tell).count();
        let (count, verdict) = match row.holds(config.required) {
            Some(holds) => (
                format!("{}/{} ({cannot_tell})", row.named(), row.injections.len()),
                if holds { "yes" } else { "**no**" }.to_string(),
            ),
            None => ("-".into(), "-".into()),
        };
        let other = if row.other.is_empty() {
            "-".to_string()
        } else {
            format!(
                "{}/{} ({} of {})",
                row.other_named(),
                row.other.len(),
                row.other_missed_below_own_limit(),
                row.other.len() - row.other_named()
            )
        };
        let _ =
            writeln!(out, "| {} | {} | {stated} | {injected} | {count} | {verdict} | {other} |", row.variant, row.kind);
    }
    out
}

/// One line per injection: variant, kind, the stated limit (parameter units), the excitation
/// ("same" as the clean log's, with a noise seed, or "other"), the injected change, seed, noise
/// seed, the log's own limit (other excitations), named, cannot tell, found effects, error.
pub fn csv(rows: &[LimitRow]) -> String {
    let mut out = String::from(
        "variant,kind,parameter,unit,stated_limit,excitation,injected_change,seed,noise_seed,own_limit,named,cannot_tell,found,error\n",
    );
    for row in rows {
        let Ok(limit) = &row.stated else {
            let why = row.stated.as_ref().err().map(|w| w.replace(',', ";")).unwrap_or_default();
            let _ = writeln!(out, "{},{},,,,,,,,,,,,{why}", row.variant, row.kind);
            continue;
        };
        for (excitation, i) in row.injections.iter().map(|i| ("same", i)).chain(row.other.iter().map(|i| ("other", i)))
        {
            let _ = writeln!(
                out,
                "{},{},{},{},{:.6e},{excitation},{:.6e},{},{},{},{},{},{},{}",
                row.variant,
                row.kind,
                limit.parameter,
                limit.unit,
                limit.size,
                i.change,
                i.seed,
                i.noise_seed.map(|n| n.to_string()).unwrap_or_default(),
                i.own_limit.map(|l| format!("{l:.6e}")).unwrap_or_default(),
                i.named,
                i.cannot_tell,
                i.found.join(" "),
                i.error.as_deref().unwrap_or("").replace(',', ";")
            );
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn injection(named: bool, cannot_tell: bool) -> Injection {
        Injection {
            seed: 1,
            noise_seed: Some(2),
            own_limit: None,
            change: 2.0,
            named,
            cannot_tell,
            found: Vec::new(),
            error: None,
        }
    }

    fn row(injections: Vec<Injection>) -> LimitRow {
        let limit = DetectionLimit {
            parameter: "effect.torque_offset",
            size: 1.0,
            unit: "N m",
            effect_to_noise: 1.0,
            set_by: antenna_validate::selection::LimitSetBy::Significance,
            searched: Vec::new(),
        };
        LimitRow {
            variant: "suite".into(),
            kind: "torque_offset".into(),
            stated: Ok(limit),
            linear: false,
            injections,
            other: Vec::new(),
        }
    }

    #[test]
    fn the_clean_log_that_states_the_limits_shares_its_injections_excitation() {
        // Without sensor noise, two logs of one excitation are the same log: the clean log and
        // an injection's base must be, or the limit is stated for another log than the one
        // the injections test.
        let config = LimitsConfig::default();
        let mut truth = TruthConfig { duration: 2.0, ..TruthConfig::default() };
        truth.noise.current_sigma = 0.0;
        truth.noise.load_encoder_sigma = 0.0;
        let log = |noise_seed| {
            let truth = TruthConfig { noise_seed, ..truth.clone() };
            generate_with_effects(&truth, config.clean_seed, &[], "clean.csv").map(|(text, _)| text).unwrap()
        };
        let clean = log(clean_noise_seed(&config, config.clean_seed));
        assert_eq!(clean, log(Some(config.first_seed)));
        // The clean logs of other excitations keep their injections' own (no noise seed).
        assert_eq!(clean_noise_seed(&config, config.first_seed), None);
    }

    #[test]
    fn an_offset_limit_beside_an_unbalance_the_log_resolves_below_the_floor_holds() {
        // With the load encoder's error the clean log of excitation 301 resolves an
        // unbalance-shaped torque below the noise floor over its 12.7 deg stroke, where an
        // offset is the unbalance's constant part: the offset's limit must be stated beside
        // it, and an offset at 1.5 times that limit must be named.
        let config = LimitsConfig {
            variants: vec!["load-encoder-error".into()],
            kinds: vec!["torque_offset".into()],
            injections: 2,
            other_excitations: false,
            ..LimitsConfig::default()
        };
        let rows = run(&config, &ValidateOptions::default(), None, 2, &|_| {}).unwrap();
        let limit = rows[0].stated.as_ref().unwrap();
        assert_eq!(
            limit.set_by,
            antenna_validate::selection::LimitSetBy::Beside(antenna_validate::candidates::Kind::Unbalance),
            "{limit:?}"
        );
        assert_eq!(rows[0].named(), 2, "{:?}", rows[0].injections);
    }

    #[test]
    fn a_cannot_tell_listing_counts_as_named_and_ninety_percent_holds() {
        let mut injections: Vec<Injection> = (0..8).map(|_| injection(true, false)).collect();
        injections.push(injection(false, true));
        injections.push(injection(false, false));
        let nine = row(injections.clone());
        assert_eq!(nine.named(), 9);
        assert_eq!(nine.holds(0.9), Some(true));
        injections[8] = injection(false, false);
        let eight = row(injections);
        assert_eq!(eight.named(), 8);
        assert_eq!(eight.holds(0.9), Some(false));
        assert_eq!(row(Vec::new()).holds(0.9), None);
    }

    #[test]
    fn the_csv_has_a_line_per_injection_and_one_per_kind_without_a_limit() {
        let mut rows = vec![row(vec![injection(true, false), injection(false, true)])];
        rows.push(LimitRow { stated: Err("not observable: one encoder".into()), ..row(Vec::new()) });
        let text = csv(&rows);
        assert_eq!(text.lines().count(), 1 + 2 + 1);
        assert!(text.lines().nth(2).is_some_and(|l| l.contains(",false,true,")));
    }

    #[test]
    fn a_miss_in_another_excitation_is_foretold_only_where_its_own_limit_reaches_the_change() {
        let mut below = injection(false, false);
        below.own_limit = Some(3.0);
        let mut above = injection(false, false);
        above.own_limit = Some(1.0);
        let named = Injection { own_limit: Some(3.0), ..injection(true, false) };
        let unknown = injection(false, false);
        let mut with_other = row(Vec::new());
        with_other.other = vec![below, above, named, unknown];
        assert_eq!(with_other.other_named(), 1);
        assert_eq!(with_other.other_missed_below_own_limit(), 1);
        let table = markdown(&[with_other], &LimitsConfig::default());
        assert!(table.lines().nth(2).is_some_and(|l| l.ends_with("| 1/4 (1 of 3) |")));
    }

    #[test]
    fn an_unknown_variant_is_refused_before_any_work() {
        let config = LimitsConfig { variants: vec!["no-such-variant".into()], ..LimitsConfig::default() };
        let result = run(&config, &ValidateOptions::default(), None, 1, &|_| {});
        assert!(matches!(result, Err(LimitsError::UnknownVariant { .. })));
    }
}
