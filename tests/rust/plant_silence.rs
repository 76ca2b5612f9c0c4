//! An FMU must never write to stdout or stderr: a master owns its console, and messages belong
//! to the logger callback. This test re-runs its own binary as a child process that drives
//! every packaged FMU through a misuse sequence with all log categories on (wrong GUID, calls
//! in the wrong phase, NaN inputs, unknown value references, bad steps, printf directives in
//! strings the FMU echoes back, corrupt states), checks that each error was reported through
//! the logger, and prints nothing itself. The parent asserts that the child's captured stdout
//! and stderr are empty. It is a plain `main` (harness = false) because the libtest harness
//! prints to stdout.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

use fmi2_ffi::Status;
use fmu_import::{Fmu, ImportError, Instance};

const CHILD: &str = "ANTENNA_TESTS_SILENCE_CHILD";
const REPORT: &str = "ANTENNA_TESTS_SILENCE_REPORT";

fn main() -> ExitCode {
    if std::env::var_os(CHILD).is_some() {
        return child();
    }
    let fmus = antenna_tests::packaged_fmus();
    let report = std::env::temp_dir().join(format!("antenna-silence-{}.txt", std::process::id()));
    let output = Command::new(std::env::current_exe().expect("own path"))
        .env(CHILD, "1")
        .env(REPORT, &report)
        // A panic inside an FMU must not print either, whatever the environment asks for.
        .env("RUST_BACKTRACE", "full")
        .output()
        .expect("cannot run the child process");
    let summary = std::fs::read_to_string(&report).unwrap_or_default();
    let _ = std::fs::remove_file(&report);
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    let mut failed = false;
    if !output.status.success() {
        eprintln!("plant_silence: the child failed ({}): {summary}", output.status);
        failed = true;
    }
    if !stdout.is_empty() {
        eprintln!("plant_silence: the FMUs wrote to stdout:\n{stdout}");
        failed = true;
    }
    if !stderr.is_empty() {
        eprintln!("plant_silence: the FMUs wrote to stderr:\n{stderr}");
        failed = true;
    }
    if failed {
        return ExitCode::FAILURE;
    }
    println!("plant_silence: {} FMUs, nothing on stdout or stderr; {summary}", fmus.len());
    ExitCode::SUCCESS
}

/// The misuse sequence. Prints nothing: failures are reported through the exit code and the
/// report file.
fn child() -> ExitCode {
    let report = PathBuf::from(std::env::var_os(REPORT).expect("report path"));
    let mut errors = 0usize;
    let mut messages = 0usize;
    for path in antenna_tests::packaged_fmus() {
        match misuse(&path) {
            Ok((e, m)) => {
                errors += e;
                messages += m;
            }
            Err(why) => {
                let _ = std::fs::write(&report, format!("{}: {why}", path.display()));
                return ExitCode::from(3);
            }
        }
    }
    let _ = std::fs::write(
        &report,
        format!("{errors} deliberate errors, {messages} messages, all through the logger callback"),
    );
    ExitCode::SUCCESS
}

/// Counts an expected fmi2Error and checks the FMU logged why.
fn expect_error<T>(
    result: Result<T, ImportError>,
    instance: &Instance,
    what: &str,
    errors: &mut usize,
) -> Result<(), String> {
    match result {
        Err(ImportError::Call { status: Status::Error, messages, .. }) if !messages.is_empty() => {
            if !instance.log_records().iter().any(|r| r.status == Status::Error) {
                return Err(format!("{what}: no error record in the log"));
            }
            *errors += 1;
            Ok(())
        }
        Err(e) => Err(format!("{what}: expected fmi2Error with a message, got {e}")),
        Ok(_) => Err(format!("{what}: expected fmi2Error, the call succeeded")),
    }
}

/// An instance with every log category on (including the per-call trace), set up and ready.
fn verbose(fmu: &Fmu, name: &str) -> Result<Instance, String> {
    let mut instance = fmu.instantiate(name, true).map_err(|e| e.to_string())?;
    instance.set_debug_logging(true, &[]).map_err(|e| e.to_string())?;
    Ok(instance)
}

fn misuse(path: &Path) -> Result<(usize, usize), String> {
    let fmu = Fmu::open(path).map_err(|e| e.to_string())?;
    let md = fmu.description.clone();
    let mut errors = 0;
    let mut messages = 0;

    // A wrong GUID: NULL with a message, nothing printed.
    match fmu.instantiate_with("%s%n wrong guid", "{not-this-fmu}", true, false) {
        Err(ImportError::Instantiate { messages: m }) if !m.is_empty() => {
            errors += 1;
            messages += m.len();
        }
        Err(e) => return Err(format!("wrong GUID: {e}")),
        Ok(_) => return Err("wrong GUID accepted".into()),
    }

    // The instance name and every string the FMU echoes in messages carry printf directives:
    // the FMU must escape them for the variadic logger.
    let mut instance = verbose(&fmu, "%s%s%n%p instance")?;
    expect_error(instance.do_step(0.0, 1e-3), &instance, "DoStep before initialisation", &mut errors)?;
    messages += instance.take_log().len();

    let mut instance = verbose(&fmu, "unknown category")?;
    expect_error(
        instance.set_debug_logging(true, &["%s%n no such category"]),
        &instance,
        "unknown log category",
        &mut errors,
    )?;
    messages += instance.take_log().len();

    let first_input =
        md.variables.iter().find(|v| v.causality == "input" && v.type_name == "Real").map(|v| v.value_reference);
    let parameter_file = md.vr("parameter_file").ok();

    if let Some(vr) = parameter_file {
        let mut instance = verbose(&fmu, "bad file")?;
        instance.setup_experiment(0.0, None).map_err(|e| e.to_string())?;
        instance.enter_initialization_mode().map_err(|e| e.to_string())?;
        expect_error(
            instance.set_string(&[vr], &["%s%s%n%x.params"]),
            &instance,
            "parameter file with printf directives",
            &mut errors,
        )?;
        messages += instance.take_log().len();
    }

    let mut instance = verbose(&fmu, "stepping")?;
    instance.initialize(0.0, &[]).map_err(|e| e.to_string())?;
    for k in 0..50 {
        instance.do_step(k as f64 * 1e-3, 1e-3).map_err(|e| e.to_string())?;
    }
    let state = instance.get_state().map_err(|e| e.to_string())?;
    let bytes = instance.serialize_state(&state).map_err(|e| e.to_string())?;
    expect_error(instance.deserialize_state(&bytes[..bytes.len() / 3]), &instance, "corrupt state", &mut errors)?;
    messages += instance.take_log().len();

    let unknown = md.variables.iter().map(|v| v.value_reference).max().unwrap_or(0) + 1;
    let mut instance = verbose(&fmu, "unknown vr")?;
    instance.initialize(0.0, &[]).map_err(|e| e.to_string())?;
    let mut value = [0.0];
    expect_error(instance.get_real(&[unknown], &mut value), &instance, "unknown value reference", &mut errors)?;
    messages += instance.take_log().len();

    if let Some(vr) = first_input {
        let mut instance = verbose(&fmu, "nan input")?;
        instance.initialize(0.0, &[]).map_err(|e| e.to_string())?;
        expect_error(instance.set_real(&[vr], &[f64::NAN]), &instance, "NaN input", &mut errors)?;
        messages += instance.take_log().len();
    }

    for (point, step, what) in [(0.0, -1e-3, "negative step"), (0.25, 1e-3, "wrong communication point")] {
        let mut instance = verbose(&fmu, what)?;
        instance.initialize(0.0, &[]).map_err(|e| e.to_string())?;
        expect_error(instance.do_step(point, step), &instance, what, &mut errors)?;
        messages += instance.take_log().len();
    }

    let mut instance = verbose(&fmu, "terminate twice")?;
    instance.initialize(0.0, &[]).map_err(|e| e.to_string())?;
    instance.terminate().map_err(|e| e.to_string())?;
    expect_error(instance.terminate(), &instance, "second Terminate", &mut errors)?;
    expect_error(instance.do_step(0.0, 1e-3), &instance, "DoStep after Terminate", &mut errors)?;
    instance.reset().map_err(|e| e.to_string())?;
    messages += instance.take_log().len();
    Ok((errors, messages))
}
