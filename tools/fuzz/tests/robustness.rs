//! The bounds of docs/fmu-robustness.md through the C ABI of the packaged FMUs (run
//! `cargo xtask package` first): a step whose work exceeds the budget is refused at once, the
//! controllers' memory does not grow with the step, and files that never end are refused.

use std::time::Instant;

use fmu_import::{Fmu, Instance};

fn open(name: &str) -> Fmu {
    Fmu::open(fmu_fuzz::fmu_path(name)).unwrap_or_else(|e| panic!("{name}: {e}; run `cargo xtask package` first"))
}

fn instance(fmu: &Fmu, reals: &[(&str, f64)]) -> Instance {
    let mut instance = fmu.instantiate("robustness", false).expect("instantiate");
    let values: Vec<(u32, f64)> = reals.iter().map(|(n, v)| (fmu.description.vr(n).unwrap(), *v)).collect();
    instance.initialize(0.0, &values).expect("initialise");
    instance
}

/// The peak resident memory of this process, kB (Linux).
fn peak_memory_kb() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

#[test]
fn a_plant_step_beyond_the_work_budget_is_refused_at_once_with_the_count() {
    for plant in ["AzimuthPlant", "ElevationPlant"] {
        let fmu = open(plant);
        let mut instance =
            instance(&fmu, &[("numerics.event_time_resolution", 1e-9), ("numerics.event_check_interval", 1e-6)]);
        let started = Instant::now();
        let error = instance.do_step(0.0, 86_400.0).expect_err("a day in microsecond pieces");
        assert!(started.elapsed().as_secs_f64() < 1.0, "{plant}: the refusal took {:?}", started.elapsed());
        let text = error.to_string();
        assert!(text.contains("8.640e10 pieces") && text.contains("event_check_interval"), "{plant}: {text}");
        // The instance is usable again after restoring a state or resetting.
        instance.reset().expect("reset");
    }
}

#[test]
fn a_long_controller_step_takes_no_memory_in_proportion_to_its_length() {
    let fmu = open("AzimuthController");
    let mut instance = instance(&fmu, &[]);
    instance.do_step(0.0, 1.0).expect("a short step first");
    let before = peak_memory_kb();
    // 10^6 samples: before the queue was drained as it went, some 100 MB of queued outputs.
    instance.do_step(1.0, 1000.0).expect("a 1000 s step");
    let grown = peak_memory_kb().saturating_sub(before);
    assert!(grown < 10_000, "the peak memory grew by {grown} kB over a 1000 s step");
}

#[test]
fn files_that_never_end_are_refused_at_once() {
    let dir = std::env::temp_dir().join(format!("fmu-fuzz-fifo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let fifo = dir.join("pipe.params");
    let has_fifo = std::process::Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success());
    let mut names = vec![("/dev/zero".to_string(), "character device")];
    if has_fifo {
        names.push((fifo.display().to_string(), "FIFO"));
    }
    for (fmu_name, variable) in
        [("AzimuthPlant", "parameter_file"), ("Structure", "modes_file"), ("Wind", "coefficient_file")]
    {
        let fmu = open(fmu_name);
        for (path, kind) in &names {
            let mut instance = fmu.instantiate("files", false).expect("instantiate");
            let vr = fmu.description.vr(variable).unwrap();
            let started = Instant::now();
            let error = instance.set_string(&[vr], &[path.as_str()]).err().map(|e| e.to_string());
            // The wind reads its coefficient file at initialisation.
            let error = error.or_else(|| instance.initialize(0.0, &[]).err().map(|e| e.to_string()));
            let error = error.unwrap_or_else(|| panic!("{fmu_name}: {variable} = {path} was accepted"));
            assert!(started.elapsed().as_secs_f64() < 1.0, "{fmu_name}: {path} took {:?}", started.elapsed());
            assert!(error.contains(kind) && error.contains("not a regular file"), "{fmu_name}: {path}: {error}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
