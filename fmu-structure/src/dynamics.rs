//! The modal structure in time: each mode a damped oscillator stepped with its exact
//! zero-order-hold solution (`lti::zoh`), so that a run with piecewise-constant loads gives the
//! same beam offsets at any communication step that resolves the loads' changes; and the torque
//! the modes pass to the drives, for a master that couples them both ways.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::modes::{Mode, LOADS};

/// Why the modal structure refuses a step or a saved state.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StructureError {
    /// A step whose modal coordinates came out NaN or infinite; nothing changed.
    #[error("mode {mode} of the structure left the finite numbers over a step of {step} s (loads {loads:?}); the state is unchanged")]
    NonFiniteStep { mode: usize, step: f64, loads: [f64; LOADS] },
    #[error("the state holds {state} modes, the modes file {modes}")]
    ModeCount { state: usize, modes: usize },
    #[error("the state holds a non-finite modal coordinate")]
    NonFiniteCoordinate,
    #[error("the state holds a non-finite axis speed, step or acceleration")]
    NonFiniteMotion,
}

/// Radians to arcseconds.
pub const ARCSEC_PER_RAD: f64 = 180.0 / std::f64::consts::PI * 3600.0;

/// One mode's zero-order-hold step over a given step size: `x <- ad x + bd m`, with
/// `x = (q, q')` and `m` the modal load over the stiffness (the static coordinate); and the
/// mean of `x` over the step, `mean_ad x + mean_bd m`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ModeStep {
    ad: [[f64; 2]; 2],
    bd: [f64; 2],
    mean_ad: [[f64; 2]; 2],
    mean_bd: [f64; 2],
}

impl ModeStep {
    fn new(mode: &Mode, step: f64) -> ModeStep {
        let w = mode.omega();
        // The mode's two states and their integrals over the step, in one exponential: the
        // integrals' rows of the discretised system are the mean state times the step.
        #[rustfmt::skip]
        let a = DMatrix::from_row_slice(4, 4, &[
            0.0, 1.0, 0.0, 0.0,
            -w * w, -2.0 * mode.damping_ratio * w, 0.0, 0.0,
            1.0, 0.0, 0.0, 0.0,
            0.0, 1.0, 0.0, 0.0,
        ]);
        let b = DMatrix::from_row_slice(4, 1, &[0.0, w * w, 0.0, 0.0]);
        let (ad, bd) = lti::zoh(&a, &b, step);
        let mean = |i: usize, j: usize| ad[(i, j)] / step;
        ModeStep {
            ad: [[ad[(0, 0)], ad[(0, 1)]], [ad[(1, 0)], ad[(1, 1)]]],
            bd: [bd[(0, 0)], bd[(1, 0)]],
            mean_ad: [[mean(2, 0), mean(2, 1)], [mean(3, 0), mean(3, 1)]],
            mean_bd: [bd[(2, 0)] / step, bd[(3, 0)] / step],
        }
    }

    fn apply(&self, x: [f64; 2], static_coordinate: f64) -> [f64; 2] {
        [
            self.ad[0][0] * x[0] + self.ad[0][1] * x[1] + self.bd[0] * static_coordinate,
            self.ad[1][0] * x[0] + self.ad[1][1] * x[1] + self.bd[1] * static_coordinate,
        ]
    }

    fn mean(&self, x: [f64; 2], static_coordinate: f64) -> [f64; 2] {
        [
            self.mean_ad[0][0] * x[0] + self.mean_ad[0][1] * x[1] + self.mean_bd[0] * static_coordinate,
            self.mean_ad[1][0] * x[0] + self.mean_ad[1][1] * x[1] + self.mean_bd[1] * static_coordinate,
        ]
    }
}

/// The width of the elevation cells over which a mode that changes with elevation is held at its
/// cell centre's frequency, deg: the plants' default parameter grid (`numerics.parameter_grid_cell`),
/// so that the inertia a mode carries and the rest that the azimuth plant keeps are taken at the
/// same elevation. Each new cell costs one discretisation of the modes (a matrix exponential);
/// within a cell the frequency moves by at most 0.2 % between the horizon and the zenith of the
/// shipped ranges.
pub const ELEVATION_CELL_DEG: f64 = 0.25;

/// The elevation cell holding an elevation.
fn elevation_cell(elevation_deg: f64) -> i64 {
    (elevation_deg / ELEVATION_CELL_DEG).floor() as i64
}

/// The modes as read and the cells they were last evaluated in, for a structure with a mode
/// that changes with elevation.
#[derive(Debug, Clone)]
struct ElevationCells {
    /// The modes as read (zenith and horizon frequencies).
    read: Vec<Mode>,
    /// The cell that the structure's modes and discretisation are for.
    cell: i64,
    /// The cell before it, with its modes and discretisation, kept because an axis held near a
    /// cell boundary crosses it back and forth.
    other: Option<(i64, Vec<Mode>, StepCache)>,
}

/// The discretisation of the modes for one step size (its bits), if computed.
type StepCache = Option<(u64, Vec<ModeStep>)>;

/// The modes and their coordinates and velocities.
#[derive(Debug, Clone)]
pub struct ModalStructure {
    /// The modes at the current elevation cell (as read when none changes with elevation).
    modes: Vec<Mode>,
    /// Where a mode changes with elevation, the modes as read and the cells; `None` otherwise.
    elevation: Option<ElevationCells>,
    /// `(q, q')` of each mode.
    states: Vec<[f64; 2]>,
    /// The axes' speeds (rad/s) at the start of the previous step and its length, s: the
    /// acceleration over it is the difference of the speeds over the length.
    previous_speeds: Option<([f64; 2], f64)>,
    /// The axes' mean accelerations (rad/s^2) over the step before the previous one and its
    /// length, s: with the previous step's, they extrapolate the acceleration to the next step.
    earlier_accelerations: Option<([f64; 2], f64)>,
    /// The axes' accelerations held over the current step, rad/s^2.
    accelerations: [f64; 2],
    /// The discretisation for the last step size (masters usually keep one): a cache, not state.
    cache: StepCache,
    /// Scratch for the next step's modal states (not part of the state).
    next_states: Vec<[f64; 2]>,
    /// The elevation last set (deg) and its cosine, which projects the modes' rotations about
    /// the azimuth axis on the sky; the cosine is computed only when a mode has such a rotation
    /// and the elevation changed.
    projection: (f64, f64),
    /// Whether a mode rotates the beam about the azimuth axis.
    rotates_about_azimuth: bool,
}

/// The structure's part of an FMU state: every mode's coordinate and velocity, and what the
/// axes' accelerations are computed from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModalState {
    pub states: Vec<[f64; 2]>,
    pub previous_speeds: Option<([f64; 2], f64)>,
    pub earlier_accelerations: Option<([f64; 2], f64)>,
    pub accelerations: [f64; 2],
}

impl ModalStructure {
    /// The structure at rest in the static deflection under `loads` (which does not depend on
    /// the frequencies), with its modes at the zenith until [`Self::set_elevation`] says
    /// otherwise.
    pub fn at_rest(modes: Vec<Mode>, loads: &[f64; LOADS]) -> ModalStructure {
        let states = modes.iter().map(|m| [m.static_coordinate(loads), 0.0]).collect();
        let elevation = modes.iter().any(Mode::varies_with_elevation).then(|| ElevationCells {
            read: modes.clone(),
            cell: i64::MIN,
            other: None,
        });
        let rotates_about_azimuth = modes.iter().any(|m| m.beam_azimuth_rotation != 0.0);
        let mut structure = ModalStructure {
            modes,
            elevation,
            states,
            previous_speeds: None,
            earlier_accelerations: None,
            accelerations: [0.0; 2],
            cache: None,
            next_states: Vec::new(),
            projection: (f64::NAN, 0.0),
            rotates_about_azimuth,
        };
        structure.set_elevation(90.0);
        structure
    }

    /// The modes at the current elevation cell.
    pub fn modes(&self) -> &[Mode] {
        &self.modes
    }

    /// Sets the elevation (deg) at which the modes that change with elevation are taken from
    /// now on: their frequencies at the centre of its [`ELEVATION_CELL_DEG`] cell. The modal
    /// states are kept: the frequency changes, the mode's coordinate and velocity do not. The
    /// beam offsets project the modes' rotations about the azimuth axis on the sky with the
    /// cosine of this elevation itself, not of its cell's centre.
    #[inline]
    pub fn set_elevation(&mut self, elevation_deg: f64) {
        if self.rotates_about_azimuth && self.projection.0.to_bits() != elevation_deg.to_bits() {
            self.projection = (elevation_deg, elevation_deg.to_radians().cos());
        }
        // Called before every step and every feedthrough update: the common structure, whose
        // modes do not change with elevation, pays one test.
        if self.elevation.is_some() {
            self.move_to_elevation(elevation_deg);
        }
    }

    #[inline(never)]
    fn move_to_elevation(&mut self, elevation_deg: f64) {
        let Some(cells) = &mut self.elevation else { return };
        let cell = elevation_cell(elevation_deg);
        if cell == cells.cell {
            return;
        }
        let (modes, cache) = match cells.other.take() {
            Some((other, modes, cache)) if other == cell => (modes, cache),
            _ => {
                let centre = (cell as f64 + 0.5) * ELEVATION_CELL_DEG;
                (cells.read.iter().map(|m| m.at_elevation(centre)).collect(), None)
            }
        };
        let left_modes = std::mem::replace(&mut self.modes, modes);
        let left_cache = std::mem::replace(&mut self.cache, cache);
        if cells.cell != i64::MIN {
            cells.other = Some((cells.cell, left_modes, left_cache));
        }
        cells.cell = cell;
    }

    /// The axes' accelerations (rad/s^2) to hold over a coming step of `step` seconds, with
    /// `speeds` the axes' speeds at its start, and the mean accelerations over the previous step
    /// (zero before the first).
    ///
    /// The speeds' differences give the mean acceleration over each past step, centred half a
    /// step back. Holding the last one over the next step would act a whole step late, and in a
    /// master that couples the modes back to the drives (see [`Self::drive_torques`]) that
    /// delay takes damping out of the drive's modes (at 1 ms, a third of a 2.7 % mode at 46 Hz,
    /// docs/structure-model.md); the two last means extrapolated linearly to the middle of the
    /// coming step are exact for any acceleration that changes linearly in time, and leave the
    /// modes' damping within 0.1 points of the continuous system's at 1 ms.
    fn held_accelerations(&self, speeds: &[f64; 2], step: f64) -> ([f64; 2], [f64; 2]) {
        let Some((previous, length)) = self.previous_speeds else { return ([0.0; 2], [0.0; 2]) };
        let last = [0, 1].map(|k| (speeds[k] - previous[k]) / length);
        let held = match self.earlier_accelerations {
            None => last,
            Some((earlier, earlier_length)) => {
                let reach = (length + step) / (length + earlier_length);
                [0, 1].map(|k| last[k] + (last[k] - earlier[k]) * reach)
            }
        };
        (held, last)
    }

    /// Advances by `step` seconds with the loads held constant. `speeds` are the axes' speeds
    /// (rad/s, azimuth and elevation) at the start of the step: the axes' accelerations held
    /// over it are extrapolated from the speeds' last changes ([`Self::held_accelerations`]),
    /// whose inertial loads the modes feel as the drives swing the structure. A step whose
    /// result is not finite (loads far beyond any structure) changes nothing and is an error.
    pub fn step(&mut self, loads: &[f64; LOADS], speeds: &[f64; 2], step: f64) -> Result<(), StructureError> {
        let key = step.to_bits();
        if self.cache.as_ref().is_none_or(|(k, _)| *k != key) {
            self.cache = Some((key, self.modes.iter().map(|m| ModeStep::new(m, step)).collect()));
        }
        let (accelerations, last) = self.held_accelerations(speeds, step);
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
            return Err(StructureError::NonFiniteStep { mode: k + 1, step, loads: *loads });
        }
        self.next_states = std::mem::replace(&mut self.states, next);
        self.earlier_accelerations = self.previous_speeds.map(|(_, length)| (last, length));
        self.previous_speeds = Some((*speeds, step));
        self.accelerations = accelerations;
        Ok(())
    }

    /// The torques the structure passes to the drives' load side about azimuth and elevation,
    /// N m, as a mean over a coming step as long as the last one (at the state itself before
    /// the first step), with `loads` and `speeds` the inputs at its start.
    ///
    /// Each mode's moving part is a body on the mode's spring: of the loads it takes, what does
    /// not accelerate it goes through the spring into the axes. So the drives get the torques
    /// about the axes less, through each mode's participation, the force that accelerates the
    /// mode's body, `K (m - q - (2 zeta / w) q')` with `m` its static coordinate under the
    /// loads: `T_i - sum_k p_i,k K_k (m_k - q_k - (2 zeta_k / w_k) q'_k)`. For one mode
    /// of participation 1 that is its spring and damper, `K q + c q'`. A master that connects
    /// these to the plants' `load.disturbance_torque` in place of the wind's torques, and
    /// lowers the plants' load inertias by [`Self::modal_inertias`], couples the modes both ways:
    /// under slow loads the drives see what they saw without the structure.
    pub fn drive_torques(&self, loads: &[f64; LOADS], speeds: &[f64; 2]) -> [f64; 2] {
        self.feedthrough(loads, speeds).1
    }

    /// [`Self::static_offset`] and [`Self::drive_torques`] in one pass over the modes (each
    /// mode's load taken once): what the FMU's feedthrough outputs need after every set.
    pub fn feedthrough(&self, loads: &[f64; LOADS], speeds: &[f64; 2]) -> ([f64; 2], [f64; 2]) {
        let mut offset = [0.0; 2];
        let mut torques = [loads[0], loads[1]];
        // The discretisation of the last step's length: the cache's, or (after a restored
        // state, whose cache may hold another length) computed afresh, the same numbers.
        let fresh: Vec<ModeStep>;
        let (window, steps) = match (&self.previous_speeds, &self.cache) {
            (Some((_, length)), Some((key, steps))) if length.to_bits() == *key => (*length, Some(steps)),
            (Some((_, length)), _) => {
                fresh = self.modes.iter().map(|m| ModeStep::new(m, *length)).collect();
                (*length, Some(&fresh))
            }
            (None, _) => (0.0, None),
        };
        let accelerations = if steps.is_some() { self.held_accelerations(speeds, window).0 } else { [0.0; 2] };
        for (k, (mode, x)) in self.modes.iter().zip(&self.states).enumerate() {
            let load = mode.static_coordinate(loads);
            let settled = load + mode.inertial_load(&self.accelerations) / mode.stiffness;
            let beam = mode.beam_on_sky(self.projection.1);
            offset[0] += beam[0] * settled;
            offset[1] += beam[1] * settled;
            let forcing = load + mode.inertial_load(&accelerations) / mode.stiffness;
            let [q, v] = match steps {
                Some(steps) => steps[k].mean(*x, forcing),
                None => *x,
            };
            let inertial_force = mode.stiffness * (load - q - 2.0 * mode.damping_ratio / mode.omega() * v);
            torques[0] -= mode.participation[0] * inertial_force;
            torques[1] -= mode.participation[1] * inertial_force;
        }
        (offset, torques)
    }

    /// The modes' inertia about each axis at the current elevation cell, kg m^2 (azimuth,
    /// elevation): `sum_k p_i,k^2 K_k / w_k^2`. The modes carry it, so a plant coupled to
    /// [`Self::drive_torques`] keeps only the rest of its load inertia.
    pub fn modal_inertias(&self) -> [f64; 2] {
        carried_inertias(&self.modes, Mode::inertia)
    }

    /// [`Self::modal_inertias`] with the dish at the zenith and at the horizon: `(zenith,
    /// horizon)`, equal for modes that do not change with elevation. Between them the inertia
    /// turns as `horizon cos^2(el) + zenith sin^2(el)`.
    pub fn modal_inertias_zenith_and_horizon(&self) -> ([f64; 2], [f64; 2]) {
        let read = self.elevation.as_ref().map_or(&self.modes, |cells| &cells.read);
        (carried_inertias(read, Mode::inertia), carried_inertias(read, Mode::horizon_inertia))
    }

    /// The beam offset, rad (on the sky: cross-elevation, elevation), from the modes'
    /// coordinates, with the rotations about the azimuth axis projected at the elevation last
    /// set.
    pub fn beam_offset(&self) -> [f64; 2] {
        let mut offset = [0.0; 2];
        for (mode, x) in self.modes.iter().zip(&self.states) {
            let beam = mode.beam_on_sky(self.projection.1);
            offset[0] += beam[0] * x[0];
            offset[1] += beam[1] * x[0];
        }
        offset
    }

    /// The quasi-static beam offset, rad: where the beam would settle under `loads` and the
    /// accelerations of the current step held for ever.
    pub fn static_offset(&self, loads: &[f64; LOADS]) -> [f64; 2] {
        // The axes' speeds move only the drive torques.
        self.feedthrough(loads, &[0.0; 2]).0
    }

    pub fn save_state(&self) -> ModalState {
        ModalState {
            states: self.states.clone(),
            previous_speeds: self.previous_speeds,
            earlier_accelerations: self.earlier_accelerations,
            accelerations: self.accelerations,
        }
    }

    /// [`save_state`](Self::save_state) written over `state`, reusing its storage.
    pub fn save_state_into(&self, state: &mut ModalState) {
        state.states.clone_from(&self.states);
        state.previous_speeds = self.previous_speeds;
        state.earlier_accelerations = self.earlier_accelerations;
        state.accelerations = self.accelerations;
    }

    /// Restores a saved state into a structure with the same number of modes.
    pub fn load_state(&mut self, state: ModalState) -> Result<(), StructureError> {
        if state.states.len() != self.modes.len() {
            return Err(StructureError::ModeCount { state: state.states.len(), modes: self.modes.len() });
        }
        if !state.states.iter().flatten().all(|v| v.is_finite()) {
            return Err(StructureError::NonFiniteCoordinate);
        }
        let speeds_finite =
            state.previous_speeds.is_none_or(|(v, h)| v.iter().all(|x| x.is_finite()) && h.is_finite() && h > 0.0);
        let earlier_finite = state
            .earlier_accelerations
            .is_none_or(|(a, h)| a.iter().all(|x| x.is_finite()) && h.is_finite() && h > 0.0);
        if !speeds_finite || !earlier_finite || !state.accelerations.iter().all(|a| a.is_finite()) {
            return Err(StructureError::NonFiniteMotion);
        }
        self.states = state.states;
        self.previous_speeds = state.previous_speeds;
        self.earlier_accelerations = state.earlier_accelerations;
        self.accelerations = state.accelerations;
        Ok(())
    }
}

/// `sum_k p_i,k^2 J_k` about each axis (azimuth, elevation), with each mode's inertia `J_k` as
/// `inertia` gives it.
fn carried_inertias(modes: &[Mode], inertia: impl Fn(&Mode) -> f64) -> [f64; 2] {
    let mut inertias = [0.0; 2];
    for mode in modes {
        let inertia = inertia(mode);
        inertias[0] += mode.participation[0] * mode.participation[0] * inertia;
        inertias[1] += mode.participation[1] * mode.participation[1] * inertia;
    }
    inertias
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mode(frequency_hz: f64, damping_ratio: f64) -> Mode {
        Mode {
            frequency_hz,
            horizon_frequency_hz: None,
            damping_ratio,
            stiffness: 4e8,
            participation: [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            beam: [1.0, 0.0],
            beam_azimuth_rotation: 0.0,
        }
    }

    #[test]
    fn crossing_elevation_cells_back_and_forth_steps_each_cell_with_its_own_frequency() {
        // An axis held at a cell boundary (45 deg) crosses it at every step: the structure
        // keeps the other cell's discretisation, and must step exactly as one discretised
        // afresh in each step's cell.
        let varying = Mode { horizon_frequency_hz: Some(4.0), ..mode(6.0, 0.015) };
        let loads = [2e4, 0.0, 0.0, 0.0, 0.0, 0.0];
        let mut kept = ModalStructure::at_rest(vec![varying.clone()], &[0.0; LOADS]);
        let mut fresh_state = kept.save_state();
        for k in 0..400 {
            let elevation = if k % 3 == 0 { 45.01 } else { 44.99 };
            let speeds = [1e-3 * (k as f64 * 0.01).sin(), 0.0];
            kept.set_elevation(elevation);
            kept.step(&loads, &speeds, 1e-3).unwrap();
            let centre = if elevation > 45.0 { 45.125 } else { 44.875 };
            let mut fresh = ModalStructure::at_rest(vec![varying.at_elevation(centre)], &[0.0; LOADS]);
            fresh.load_state(fresh_state).unwrap();
            fresh.step(&loads, &speeds, 1e-3).unwrap();
            fresh_state = fresh.save_state();
            assert_eq!(kept.save_state(), fresh_state, "step {k}");
            assert_eq!(kept.modes()[0].frequency_hz, varying.frequency_at(centre));
        }
        // The two ends' inertias, and the current cell's between them.
        let ([zenith, _], [horizon, _]) = kept.modal_inertias_zenith_and_horizon();
        assert_eq!((zenith, horizon), (mode(6.0, 0.0).inertia(), mode(4.0, 0.0).inertia()));
        let current = kept.modal_inertias()[0];
        assert!(zenith < current && current < horizon);
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
        let state = ModalState {
            states: vec![[0.0; 2]; 2],
            previous_speeds: None,
            earlier_accelerations: None,
            accelerations: [0.0; 2],
        };
        let error = s.load_state(state).unwrap_err().to_string();
        assert!(error.contains("2 modes"), "{error}");
    }

    #[test]
    fn under_a_constant_load_the_drive_torque_is_the_load_itself() {
        // At rest the spring passes the whole load on: the drives see what they saw without
        // the structure.
        let loads = [1e4, -2e4, 0.0, 0.0, 0.0, 0.0];
        let mut el_mode = mode(7.0, 0.02);
        el_mode.participation = [0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
        el_mode.beam = [0.0, 1.0];
        let mut s = ModalStructure::at_rest(vec![mode(6.0, 0.015), el_mode], &loads);
        assert_eq!(s.drive_torques(&loads, &[0.0; 2]), [1e4, -2e4]);
        let [az, el] = s.feedthrough(&loads, &[0.0; 2]).0;
        assert!((az / (1e4 / 4e8) - 1.0).abs() < 1e-12 && (el / (-2e4 / 4e8) - 1.0).abs() < 1e-12, "{az} {el}");
        for _ in 0..100 {
            s.step(&loads, &[0.0; 2], 1e-3).unwrap();
        }
        let [az, el] = s.drive_torques(&loads, &[0.0; 2]);
        assert!((az / 1e4 - 1.0).abs() < 1e-12 && (el / -2e4 - 1.0).abs() < 1e-12, "{az} {el}");
        // Under a constant acceleration the drive also carries the modal body along.
        let m = mode(6.0, 0.015);
        let inertia = m.stiffness / (m.omega() * m.omega());
        assert_eq!(s.modal_inertias()[0], inertia);
        let mut a = ModalStructure::at_rest(vec![m], &[0.0; LOADS]);
        let (acceleration, h) = (0.01, 1e-3);
        for k in 0..30_000 {
            a.step(&[0.0; LOADS], &[acceleration * k as f64 * h, 0.0], h).unwrap();
        }
        let torque = a.drive_torques(&[0.0; LOADS], &[acceleration * 30_000.0 * h, 0.0])[0];
        assert!((torque / (-inertia * acceleration) - 1.0).abs() < 1e-6, "{torque}");
    }

    /// A body of inertia `body` on a spring `ground` to the ground (a drive held by its
    /// gear), carrying the structure's mode both ways through the drive torque and stepped
    /// exactly over each step `h`: returns the axis angle and the mode's coordinate at each
    /// point after a push.
    fn two_way_free_decay(m: &Mode, body: f64, ground: f64, h: f64, steps: usize) -> Vec<[f64; 2]> {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -ground / body, 0.0]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0 / body]);
        let (ad, bd) = lti::zoh(&a, &b, h);
        let mut s = ModalStructure::at_rest(vec![m.clone()], &[0.0; LOADS]);
        let mut x = [0.0, 1e-4];
        let mut out = Vec::new();
        for _ in 0..steps {
            let torque = s.drive_torques(&[0.0; LOADS], &[x[1], 0.0])[0];
            s.step(&[0.0; LOADS], &[x[1], 0.0], h).unwrap();
            x = [
                ad[(0, 0)] * x[0] + ad[(0, 1)] * x[1] + bd[(0, 0)] * torque,
                ad[(1, 0)] * x[0] + ad[(1, 1)] * x[1] + bd[(1, 0)] * torque,
            ];
            out.push([x[0], s.beam_offset()[0]]);
        }
        out
    }

    #[test]
    fn coupled_both_ways_to_a_drive_the_mode_rings_at_the_two_body_frequency_at_any_step() {
        // Elevation-like numbers: the mode (6 Hz clamped, 2.8e5 kg m^2) carries four fifths of
        // the load; the rest (7e4 kg m^2) sits on a 5.5e9 N m/rad drive. The exact system of
        // the two bodies has its lower mode at 5.80 Hz; the coupling through the drive torque
        // must find it at 1 ms and 2 ms steps, and stay stable.
        let m = mode(6.0, 0.015);
        let (body, ground) = (7e4, 5.5e9);
        let inertia = m.stiffness / (m.omega() * m.omega());
        // Eigenfrequencies of [[ground + K, -K], [-K, K]] against diag(body, inertia).
        let (k, j1, j2) = (m.stiffness, body, inertia);
        let (tr, det) = ((ground + k) / j1 + k / j2, ground * k / (j1 * j2));
        let lower = ((tr - (tr * tr - 4.0 * det).sqrt()) / 2.0).sqrt() / (2.0 * std::f64::consts::PI);
        for h in [5e-4, 1e-3, 2e-3] {
            let n = (20.0 / h) as usize;
            let trace = two_way_free_decay(&m, body, ground, h, n);
            // The beam coordinate's upward zero crossings over the last 15 s (the drive's
            // 46 Hz mode has decayed; the structure's rings on).
            let q: Vec<f64> = trace.iter().map(|x| x[1]).collect();
            let crossings: Vec<f64> = (n / 4..n)
                .filter(|&i| q[i - 1] < 0.0 && q[i] >= 0.0)
                .map(|i| (i as f64 - q[i] / (q[i] - q[i - 1])) * h)
                .collect();
            let frequency = (crossings.len() - 1) as f64 / (crossings[crossings.len() - 1] - crossings[0]);
            assert!((frequency / lower - 1.0).abs() < 2e-3, "h {h}: {frequency} Hz against {lower} Hz");
            // Stable: the oscillation decays.
            let peak = |range: std::ops::Range<usize>| range.map(|i| q[i].abs()).fold(0.0, f64::max);
            assert!(peak(n - n / 10..n) < 0.5 * peak(n / 10..n / 5), "h {h}: no decay");
        }
    }
}
