//! The tools are as strict with what a user hands them as the FMUs are with a master: every
//! hostile input ends quickly in exit code 2 with a message that names the option or the file,
//! never in a panic, a hang or an allocation that takes the machine down.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// How long a refusal may take: reading the arguments and the head of a file.
const QUICK: Duration = Duration::from_secs(20);

/// A scratch folder of this test process.
fn scratch() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hostile-inputs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs `program` with `args`, kills it after [`QUICK`], and asserts exit code 2, a message on
/// stderr containing `expected`, and no panic.
fn refused(program: &str, args: &[&str], expected: &str) {
    let started = Instant::now();
    let mut child = Command::new(program)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start {program}: {e}"));
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if started.elapsed() > QUICK {
            child.kill().ok();
            panic!("{program} {args:?} still ran after {QUICK:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{program} {args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{program} {args:?} panicked: {stderr}");
    assert!(stderr.contains(expected), "{program} {args:?}: the message does not say `{expected}`: {stderr}");
}

fn antenna() -> &'static str {
    env!("CARGO_BIN_EXE_antenna")
}

fn validate() -> &'static str {
    env!("CARGO_BIN_EXE_validate")
}

/// A FIFO nobody writes to: opening it for reading would block for ever.
fn fifo(dir: &Path) -> String {
    let path = dir.join("fifo");
    let _ = std::fs::remove_file(&path);
    let status = Command::new("mkfifo").arg(&path).status().expect("mkfifo");
    assert!(status.success());
    path.display().to_string()
}

/// The first rows of the shipped KUKA log, with `edit` applied to each data row (index, row).
fn log_with(dir: &Path, name: &str, edit: impl Fn(usize, &str) -> String) -> String {
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/measured/kuka-robot-drive/axis1.csv");
    let text = std::fs::read_to_string(source).unwrap();
    let mut lines = text.lines();
    let mut out = format!("{}\n", lines.next().unwrap());
    for (i, row) in lines.take(600).enumerate() {
        out.push_str(&edit(i, row));
        out.push('\n');
    }
    let path = dir.join(name);
    std::fs::write(&path, out).unwrap();
    path.display().to_string()
}

#[test]
fn files_that_are_no_regular_files_are_refused_without_blocking() {
    let dir = scratch();
    let fifo = fifo(&dir);
    let folder = dir.display().to_string();
    let log = log_with(&dir, "plain.csv", |_, row| row.to_string());
    for hostile in [fifo.as_str(), "/dev/zero", folder.as_str()] {
        refused(antenna(), &["--no-build", "--commands", hostile], "not a regular file");
        refused(validate(), &["run", hostile, "--params", "/dev/null", "--no-fmu"], "not a regular file");
        refused(validate(), &["run", &log, "--params", hostile, "--no-fmu"], "not a regular file");
        refused(
            antenna(),
            &["sweep", "--sweep-file", hostile, "--samples", "1", "--out", &folder],
            "not a regular file",
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_command_table_too_long_to_keep_is_refused_before_anything_is_reserved() {
    let dir = scratch().join("commands");
    std::fs::create_dir_all(&dir).unwrap();
    for end in ["1e308", "1e7"] {
        let path = dir.join(format!("end-{end}.csv"));
        std::fs::write(&path, format!("time_s,azimuth_deg,elevation_deg\n0,30,45\n{end},30,45\n")).unwrap();
        refused(antenna(), &["--no-build", "--commands", path.to_str().unwrap()], "a run spans at most");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn numeric_options_out_of_their_range_are_refused_naming_the_option() {
    let dir = scratch();
    let log = log_with(&dir, "options.csv", |_, row| row.to_string());
    for (option, value) in [
        ("--window", "0"),
        ("--window", "-1"),
        ("--window", "NaN"),
        ("--window", "1e308"),
        ("--alpha", "2"),
        ("--alpha", "0"),
        ("--alpha", "NaN"),
        ("--min-effect-to-noise", "-3"),
        ("--drive-window", "inf"),
    ] {
        let argument = format!("{option}={value}");
        refused(validate(), &["run", &log, "--params", "/dev/null", "--no-fmu", &argument], option);
    }
}

#[test]
fn logs_with_absurd_values_or_sample_times_are_refused_naming_the_column() {
    let dir = scratch();
    let huge = log_with(&dir, "huge.csv", |i, row| {
        if i == 100 {
            format!("{},1e300", row.rsplit_once(',').unwrap().0)
        } else {
            row.to_string()
        }
    });
    refused(validate(), &["run", &huge, "--params", "/dev/null", "--no-fmu"], "motor_torque_Nm");
    let spread =
        log_with(&dir, "spread.csv", |i, row| format!("{:e},{}", i as f64 * 1e300, row.split_once(',').unwrap().1));
    refused(validate(), &["run", &spread, "--params", "/dev/null", "--no-fmu"], "sample interval");
}

#[test]
fn a_pointing_model_table_that_is_no_regular_file_or_malformed_is_refused_naming_what_is_wrong() {
    let dir = scratch().join("pointing-model");
    std::fs::create_dir_all(&dir).unwrap();
    let fifo = fifo(&dir);
    let folder = dir.display().to_string();
    for hostile in [fifo.as_str(), "/dev/zero", folder.as_str()] {
        refused(antenna(), &["--no-build", "--pointing-model", hostile], "not a regular file");
    }
    let header =
        "term,azimuth_deg,elevation_deg,wind_speed_m_s,wind_direction_relative_deg,cross_elevation_error_arcsec";
    let path = dir.join("no-elevation-column.csv");
    std::fs::write(&path, format!("{header}\nencoder,0,15,,,1.0\n")).unwrap();
    refused(
        antenna(),
        &["--no-build", "--pointing-model", path.to_str().unwrap()],
        "missing column `elevation_error_arcsec`",
    );
    std::fs::remove_dir_all(&dir).ok();
}
