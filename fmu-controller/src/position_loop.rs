//! The position loop: proportional control of the axis encoder position (optionally with a
//! small integral term) plus the velocity feedforward, limited in velocity and in acceleration,
//! and the anti-limit-cycle hold that freezes the integrators once the axis has stuck near a
//! stationary target.
//!
//! The acceleration limit is a rate limiter on the velocity reference. Its state is also used
//! by velocity mode, so that switching between the modes never makes the velocity reference
//! jump.

use serde::{Deserialize, Serialize};

use crate::params::{AntiLimitCycleParams, PositionLoopParams};

/// A change of the held reference larger than this ends the anti-limit-cycle hold, rad: 1e-3
/// arcsec, a fortieth of a 25-bit encoder count, and 1e8 times the rounding noise of a constant
/// command formed by interpolation.
pub const REFERENCE_CHANGE_RAD: f64 = 1e-3 / 3600.0 * std::f64::consts::PI / 180.0;

/// What the position loop hands to the velocity loop, axis units.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PositionLoopOutput {
    /// Velocity reference after the limits, rad/s.
    pub velocity_reference: f64,
    /// True when the velocity or acceleration limit changed the reference.
    pub limited: bool,
    /// True while the anti-limit-cycle hold freezes the integrators.
    pub holding: bool,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Settings {
    sample_time: f64,
    proportional_gain: f64,
    integral_gain: f64,
    integrator_enabled: bool,
    max_velocity: f64,
    max_velocity_change: f64,
    anti_limit_cycle: bool,
    hold_entry: f64,
    hold_release: f64,
    hold_motion_band: f64,
    /// Samples at rest needed before the hold engages.
    rest_samples: u64,
}

/// See the module documentation.
#[derive(Debug, Clone, PartialEq)]
pub struct PositionLoop {
    settings: Settings,
    /// Integral term, rad/s.
    integral: f64,
    /// Velocity reference of the previous sample, the rate limiter's state, rad/s.
    previous_velocity_reference: f64,
    holding: bool,
    /// The reference position when the hold began, rad.
    held_reference: f64,
    /// The measured position when the hold began, rad.
    held_measured: f64,
    /// Consecutive samples the axis has been at rest.
    samples_at_rest: u64,
}

impl PositionLoop {
    pub fn new(params: &PositionLoopParams, anti_limit_cycle: &AntiLimitCycleParams, sample_time_s: f64) -> Self {
        let proportional_gain =
            params.proportional_gain_override_per_s.unwrap_or(std::f64::consts::TAU * params.bandwidth_hz);
        let settings = Settings {
            sample_time: sample_time_s,
            proportional_gain,
            integral_gain: proportional_gain * std::f64::consts::TAU * params.integral_corner_hz,
            integrator_enabled: params.integrator_enabled,
            max_velocity: params.max_velocity_deg_per_s.to_radians(),
            max_velocity_change: params.max_acceleration_deg_per_s2.to_radians() * sample_time_s,
            anti_limit_cycle: anti_limit_cycle.enabled,
            hold_entry: anti_limit_cycle.hold_entry_error_deg.to_radians(),
            hold_release: anti_limit_cycle.hold_release_error_deg.to_radians(),
            hold_motion_band: anti_limit_cycle.hold_motion_band_deg.to_radians(),
            rest_samples: (anti_limit_cycle.rest_time_s / sample_time_s).round().max(1.0) as u64,
        };
        Self {
            settings,
            integral: 0.0,
            previous_velocity_reference: 0.0,
            holding: false,
            held_reference: 0.0,
            held_measured: 0.0,
            samples_at_rest: 0,
        }
    }

    /// Proportional gain, 1/s.
    pub fn proportional_gain(&self) -> f64 {
        self.settings.proportional_gain
    }

    /// Integral gain, 1/s^2 (0 when the integrator is off).
    pub fn integral_gain(&self) -> f64 {
        if self.settings.integrator_enabled {
            self.settings.integral_gain
        } else {
            0.0
        }
    }

    /// Restarts at a mode change: the rate limiter continues from `velocity_reference` (rad/s)
    /// and the integral and hold start afresh.
    pub fn restart(&mut self, velocity_reference: f64) {
        self.previous_velocity_reference = velocity_reference;
        self.integral = 0.0;
        self.holding = false;
    }

    /// The last velocity reference, rad/s.
    pub fn velocity_reference(&self) -> f64 {
        self.previous_velocity_reference
    }

    /// One sample of the position loop. `reference` and `measured` are the reference and
    /// encoder positions (rad), `feedforward_velocity` the velocity feedforward (rad/s, 0 when
    /// switched off), `stationary` whether the command is at rest (the hold is only allowed
    /// then), `at_rest` whether the axis has stopped, and `integrate` whether the integral may
    /// run (not while a profile runs).
    pub fn update(
        &mut self,
        reference: f64,
        measured: f64,
        feedforward_velocity: f64,
        stationary: bool,
        at_rest: bool,
        integrate: bool,
    ) -> PositionLoopOutput {
        let s = self.settings;
        let error = reference - measured;
        self.samples_at_rest = if at_rest { self.samples_at_rest.saturating_add(1) } else { 0 };
        if s.anti_limit_cycle && stationary {
            if self.holding {
                // A new command ends the hold: the operator wants to move. "New" means moved by
                // more than REFERENCE_CHANGE_RAD, far below any encoder count, so that rounding
                // in how a master forms a constant command cannot end (and re-arm) the hold.
                // An axis that moves while held is pushed (by wind), not stuck: it needs its
                // integrators back, before the error reaches the release level.
                self.holding = error.abs() <= s.hold_release
                    && (reference - self.held_reference).abs() <= REFERENCE_CHANGE_RAD
                    && (measured - self.held_measured).abs() <= s.hold_motion_band;
            } else if self.samples_at_rest >= s.rest_samples && error.abs() < s.hold_entry {
                // Only an axis that has actually stuck near the target is held: while it still
                // moves, the integrators help it converge.
                self.holding = true;
                self.held_reference = reference;
                self.held_measured = measured;
            }
        } else {
            self.holding = false;
        }
        let integral = if s.integrator_enabled { self.integral } else { 0.0 };
        let wanted = feedforward_velocity + s.proportional_gain * error + integral;
        let velocity_reference = self.limit(wanted);
        let limited = velocity_reference != wanted;
        // Conditional integration: an integral that keeps growing while the limits hold the
        // reference back would only have to be unwound afterwards, as overshoot.
        if s.integrator_enabled && integrate && !limited && !self.holding {
            self.integral += s.integral_gain * error * s.sample_time;
        }
        PositionLoopOutput { velocity_reference, limited, holding: self.holding }
    }

    /// Applies the velocity and acceleration limits to a wanted velocity reference (rad/s) and
    /// advances the rate limiter; velocity mode uses this directly.
    pub fn limit(&mut self, wanted: f64) -> f64 {
        let s = &self.settings;
        let clamped = wanted.clamp(-s.max_velocity, s.max_velocity);
        let change = (clamped - self.previous_velocity_reference).clamp(-s.max_velocity_change, s.max_velocity_change);
        self.previous_velocity_reference += change;
        self.previous_velocity_reference
    }

    /// Applies only the velocity limit and moves the rate limiter along with it, for velocity
    /// mode without acceleration limiting.
    pub fn limit_velocity_only(&mut self, wanted: f64) -> f64 {
        let s = &self.settings;
        self.previous_velocity_reference = wanted.clamp(-s.max_velocity, s.max_velocity);
        self.previous_velocity_reference
    }

    pub(crate) fn saved_state(&self) -> PositionLoopState {
        PositionLoopState {
            integral: self.integral,
            previous_velocity_reference: self.previous_velocity_reference,
            holding: self.holding,
            held_reference: self.held_reference,
            held_measured: self.held_measured,
            samples_at_rest: self.samples_at_rest,
        }
    }

    pub(crate) fn restore(&mut self, state: PositionLoopState) {
        let PositionLoopState {
            integral,
            previous_velocity_reference,
            holding,
            held_reference,
            held_measured,
            samples_at_rest,
        } = state;
        self.integral = integral;
        self.previous_velocity_reference = previous_velocity_reference;
        self.holding = holding;
        self.held_reference = held_reference;
        self.held_measured = held_measured;
        self.samples_at_rest = samples_at_rest;
    }
}

/// What an FMU state holds of a [`PositionLoop`] (the fields are the loop's, same units).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PositionLoopState {
    pub integral: f64,
    pub previous_velocity_reference: f64,
    pub holding: bool,
    pub held_reference: f64,
    pub held_measured: f64,
    pub samples_at_rest: u64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::{AzimuthControllerParams, ARCSEC_DEG};

    const TS: f64 = 1e-3;

    fn loop_with(integrator: bool, alc: bool) -> PositionLoop {
        let p = AzimuthControllerParams::default().cascade;
        let pl = PositionLoopParams { integrator_enabled: integrator, ..p.position_loop };
        // One sample at rest is enough here; the rest time has its own test.
        let a = AntiLimitCycleParams { enabled: alc, rest_time_s: 0.0, ..p.anti_limit_cycle };
        PositionLoop::new(&pl, &a, TS)
    }

    #[test]
    fn small_error_gives_proportional_velocity_plus_feedforward() {
        let mut l = loop_with(false, false);
        let kp = l.proportional_gain();
        assert!((kp - std::f64::consts::TAU * 0.75).abs() < 1e-12);
        l.restart(1e-4);
        let out = l.update(1e-6, 0.0, 1e-4, false, false, true);
        assert!(!out.limited);
        assert!((out.velocity_reference - (1e-4 + kp * 1e-6)).abs() < 1e-18);
    }

    #[test]
    fn velocity_reference_respects_speed_and_acceleration_limits() {
        let params = AzimuthControllerParams::default().cascade.position_loop;
        let mut l = loop_with(false, false);
        let v_max = params.max_velocity_deg_per_s.to_radians();
        let dv_max = params.max_acceleration_deg_per_s2.to_radians() * TS;
        let mut previous = 0.0;
        for _ in 0..5000 {
            let out = l.update(1.0, 0.0, 0.0, false, false, true);
            assert!(out.velocity_reference.abs() <= v_max * (1.0 + 1e-12));
            assert!((out.velocity_reference - previous).abs() <= dv_max * (1.0 + 1e-9));
            previous = out.velocity_reference;
        }
        assert!((previous - v_max).abs() < 1e-12, "should reach the velocity limit");
    }

    #[test]
    fn integral_does_not_wind_up_while_limited() {
        let mut l = loop_with(true, false);
        for _ in 0..10_000 {
            l.update(1.0, 0.0, 0.0, false, false, true);
        }
        assert_eq!(l.integral, 0.0, "the large error kept the reference limited throughout");
        // The rate limiter needs about a second to bring the reference down from the velocity
        // limit; integration resumes once it no longer limits.
        for _ in 0..3000 {
            l.update(1e-5, 0.0, 0.0, false, false, true);
        }
        assert!(l.integral > 0.0, "a small error is integrated");
    }

    #[test]
    fn hold_waits_until_the_axis_has_been_at_rest_for_the_rest_time() {
        let p = AzimuthControllerParams::default().cascade;
        let mut l = PositionLoop::new(&p.position_loop, &p.anti_limit_cycle, TS);
        let samples = (p.anti_limit_cycle.rest_time_s / TS).round() as usize;
        // A speed signal that dips below the rest speed now and then (noise, or an axis the
        // wind swings through zero speed) never engages the hold.
        for k in 0..10 * samples {
            assert!(!l.update(0.0, 0.0, 0.0, true, k % 50 != 0, true).holding, "sample {k}");
        }
        assert!(!l.update(0.0, 0.0, 0.0, true, false, true).holding);
        for _ in 1..samples {
            assert!(!l.update(0.0, 0.0, 0.0, true, true, true).holding);
        }
        assert!(l.update(0.0, 0.0, 0.0, true, true, true).holding, "stuck for the rest time: held");
    }

    #[test]
    fn hold_needs_a_stuck_axis_has_hysteresis_and_only_acts_on_a_stationary_command() {
        // The hysteresis alone: a motion band wider than the release level.
        let p = AzimuthControllerParams::default().cascade;
        let wide = AntiLimitCycleParams { hold_motion_band_deg: 1.0, rest_time_s: 0.0, ..p.anti_limit_cycle };
        let mut l = PositionLoop::new(&p.position_loop, &wide, TS);
        let entry = (2.0 * ARCSEC_DEG).to_radians();
        let release = (4.0 * ARCSEC_DEG).to_radians();
        assert!(!l.update(0.0, -(0.9 * entry), 0.0, false, true, true).holding, "moving command: no hold");
        assert!(!l.update(0.0, -(0.9 * entry), 0.0, true, false, true).holding, "axis still moving: no hold");
        assert!(l.update(0.0, -(0.9 * entry), 0.0, true, true, true).holding);
        assert!(
            l.update(0.0, -(1.5 * entry), 0.0, true, false, true).holding,
            "inside the hysteresis band, even moving"
        );
        assert!(l.update(0.0, -(0.99 * release), 0.0, true, true, true).holding);
        assert!(!l.update(0.0, -(1.01 * release), 0.0, true, true, true).holding, "released beyond the band");
        assert!(!l.update(0.0, -(1.01 * entry), 0.0, true, true, true).holding, "must come back below entry first");
        assert!(!l.update(0.0, 0.0, 0.0, false, true, true).holding, "a moving command ends the hold");
        assert!(l.update(0.0, 0.0, 0.0, true, true, true).holding);
        assert!(l.update(1e-15, 0.0, 0.0, true, true, true).holding, "rounding noise is not a new command");
        // The motion band: a held axis that is pushed away is released before the error
        // reaches the release level.
        let mut l = loop_with(false, true);
        assert!(l.update(0.0, 0.0, 0.0, true, true, true).holding);
        let band = AzimuthControllerParams::default().cascade.anti_limit_cycle.hold_motion_band_deg.to_radians();
        assert!(l.update(1e-15, -(0.9 * band), 0.0, true, false, true).holding, "moved within the band: still held");
        assert!(!l.update(1e-15, -(1.1 * band), 0.0, true, false, true).holding, "pushed beyond the band: released");
        assert!(l.update(1e-15, -(1.1 * band), 0.0, true, true, true).holding, "stuck again: held again");
        assert!(!l.update(1e-8, 0.0, 0.0, true, true, true).holding, "a new command ends the hold");
        let mut off = loop_with(false, false);
        assert!(!off.update(0.0, 0.0, 0.0, true, true, true).holding, "switched off: never holds");
    }
}
