//! The hybrid, piecewise-linear integrator shared by both axes.
//!
//! A drive train here is one load driven by `P` motors (azimuth 2, elevation 1), each through
//! its own compliant path with optional backlash, each with a first-order current loop. All
//! rotational quantities are reflected to the motor side (motor radians), which keeps the
//! system matrix well scaled: every entry is within a few decades of the others, so the matrix
//! exponential is accurate to near machine precision. The state vector is
//!
//! ```text
//! x = [p_L, v_L,  d_1, v_M1, i_1, beta_1,  ...,  d_P, v_MP, i_P, beta_P]
//! ```
//!
//! with `p_L`, `v_L` the load position and speed on the motor side (motor rad, rad/s: the
//! azimuth angle times `N`; for elevation the actuator length times `n_s`, see `elevation`),
//! `d_k = theta_Mk - p_L` the total angle difference of path `k` (twist plus backlash travel),
//! `v_Mk` the motor speed, `i_k` the motor current, and `beta_k` the backlash position: the
//! spring deflection is `d_k - beta_k`. The path torque (motor side) is
//! `T_k = K_k (d_k - beta_k) + C_k (v_Mk - v_L)` while the pinion is in contact, with
//! `beta_k = +/- b_k/2` fixed on the flank in contact; in the gap `T_k = 0` and the massless
//! spring relaxes, `C_k d(d_k - beta_k)/dt = -K_k (d_k - beta_k)`. This is the "physical"
//! backlash model of Nordin and Gutman (Automatica 38, 2002): unlike the dead-zone model it
//! cannot pull on a tooth flank.
//!
//! Friction is Coulomb and static on every body (each load or motor either slides forward,
//! slides backward or sticks) and viscous; Coulomb levels enter as a constant input, so within
//! a fixed discrete mode the system is linear and time-invariant and one step is one exact
//! zero-order-hold product `x' = Ad x + Bd u`. After a tentative step the new state is checked
//! against the mode (a sliding body must not have reversed; a sticking body's holding torque
//! must stay within its breakaway level; a pinion in contact must still push; a pinion in the
//! gap must not have passed a flank). If it is inconsistent, the step is subdivided dyadically
//! down to the event time resolution, the mode is switched there and the step continues in
//! aligned dyadic pieces: every sub-step length is of the form `L / 2^j`, a rung of one cached
//! [`Ladder`] per (mode, grid cell, piece length `L`).

use std::sync::Arc;

use fmu_runtime::state::StateError;
use lti::zoh;
use nalgebra::{DMatrix, SMatrix, SVector};
use serde::{Deserialize, Serialize};

use crate::cache::{BoundedCache, DiscretisationKey};
use crate::delay::DelayLine;
use crate::error::PlantError;
use crate::floor::ceil;
use crate::params::FrictionParams;
use crate::sensors::SampleClock;

/// Fastest rate of the linear dynamics a plant accepts, 1/s.
///
/// Above it the matrix exponential, though finite, loses accuracy: with tiny motor inertias
/// the linear configuration's 1 ms and 0.1 ms runs, which agree to 1e-14 at the defaults,
/// differ by 1.6e-11 of their range at a rate of 6.5e7 1/s, 6.7e-10 at 6.5e9, 2.6e-8 at 6.5e10
/// and 1.6e-2 at 6.5e16. The default drives' fastest rate is about 1.4e3 1/s (the spring's
/// relaxation in the backlash gap), so this leaves seven decades for studies.
pub(crate) const MAX_RATE_PER_S: f64 = 1e10;

/// True for a rate above [`MAX_RATE_PER_S`], or NaN (0/0), which is as unusable.
fn too_fast(rate: f64) -> bool {
    rate.is_nan() || rate > MAX_RATE_PER_S
}

pub(crate) const LOAD_ANGLE: usize = 0;
pub(crate) const LOAD_SPEED: usize = 1;

pub(crate) const fn twist_index(path: usize) -> usize {
    2 + 4 * path
}

pub(crate) const fn motor_speed_index(path: usize) -> usize {
    3 + 4 * path
}

pub(crate) const fn current_index(path: usize) -> usize {
    4 + 4 * path
}

pub(crate) const fn backlash_index(path: usize) -> usize {
    5 + 4 * path
}

/// The linear dynamics in one parameter-grid cell, reflected to the motor side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CellModel<const P: usize> {
    /// Motor radians per axis radian in this cell.
    pub gear_ratio: f64,
    /// Load inertia divided by `N^2`, kg m^2.
    pub load_inertia: f64,
    /// Load viscous friction divided by `N^2`, N m s/rad.
    pub load_viscous: f64,
    pub motor_inertia: [f64; P],
    pub motor_viscous: [f64; P],
    /// Effective torque constant (with its scale), N m/A.
    pub torque_per_amp: [f64; P],
    /// Current-loop bandwidth, rad/s.
    pub current_loop_rad_per_s: [f64; P],
    /// Path stiffness divided by `N^2`, N m/rad.
    pub stiffness: [f64; P],
    /// Path damping divided by `N^2`, N m s/rad.
    pub damping: [f64; P],
    /// Presliding (bristle) stiffness and damping of each motor's friction, N m/rad and
    /// N m s/rad at the motor; 0 is a rigid stick. See [`DriveCore`]'s anchors.
    pub presliding_stiffness: [f64; P],
    pub presliding_damping: [f64; P],
}

/// Friction on one body, made of up to two elements that act together (the elevation motor
/// carries both its own and the jackscrew's friction). Torques and speeds in the body's units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct BodyFriction {
    pub elements: [FrictionParams; 2],
}

impl BodyFriction {
    pub fn single(element: FrictionParams) -> Self {
        Self { elements: [element, FrictionParams::NONE] }
    }

    pub fn is_present(&self) -> bool {
        self.elements.iter().any(FrictionParams::is_present)
    }

    pub fn has_stribeck(&self) -> bool {
        self.elements.iter().any(|e| e.stribeck_velocity_rad_per_s > 0.0 && e.static_nm > e.coulomb_nm)
    }

    /// Sliding (Coulomb) level for motion in `direction` (+1 or -1), without the Stribeck excess.
    pub fn kinetic(&self, direction: f64) -> f64 {
        self.elements.iter().map(|e| (1.0 + direction * e.asymmetry) * e.coulomb_nm).sum()
    }

    /// Breakaway level for a push in `direction`.
    pub fn breakaway(&self, direction: f64) -> f64 {
        self.elements.iter().map(|e| (1.0 + direction * e.asymmetry) * e.static_nm).sum()
    }

    /// Stribeck excess over the Coulomb level at a sliding speed, for motion in `direction`:
    /// the definition, which [`FrictionLevels`] evaluates from prepared factors.
    #[cfg(test)]
    pub fn stribeck_excess(&self, direction: f64, speed: f64) -> f64 {
        self.elements
            .iter()
            .filter(|e| e.stribeck_velocity_rad_per_s > 0.0)
            .map(|e| {
                let ratio = speed / e.stribeck_velocity_rad_per_s;
                (1.0 + direction * e.asymmetry) * (e.static_nm - e.coulomb_nm) * (-ratio * ratio).exp()
            })
            .sum()
    }
}

/// A body's friction levels in both directions, computed once from its [`BodyFriction`]: the
/// integrator needs them for every piece (the input vector) and every consistency check, and
/// summing the elements' asymmetric levels each time was a few percent of a plant's step. Each
/// number is the one `BodyFriction` computes, by the same operations in the same order, so the
/// friction torques are the same bits.
#[derive(Debug, Clone, Copy, PartialEq)]
struct FrictionLevels {
    /// [`BodyFriction::is_present`].
    present: bool,
    /// [`BodyFriction::kinetic`] forward (+1) and backward (-1).
    kinetic: [f64; 2],
    /// [`BodyFriction::breakaway`] forward and backward.
    breakaway: [f64; 2],
    /// The elements with a Stribeck curve (the first `stribeck_count`): the Stribeck velocity
    /// and the excess at zero speed `(1 + d a)(static - coulomb)` forward and backward.
    stribeck: [(f64, [f64; 2]); 2],
    stribeck_count: usize,
}

impl FrictionLevels {
    fn new(friction: &BodyFriction) -> Self {
        let mut levels = Self {
            present: friction.is_present(),
            kinetic: [friction.kinetic(1.0), friction.kinetic(-1.0)],
            breakaway: [friction.breakaway(1.0), friction.breakaway(-1.0)],
            stribeck: [(0.0, [0.0; 2]); 2],
            stribeck_count: 0,
        };
        for e in friction.elements.iter().filter(|e| e.stribeck_velocity_rad_per_s > 0.0) {
            let excess = |direction: f64| (1.0 + direction * e.asymmetry) * (e.static_nm - e.coulomb_nm);
            levels.stribeck[levels.stribeck_count] = (e.stribeck_velocity_rad_per_s, [excess(1.0), excess(-1.0)]);
            levels.stribeck_count += 1;
        }
        levels
    }

    /// The friction torque opposing a body sliding in `motion` at the Stribeck sampling speed
    /// `speed` (positive for forward motion); zero for a stuck body or no friction.
    fn sliding_torque(&self, motion: Motion, speed: f64) -> f64 {
        let side = match motion {
            Motion::Forward => 0,
            Motion::Backward => 1,
            Motion::Stuck => return 0.0,
        };
        if !self.present {
            return 0.0;
        }
        let excess: f64 = self.stribeck[..self.stribeck_count]
            .iter()
            .map(|&(velocity, excess)| {
                let ratio = speed / velocity;
                excess[side] * (-ratio * ratio).exp()
            })
            .sum();
        motion.direction() * (self.kinetic[side] + excess)
    }

    /// True if a stuck body holds against `torque` (divided by `scale` into the body's units).
    fn holds(&self, torque: f64, scale: f64) -> bool {
        torque <= self.breakaway[0] / scale && torque >= -self.breakaway[1] / scale
    }
}

/// Counters of the integrator's work, for performance diagnosis. Not part of the state.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NumericsStatistics {
    /// Calls of `step`.
    pub steps: u64,
    /// Mode switches handled (each localised by dyadic subdivision).
    pub events: u64,
    /// Matrix-vector products beyond one per piece: the price of localising events.
    pub extra_propagations: u64,
    /// Discretisations computed (matrix exponentials), i.e. cache misses.
    pub discretisations_computed: u64,
}

/// Fixed (not cell-dependent) settings of a drive train.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CoreConfig<const P: usize> {
    /// Motor friction, N m and rad/s at the motor.
    pub motor_friction: [BodyFriction; P],
    /// Load friction, N m and rad/s about the axis (referred through the cell's ratio).
    pub load_friction: BodyFriction,
    /// Total free play of each path, motor rad.
    pub backlash: [f64; P],
    /// Current limit of each motor, A.
    pub current_limit: [f64; P],
    /// Delay of each motor's current command, s.
    pub command_delay: [f64; P],
    /// Longest sub-step for torques that are not piecewise linear, s.
    pub substep: f64,
    /// Resolution of event localisation, s.
    pub event_resolution: f64,
    /// Longest piece whose consistency is checked only at its end, s.
    pub event_check_interval: f64,
    pub cache_capacity: usize,
    /// True if the owner supplies state-dependent torques, evaluated at the start of every
    /// piece of a step (cogging, ripple, unbalance, the elevation's kinematic curvature term).
    pub position_dependent_torques: bool,
    /// True if some of those torques vary fast enough to need the internal sub-step grid
    /// (cogging, ripple, unbalance; not the slowly varying curvature term).
    pub substep_torques: bool,
}

/// How a body with friction is moving.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Motion {
    /// Sliding with non-negative speed (also used for bodies without friction).
    Forward,
    /// Sliding with non-positive speed.
    Backward,
    /// Held by static friction at zero speed.
    Stuck,
}

impl Motion {
    fn direction(self) -> f64 {
        match self {
            Motion::Forward => 1.0,
            Motion::Backward => -1.0,
            Motion::Stuck => 0.0,
        }
    }
}

/// The state of a pinion (or nut) mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Mesh {
    /// In contact on the flank that drives the load positively (`beta = +b/2`); also the
    /// permanent state of a path without backlash (`beta = 0`).
    PositiveFlank,
    /// In contact on the other flank (`beta = -b/2`).
    NegativeFlank,
    /// Free in the backlash gap.
    Gap,
}

impl Mesh {
    pub fn flank_sign(self) -> i32 {
        match self {
            Mesh::PositiveFlank => 1,
            Mesh::NegativeFlank => -1,
            Mesh::Gap => 0,
        }
    }
}

/// The owner's state-dependent torques: for a state and the cell's model, the torques on the
/// motors (N m at the motor) and on the load (N m about the axis).
pub(crate) type PositionTorques<'a, const P: usize, const S: usize> =
    &'a dyn Fn(&SVector<f64, S>, &CellModel<P>) -> ([f64; P], f64);

/// Inputs held constant over one piece of a step.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PieceInputs<const P: usize> {
    /// Current commands after delay and saturation, A.
    pub commands: [f64; P],
    /// Position-dependent torques on the motors (cogging), N m at the motor.
    pub motor_torque: [f64; P],
    /// Disturbance, offset and position-dependent torques on the load, N m about the axis.
    pub load_torque_axis: f64,
}

/// Exact zero-order-hold matrices for one (mode, cell, step length).
#[derive(Debug, Clone)]
pub(crate) struct Discretisation<const S: usize, const U: usize> {
    pub ad: SMatrix<f64, S, S>,
    pub bd: SMatrix<f64, S, U>,
}

/// The discretisations of one (mode, cell) for a piece of length `L` and all its dyadic
/// fractions: `rungs[j]` is exact for `L / 2^j`, down to the event time resolution.
///
/// The full-length rung, the only one a step without events uses, comes straight from a
/// matrix exponential, and it is all a new ladder holds: the others are added the first time an
/// event has to be localised with it. The finest rung also comes from an exponential; the ones
/// between follow from it by doubling,
/// `Ad(2t) = Ad(t)^2`, `Bd(2t) = Ad(t) Bd(t) + Bd(t)`, as scaling and squaring does inside the
/// exponential. The finest exponential is cheap (its argument is small), so a ladder costs
/// little more than `exp(A L)` alone, and localising an event needs no further exponentials or
/// cache look-ups. Each doubling can double the rounding error, so the intermediate rungs are
/// accurate to about `2^levels` machine epsilons, some 1e-13 relative: far below the error of
/// placing an event on the resolution grid, which is what they serve.
#[derive(Debug, Clone)]
pub(crate) struct Ladder<const S: usize, const U: usize> {
    pub rungs: Vec<Discretisation<S, U>>,
}

impl<const S: usize, const U: usize> Ladder<S, U> {
    /// A ladder with only its full-length rung.
    fn top<const P: usize>(model: &CellModel<P>, mode: u32, length: f64) -> Self {
        Self { rungs: vec![Discretisation::new(model, mode, length)] }
    }

    /// This ladder with all its rungs down to `length / 2^levels`.
    fn completed<const P: usize>(&self, model: &CellModel<P>, mode: u32, length: f64, levels: u32) -> Self {
        let finest = Discretisation::new(model, mode, length / (1u64 << levels) as f64);
        let mut rungs = vec![finest; levels as usize + 1];
        for j in (1..levels as usize).rev() {
            let half = &rungs[j + 1];
            let doubled = Discretisation { ad: half.ad * half.ad, bd: half.ad * half.bd + half.bd };
            rungs[j] = doubled;
        }
        rungs[0] = self.rungs[0].clone();
        Self { rungs }
    }
}

/// The continuous-time matrices `(A, B)` of a cell model in a mode.
pub(crate) fn continuous_model<const P: usize>(model: &CellModel<P>, mode: u32) -> (DMatrix<f64>, DMatrix<f64>) {
    let states = 2 + 4 * P;
    let inputs = 2 * P + 1;
    let mut a = DMatrix::<f64>::zeros(states, states);
    let mut b = DMatrix::<f64>::zeros(states, inputs);
    let load_stuck = mode & 1 != 0;
    let jl = model.load_inertia;
    if !load_stuck {
        a[(LOAD_ANGLE, LOAD_SPEED)] = 1.0;
        a[(LOAD_SPEED, LOAD_SPEED)] -= model.load_viscous / jl;
        b[(LOAD_SPEED, 2 * P)] = 1.0 / jl;
    }
    for k in 0..P {
        let motor_stuck = mode & (1 << (1 + k)) != 0;
        let gap = mode & (1 << (1 + P + k)) != 0;
        let (d, v, i, beta) = (twist_index(k), motor_speed_index(k), current_index(k), backlash_index(k));
        let (stiffness, damping, jm) = (model.stiffness[k], model.damping[k], model.motor_inertia[k]);
        // A sticking motor with a presliding element moves: it is held to its friction anchor
        // by the bristle spring sigma (theta_M - anchor) and damper c v_M, with theta_M = d_k +
        // p_L. The anchor enters as a constant input (DriveCore::propagate), so the mode stays
        // linear; without the element a sticking motor is rigidly at rest (zero rows).
        let presliding = motor_stuck && model.presliding_stiffness[k] > 0.0;
        let motor_stuck = motor_stuck && !presliding;
        a[(d, v)] = 1.0;
        a[(d, LOAD_SPEED)] = -1.0;
        if gap {
            // The massless spring-damper relaxes towards zero deflection while the tooth floats.
            a[(beta, v)] = 1.0;
            a[(beta, LOAD_SPEED)] = -1.0;
            a[(beta, d)] = stiffness / damping;
            a[(beta, beta)] = -stiffness / damping;
        } else {
            // T_k = K (d - beta) + C (v_M - v_L) pushes the load forward and the motor back.
            if !load_stuck {
                a[(LOAD_SPEED, d)] += stiffness / jl;
                a[(LOAD_SPEED, beta)] -= stiffness / jl;
                a[(LOAD_SPEED, v)] += damping / jl;
                a[(LOAD_SPEED, LOAD_SPEED)] -= damping / jl;
            }
            if !motor_stuck {
                a[(v, d)] -= stiffness / jm;
                a[(v, beta)] += stiffness / jm;
                a[(v, v)] -= damping / jm;
                a[(v, LOAD_SPEED)] += damping / jm;
            }
        }
        if !motor_stuck {
            a[(v, v)] -= model.motor_viscous[k] / jm;
            a[(v, i)] += model.torque_per_amp[k] / jm;
            b[(v, P + k)] = 1.0 / jm;
        }
        if presliding {
            let sigma = model.presliding_stiffness[k];
            a[(v, d)] -= sigma / jm;
            a[(v, LOAD_ANGLE)] -= sigma / jm;
            a[(v, v)] -= model.presliding_damping[k] / jm;
        }
        a[(i, i)] = -model.current_loop_rad_per_s[k];
        b[(i, k)] = model.current_loop_rad_per_s[k];
    }
    (a, b)
}

impl<const S: usize, const U: usize> Discretisation<S, U> {
    fn new<const P: usize>(model: &CellModel<P>, mode: u32, h: f64) -> Self {
        let (a, b) = continuous_model(model, mode);
        let (ad_dyn, bd_dyn) = zoh(&a, &b, h);
        let mut ad = SMatrix::<f64, S, S>::zeros();
        let mut bd = SMatrix::<f64, S, U>::zeros();
        ad.copy_from(&ad_dyn);
        bd.copy_from(&bd_dyn);
        // Restore structure that holds exactly but that the Pade approximant reproduces only to
        // rounding: a state with an all-zero row in [A B] is constant (a sticking body's speed,
        // a flank-locked backlash position), and a state with an all-zero column in A feeds
        // nothing (the load angle), so its column of exp(A h) is a unit vector. Exact ones and
        // zeros keep a stuck body exactly at rest and the large load angle free of rounding.
        for r in 0..S {
            let row_is_zero = (0..S).all(|c| a[(r, c)] == 0.0) && (0..U).all(|c| b[(r, c)] == 0.0);
            if row_is_zero {
                for c in 0..S {
                    ad[(r, c)] = if r == c { 1.0 } else { 0.0 };
                }
                for c in 0..U {
                    bd[(r, c)] = 0.0;
                }
            }
        }
        for c in 0..S {
            if (0..S).all(|r| a[(r, c)] == 0.0) {
                for r in 0..S {
                    ad[(r, c)] = if r == c { 1.0 } else { 0.0 };
                }
            }
        }
        Self { ad, bd }
    }
}

/// What a step changes in a drive, taken before the step so that a step whose result is not
/// finite can be undone ([`DriveCore::checkpoint`], [`DriveCore::rollback`]). It is small and
/// `Copy`, so taking one on every step costs a copy of about a hundred bytes and no allocation.
/// The delay lines, which own a buffer, are copied into spare lines kept by the core instead,
/// and only when a delay is on. The cell's model is not kept: it follows from the cell.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Checkpoint<const P: usize, const S: usize> {
    x: SVector<f64, S>,
    load_angle_low: f64,
    load_motion: Motion,
    motor_motion: [Motion; P],
    mesh: [Mesh; P],
    anchor: [f64; P],
    time: f64,
    cell: i64,
}

/// A drive train with `P` paths, `S = 2 + 4P` states and `U = 2P + 1` inputs.
#[derive(Debug, Clone)]
pub(crate) struct DriveCore<const P: usize, const S: usize, const U: usize> {
    config: CoreConfig<P>,
    /// The friction levels of the load and of each motor, from `config`.
    load_friction: FrictionLevels,
    motor_friction: [FrictionLevels; P],
    /// True if a step is cut into sub-steps no longer than `config.substep` (see
    /// [`DriveCore::step`]).
    needs_substeps: bool,
    x: SVector<f64, S>,
    /// Low-order part of the load angle: `x[LOAD_ANGLE] + load_angle_low` is the angle. The
    /// load angle is large (N times the axis angle) while each step moves it little, so it is
    /// accumulated with compensated (Neumaier) summation; otherwise its rounding would make
    /// results depend on the number of steps at the 1e-10 level.
    load_angle_low: f64,
    load_motion: Motion,
    motor_motion: [Motion; P],
    mesh: [Mesh; P],
    /// Friction anchor of each motor with a presliding element, motor rad: while the motor
    /// sticks, its bristle deflection is theta_M - anchor = d_k + p_L - anchor. Set when the
    /// motor comes to rest, so that the bristle torque then equals the friction it had.
    anchor: [f64; P],
    time: f64,
    delay: [DelayLine; P],
    /// Copies of the delay lines at the last checkpoint (used only when a delay is on).
    delay_at_checkpoint: [DelayLine; P],
    cell: i64,
    model: CellModel<P>,
    /// Speeds at which the Stribeck excess is sampled for the current piece (load in axis
    /// rad/s, then motors); reset to zero when a body breaks away within the piece.
    stribeck_speed: [f64; 8],
    cache: BoundedCache<Ladder<S, U>>,
    last: Option<(DiscretisationKey, Arc<Ladder<S, U>>)>,
    /// Length and number of dyadic levels of the piece being advanced.
    piece: (f64, u32),
    breakpoints: Vec<f64>,
    statistics: NumericsStatistics,
}

impl<const P: usize, const S: usize, const U: usize> DriveCore<P, S, U> {
    pub fn new(config: CoreConfig<P>, cell: i64, model: CellModel<P>) -> Self {
        assert!(S == 2 + 4 * P && U == 2 * P + 1 && P < 7, "state and input sizes do not match the number of paths");
        let delay = std::array::from_fn(|k| DelayLine::new(config.command_delay[k]));
        let needs_substeps = config.substep_torques
            || config.load_friction.has_stribeck()
            || config.motor_friction.iter().any(BodyFriction::has_stribeck);
        let mut core = Self {
            config,
            load_friction: FrictionLevels::new(&config.load_friction),
            motor_friction: config.motor_friction.map(|f| FrictionLevels::new(&f)),
            needs_substeps,
            x: SVector::zeros(),
            load_angle_low: 0.0,
            load_motion: Motion::Forward,
            motor_motion: [Motion::Forward; P],
            mesh: [Mesh::PositiveFlank; P],
            anchor: [0.0; P],
            time: 0.0,
            delay_at_checkpoint: delay.clone(),
            delay,
            cell,
            model,
            stribeck_speed: [0.0; 8],
            cache: BoundedCache::new(config.cache_capacity),
            last: None,
            piece: (0.0, 0),
            breakpoints: Vec::with_capacity(64),
            statistics: NumericsStatistics::default(),
        };
        core.set_at_rest(0.0);
        core
    }

    /// Puts the drive at rest with the load at `load_angle_motor_rad` (= N * axis angle),
    /// untwisted paths, pinions centred in their backlash, zero currents and a fresh clock.
    pub fn set_at_rest(&mut self, load_angle_motor_rad: f64) {
        self.x = SVector::zeros();
        self.x[LOAD_ANGLE] = load_angle_motor_rad;
        self.load_angle_low = 0.0;
        self.load_motion = if self.config.load_friction.is_present() { Motion::Stuck } else { Motion::Forward };
        for k in 0..P {
            self.motor_motion[k] =
                if self.config.motor_friction[k].is_present() { Motion::Stuck } else { Motion::Forward };
            self.mesh[k] = if self.config.backlash[k] > 0.0 { Mesh::Gap } else { Mesh::PositiveFlank };
            self.delay[k].clear();
            // At rest with a relaxed bristle.
            self.anchor[k] = load_angle_motor_rad;
        }
        self.time = 0.0;
    }

    pub fn state(&self) -> &SVector<f64, S> {
        &self.x
    }

    /// The load angle at the motor side (N times the axis angle), with its low-order part.
    pub fn load_angle(&self) -> f64 {
        self.x[LOAD_ANGLE] + self.load_angle_low
    }

    pub fn time(&self) -> f64 {
        self.time
    }

    pub fn model(&self) -> &CellModel<P> {
        &self.model
    }

    pub fn cell(&self) -> i64 {
        self.cell
    }

    pub fn mesh(&self) -> [Mesh; P] {
        self.mesh
    }

    #[cfg(test)]
    pub fn load_motion(&self) -> Motion {
        self.load_motion
    }

    #[cfg(test)]
    pub fn motor_motion(&self) -> [Motion; P] {
        self.motor_motion
    }

    pub fn statistics(&self) -> NumericsStatistics {
        self.statistics
    }

    /// Number of discretisations held by the cache.
    pub fn cached_discretisations(&self) -> usize {
        self.cache.len()
    }

    /// Switches to another grid cell. The state is kept: it is expressed in coordinates that
    /// do not depend on the cell.
    pub fn set_cell(&mut self, cell: i64, model: CellModel<P>) {
        self.cell = cell;
        self.model = model;
    }

    /// Everything a step changes, to undo it with [`rollback`](Self::rollback).
    pub fn checkpoint(&mut self) -> Checkpoint<P, S> {
        for k in 0..P {
            if self.config.command_delay[k] > 0.0 {
                self.delay_at_checkpoint[k].copy_from(&self.delay[k]);
            }
        }
        Checkpoint {
            x: self.x,
            load_angle_low: self.load_angle_low,
            load_motion: self.load_motion,
            motor_motion: self.motor_motion,
            mesh: self.mesh,
            anchor: self.anchor,
            time: self.time,
            cell: self.cell,
        }
    }

    /// Puts the drive back where it was at `checkpoint`, the last one taken; `model_of_cell`
    /// gives the model of the checkpoint's cell if the cell changed since.
    pub fn rollback(&mut self, checkpoint: Checkpoint<P, S>, model_of_cell: impl FnOnce(i64) -> CellModel<P>) {
        if self.cell != checkpoint.cell {
            self.set_cell(checkpoint.cell, model_of_cell(checkpoint.cell));
        }
        self.x = checkpoint.x;
        self.load_angle_low = checkpoint.load_angle_low;
        self.load_motion = checkpoint.load_motion;
        self.motor_motion = checkpoint.motor_motion;
        self.mesh = checkpoint.mesh;
        self.anchor = checkpoint.anchor;
        self.time = checkpoint.time;
        for k in 0..P {
            if self.config.command_delay[k] > 0.0 {
                std::mem::swap(&mut self.delay[k], &mut self.delay_at_checkpoint[k]);
            }
        }
    }

    /// True if every state is a finite number. Ten comparisons: cheap enough for every step.
    pub fn is_finite(&self) -> bool {
        self.x.iter().all(|v| v.is_finite()) && self.load_angle_low.is_finite()
    }

    /// The fastest rate of the linear dynamics in use, 1/s, and where it comes from: the
    /// largest of the current-loop bandwidths, the path and viscous rates, and (with backlash)
    /// the spring's relaxation rate in the gap. A NaN rate (0/0) counts as the fastest.
    pub fn fastest_rate(&self) -> (f64, String) {
        self.fastest_rate_of(&self.model)
    }

    /// [`fastest_rate`](Self::fastest_rate) of another cell's model, with this drive's backlash.
    pub fn fastest_rate_of(&self, m: &CellModel<P>) -> (f64, String) {
        let mut rates: Vec<(f64, String)> = Vec::new();
        for k in 0..P {
            let path = if P > 1 { format!(" of path {}", k + 1) } else { String::new() };
            let (stiffness, damping, jm) = (m.stiffness[k], m.damping[k], m.motor_inertia[k]);
            rates.push(((stiffness / jm).sqrt(), format!("sqrt(stiffness{path} / motor inertia)")));
            rates.push(((stiffness / m.load_inertia).sqrt(), format!("sqrt(stiffness{path} / load inertia)")));
            rates.push((damping / jm, format!("damping{path} / motor inertia")));
            rates.push((damping / m.load_inertia, format!("damping{path} / load inertia")));
            if self.config.backlash[k] > 0.0 {
                rates.push((
                    stiffness / damping,
                    format!("stiffness{path} / damping{path} (relaxation in the backlash gap)"),
                ));
            }
            rates.push((m.motor_viscous[k] / jm, format!("viscous friction / inertia of motor {}", k + 1)));
            rates.push((m.current_loop_rad_per_s[k], format!("current-loop bandwidth of motor {}", k + 1)));
            if m.presliding_stiffness[k] > 0.0 {
                rates.push((
                    (m.presliding_stiffness[k] / jm).sqrt(),
                    format!("sqrt(presliding stiffness / inertia of motor {})", k + 1),
                ));
                rates.push((m.presliding_damping[k] / jm, format!("presliding damping / inertia of motor {}", k + 1)));
            }
        }
        rates.push((m.load_viscous / m.load_inertia, "load viscous friction / load inertia".to_string()));
        rates
            .into_iter()
            .max_by(|a, b| a.0.is_nan().cmp(&b.0.is_nan()).then(a.0.total_cmp(&b.0)))
            .expect("at least one rate")
    }

    /// Checks that the dynamics of each of `models` (the cells where the owner's parameters
    /// are most extreme) are no faster than [`MAX_RATE_PER_S`].
    pub fn check_rates(
        &self,
        axis: &'static str,
        models: impl IntoIterator<Item = CellModel<P>>,
    ) -> Result<(), PlantError> {
        let Some((rate, rate_of)) =
            models.into_iter().map(|m| self.fastest_rate_of(&m)).find(|(rate, _)| too_fast(*rate))
        else {
            return Ok(());
        };
        Err(PlantError::TooFast { axis, rate_of, rate, max_rate: MAX_RATE_PER_S })
    }

    /// Why a step may have produced a non-finite state, for the error message: the fastest
    /// rate of the linear dynamics in use when it is too fast, otherwise the inputs.
    pub fn likely_cause_of_non_finite_state(&self, commands: &[f64; P], load_torque_axis: f64) -> String {
        let (rate, source) = self.fastest_rate();
        if too_fast(rate) {
            format!(
                "the drive's fastest rate, {source}, is {rate:.3e} 1/s (the default drive's is about 1.4e3 1/s): \
                 a stiffness, damping or current-loop bandwidth this large, or an inertia this small, \
                 is beyond what the exact discretisation can represent"
            )
        } else {
            format!(
                "the inputs, or the torques and speeds they cause, are too large to represent (current commands \
                 {commands:?} A, load torque {load_torque_axis:e} N m about the axis)"
            )
        }
    }

    /// Path torque at the motor side, N m: what the spring-damper transmits (zero in the gap).
    pub fn path_torque(&self, k: usize) -> f64 {
        Self::path_torque_of(&self.x, &self.model, self.mesh[k], k)
    }

    fn path_torque_of(x: &SVector<f64, S>, model: &CellModel<P>, mesh: Mesh, k: usize) -> f64 {
        match mesh {
            Mesh::Gap => 0.0,
            _ => {
                model.stiffness[k] * (x[twist_index(k)] - x[backlash_index(k)])
                    + model.damping[k] * (x[motor_speed_index(k)] - x[LOAD_SPEED])
            }
        }
    }

    fn mode_bits(&self) -> u32 {
        let mut bits = u32::from(self.load_motion == Motion::Stuck);
        for k in 0..P {
            bits |= u32::from(self.motor_motion[k] == Motion::Stuck) << (1 + k);
            bits |= u32::from(self.mesh[k] == Mesh::Gap) << (1 + P + k);
        }
        bits
    }

    /// Advances by `h` with the current commands (A) and the load torque (N m about the axis)
    /// held constant. `position_torques` returns the position-dependent torques (motor side
    /// per motor, axis side on the load) for a state; it is evaluated at the start of every
    /// internal sub-step and held over it.
    pub fn step(&mut self, commands: [f64; P], load_torque_axis: f64, h: f64, position_torques: PositionTorques<P, S>) {
        let start = self.time;
        self.statistics.steps += 1;
        // Pieces no longer than the event check interval, and no longer than the sub-step when
        // torques that are not piecewise linear are on.
        let longest = if self.needs_substeps {
            self.config.substep.min(self.config.event_check_interval)
        } else {
            self.config.event_check_interval
        };
        let substeps = ceil(h / longest * (1.0 - 1e-12)).max(1.0);
        let delayed = self.config.command_delay.iter().any(|&d| d > 0.0);
        if !delayed {
            // Common case: the commands are constant over the step, which is cut into equal
            // sub-steps (one unless non-piecewise-linear torques are on). Equal lengths keep
            // every sub-step on the same cached discretisation.
            let mut inputs = PieceInputs { commands, motor_torque: [0.0; P], load_torque_axis };
            for k in 0..P {
                let limit = self.config.current_limit[k];
                inputs.commands[k] = commands[k].clamp(-limit, limit);
            }
            let length = h / substeps;
            for _ in 0..substeps as usize {
                self.prepare_piece(&mut inputs, load_torque_axis, position_torques);
                self.advance_piece(length, &inputs);
            }
        } else {
            self.step_with_delay(commands, load_torque_axis, h, substeps, position_torques);
        }
        self.time = start + h;
    }

    /// Samples the position-dependent torques and the Stribeck speeds at the start of a piece.
    fn prepare_piece(
        &mut self,
        inputs: &mut PieceInputs<P>,
        load_torque_axis: f64,
        position_torques: PositionTorques<P, S>,
    ) {
        if self.config.position_dependent_torques {
            let (motor, load) = position_torques(&self.x, &self.model);
            inputs.motor_torque = motor;
            inputs.load_torque_axis = load_torque_axis + load;
        }
        self.stribeck_speed[0] = self.x[LOAD_SPEED] / self.model.gear_ratio;
        for k in 0..P {
            self.stribeck_speed[1 + k] = self.x[motor_speed_index(k)];
        }
    }

    /// A step in which some current command is delayed: the applied command is piecewise
    /// constant, changing one delay after each change of the input, so the step is cut there
    /// as well as on the sub-step grid.
    fn step_with_delay(
        &mut self,
        commands: [f64; P],
        load_torque_axis: f64,
        h: f64,
        substeps: f64,
        position_torques: PositionTorques<P, S>,
    ) {
        let start = self.time;
        for k in 0..P {
            if self.config.command_delay[k] > 0.0 {
                self.delay[k].push(start, commands[k]);
            }
        }
        // Piece boundaries in local time. Times within `snap` of each other are one boundary,
        // so the rounding of the accumulated clock never creates sliver pieces.
        let snap = 64.0 * f64::EPSILON * start.abs().max(1.0) + 1e-12 * h;
        let mut breakpoints = std::mem::take(&mut self.breakpoints);
        breakpoints.clear();
        for j in 1..substeps as usize {
            breakpoints.push(h * j as f64 / substeps);
        }
        for k in 0..P {
            if self.config.command_delay[k] > 0.0 {
                self.delay[k].changes_between(start, start + h, |t| breakpoints.push(t - start));
            }
        }
        breakpoints.push(h);
        breakpoints.sort_by(f64::total_cmp);
        let mut piece_start = 0.0;
        for &piece_end in &breakpoints {
            if piece_end != h && (piece_end - piece_start <= snap || h - piece_end <= snap) {
                continue;
            }
            let middle = start + 0.5 * (piece_start + piece_end);
            let mut inputs = PieceInputs { commands, motor_torque: [0.0; P], load_torque_axis };
            for k in 0..P {
                let command =
                    if self.config.command_delay[k] > 0.0 { self.delay[k].applied_at(middle) } else { commands[k] };
                let limit = self.config.current_limit[k];
                inputs.commands[k] = command.clamp(-limit, limit);
            }
            self.prepare_piece(&mut inputs, load_torque_axis, position_torques);
            self.advance_piece(piece_end - piece_start, &inputs);
            piece_start = piece_end;
        }
        self.breakpoints = breakpoints;
        for k in 0..P {
            self.delay[k].forget_before(start + h);
        }
    }

    /// The input vector `u` for the current mode.
    #[inline]
    fn input_vector(&self, inputs: &PieceInputs<P>) -> SVector<f64, U> {
        let mut u = SVector::<f64, U>::zeros();
        for k in 0..P {
            u[k] = inputs.commands[k];
            u[P + k] = inputs.motor_torque[k]
                - self.motor_friction[k].sliding_torque(self.motor_motion[k], self.stribeck_speed[1 + k]);
        }
        let load_friction = self.load_friction.sliding_torque(self.load_motion, self.stribeck_speed[0]);
        u[2 * P] = (inputs.load_torque_axis - load_friction) / self.model.gear_ratio;
        u
    }

    /// The state after `piece_length / 2^level` in the current mode, except that its
    /// load-angle entry holds the increment of the load angle rather than the angle (see
    /// [`accept`](Self::accept)).
    // Inlined into the piece loop, with the discretisation's look-up out of line in
    // `fetch_ladder`: the common call finds the last ladder and needs nothing else.
    #[inline]
    fn propagate(&mut self, level: u32, u: &SVector<f64, U>) -> SVector<f64, S> {
        let key = DiscretisationKey { mode: self.mode_bits(), cell: self.cell, step_bits: self.piece.0.to_bits() };
        let d = match &self.last {
            Some((k, ladder)) if *k == key && (level as usize) < ladder.rungs.len() => &ladder.rungs[level as usize],
            _ => {
                self.fetch_ladder(key, level);
                &self.last.as_ref().expect("set by fetch_ladder").1.rungs[level as usize]
            }
        };
        // The load angle's column of Ad is exactly a unit vector (nothing depends on the
        // angle), so leaving it out yields the increment in that entry and changes no other.
        // A sticking motor's bristle does depend on the angle: its torque -sigma (d_k + p_L -
        // anchor) is split into the part in the increment of p_L over the piece (in A) and the
        // constant sigma (anchor - p_L) at the piece's start, added to the motor's input here.
        let mut x = self.x;
        x[LOAD_ANGLE] = 0.0;
        if self.any_presliding() {
            let mut u = *u;
            for k in 0..P {
                if self.presliding_sticks(k) {
                    u[P + k] += self.model.presliding_stiffness[k] * (self.anchor[k] - self.load_angle_now());
                }
            }
            return d.ad * x + d.bd * u;
        }
        d.ad * x + d.bd * u
    }

    /// Makes `last` the ladder of `key` with at least `level + 1` rungs: from the cache, or
    /// computed (the top rung, then the finer ones when a piece is subdivided that far).
    #[cold]
    #[inline(never)]
    fn fetch_ladder(&mut self, key: DiscretisationKey, level: u32) {
        let (length, levels) = self.piece;
        if self.last.as_ref().is_none_or(|(k, _)| *k != key) {
            let model = self.model;
            let computed = &mut self.statistics.discretisations_computed;
            let ladder = self.cache.get_or_insert_with(key, || {
                *computed += 1;
                Ladder::top(&model, key.mode, length)
            });
            self.last = Some((key, ladder));
        }
        if level as usize >= self.last.as_ref().expect("set just above").1.rungs.len() {
            let completed =
                Arc::new(self.last.as_ref().expect("set above").1.completed(&self.model, key.mode, length, levels));
            self.statistics.discretisations_computed += 1;
            self.cache.replace(key, Arc::clone(&completed));
            self.last = Some((key, completed));
        }
    }

    /// True if some motor has a presliding element and sticks (the bristle holds it).
    fn any_presliding(&self) -> bool {
        (0..P).any(|k| self.presliding_sticks(k))
    }

    fn presliding_sticks(&self, k: usize) -> bool {
        self.motor_motion[k] == Motion::Stuck && self.model.presliding_stiffness[k] > 0.0
    }

    /// The load angle, motor rad, with its low-order part.
    fn load_angle_now(&self) -> f64 {
        self.x[LOAD_ANGLE] + self.load_angle_low
    }

    /// The bristle torque on sticking motor `k` (the friction it carries, positive opposing
    /// forward motion) for a propagated candidate, whose load-angle entry is the increment.
    fn bristle_torque(&self, candidate: &SVector<f64, S>, k: usize) -> f64 {
        let deflection = candidate[twist_index(k)] + (candidate[LOAD_ANGLE] + self.load_angle_now() - self.anchor[k]);
        self.model.presliding_stiffness[k] * deflection
            + self.model.presliding_damping[k] * candidate[motor_speed_index(k)]
    }

    /// Takes a propagated state, adding its load-angle increment with compensated summation.
    #[inline]
    fn accept(&mut self, mut next: SVector<f64, S>) {
        let increment = next[LOAD_ANGLE];
        let angle = self.x[LOAD_ANGLE];
        let sum = angle + increment;
        self.load_angle_low +=
            if angle.abs() >= increment.abs() { (angle - sum) + increment } else { (increment - sum) + angle };
        next[LOAD_ANGLE] = sum;
        self.x = next;
    }

    /// Number of dyadic halvings that bring a piece down to the event time resolution.
    fn levels_for(&self, length: f64) -> u32 {
        (length / self.config.event_resolution).log2().ceil().clamp(1.0, 40.0) as u32
    }

    /// Advances over one piece with constant inputs, handling mode switches inside it.
    fn advance_piece(&mut self, length: f64, inputs: &PieceInputs<P>) {
        if self.piece.0 != length {
            self.piece = (length, self.levels_for(length));
        }
        let levels = self.piece.1;
        let mut u = self.input_vector(inputs);
        let tentative = self.propagate(0, &u);
        if self.is_consistent(&tentative, inputs) {
            self.accept(tentative);
            return;
        }
        // Work in units of the finest rung; every sub-step is an aligned power-of-two number
        // of units, so it is a rung of the ladder.
        let total: u64 = 1 << levels;
        let mut done: u64 = 0;
        // The whole piece was just tried: begin with its first half.
        let mut first = true;
        while done < total {
            let remaining = total - done;
            let aligned = if done == 0 { levels } else { done.trailing_zeros() };
            let mut units_log2 = aligned.min(63 - remaining.leading_zeros());
            if first {
                units_log2 = levels - 1;
                first = false;
            }
            loop {
                let candidate = self.propagate(levels - units_log2, &u);
                self.statistics.extra_propagations += 1;
                if self.is_consistent(&candidate, inputs) {
                    self.accept(candidate);
                    done += 1 << units_log2;
                    break;
                }
                if units_log2 == 0 {
                    // The event lies within this finest interval: step past it and switch.
                    self.accept(candidate);
                    done += 1;
                    self.statistics.events += 1;
                    self.switch_modes(inputs);
                    u = self.input_vector(inputs);
                    break;
                }
                units_log2 -= 1;
            }
        }
    }

    /// Holding torque on the stuck load, motor side: everything but its friction.
    fn load_holding_torque(&self, x: &SVector<f64, S>, inputs: &PieceInputs<P>) -> f64 {
        let mut torque = inputs.load_torque_axis / self.model.gear_ratio - self.model.load_viscous * x[LOAD_SPEED];
        for k in 0..P {
            torque += Self::path_torque_of(x, &self.model, self.mesh[k], k);
        }
        torque
    }

    /// Holding torque on stuck motor `k`: everything but its friction.
    fn motor_holding_torque(&self, x: &SVector<f64, S>, inputs: &PieceInputs<P>, k: usize) -> f64 {
        self.model.torque_per_amp[k] * x[current_index(k)] + inputs.motor_torque[k]
            - self.model.motor_viscous[k] * x[motor_speed_index(k)]
            - Self::path_torque_of(x, &self.model, self.mesh[k], k)
    }

    #[inline]
    fn is_consistent(&self, x: &SVector<f64, S>, inputs: &PieceInputs<P>) -> bool {
        for k in 0..P {
            let half_gap = 0.5 * self.config.backlash[k];
            if half_gap == 0.0 {
                continue;
            }
            let consistent = match self.mesh[k] {
                Mesh::PositiveFlank => Self::path_torque_of(x, &self.model, self.mesh[k], k) >= 0.0,
                Mesh::NegativeFlank => Self::path_torque_of(x, &self.model, self.mesh[k], k) <= 0.0,
                Mesh::Gap => x[backlash_index(k)].abs() <= half_gap,
            };
            if !consistent {
                return false;
            }
        }
        if self.load_friction.present {
            let consistent = match self.load_motion {
                Motion::Forward => x[LOAD_SPEED] >= 0.0,
                Motion::Backward => x[LOAD_SPEED] <= 0.0,
                Motion::Stuck => self.load_friction.holds(self.load_holding_torque(x, inputs), self.model.gear_ratio),
            };
            if !consistent {
                return false;
            }
        }
        for k in 0..P {
            let friction = &self.motor_friction[k];
            if !friction.present {
                continue;
            }
            let v = x[motor_speed_index(k)];
            let consistent = match self.motor_motion[k] {
                Motion::Forward => v >= 0.0,
                Motion::Backward => v <= 0.0,
                Motion::Stuck if self.model.presliding_stiffness[k] > 0.0 => {
                    friction.holds(self.bristle_torque(x, k), 1.0)
                }
                Motion::Stuck => friction.holds(self.motor_holding_torque(x, inputs, k), 1.0),
            };
            if !consistent {
                return false;
            }
        }
        true
    }

    /// Switches every inconsistent part of the mode, at the current state (just past an event).
    fn switch_modes(&mut self, inputs: &PieceInputs<P>) {
        // Meshes first: they decide which torques reach the bodies.
        for k in 0..P {
            let half_gap = 0.5 * self.config.backlash[k];
            if half_gap == 0.0 {
                continue;
            }
            let torque = self.path_torque(k);
            let beta = backlash_index(k);
            match self.mesh[k] {
                Mesh::PositiveFlank if torque < 0.0 => self.mesh[k] = Mesh::Gap,
                Mesh::NegativeFlank if torque > 0.0 => self.mesh[k] = Mesh::Gap,
                Mesh::Gap if self.x[beta] > half_gap => {
                    self.mesh[k] = Mesh::PositiveFlank;
                    self.x[beta] = half_gap;
                }
                Mesh::Gap if self.x[beta] < -half_gap => {
                    self.mesh[k] = Mesh::NegativeFlank;
                    self.x[beta] = -half_gap;
                }
                _ => {}
            }
        }
        // Bodies whose sliding speed changed sign come to rest at the event; then every body
        // at rest either sticks or slides off in the direction of its holding torque.
        let mut load_candidate = false;
        let mut motor_candidate = [false; P];
        if self.load_friction.present {
            let v = self.x[LOAD_SPEED];
            if (self.load_motion == Motion::Forward && v < 0.0) || (self.load_motion == Motion::Backward && v > 0.0) {
                self.x[LOAD_SPEED] = 0.0;
                load_candidate = true;
            }
        }
        for k in 0..P {
            if !self.motor_friction[k].present {
                continue;
            }
            let v = self.x[motor_speed_index(k)];
            let motion = self.motor_motion[k];
            if (motion == Motion::Forward && v < 0.0) || (motion == Motion::Backward && v > 0.0) {
                // With a presliding element the motor keeps its (tiny) speed: the bristle
                // takes it over; without, it comes to rest exactly.
                if self.model.presliding_stiffness[k] == 0.0 {
                    self.x[motor_speed_index(k)] = 0.0;
                }
                motor_candidate[k] = true;
            }
        }
        if load_candidate || self.load_motion == Motion::Stuck {
            let torque = self.load_holding_torque(&self.x, inputs);
            let next = if self.load_friction.holds(torque, self.model.gear_ratio) {
                self.x[LOAD_SPEED] = 0.0;
                Motion::Stuck
            } else if torque > 0.0 {
                Motion::Forward
            } else {
                Motion::Backward
            };
            if next != Motion::Stuck && self.load_motion == Motion::Stuck {
                self.stribeck_speed[0] = 0.0;
            }
            self.load_motion = next;
        }
        for k in 0..P {
            let sigma = self.model.presliding_stiffness[k];
            if sigma > 0.0 && self.motor_friction[k].present {
                // Presliding: a motor that came to rest sticks to an anchor placed so that the
                // bristle carries the friction it had at zero speed in its direction (torque
                // continuous); a sticking motor slips when the bristle torque passes breakaway,
                // in the direction of that torque, keeping its speed.
                let friction = self.config.motor_friction[k];
                if motor_candidate[k] {
                    let direction = self.motor_motion[k].direction();
                    let level = direction * friction.breakaway(direction);
                    let held = level - self.model.presliding_damping[k] * self.x[motor_speed_index(k)];
                    self.anchor[k] = self.x[twist_index(k)] + self.load_angle_now() - held / sigma;
                    self.motor_motion[k] = Motion::Stuck;
                } else if self.motor_motion[k] == Motion::Stuck {
                    // The accepted state holds the angle itself, not an increment.
                    let mut here = self.x;
                    here[LOAD_ANGLE] = 0.0;
                    let torque = self.bristle_torque(&here, k);
                    if !self.motor_friction[k].holds(torque, 1.0) {
                        self.motor_motion[k] = if torque > 0.0 { Motion::Forward } else { Motion::Backward };
                        self.stribeck_speed[1 + k] = 0.0;
                    }
                }
                continue;
            }
            if motor_candidate[k] || self.motor_motion[k] == Motion::Stuck {
                let torque = self.motor_holding_torque(&self.x, inputs, k);
                let next = if self.motor_friction[k].holds(torque, 1.0) {
                    self.x[motor_speed_index(k)] = 0.0;
                    Motion::Stuck
                } else if torque > 0.0 {
                    Motion::Forward
                } else {
                    Motion::Backward
                };
                if next != Motion::Stuck && self.motor_motion[k] == Motion::Stuck {
                    self.stribeck_speed[1 + k] = 0.0;
                }
                self.motor_motion[k] = next;
            }
        }
    }

    /// Everything that affects the future (not the caches), bitwise.
    pub fn saved_state(&self) -> DriveState {
        let mut state = DriveState {
            time: 0.0,
            cell: 0,
            x: Vec::with_capacity(S),
            load_angle_low: 0.0,
            load_motion: Motion::Forward,
            sensor_clock: SampleClock::default(),
            paths: Vec::with_capacity(P),
        };
        self.save_into(&mut state);
        state
    }

    /// [`saved_state`](Self::saved_state) written over `state`, reusing its vectors (the
    /// runtime keeps a state before every step: this way the step does not allocate). The
    /// sensor clock is left as it is: the plants write their own.
    pub fn save_into(&self, state: &mut DriveState) {
        state.time = self.time;
        state.cell = self.cell;
        state.x.clear();
        state.x.extend_from_slice(self.x.as_slice());
        state.load_angle_low = self.load_angle_low;
        state.load_motion = self.load_motion;
        state.paths.truncate(P);
        while state.paths.len() < P {
            state.paths.push(PathState {
                motor_motion: Motion::Forward,
                mesh: Mesh::PositiveFlank,
                delay: Vec::new(),
                anchor: None,
            });
        }
        for (k, path) in state.paths.iter_mut().enumerate() {
            path.motor_motion = self.motor_motion[k];
            path.mesh = self.mesh[k];
            self.delay[k].entries_into(&mut path.delay);
            path.anchor = (self.model.presliding_stiffness[k] > 0.0).then_some(self.anchor[k]);
        }
    }

    /// Restores what [`saved_state`](Self::saved_state) returned for a drive with the same parameters and
    /// returns the cell index; the caller must install that cell's model with
    /// [`set_cell`](Self::set_cell) before stepping. On error nothing changes.
    pub fn restore(&mut self, state: DriveState) -> Result<i64, StateError> {
        let DriveState { time, cell, x, load_angle_low, load_motion, paths, sensor_clock: _ } = state;
        if x.len() != S {
            return Err(StateError::Size { part: "drive's number of states", in_state: x.len(), expected: S });
        }
        if paths.len() != P {
            return Err(StateError::Size { part: "drive's number of paths", in_state: paths.len(), expected: P });
        }
        let mut anchor = self.anchor;
        for (k, path) in paths.iter().enumerate() {
            match (self.model.presliding_stiffness[k] > 0.0, path.anchor) {
                (true, Some(a)) => anchor[k] = a,
                (false, None) => {}
                _ => return Err(StateError::PathParts { path: k + 1, part: "a presliding element" }),
            }
        }
        for (k, path) in paths.into_iter().enumerate() {
            self.motor_motion[k] = path.motor_motion;
            self.mesh[k] = path.mesh;
            self.delay[k].set_entries(path.delay);
        }
        self.time = time;
        self.cell = cell;
        self.anchor = anchor;
        self.x = SVector::from_column_slice(&x);
        self.load_angle_low = load_angle_low;
        self.load_motion = load_motion;
        Ok(cell)
    }
}

/// Everything of a drive train that determines its future (not the caches), as its FMU state
/// holds it. `docs/plant-model.md` (section 7) describes the fields.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DriveState {
    /// Time since the start, s.
    pub time: f64,
    /// The elevation cell whose frozen parameters the drive uses.
    pub cell: i64,
    /// The state vector `[p_L, v_L, (d_k, v_Mk, i_k, beta_k) per path]`, motor side.
    pub x: Vec<f64>,
    /// The low-order part of the load angle (compensated summation).
    pub load_angle_low: f64,
    pub load_motion: Motion,
    pub paths: Vec<PathState>,
    /// The sensors' sample clock (`sensors.rs`): not the drive's physics, but kept with it so
    /// that a restored state replays the same noise samples. The drive core writes a fresh
    /// clock; the plants put in their own.
    pub sensor_clock: SampleClock,
}

/// One path's part of a [`DriveState`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PathState {
    pub motor_motion: Motion,
    pub mesh: Mesh,
    /// The current commands issued within the delay, `(time issued, command)`, oldest first.
    pub delay: Vec<(f64, f64)>,
    /// The motor's friction anchor, motor rad; present exactly when it has a presliding
    /// element.
    pub anchor: Option<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn single_path_model() -> CellModel<1> {
        CellModel {
            gear_ratio: 100.0,
            load_inertia: 0.01,
            load_viscous: 0.0,
            motor_inertia: [0.006],
            motor_viscous: [1e-3],
            torque_per_amp: [0.8],
            current_loop_rad_per_s: [628.0],
            stiffness: [90.0],
            damping: [0.06],
            presliding_stiffness: [0.0],
            presliding_damping: [0.0],
        }
    }

    #[test]
    fn sticking_rows_and_the_load_angle_column_are_exact_after_discretisation() {
        let model = single_path_model();
        // Load stuck and motor stuck.
        let d = Discretisation::<6, 3>::new(&model, 0b11, 1e-3);
        assert_eq!(d.ad[(LOAD_SPEED, LOAD_SPEED)], 1.0);
        assert_eq!(d.ad[(motor_speed_index(0), motor_speed_index(0))], 1.0);
        for c in 0..6 {
            if c != LOAD_SPEED {
                assert_eq!(d.ad[(LOAD_SPEED, c)], 0.0);
            }
        }
        let free = Discretisation::<6, 3>::new(&model, 0, 1e-3);
        for r in 0..6 {
            assert_eq!(free.ad[(r, LOAD_ANGLE)], if r == LOAD_ANGLE { 1.0 } else { 0.0 });
        }
    }

    #[test]
    fn prepared_friction_levels_give_the_definitions_bits() {
        let element = |coulomb_nm, static_nm, stribeck_velocity_rad_per_s, asymmetry| FrictionParams {
            coulomb_nm,
            static_nm,
            stribeck_velocity_rad_per_s,
            asymmetry,
        };
        let bodies = [
            BodyFriction::single(FrictionParams::NONE),
            BodyFriction::single(element(1500.0, 2000.0, 8.7e-5, 0.0)),
            BodyFriction::single(element(0.3, 0.4, 0.0, -0.2)),
            BodyFriction {
                elements: [element(0.3, 0.4, 1.5, 0.1), element(8.0 / 60.0, 10.0 / 60.0, 0.055 * 60.0, -0.3)],
            },
            BodyFriction { elements: [element(0.0, 0.5, 0.2, 0.0), element(0.2, 0.2, 0.7, 0.05)] },
        ];
        for body in &bodies {
            let levels = FrictionLevels::new(body);
            assert_eq!(levels.present, body.is_present());
            assert_eq!(
                levels.breakaway.map(f64::to_bits),
                [body.breakaway(1.0), body.breakaway(-1.0)].map(f64::to_bits)
            );
            for speed in [0.0, -0.0, 1e-6, -3e-5, 8.7e-5, 0.01, -0.3, 1.0, 2.5, -40.0, 1e4] {
                for motion in [Motion::Forward, Motion::Backward, Motion::Stuck] {
                    // The torque as the integrator computed it before the levels were prepared.
                    let direction = motion.direction();
                    let definition = if direction == 0.0 || !body.is_present() {
                        0.0
                    } else {
                        direction * (body.kinetic(direction) + body.stribeck_excess(direction, speed))
                    };
                    let prepared = levels.sliding_torque(motion, speed);
                    assert_eq!(prepared.to_bits(), definition.to_bits(), "{body:?} {motion:?} at {speed}");
                }
            }
        }
    }
}
