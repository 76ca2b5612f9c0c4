//! The validate tool on the real KUKA robot drive (tests/data/measured/kuka-robot-drive/, shipped
//! with the repository): what it finds there was not put there by anyone here, so these tests
//! guard the tool against data nobody simulated.
//!
//! The equation-error route only (no plant FMU needed): friction must be found on every axis,
//! and the two encoders' timing skew (the load encoder read about 3 ms after the motor
//! encoder on all three axes, an effect the data's README does not declare) must be found,
//! corrected, and must explain most of the measured twist.

use antenna_validate::measured_log::MeasuredLog;
use antenna_validate::parameters::ParameterSet;
use antenna_validate::{validate, ValidateOptions};
use std::path::{Path, PathBuf};

fn kuka_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/measured/kuka-robot-drive")
}

fn validate_axis(dir: &Path, axis: usize) -> antenna_validate::Validation {
    let log = MeasuredLog::read(&dir.join(format!("axis{axis}.csv"))).unwrap();
    let params =
        ParameterSet::read(&Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("data/kuka/axis{axis}.params")))
            .unwrap();
    validate(&log, &params, &ValidateOptions::default()).unwrap()
}

#[test]
fn the_load_encoders_three_millisecond_lag_is_found_and_corrected_on_every_axis() {
    let dir = kuka_dir();
    for axis in 1..=3 {
        let v = validate_axis(&dir, axis);
        let skew = v.encoder_skew.unwrap_or_else(|| panic!("axis {axis}: no encoder skew found"));
        assert!((2.7e-3..3.4e-3).contains(&skew), "axis {axis}: skew {skew}");
        let twist = v.twist.as_ref().unwrap();
        assert!(
            twist.rms_after < 0.2 * twist.rms_before,
            "axis {axis}: twist {} -> {}",
            twist.rms_before,
            twist.rms_after
        );
        assert!(
            v.notes.iter().enumerate().all(|(i, n)| !v.notes[..i].contains(n)),
            "axis {axis}: a note given twice: {:?}",
            v.notes
        );
        assert!(
            v.notes.iter().any(|n| n.contains("load encoder's angle")
                && n.contains("behind the motor encoder's")
                && n.contains("validated again")),
            "axis {axis}: {:?}",
            v.notes
        );
    }
}

#[test]
fn friction_is_found_on_every_axis() {
    let dir = kuka_dir();
    for axis in 1..=3 {
        let v = validate_axis(&dir, axis);
        let names: Vec<&str> = v.selection.found.iter().map(|f| f.kind.name()).collect();
        assert!(
            names.iter().any(|n| ["coulomb", "viscous", "stribeck", "asymmetry"].contains(n)),
            "axis {axis}: found {names:?}"
        );
    }
}
