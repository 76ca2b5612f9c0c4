//! The figures the requirements are judged by, computed from a coupled run's trace.

use super::coupled::Trace;
use super::scenario::{JITTER_LIMIT_ARCSEC, JITTER_WINDOW_S, SETTLE_HOLD_S};
use crate::dsp;

/// Worst RMS pointing error over sliding windows of `JITTER_WINDOW_S`, from `from_s` on.
pub fn worst_window_jitter_arcsec(trace: &Trace, from_s: f64) -> Option<(f64, f64)> {
    let error = trace.pointing_error_arcsec();
    let start = trace.time_s.partition_point(|&t| t < from_s);
    let dt = trace.time_s.get(1).zip(trace.time_s.first()).map(|(b, a)| b - a)?;
    let window = (JITTER_WINDOW_S / dt).round() as usize;
    let worst = dsp::max_moving_rms(&error[start..], window)?;
    Some((worst.value, trace.time_s[start + worst.start]))
}

/// Settling after a command jump.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settling {
    /// When the controller's profiled reference reached the target (both axes), s.
    pub profile_arrival_s: f64,
    /// From then on, the error stays within the band for the hold time, s.
    pub settled_at_s: f64,
    /// `settled_at_s - profile_arrival_s`: the settling time.
    pub after_profile_s: f64,
    /// `settled_at_s - jump_s`: the time from the command.
    pub after_command_s: f64,
    /// Largest error after the profile arrived, arcsec (overshoot and ringing).
    pub peak_error_after_arrival_arcsec: f64,
}

/// The settling figures, or `None` if the run never settles (the error does not stay in the
/// band for the hold time before the run ends).
pub fn settling(trace: &Trace, jump_s: f64, target: (f64, f64)) -> Option<Settling> {
    let error = trace.pointing_error_arcsec();
    let n = trace.time_s.len();
    let arrival = (0..n).find(|&k| {
        trace.time_s[k] >= jump_s
            && (trace.reference_azimuth_deg[k] - target.0).abs() < 1e-5
            && (trace.reference_elevation_deg[k] - target.1).abs() < 1e-5
    })?;
    let dt = trace.time_s[1] - trace.time_s[0];
    let hold = (SETTLE_HOLD_S / dt).round() as usize;
    // The settling instant: the start of the first stretch, at or after arrival, in which the
    // error stays in the band for the whole hold time.
    let mut candidate = arrival;
    let mut k = arrival;
    while k < n {
        if error[k] > JITTER_LIMIT_ARCSEC {
            candidate = k + 1;
        } else if k + 1 - candidate >= hold {
            break;
        }
        k += 1;
    }
    if k >= n {
        return None;
    }
    let peak = error[arrival..].iter().cloned().fold(0.0, f64::max);
    let settled = trace.time_s[candidate];
    Some(Settling {
        profile_arrival_s: trace.time_s[arrival],
        settled_at_s: settled,
        after_profile_s: settled - trace.time_s[arrival],
        after_command_s: settled - jump_s,
        peak_error_after_arrival_arcsec: peak,
    })
}
