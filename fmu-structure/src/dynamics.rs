//! The modal structure in time: each mode a damped oscillator stepped with its exact
//! zero-order-hold solution (`lti::zoh`), so that a run with piecewise-constant loads gives the
//! same beam offsets at any communication step that resolves the loads' changes.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::modes::{Mode, LOADS};

/// Radians to arcseconds.
pub const ARCSEC_PER_RAD: f64 = 180.0 / std::f64::consts::PI * 3600.0;

/// One mode's zero-order-hold step over a given step size: `x <- ad x + bd m`, with
/// `x = (q, q')` and `m` the modal load over the stiffness (the static coordinate).
#[derive(Debug, Clone, Copy, PartialEq)]
struct ModeStep {
    ad: [[f64; 2]; 2],
    bd: [f64; 2],
}

impl ModeStep {
    fn new(mode: &Mode, step: f64) -> ModeStep {
        let w = mode.omega();
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -w * w, -2.0 * mode.damping_ratio * w]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, w * w]);
        let (ad, bd) = lti::zoh(&a, &b, step);
        ModeStep { ad: [[ad[(0, 0)], ad[(0, 1)]], [ad[(1, 0)], ad[(1, 1)]]], bd: [bd[(0, 0)], bd[(1, 0)]] }
    }

    fn apply(&self, x: [f64; 2], static_coordinate: f64) -> [f64; 2] {
        [
            self.ad[0][0] * x[0] + self.ad[0][1] * x[1] + self.bd[0] * static_coordinate,
            self.ad[1][0] * x[0] + self.ad[1][1] * x[1] + self.bd[1] * static_coordinate,
        ]
    }
}

/// The modes and their coordinates and velocities.
#[derive(Debug, Clone)]
pub struct ModalStructure {
    modes: Vec<Mode>,
    /// `(q, q')` of each mode.
    states: Vec<[f64; 2]>,
    /// The axes' speeds (rad/s) at the start of the previous step and its length, s: the
    /// acceleration over it is the difference of the speeds over the length.
    previous_speeds: Option<([f64; 2], f64)>,
    /// The axes' accelerations held over the current step, rad/s^2.
    accelerations: [f64; 2],
    /// The discretisation for the last step size (masters usually keep one): a cache, not state.
    cache: Option<(u64, Vec<ModeStep>)>,
    /// Scratch for the next step's modal states (not part of the state).
    next_states: Vec<[f64; 2]>,
}

/// The structure's part of an FMU state: every mode's coordinate and velocity, and what the
/// axes' accelerations are computed from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModalState {
    pub states: Vec<[f64; 2]>,
    pub previous_speeds: Option<([f64; 2], f64)>,
    pub accelerations: [f64; 2],
}

impl ModalStructure {
    /// The structure at rest in the static deflection under `loads`.
    pub fn at_rest(modes: Vec<Mode>, loads: &[f64; LOADS]) -> ModalStructure {
        let states = modes.iter().map(|m| [m.static_coordinate(loads), 0.0]).collect();
        ModalStructure {
            modes,
            states,
            previous_speeds: None,
            accelerations: [0.0; 2],
            cache: None,
            next_states: Vec::new(),
        }
    }

    pub fn modes(&self) -> &[Mode] {
        &self.modes
    }

    /// Advances by `step` seconds with the loads held constant. `speeds` are the axes' speeds
    /// (rad/s, azimuth and elevation) at the start of the step: the axes' accelerations held
    /// over it are their mean over the previous step (zero on the first step), whose inertial
    /// loads the modes feel as the drives swing the structure. A step whose result is not
    /// finite (loads far beyond any structure) changes nothing and is an error.
    pub fn step(&mut self, loads: &[f64; LOADS], speeds: &[f64; 2], step: f64) -> Result<(), String> {
        let key = step.to_bits();
        if self.cache.as_ref().is_none_or(|(k, _)| *k != key) {
            self.cache = Some((key, self.modes.iter().map(|m| ModeStep::new(m, step)).collect()));
        }
        let accelerations = match self.previous_speeds {
            Some((previous, length)) => [0, 1].map(|k| (speeds[k] - previous[k]) / length),
            None => [0.0; 2],
        };
        let (_, steps) = self.cache.as_ref().expect("filled above");
        // The new states go to a buffer kept between steps (no allocation per step) and replace
        // the old ones only when all are finite.
        let mut next = std::mem::take(&mut self.next_states);
        next.clear();
        next.extend(self.modes.iter().zip(steps).zip(&self.states).map(|((mode, s), x)| {
            s.apply(*x, mode.static_coordinate(loads) + mode.inertial_load(&accelerations) / mode.stiffness)
        }));
        if let Some(k) = next.iter().position(|x| !x.iter().all(|v| v.is_finite())) {
            self.next_states = next;
            return Err(format!(
                "mode {} of the structure left the finite numbers over a step of {step} s (loads {loads:?}); the state is unchanged",
                k + 1
            ));
        }
        self.next_states = std::mem::replace(&mut self.states, next);
        self.previous_speeds = Some((*speeds, step));
        self.accelerations = accelerations;
        Ok(())
    }

    /// The beam offset, rad (on-sky azimuth, elevation), from the modes' coordinates.
    pub fn beam_offset(&self) -> [f64; 2] {
        let mut offset = [0.0; 2];
        for (mode, x) in self.modes.iter().zip(&self.states) {
            offset[0] += mode.beam[0] * x[0];
            offset[1] += mode.beam[1] * x[0];
        }
        offset
    }

    /// The quasi-static beam offset, rad: where the beam would settle under `loads` and the
    /// accelerations of the current step held for ever.
    pub fn static_offset(&self, loads: &[f64; LOADS]) -> [f64; 2] {
        let mut offset = [0.0; 2];
        for mode in &self.modes {
            let q = mode.static_coordinate(loads) + mode.inertial_load(&self.accelerations) / mode.stiffness;
            offset[0] += mode.beam[0] * q;
            offset[1] += mode.beam[1] * q;
        }
        offset
    }

    pub fn save_state(&self) -> ModalState {
        ModalState {
            states: self.states.clone(),
            previous_speeds: self.previous_speeds,
            accelerations: self.accelerations,
        }
    }

    /// [`save_state`](Self::save_state) written over `state`, reusing its storage.
    pub fn save_state_into(&self, state: &mut ModalState) {
        state.states.clone_from(&self.states);
        state.previous_speeds = self.previous_speeds;
        state.accelerations = self.accelerations;
    }

    /// Restores a saved state into a structure with the same number of modes.
    pub fn load_state(&mut self, state: ModalState) -> Result<(), String> {
        if state.states.len() != self.modes.len() {
            return Err(format!("the state holds {} modes, the modes file {}", state.states.len(), self.modes.len()));
        }
        if !state.states.iter().flatten().all(|v| v.is_finite()) {
            return Err("the state holds a non-finite modal coordinate".into());
        }
        let speeds_finite =
            state.previous_speeds.is_none_or(|(v, h)| v.iter().all(|x| x.is_finite()) && h.is_finite() && h > 0.0);
        if !speeds_finite || !state.accelerations.iter().all(|a| a.is_finite()) {
            return Err("the state holds a non-finite axis speed, step or acceleration".into());
        }
        self.states = state.states;
        self.previous_speeds = state.previous_speeds;
        self.accelerations = state.accelerations;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mode(frequency_hz: f64, damping_ratio: f64) -> Mode {
        Mode {
            frequency_hz,
            damping_ratio,
            stiffness: 4e8,
            participation: [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            beam: [1.0, 0.0],
        }
    }

    #[test]
    fn a_constant_load_settles_at_load_over_stiffness() {
        let mut s = ModalStructure::at_rest(vec![mode(6.0, 0.015)], &[0.0; LOADS]);
        let loads = [1e4, 0.0, 0.0, 0.0, 0.0, 0.0];
        for _ in 0..30_000 {
            s.step(&loads, &[0.0; 2], 1e-3).unwrap();
        }
        let expected = 1e4 / 4e8;
        assert!((s.beam_offset()[0] / expected - 1.0).abs() < 1e-6, "{:?}", s.beam_offset());
        assert_eq!(s.static_offset(&loads)[0], expected);
    }

    #[test]
    fn a_constant_axis_acceleration_deflects_the_beam_by_minus_acceleration_over_omega_squared() {
        // The axis speeds up at 0.5 deg/s^2 (a slew's acceleration): the dish lags the gear by
        // a / w^2 once the ringing has decayed (1.5 % damping: tau = 1.8 s).
        let m = mode(6.0, 0.015);
        let mut s = ModalStructure::at_rest(vec![m.clone()], &[0.0; LOADS]);
        let (a, h) = (0.5_f64.to_radians(), 1e-3);
        for k in 0..30_000 {
            s.step(&[0.0; LOADS], &[a * k as f64 * h, 0.0], h).unwrap();
        }
        let expected = -a / (m.omega() * m.omega());
        assert!((s.beam_offset()[0] / expected - 1.0).abs() < 1e-6, "{} against {expected}", s.beam_offset()[0]);
        assert!((s.static_offset(&[0.0; LOADS])[0] / expected - 1.0).abs() < 1e-9);
        // Elevation speeds do not move an azimuth mode.
        let mut e = ModalStructure::at_rest(vec![m], &[0.0; LOADS]);
        for k in 0..1000 {
            e.step(&[0.0; LOADS], &[0.0, a * k as f64 * h], h).unwrap();
        }
        assert_eq!(e.beam_offset()[0], 0.0);
    }

    #[test]
    fn one_long_step_equals_many_short_ones() {
        let loads = [1e4, 0.0, 0.0, 0.0, 0.0, 0.0];
        let mut long = ModalStructure::at_rest(vec![mode(6.0, 0.015), mode(9.0, 0.02)], &[0.0; LOADS]);
        let mut short = long.clone();
        long.step(&loads, &[0.0; 2], 0.1).unwrap();
        for _ in 0..400 {
            short.step(&loads, &[0.0; 2], 0.25e-3).unwrap();
        }
        let (a, b) = (long.beam_offset()[0], short.beam_offset()[0]);
        assert!((a - b).abs() < 1e-12 * 1e4 / 4e8, "{a} against {b}");
    }

    #[test]
    fn the_free_oscillation_rings_at_the_damped_frequency_and_decays_at_zeta_omega() {
        let m = mode(6.0, 0.015);
        let mut s = ModalStructure::at_rest(vec![m.clone()], &[1e4, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let h = 1e-4;
        let mut previous = s.beam_offset()[0];
        let mut crossings = Vec::new();
        for k in 1..=20_000 {
            s.step(&[0.0; LOADS], &[0.0; 2], h).unwrap();
            let now = s.beam_offset()[0];
            if previous > 0.0 && now <= 0.0 {
                crossings.push(k as f64 * h - h * now / (now - previous));
            }
            previous = now;
        }
        let period = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
        let damped = m.frequency_hz * (1.0 - m.damping_ratio * m.damping_ratio).sqrt();
        assert!((1.0 / period / damped - 1.0).abs() < 1e-6, "period {period}");
    }

    #[test]
    fn a_state_saved_over_a_kept_one_equals_a_fresh_save() {
        let mut s = ModalStructure::at_rest(vec![mode(6.0, 0.015), mode(7.0, 0.02)], &[1e4, 2e4, 0.0, 0.0, 0.0, 0.0]);
        // Kept from a structure with one mode: the vector must be rewritten whole.
        let mut kept = ModalStructure::at_rest(vec![mode(5.0, 0.01)], &[0.0; LOADS]).save_state();
        for k in 0..10 {
            s.step(&[1e4 + 1e3 * k as f64, 2e4, 0.0, 0.0, 0.0, 0.0], &[1e-3 * k as f64, 0.0], 1e-3).unwrap();
            s.save_state_into(&mut kept);
            assert_eq!(kept, s.save_state(), "step {k}");
        }
    }

    #[test]
    fn a_state_with_another_mode_count_is_refused() {
        let mut s = ModalStructure::at_rest(vec![mode(6.0, 0.015)], &[0.0; LOADS]);
        let state = ModalState { states: vec![[0.0; 2]; 2], previous_speeds: None, accelerations: [0.0; 2] };
        let error = s.load_state(state).unwrap_err();
        assert!(error.contains("2 modes"), "{error}");
    }
}
