//! The fuzzer in the test command: a fixed range of seeds per FMU through the packaged `.fmu`
//! files (run `cargo xtask package` first), each sequence in a child process of the `fmu-fuzz`
//! binary, so that an abort or a hang fails the test with its seed and minimal sequence
//! instead of ending the test run. 1,000 sequences per FMU in the test command (about 25 s on
//! two cores), 3,000 more with `tools/test-all.sh --long`.

use std::time::Duration;

use fmu_fuzz::campaign::{run_campaign, Config};
use fmu_fuzz::{fmu_path, FMUS};

/// Sequences per FMU in the test command (seeds 0..SEQUENCES).
const SEQUENCES: u64 = 1000;
/// The seeds the long tier adds (the long campaign of docs/fmu-robustness.md continues from
/// there).
const LONG_SEEDS: std::ops::Range<u64> = SEQUENCES..4 * SEQUENCES;

#[test]
fn random_call_sequences_keep_every_promise_of_every_fmu() {
    campaign(0..SEQUENCES);
}

#[test]
#[ignore = "long: tools/test-all.sh --long"]
fn three_thousand_more_sequences_keep_every_promise_of_every_fmu() {
    campaign(LONG_SEEDS);
}

/// Runs the sequences of `seeds` on every FMU and fails with each failing sequence's seed and
/// minimal reproduction.
fn campaign(seeds: std::ops::Range<u64>) {
    let count = seeds.end - seeds.start;
    let fmus: Vec<(String, std::path::PathBuf)> = FMUS.iter().map(|n| (n.to_string(), fmu_path(n))).collect();
    for (name, path) in &fmus {
        assert!(path.is_file(), "{name}: {} not found; run `cargo xtask package` first", path.display());
    }
    let config = Config {
        exe: env!("CARGO_BIN_EXE_fmu-fuzz").into(),
        fmus,
        seeds,
        campaign_limits: false,
        timeout: Duration::from_secs(60),
        jobs: 2,
        chunk: 250,
        threads_every: 8,
        wrapper: Vec::new(),
        shrink_trials: 100,
    };
    let summaries = run_campaign(&config).expect("the campaign runs");
    let mut report = Vec::new();
    for s in &summaries {
        assert_eq!(s.sequences, count, "{}: not every sequence ran", s.fmu);
        // The sequences must get past their first error to mean anything.
        assert!(s.reached.steps > count, "{}: only {} steps succeeded", s.fmu, s.reached.steps);
        assert!(s.reached.restores > count / 4, "{}: only {} states restored", s.fmu, s.reached.restores);
        for f in &s.failures {
            report.push(format!(
                "{} seed {} ({:?}): {}\n  reproduce: fmu-fuzz --fmu {} --first {} --sequences 1\n  minimal sequence:\n    {}",
                f.fmu,
                f.seed,
                f.kind,
                f.message,
                f.fmu,
                f.seed,
                f.minimal.join("\n    ")
            ));
        }
    }
    assert!(report.is_empty(), "{} failing sequences:\n{}", report.len(), report.join("\n"));
}
