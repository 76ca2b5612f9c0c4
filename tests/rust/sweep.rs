//! `antenna sweep`'s promise of reproducibility, on the packaged FMUs: the same seed gives the
//! same rows, to the bit, whether one thread or two ran them, and whether the sweep ran whole or
//! in batches whose files are concatenated (what the distributed engine does; its own test,
//! tests/python/test_sweep_distributed.py, compares the engine's gathered file with a local run).

use antenna_sim::sweep::rows::RowWriter;
use antenna_sim::sweep::run::run_samples;
use antenna_sim::sweep::{Method, Sweep, SweepSpec};
use antenna_sim::FmuSet;

fn fmus() -> FmuSet {
    let directory = antenna_fmus::fmu_directory();
    FmuSet::open(&directory).unwrap_or_else(|e| {
        panic!("cannot open the FMUs in {}: {e}; package them first (cargo xtask package)", directory.display())
    })
}

/// A small sweep over every parameter of the table (the wind narrowed by a sweep file, to go
/// through that path too), on the shortest requirement scenario.
fn small_sweep(method: Method) -> Sweep {
    let sweep_file = antenna_fmus::workspace_root().join("tools/sweep_distributed/strong_wind.csv");
    Sweep::new(SweepSpec {
        samples: 6,
        seed: 42,
        method,
        scenarios: vec!["step-30arcmin-el45".into()],
        vary: Vec::new(),
        fix: Vec::new(),
        sweep_file: Some(sweep_file),
    })
    .expect("the sweep is valid")
}

/// The CSV bytes of samples `range` run on `threads` threads.
fn rows(sweep: &Sweep, fmus: &FmuSet, range: std::ops::Range<u64>, threads: usize) -> Vec<u8> {
    let mut writer = RowWriter::new(Vec::new(), &sweep.parameters).unwrap();
    run_samples(sweep, fmus, range, threads, &mut |row| writer.write(&row), &mut |_, _| {}).unwrap();
    writer.into_inner().unwrap()
}

#[test]
fn the_same_seed_gives_the_same_rows_on_one_and_on_two_threads() {
    let fmus = fmus();
    let sweep = small_sweep(Method::Lhs);
    let one = rows(&sweep, &fmus, 0..sweep.len(), 1);
    let two = rows(&sweep, &fmus, 0..sweep.len(), 2);
    assert_eq!(String::from_utf8_lossy(&one), String::from_utf8_lossy(&two));
    let text = String::from_utf8(one).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 1 + 6, "a header and one row per sample:\n{text}");
    // Every run ran and was judged (no error column filled, a finite settling time).
    for line in &lines[1..] {
        let fields: Vec<&str> = line.split(',').collect();
        assert!(fields[4].parse::<f64>().unwrap().is_finite() && fields[8].is_empty(), "{line}");
    }
    // The samples differ from one another: the parameters were drawn.
    assert_ne!(lines[1].split_once(",Req. 4,").unwrap().1, lines[2].split_once(",Req. 4,").unwrap().1);
}

#[test]
fn batches_concatenated_give_the_rows_of_the_whole_sweep() {
    let fmus = fmus();
    let sweep = small_sweep(Method::Sobol);
    let whole = String::from_utf8(rows(&sweep, &fmus, 0..sweep.len(), 2)).unwrap();
    let mut gathered = String::new();
    for i in 0..4 {
        let batch = String::from_utf8(rows(&sweep, &fmus, sweep.batch(&format!("{i}/4")).unwrap(), 1)).unwrap();
        let (header, body) = batch.split_once('\n').unwrap();
        if i == 0 {
            gathered.push_str(header);
            gathered.push('\n');
        }
        gathered.push_str(body);
    }
    assert_eq!(gathered, whole);
}

#[test]
fn a_sample_rerun_alone_with_traces_gives_the_figure_of_its_row() {
    let fmus = fmus();
    let sweep = small_sweep(Method::Random);
    let mut rows = Vec::new();
    run_samples(
        &sweep,
        &fmus,
        0..sweep.len(),
        2,
        &mut |row| {
            rows.push(row);
            Ok::<(), std::io::Error>(())
        },
        &mut |_, _| {},
    )
    .unwrap();
    let folder = std::env::temp_dir().join(format!("antenna-sweep-rerun-{}", std::process::id()));
    let (_, outcomes) = antenna_sim::sweep::run::run_one_sample(&sweep, &fmus, 4, &folder).unwrap();
    std::fs::remove_dir_all(&folder).unwrap();
    assert_eq!(outcomes.len(), 1);
    assert_eq!(outcomes[0].figure.to_bits(), rows[4].figure.to_bits());
    assert!(!outcomes[0].trace.time_s.is_empty(), "the rerun keeps its trace");
}
