//! An independent truth generator: a reference simulation of one drive axis that writes
//! measured logs with effects the model does not declare.
//!
//! It exists to test the validate tool on data whose truth is known but hidden. It is written
//! separately from the plant FMU and deliberately uses different model forms where reality
//! differs from models: LuGre friction (bristle dynamics, Stribeck curve) where the model has
//! static Coulomb/Stribeck friction, a smooth contact law where the model has a dead zone, a
//! current loop, a sampled cascade controller, band-limited excitation, sensor noise and
//! quantisation. It integrates with RK4 at a high internal rate (20 kHz by default, cut into
//! substeps while the stiff friction bristles relax fast) and logs at
//! a realistic rate (500 Hz by default). The nominal parameters are the model's starting
//! parameter set; each effect is added only in the truth.

pub mod limits;
pub mod scoring;
pub mod second;
pub mod sensors;
pub mod suite;
mod trajectory;

use antenna_validate::measured_log::{Channel, MeasuredLog, Signal};
use antenna_validate::parameters::{names, ParameterSet};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use std::collections::BTreeMap;

pub use sensors::{EncoderError, Harmonic, DEFAULT_ENCODER_HARMONICS};
pub use trajectory::{Trajectory, TrajectoryConfig};

/// Why a truth configuration cannot be built as asked.
#[derive(Debug, thiserror::Error)]
pub enum TruthError {
    /// The intermediate inertia of a three-mass drive must be a fraction strictly between 0
    /// and 1 of the load inertia.
    #[error("the intermediate inertia must be a fraction between 0 and 1 of the load inertia, not {fraction}")]
    IntermediateFraction { fraction: f64 },
    /// Two compliances in series with the nominal path's cannot put the intermediate mode this
    /// low: its frequency is at least twice the locked-motor anti-resonance over the square
    /// root of the intermediate inertia's fraction.
    #[error("a second mode at {hz} Hz is below the lowest two compliances in series reach, {lowest:.3} Hz")]
    SecondModeTooLow { hz: f64, lowest: f64 },
}

/// A progress bar on stderr for a run over `len` items; it draws nothing when stderr is not a
/// terminal (indicatif's default target), so logs and pipes stay clean.
pub fn progress_bar(len: usize, message: &'static str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len as u64).with_message(message);
    if let Ok(style) = indicatif::ProgressStyle::with_template("{msg} {bar:40} {pos}/{len} ({elapsed}, {eta} left)") {
        bar.set_style(style);
    }
    bar
}

/// Nominal plant of the truth, all axis-side except the motor inertia and torque constant.
/// These values are also the model's starting parameter set.
#[derive(Debug, Clone)]
pub struct TruthPlant {
    pub gear_ratio: f64,
    /// Motor side, kg m^2.
    pub motor_inertia: f64,
    /// Motor side, N m/A.
    pub torque_constant: f64,
    pub load_inertia: f64,
    pub stiffness: f64,
    pub damping: f64,
    /// Steady-state friction at the motor referred to the axis: viscous, Coulomb, static level
    /// and Stribeck velocity, the curve the LuGre model slides on.
    pub viscous: f64,
    pub coulomb: f64,
    pub static_friction: f64,
    pub stribeck_velocity: f64,
    /// LuGre bristle deflection at breakaway (axis rad): sets the bristle stiffness
    /// sigma0 = Fs/z0. Truth only. The friction sits at the motor and gearbox, whose contacts
    /// slide after a few micrometres (Armstrong-Helouvry et al. 1994): 1e-7 rad at the axis is
    /// 1.2e-4 rad at the motor shaft, 6 um at a 5 cm pinion radius.
    pub presliding_displacement: f64,
    /// LuGre micro-damping ratio of the bristle-inertia mode. Truth only.
    pub bristle_damping_ratio: f64,
    /// Cogging cycles per motor revolution (from the motor's poles and slots, e.g. 2p or 6p
    /// for p pole pairs): when set, a cogging effect's period is the motor physics' 2 pi /
    /// (N K) at the axis instead of one drawn from the seed. Off (`None`) by default.
    pub cogging_per_motor_rev: Option<u32>,
    /// A third mass: the path splits into a gearbox compliance, an intermediate inertia and a
    /// second compliance before the load. Off (`None`, the two-mass drive) by default.
    pub three_mass: Option<ThreeMass>,
}

/// A three-mass drive: motor, gearbox compliance, intermediate inertia, second compliance,
/// load. The two compliances in series are the nominal path's (so the static twist and the
/// locked-motor anti-resonance the two-mass model knows stay nearly what they were) and the
/// intermediate inertia is taken from the load's (so the total inertia is unchanged): the
/// two-mass model is wrong only by the extra mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThreeMass {
    /// The intermediate inertia as a fraction of the load inertia; the load keeps the rest.
    pub inertia_fraction: f64,
    /// The gearbox's share of the path's compliance (between 0 and 1): the gearbox stiffness
    /// is K / share, the second compliance's K / (1 - share).
    pub gearbox_compliance_share: f64,
    /// Damping ratio of the second compliance over the intermediate and load inertias.
    pub second_damping_ratio: f64,
}

impl ThreeMass {
    /// The split that puts the intermediate inertia's own mode (motor and load held),
    /// sqrt((K1 + K2) / J_i) / 2 pi, at `hz`, with the intermediate inertia a `fraction` of
    /// the load inertia and the gearbox taking the larger share of the compliance. With the
    /// series constraint 1/K1 + 1/K2 = 1/K the shares s and 1 - s satisfy
    /// s (1 - s) = K / (J_i w^2).
    pub fn with_second_mode(plant: &TruthPlant, fraction: f64, hz: f64) -> Result<ThreeMass, TruthError> {
        if !(fraction > 0.0 && fraction < 1.0) {
            return Err(TruthError::IntermediateFraction { fraction });
        }
        let lowest = 2.0 * plant.anti_resonance() / fraction.sqrt();
        let omega = 2.0 * std::f64::consts::PI * hz;
        let product = plant.stiffness / (fraction * plant.load_inertia * omega * omega);
        // Written so that NaN is refused too.
        let reachable = product <= 0.25;
        if !reachable {
            return Err(TruthError::SecondModeTooLow { hz, lowest });
        }
        let share = 0.5 * (1.0 + (1.0 - 4.0 * product).sqrt());
        Ok(ThreeMass { inertia_fraction: fraction, gearbox_compliance_share: share, second_damping_ratio: 0.04 })
    }

    /// The intermediate inertia's own mode (Hz) on this plant, motor and load held.
    pub fn second_mode(&self, plant: &TruthPlant) -> f64 {
        let share = self.gearbox_compliance_share;
        let springs = plant.stiffness / share + plant.stiffness / (1.0 - share);
        (springs / (self.inertia_fraction * plant.load_inertia)).sqrt() / (2.0 * std::f64::consts::PI)
    }
}

impl Default for TruthPlant {
    /// An antenna-like azimuth drive: anti-resonance near 4 Hz, reflected motor inertia about
    /// half the load inertia, friction a noticeable part of the torque at tracking speeds.
    fn default() -> Self {
        let load_inertia = 6.0e4;
        let anti_resonance = 2.0 * std::f64::consts::PI * 4.0;
        let stiffness = load_inertia * anti_resonance * anti_resonance;
        TruthPlant {
            gear_ratio: 1200.0,
            motor_inertia: 0.02,
            torque_constant: 2.0,
            load_inertia,
            stiffness,
            damping: 2.0 * 0.04 * (stiffness * load_inertia).sqrt(),
            viscous: 2.0e4,
            coulomb: 3000.0,
            static_friction: 4000.0,
            stribeck_velocity: 0.002,
            presliding_displacement: 1.0e-7,
            bristle_damping_ratio: 1.0,
            cogging_per_motor_rev: None,
            three_mass: None,
        }
    }
}

impl TruthPlant {
    /// The cogging period at the axis (rad) the motor's poles give, 2 pi / (N K), when
    /// `cogging_per_motor_rev` sets K.
    pub fn cogging_period(&self) -> Option<f64> {
        self.cogging_per_motor_rev
            .filter(|k| *k > 0)
            .map(|k| 2.0 * std::f64::consts::PI / (self.gear_ratio * f64::from(k)))
    }

    /// Motor inertia referred to the axis side.
    pub fn reflected_motor_inertia(&self) -> f64 {
        self.motor_inertia * self.gear_ratio * self.gear_ratio
    }

    /// The anti-resonance (Hz) with the motor locked: sqrt(K / J_L) / 2 pi.
    pub fn anti_resonance(&self) -> f64 {
        (self.stiffness / self.load_inertia).sqrt() / (2.0 * std::f64::consts::PI)
    }

    /// Sets the path stiffness for a locked-motor anti-resonance of `hz`, keeping the path's
    /// damping ratio.
    pub fn set_anti_resonance(&mut self, hz: f64) {
        let ratio = self.damping / (2.0 * (self.stiffness * self.load_inertia).sqrt());
        self.stiffness = self.load_inertia * (2.0 * std::f64::consts::PI * hz).powi(2);
        self.damping = 2.0 * ratio * (self.stiffness * self.load_inertia).sqrt();
    }

    /// The model's starting parameter set: the nominal values, with every effect absent.
    pub fn starting_parameters(&self) -> ParameterSet {
        let mut set = ParameterSet::new();
        set.set(names::GEAR_RATIO, self.gear_ratio);
        set.set(names::MOTOR_INERTIA, self.motor_inertia);
        set.set(names::TORQUE_CONSTANT, self.torque_constant);
        set.set(names::LOAD_INERTIA, self.load_inertia);
        set.set(names::STIFFNESS, self.stiffness);
        set.set(names::DAMPING, self.damping);
        set.set(names::VISCOUS, self.viscous);
        set.set(names::COULOMB, self.coulomb);
        set.set(names::STATIC, self.static_friction);
        set.set(names::STRIBECK_VELOCITY, self.stribeck_velocity);
        set.set(names::ASYMMETRY, 0.0);
        set.set(names::TORQUE_OFFSET, 0.0);
        set.set(names::UNBALANCE_TORQUE, 0.0);
        set.set(names::UNBALANCE_PHASE, 0.0);
        set.set(names::DELAY, 0.0);
        set.set(names::TORQUE_CONSTANT_SCALE, 1.0);
        set.set(names::COGGING_AMPLITUDE, 0.0);
        set.set(names::COGGING_PERIOD, 0.0);
        set.set(names::COGGING_PHASE, 0.0);
        set.set(names::BACKLASH_WIDTH, 0.0);
        set
    }
}

/// An effect present in the truth and absent from the model's starting set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Effect {
    /// Coulomb level raised by this much (N m, axis side); the whole friction curve moves up.
    Coulomb(f64),
    /// Breakaway level raised by this much (N m) at the nominal Stribeck velocity.
    Stribeck(f64),
    /// Friction larger by `a` moving forward and smaller by `a` moving backward (N m).
    Asymmetry(f64),
    /// Constant torque at the motor (N m, axis side).
    TorqueOffset(f64),
    /// Lost motion of this total width (rad), through a smooth contact law.
    Backlash(f64),
    /// True stiffness = nominal * factor.
    StiffnessFactor(f64),
    /// True load inertia = nominal * factor.
    InertiaFactor(f64),
    /// Unbalance torque amplitude (N m) and phase (rad) on the axis angle.
    Unbalance { amplitude: f64, phase: f64 },
    /// The applied torque lags the logged current by this much (s).
    Delay(f64),
    /// True torque constant = nominal * scale.
    TorqueConstantScale(f64),
    /// Position-periodic torque at the motor: amplitude (N m), period and phase in axis-referred
    /// motor angle (rad).
    Cogging { amplitude: f64, period: f64, phase: f64 },
}

impl Effect {
    /// The effect's family name, as the validate tool's candidates are named.
    pub fn family(&self) -> &'static str {
        match self {
            Effect::Coulomb(_) => "coulomb",
            Effect::Stribeck(_) => "stribeck",
            Effect::Asymmetry(_) | Effect::TorqueOffset(_) => "offset",
            Effect::Backlash(_) => "backlash",
            Effect::StiffnessFactor(_) => "stiffness",
            Effect::InertiaFactor(_) => "inertia",
            Effect::Unbalance { .. } => "unbalance",
            Effect::Delay(_) => "delay",
            Effect::TorqueConstantScale(_) => "torque_constant",
            Effect::Cogging { .. } => "cogging",
        }
    }

    /// The truth generator's own name of the effect (asymmetry and offset differ here).
    pub fn kind(&self) -> &'static str {
        match self {
            Effect::Asymmetry(_) => "asymmetry",
            Effect::TorqueOffset(_) => "torque_offset",
            other => other.family(),
        }
    }
}

/// Sensor noise and quantisation of the logged signals.
#[derive(Debug, Clone)]
pub struct NoiseConfig {
    /// White noise on the measured current (A) and its quantisation step (A).
    pub current_sigma: f64,
    pub current_step: f64,
    /// Counts per revolution of the load (axis) encoder and its white noise (rad).
    pub load_encoder_counts: f64,
    pub load_encoder_sigma: f64,
    /// Counts per motor revolution of the motor encoder (referred to the axis via the gear).
    pub motor_encoder_counts: f64,
    /// What the log holds of the motor side.
    pub motor_sensor: MotorSensor,
    /// Motors whose currents the log holds in columns of their own (1 or 2). The truth's drive
    /// is one lumped motor; with 2 each logged current is half of its current with its own
    /// sensor noise and quantisation, as two identical motors without a bias would carry.
    pub motors: usize,
    /// With two motors, a torque bias (A): added to motor 1's current and taken from motor
    /// 2's. The truth's two motors share one lumped path, so the bias cancels in the drive as
    /// it does on a real one without backlash (with backlash a real bias also keeps the
    /// pinions on opposite flanks, which the lumped truth does not).
    pub current_bias: f64,
    /// What the current column holds: the measured current (with the noise above) or the
    /// current loop's command (rounded to `current_step`, no sensor noise, leading the current
    /// the motor carries by the current loop).
    pub current_log: CurrentLog,
    /// The current noise (A) that effect sizes are measured against when it differs from the
    /// logged current's own (a noiseless sensor or a logged command have none, and "ten times
    /// no noise" is no size): `None` is the log's own.
    pub size_current_sigma: Option<f64>,
    /// The load encoder's graduation and eccentricity error, in what the controller reads
    /// and what the log holds (none by default).
    pub load_encoder_error: EncoderError,
    /// How much later (s) than the motor encoder the load encoder is read: a log row stamped
    /// t holds the load angle at t + skew (negative: read earlier). 0 by default.
    pub load_encoder_skew: f64,
    /// How much later (s) than the encoders the current (or its command) is read: a row
    /// stamped t holds the current at t + skew. 0 by default. The controller is not affected:
    /// a skew is a matter of the log's time stamps.
    pub current_skew: f64,
}

/// What a log's current column holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CurrentLog {
    /// The measured current (`motor_current`).
    Measured,
    /// The current loop's command (`motor_current_command`): no sensor noise, and the current
    /// the motor carries lags it by the current loop.
    Command,
}

/// The motor-side sensor a log holds.
#[derive(Debug, Clone, PartialEq)]
pub enum MotorSensor {
    /// The motor encoder (`motor_pos`), as the suite's logs.
    Encoder,
    /// A speed signal instead (`motor_vel`, one per motor).
    Speed(SpeedSensor),
    /// Nothing: the load encoder is the only position (as the paper's closed-loop logs).
    None,
}

/// A motor speed signal instead of a motor encoder, as a servo amplifier's analogue speed
/// output (the paper's identification logged these): the true motor speed referred to the axis
/// times (1 + scale_error), plus a bias, a drift of that bias and white noise, all axis side.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedSensor {
    /// White noise at the log instants (rad/s).
    pub sigma: f64,
    pub bias: f64,
    pub scale_error: f64,
    /// RMS over the log (rad/s) of a bias drift, a random walk from the log's seed (a tacho
    /// whose offset wanders with temperature); 0 is no drift.
    pub drift: f64,
}

impl Default for SpeedSensor {
    /// A digital drive's speed estimate through an analogue output: 2e-6 rad/s at the axis
    /// (0.023 rpm at a 1200:1 motor), a bias of a tenth of that and a 0.5 % scale tolerance.
    fn default() -> Self {
        SpeedSensor { sigma: 2.0e-6, bias: 2.0e-7, scale_error: 5.0e-3, drift: 0.0 }
    }
}

impl Default for NoiseConfig {
    fn default() -> Self {
        NoiseConfig {
            current_sigma: 0.0125,
            current_step: 1e-3,
            load_encoder_counts: 2f64.powi(25),
            load_encoder_sigma: 1.0e-7,
            motor_encoder_counts: 2f64.powi(20),
            motor_sensor: MotorSensor::Encoder,
            motors: 1,
            current_bias: 0.0,
            current_log: CurrentLog::Measured,
            size_current_sigma: None,
            load_encoder_error: EncoderError::default(),
            load_encoder_skew: 0.0,
            current_skew: 0.0,
        }
    }
}

impl NoiseConfig {
    /// Standard deviation of the logged torque noise, axis side (N m).
    pub fn torque_sigma(&self, plant: &TruthPlant) -> f64 {
        let per_motor = self.current_sigma.powi(2) + self.current_step.powi(2) / 12.0;
        plant.gear_ratio * plant.torque_constant * (per_motor * self.motors.max(1) as f64).sqrt()
    }

    /// The torque noise effect sizes are measured against (axis side, N m): the logged
    /// torque's own, or the one `size_current_sigma` names.
    pub fn size_torque_sigma(&self, plant: &TruthPlant) -> f64 {
        match self.size_current_sigma {
            Some(sigma) => NoiseConfig { current_sigma: sigma, ..self.clone() }.torque_sigma(plant),
            None => self.torque_sigma(plant),
        }
    }

    /// Standard deviation of the measured twist (motor minus load encoder), rad.
    pub fn twist_sigma(&self, plant: &TruthPlant) -> f64 {
        let load_step = 2.0 * std::f64::consts::PI / self.load_encoder_counts;
        let motor_step = 2.0 * std::f64::consts::PI / (self.motor_encoder_counts * plant.gear_ratio);
        (self.load_encoder_sigma.powi(2) + load_step.powi(2) / 12.0 + motor_step.powi(2) / 12.0).sqrt()
    }
}

/// Everything one truth run needs.
#[derive(Debug, Clone)]
pub struct TruthConfig {
    pub plant: TruthPlant,
    pub effects: Vec<Effect>,
    pub noise: NoiseConfig,
    pub trajectory: TrajectoryConfig,
    pub duration: f64,
    pub internal_rate: f64,
    pub controller_rate: f64,
    pub log_rate: f64,
    /// Current-loop bandwidth (Hz).
    pub current_bandwidth: f64,
    /// Position and velocity loop bandwidths (Hz).
    pub position_bandwidth: f64,
    pub velocity_bandwidth: f64,
    /// Standard deviation (N m, axis side) of the band-limited noise torque injected on top of
    /// the tracking command, as in the paper's identification, and its bandwidth (Hz).
    pub injection_sigma: f64,
    pub injection_bandwidth: f64,
    pub seed: u64,
    /// A seed of the sensor noise alone (the current's and the load encoder's), apart from the
    /// seed of the excitation (the trajectory and the injected torque): the same excitation
    /// with another noise draw, to tell how an estimate scatters over the noise from how it
    /// scatters over excitations. `None` draws the noise from the one seed, as the suite does.
    pub noise_seed: Option<u64>,
    /// Log the axis as a linear one (positions in m, speeds in m/s: an axis of unit radius, so
    /// the numbers are the rotary drive's and only the units differ).
    pub linear: bool,
}

impl Default for TruthConfig {
    fn default() -> Self {
        TruthConfig {
            plant: TruthPlant::default(),
            effects: Vec::new(),
            noise: NoiseConfig::default(),
            trajectory: TrajectoryConfig::default(),
            duration: 60.0,
            internal_rate: 20_000.0,
            controller_rate: 2_000.0,
            log_rate: 500.0,
            current_bandwidth: 100.0,
            position_bandwidth: 1.0,
            velocity_bandwidth: 4.0,
            injection_sigma: 800.0,
            injection_bandwidth: 20.0,
            seed: 1,
            noise_seed: None,
            linear: false,
        }
    }
}

/// The result of a truth run: the log and the noise-free signals at the log instants, which
/// the suite uses to size effects (never given to the validate tool).
#[derive(Debug, Clone)]
pub struct TruthRun {
    pub log: MeasuredLog,
    pub clean: CleanSignals,
}

/// Noise-free truth signals at the log instants.
#[derive(Debug, Clone, Default)]
pub struct CleanSignals {
    pub motor_pos: Vec<f64>,
    pub motor_vel: Vec<f64>,
    pub load_pos: Vec<f64>,
    pub load_vel: Vec<f64>,
    pub load_acc: Vec<f64>,
    /// Applied torque on the motor, axis side (N m), and the shaft torque.
    pub applied_torque: Vec<f64>,
    pub shaft_torque: Vec<f64>,
    /// Applied torque at the internal rate, for sizing a delay.
    pub applied_torque_fine: Vec<f64>,
    pub fine_dt: f64,
}

/// Parameters of the truth with its effects applied.
struct Actual {
    p: TruthPlant,
    k_scale: f64,
    offset: f64,
    asymmetry: f64,
    backlash: f64,
    unbalance: (f64, f64),
    delay: f64,
    cogging: (f64, f64, f64),
    /// The three-mass drive's path, when the plant has one.
    stage: Option<Stage>,
}

/// The path of a three-mass drive with the effects applied: the gearbox spring and damper
/// (k1, c1, with the backlash), the intermediate inertia, the second spring and damper (k2,
/// c2) and the load's remaining inertia.
#[derive(Debug, Clone, Copy)]
struct Stage {
    k1: f64,
    c1: f64,
    intermediate_inertia: f64,
    k2: f64,
    c2: f64,
    load_inertia: f64,
}

impl Stage {
    /// The split of the path `p` (effects applied). The gearbox damper keeps the path's loss
    /// factor c/K; the second damper gets its own damping ratio over the two inertias.
    fn new(p: &TruthPlant, three: &ThreeMass) -> Stage {
        let share = three.gearbox_compliance_share;
        let intermediate_inertia = three.inertia_fraction * p.load_inertia;
        let load_inertia = p.load_inertia - intermediate_inertia;
        let k2 = p.stiffness / (1.0 - share);
        let reduced = intermediate_inertia * load_inertia / p.load_inertia;
        Stage {
            k1: p.stiffness / share,
            c1: p.damping / share,
            intermediate_inertia,
            k2,
            c2: 2.0 * three.second_damping_ratio * (k2 * reduced).sqrt(),
            load_inertia,
        }
    }

    /// A bound on the rates of the intermediate mass's motion: its mode with both sides held
    /// and its dampers' relaxation.
    fn fastest_rate(&self) -> f64 {
        let j = self.intermediate_inertia;
        ((self.k1 + self.k2) / j + self.k2 / self.load_inertia).sqrt()
            + (self.c1 + self.c2) / j
            + self.c2 / self.load_inertia
    }
}

impl Actual {
    fn new(config: &TruthConfig) -> Actual {
        let mut a = Actual {
            p: config.plant.clone(),
            k_scale: 1.0,
            offset: 0.0,
            asymmetry: 0.0,
            backlash: 0.0,
            unbalance: (0.0, 0.0),
            delay: 0.0,
            cogging: (0.0, 1.0, 0.0),
            stage: None,
        };
        for effect in &config.effects {
            match *effect {
                Effect::Coulomb(d) => {
                    a.p.coulomb += d;
                    a.p.static_friction += d;
                }
                Effect::Stribeck(d) => a.p.static_friction += d,
                Effect::Asymmetry(x) => a.asymmetry += x,
                Effect::TorqueOffset(x) => a.offset += x,
                Effect::Backlash(b) => a.backlash += b,
                Effect::StiffnessFactor(f) => a.p.stiffness *= f,
                Effect::InertiaFactor(f) => a.p.load_inertia *= f,
                Effect::Unbalance { amplitude, phase } => a.unbalance = (amplitude, phase),
                Effect::Delay(d) => a.delay += d,
                Effect::TorqueConstantScale(s) => a.k_scale *= s,
                Effect::Cogging { amplitude, period, phase } => a.cogging = (amplitude, period, phase),
            }
        }
        a.stage = config.plant.three_mass.as_ref().map(|three| Stage::new(&a.p, three));
        a
    }

    /// Shaft torque through a smooth contact law: a dead zone of width `backlash` whose corners
    /// are rounded over a tenth of the width (a Hertz-like soft contact rather than the model's
    /// sharp dead zone). With no backlash it is the linear spring and damper.
    fn shaft_torque(&self, twist: f64, twist_rate: f64) -> f64 {
        match &self.stage {
            Some(stage) => self.contact_torque(stage.k1, stage.c1, twist, twist_rate),
            None => self.contact_torque(self.p.stiffness, self.p.damping, twist, twist_rate),
        }
    }

    /// The contact law of [`Actual::shaft_torque`] for a spring `stiffness` and damper
    /// `damping`.
    fn contact_torque(&self, stiffness: f64, damping: f64, twist: f64, twist_rate: f64) -> f64 {
        let h = 0.5 * self.backlash;
        if h <= 0.0 {
            return stiffness * twist + damping * twist_rate;
        }
        let eps = 0.1 * self.backlash;
        let r1 = ((twist - h).powi(2) + eps * eps).sqrt();
        let r2 = ((twist + h).powi(2) + eps * eps).sqrt();
        let deflection = 0.5 * (twist - h + r1) + 0.5 * (twist + h - r2);
        let contact = 0.5 * (1.0 + (twist - h) / r1) + 0.5 * (1.0 - (twist + h) / r2);
        stiffness * deflection + damping * twist_rate * contact
    }

    /// The fastest rate (1/s) of the friction dynamics at motor speed `v`: the bristle
    /// relaxation sigma0 |v| / g (with the lowest sliding level g the curve can take), the
    /// micro-damping sigma1 / J_M and the bristle-inertia mode sqrt(sigma0 / J_M), summed as a
    /// bound.
    fn fastest_rate(&self, v: f64) -> f64 {
        let p = &self.p;
        let sigma0 = p.static_friction.max(1.0) / p.presliding_displacement;
        let lowest_level =
            (p.coulomb.min(p.static_friction) - self.asymmetry.abs()).max(1e-6 * p.static_friction.max(1.0));
        let motor = p.reflected_motor_inertia();
        let sigma1 = 2.0 * p.bristle_damping_ratio * (sigma0 * motor).sqrt();
        let friction = sigma0 * v.abs() / lowest_level + sigma1 / motor + (sigma0 / motor).sqrt();
        match &self.stage {
            Some(stage) => friction + stage.fastest_rate(),
            None => friction,
        }
    }

    /// LuGre friction (Canudas de Wit et al. 1995) with a Stribeck curve, velocity-dependent
    /// micro-damping and the asymmetry added to the sliding level. Returns (torque, dz/dt).
    fn lugre(&self, v: f64, z: f64) -> (f64, f64) {
        let p = &self.p;
        let stribeck = (-(v / p.stribeck_velocity).powi(2)).exp();
        let g = p.coulomb
            + (p.static_friction - p.coulomb) * stribeck
            + self.asymmetry * (v / (0.1 * p.stribeck_velocity)).tanh();
        let g = g.max(1e-6 * p.static_friction.max(1.0));
        let sigma0 = p.static_friction.max(1.0) / p.presliding_displacement;
        let sigma1 = 2.0 * p.bristle_damping_ratio * (sigma0 * p.reflected_motor_inertia()).sqrt() * stribeck;
        let dz = v - sigma0 * v.abs() * z / g;
        (sigma0 * z + sigma1 * dz + p.viscous * v, dz)
    }
}

impl Actual {
    /// The state derivative with the applied torque held, the shaft torque (at the motor) and
    /// the load acceleration. State: motor angle, motor speed, load angle, load speed (axis
    /// side), LuGre bristle z, actual current (whose derivative the caller sets), and the
    /// intermediate inertia's angle and speed (constant in a two-mass drive).
    fn derivative(&self, x: &[f64; STATES], applied: f64) -> ([f64; STATES], f64, f64) {
        let two_pi = 2.0 * std::f64::consts::PI;
        // The motor's spring ends at the intermediate inertia in a three-mass drive.
        let (far, far_speed) = if self.stage.is_some() { (x[6], x[7]) } else { (x[2], x[3]) };
        let twist = x[0] - far;
        let shaft = self.shaft_torque(twist, x[1] - far_speed);
        let (friction, dz) = self.lugre(x[1], x[4]);
        let (amp, period, phase) = self.cogging;
        let cogging = if amp != 0.0 { amp * (two_pi * x[0] / period + phase).sin() } else { 0.0 };
        let unbalance = self.unbalance.0 * (x[2] + self.unbalance.1).cos();
        let motor_acc = (applied - shaft - friction - self.offset - cogging) / self.p.reflected_motor_inertia();
        if let Some(stage) = &self.stage {
            let second = stage.k2 * (x[6] - x[2]) + stage.c2 * (x[7] - x[3]);
            let middle_acc = (shaft - second) / stage.intermediate_inertia;
            let load_acc = (second - unbalance) / stage.load_inertia;
            return ([x[1], motor_acc, x[3], load_acc, dz, 0.0, x[7], middle_acc], shaft, load_acc);
        }
        let load_acc = (shaft - unbalance) / self.p.load_inertia;
        ([x[1], motor_acc, x[3], load_acc, dz, 0.0, 0.0, 0.0], shaft, load_acc)
    }
}

/// The sampled cascade controller (position, velocity with integrator, acceleration
/// feed-forward, band-limited noise injection), tuned on the nominal plant as a commissioning
/// engineer would, and its state.
struct Controller {
    kp: f64,
    kv: f64,
    ki: f64,
    total_inertia: f64,
    current_limit: f64,
    tc: f64,
    speed_alpha: f64,
    injection_alpha: f64,
    injection_gain: f64,
    /// Torque-to-current factor: gear ratio times nominal torque constant.
    torque_per_amp: f64,
    integrator: f64,
    /// The current command.
    i_cmd: f64,
    motor_prev: f64,
    speed_estimate: f64,
    injection: (f64, f64),
}

impl Controller {
    fn new(config: &TruthConfig, tc: f64, unbalance0: f64, motor_start: f64) -> Controller {
        let nominal = &config.plant;
        let two_pi = 2.0 * std::f64::consts::PI;
        let total_inertia = nominal.reflected_motor_inertia() + nominal.load_inertia;
        let kv = total_inertia * two_pi * config.velocity_bandwidth;
        let injection_alpha = (-two_pi * config.injection_bandwidth * tc).exp();
        // Two cascaded first-order stages driven by unit white noise have the impulse response
        // (1-a)^2 (k+1) a^k, whose energy is (1-a)^4 (1+a^2)/(1-a^2)^3: this gain makes the
        // injected torque's standard deviation injection_sigma.
        let ia = injection_alpha;
        let injection_gain =
            config.injection_sigma / ((1.0 - ia).powi(4) * (1.0 + ia * ia) / (1.0 - ia * ia).powi(3)).sqrt();
        let torque_per_amp = nominal.gear_ratio * nominal.torque_constant;
        Controller {
            kp: two_pi * config.position_bandwidth,
            kv,
            ki: kv * two_pi * config.velocity_bandwidth / 5.0,
            total_inertia,
            current_limit: 50.0,
            tc,
            speed_alpha: (-two_pi * 300.0 * tc).exp(),
            injection_alpha,
            injection_gain,
            torque_per_amp,
            integrator: unbalance0,
            i_cmd: unbalance0 / torque_per_amp,
            motor_prev: motor_start,
            speed_estimate: 0.0,
            injection: (0.0, 0.0),
        }
    }

    /// One controller sample at time `t` from the measured load and motor angles; updates the
    /// current command. `noise` is a unit normal draw for the injection.
    fn sample(&mut self, t: f64, load_meas: f64, motor_meas: f64, trajectory: &Trajectory, noise: f64) {
        let raw_speed = (motor_meas - self.motor_prev) / self.tc;
        self.motor_prev = motor_meas;
        self.speed_estimate = self.speed_alpha * self.speed_estimate + (1.0 - self.speed_alpha) * raw_speed;
        let (r, v, a) = (trajectory.position(t), trajectory.velocity(t), trajectory.acceleration(t));
        let speed_command = v + self.kp * (r - load_meas);
        let speed_error = speed_command - self.speed_estimate;
        let (inj1, inj2) = &mut self.injection;
        *inj1 = self.injection_alpha * *inj1 + (1.0 - self.injection_alpha) * noise;
        *inj2 = self.injection_alpha * *inj2 + (1.0 - self.injection_alpha) * *inj1;
        let torque_command =
            self.kv * speed_error + self.integrator + self.total_inertia * a + self.injection_gain * *inj2;
        let unclamped = torque_command / self.torque_per_amp;
        self.i_cmd = unclamped.clamp(-self.current_limit, self.current_limit);
        if unclamped == self.i_cmd {
            self.integrator += self.ki * speed_error * self.tc;
        }
    }
}

/// The logged signals and the clean truth at the log instants, as the run goes.
struct Recorder {
    time: Vec<f64>,
    current: Vec<f64>,
    current_2: Vec<f64>,
    speeds: Vec<Vec<f64>>,
    reference: Vec<f64>,
    motor: Vec<f64>,
    load: Vec<f64>,
    /// The white noise drawn for each logged current and load reading, kept so that a skewed
    /// reading carries the same noise as the unskewed one would.
    current_noise: Vec<f64>,
    current_2_noise: Vec<f64>,
    load_noise: Vec<f64>,
    clean: CleanSignals,
}

impl Recorder {
    fn new(samples: usize, motors: usize, fine_dt: f64) -> Recorder {
        Recorder {
            time: Vec::with_capacity(samples),
            current: Vec::with_capacity(samples),
            current_2: Vec::new(),
            speeds: vec![Vec::new(); motors],
            reference: Vec::with_capacity(samples),
            motor: Vec::with_capacity(samples),
            load: Vec::with_capacity(samples),
            current_noise: Vec::with_capacity(samples),
            current_2_noise: Vec::new(),
            load_noise: Vec::with_capacity(samples),
            clean: CleanSignals { fine_dt, ..Default::default() },
        }
    }

    /// The noise-free truth at a log instant: state `x` with the `applied` torque.
    fn push_clean(&mut self, x: &[f64; STATES], applied: f64, actual: &Actual) {
        let (_, shaft, load_acc) = actual.derivative(x, applied);
        let clean = &mut self.clean;
        clean.motor_pos.push(x[0]);
        clean.motor_vel.push(x[1]);
        clean.load_pos.push(x[2]);
        clean.load_vel.push(x[3]);
        clean.load_acc.push(load_acc);
        clean.applied_torque.push(applied);
        clean.shaft_torque.push(shaft);
    }

    /// Reads the load encoder and the currents again at the instants their skews shift them
    /// to, from the true signals at the internal rate (not from the log), with the noise each
    /// row drew.
    fn read_skewed(&mut self, fine: &FineTrace, sensors: &Sensors, config: &TruthConfig, motors: usize) {
        let dt = self.clean.fine_dt;
        let (load_skew, current_skew) = (config.noise.load_encoder_skew, config.noise.current_skew);
        let bias = if motors == 2 { config.noise.current_bias } else { 0.0 };
        for (row, &t) in self.time.iter().enumerate() {
            if load_skew != 0.0 {
                let q = sensors::sample_linear(&fine.load, dt, t + load_skew);
                self.load[row] = sensors.load(q, self.load_noise[row]);
            }
            if current_skew != 0.0 {
                let at = t + current_skew;
                let actual = sensors::sample_linear(&fine.current, dt, at);
                let command = sensors::sample_held(&fine.command, dt, at);
                self.current[row] = sensors.current(actual, command, motors, bias, self.current_noise[row]);
                if motors == 2 {
                    self.current_2[row] = sensors.current(actual, command, motors, -bias, self.current_2_noise[row]);
                }
            }
        }
    }

    /// The measured log: the channels the configured sensors give.
    fn into_run(self, config: &TruthConfig, motors: usize) -> TruthRun {
        let mut metadata = BTreeMap::new();
        metadata.insert("generated_by".to_string(), "truthgen (antenna-tools)".to_string());
        let channel = |signal: Signal, motor: Option<u32>, values: Vec<f64>| Channel {
            signal,
            motor,
            column: String::new(),
            unit: String::new(),
            values,
        };
        let numbered = |k: u32| (motors == 2).then_some(k);
        let current_signal = match config.noise.current_log {
            CurrentLog::Measured => Signal::MotorCurrent,
            CurrentLog::Command => Signal::MotorCurrentCommand,
        };
        let mut channels =
            vec![channel(Signal::RefPos, None, self.reference), channel(current_signal, numbered(1), self.current)];
        if motors == 2 {
            channels.push(channel(current_signal, numbered(2), self.current_2));
        }
        match config.noise.motor_sensor {
            MotorSensor::Encoder => channels.push(channel(Signal::MotorPos, None, self.motor)),
            MotorSensor::Speed(_) => {
                for (k, speeds) in self.speeds.into_iter().enumerate() {
                    channels.push(channel(Signal::MotorVel, numbered(k as u32 + 1), speeds));
                }
            }
            MotorSensor::None => {}
        }
        channels.push(channel(Signal::LoadPos, None, self.load));
        let log = MeasuredLog { metadata, time: self.time, channels, notes: Vec::new() };
        TruthRun { log, clean: self.clean }
    }
}

/// The applied torque's recent history (the actual current, one entry per internal step) for
/// the delay effect.
struct CurrentHistory {
    values: Vec<f64>,
    head: usize,
    delay_steps: f64,
}

impl CurrentHistory {
    fn new(delay_steps: f64, current: f64) -> CurrentHistory {
        CurrentHistory { values: vec![current; delay_steps.ceil() as usize + 2], head: 0, delay_steps }
    }

    fn applied(&self, gain: f64) -> f64 {
        applied_torque(&self.values, self.head, self.delay_steps, gain)
    }

    fn push(&mut self, current: f64) {
        self.head = (self.head + 1) % self.values.len();
        self.values[self.head] = current;
    }
}

/// Advances the state over one internal step `h` with the applied torque held and the current
/// following its command through a first-order loop of time constant `tau_current`.
///
/// The bristle state relaxes at sigma0 |v| / g, which at full speed is far faster than the
/// internal rate: the step is cut into as many RK4 substeps as keep the fastest rate times the
/// substep at or below one (accurate, and well inside RK4's stability limit of 2.8), so stiff
/// bristles cost time only while the motor slides fast.
fn rk4_step(x: &mut [f64; STATES], applied: f64, i_cmd: f64, tau_current: f64, h: f64, actual: &Actual) {
    let f = |s: &[f64; STATES]| {
        let (mut d, _, _) = actual.derivative(s, applied);
        d[5] = (i_cmd - s[5]) / tau_current;
        d
    };
    let substeps = ((h * actual.fastest_rate(x[1])).ceil() as usize).clamp(1, 10_000);
    let hs = h / substeps as f64;
    for _ in 0..substeps {
        let k1 = f(x);
        let k2 = f(&add(x, &k1, 0.5 * hs));
        let k3 = f(&add(x, &k2, 0.5 * hs));
        let k4 = f(&add(x, &k3, hs));
        for i in 0..STATES {
            x[i] += hs / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }
}

/// Runs the truth simulation and returns the log and the clean signals.
pub fn simulate(config: &TruthConfig) -> TruthRun {
    let actual = Actual::new(config);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(config.seed);
    // The sensors a log variant adds (a second current, a speed signal) draw from a stream of
    // their own, so the default logs stay bit for bit what they were.
    let mut sensor_rng = rand_chacha::ChaCha8Rng::seed_from_u64(config.seed ^ 0x5e50_5e50_5e50_5e50);
    // With a noise seed of its own, the sensor noise comes from a stream apart from the
    // excitation's; without it from the one stream, so the default logs keep every bit.
    let mut noise_rng = config.noise_seed.map(|s| rand_chacha::ChaCha8Rng::seed_from_u64(s ^ 0x0015_e5ee_d000_0001));
    let motors = config.noise.motors.clamp(1, 2);
    let unit_normal = Normal::new(0.0, 1.0).expect("unit normal");
    let trajectory = Trajectory::generate(&config.trajectory, config.duration, config.seed);

    let h = 1.0 / config.internal_rate;
    let steps = (config.duration * config.internal_rate).round() as usize;
    let control_every = (config.internal_rate / config.controller_rate).round().max(1.0) as usize;
    let log_every = (config.internal_rate / config.log_rate).round().max(1.0) as usize;
    let tc = control_every as f64 * h;
    let (n_ratio, kt) = (config.plant.gear_ratio, config.plant.torque_constant);
    let two_pi = 2.0 * std::f64::consts::PI;
    let sensors = Sensors::new(config);
    let tau_current = 1.0 / (two_pi * config.current_bandwidth);

    // State: motor angle, motor speed, load angle, load speed (axis side), LuGre bristle z,
    // actual current, intermediate angle and speed. Start at rest in equilibrium with gravity
    // through the path.
    let start = trajectory.position(0.0);
    let mut x = [start, 0.0, start, 0.0, 0.0, 0.0, 0.0, 0.0];
    let unbalance0 = actual.unbalance.0 * (start + actual.unbalance.1).cos();
    x[0] += unbalance0 / actual.p.stiffness.max(1.0);
    if let Some(stage) = &actual.stage {
        x[6] = start + unbalance0 / stage.k2.max(1.0);
    }
    let mut controller = Controller::new(config, tc, unbalance0, sensors.motor(x[0]));
    x[5] = controller.i_cmd;
    let mut history = CurrentHistory::new(actual.delay / h, controller.i_cmd);
    let mut record = Recorder::new(steps / log_every + 1, motors, h);
    // The true signals at every internal step, only when a skewed reading needs them.
    let skewed = config.noise.load_encoder_skew != 0.0 || config.noise.current_skew != 0.0;
    let mut fine = skewed.then(|| FineTrace::with_capacity(steps + 1));

    for step in 0..=steps {
        let t = step as f64 * h;
        if step % control_every == 0 {
            let load_noise = unit_normal.sample(noise_rng.as_mut().unwrap_or(&mut rng));
            let load_meas = sensors.load(x[2], config.noise.load_encoder_sigma * load_noise);
            let motor_meas = sensors.motor(x[0]);
            controller.sample(t, load_meas, motor_meas, &trajectory, unit_normal.sample(&mut rng));
        }
        if let Some(fine) = &mut fine {
            fine.push(x[2], x[5], controller.i_cmd);
        }
        if step % log_every == 0 {
            let bias = if motors == 2 { config.noise.current_bias } else { 0.0 };
            let noise = config.noise.current_sigma * unit_normal.sample(noise_rng.as_mut().unwrap_or(&mut rng));
            record.time.push(t);
            record.current.push(sensors.current(x[5], controller.i_cmd, motors, bias, noise));
            record.current_noise.push(noise);
            if motors == 2 {
                let noise = config.noise.current_sigma * unit_normal.sample(&mut sensor_rng);
                record.current_2.push(sensors.current(x[5], controller.i_cmd, motors, -bias, noise));
                record.current_2_noise.push(noise);
            }
            if let MotorSensor::Speed(sensor) = &config.noise.motor_sensor {
                for speeds in record.speeds.iter_mut() {
                    speeds.push(
                        (1.0 + sensor.scale_error) * x[1]
                            + sensor.bias
                            + sensor.sigma * unit_normal.sample(&mut sensor_rng),
                    );
                }
            }
            record.reference.push(trajectory.position(t));
            record.motor.push(sensors.motor(x[0]));
            let noise = config.noise.load_encoder_sigma * unit_normal.sample(noise_rng.as_mut().unwrap_or(&mut rng));
            record.load.push(sensors.load(x[2], noise));
            record.load_noise.push(noise);
            let applied = history.applied(actual.k_scale * n_ratio * kt);
            record.push_clean(&x, applied, &actual);
        }
        if step == steps {
            break;
        }
        // The applied torque is held over the internal step: the current loop is much slower
        // than the internal rate, so this costs nothing in accuracy and keeps RK4 simple.
        let applied = history.applied(actual.k_scale * n_ratio * kt);
        record.clean.applied_torque_fine.push(applied);
        rk4_step(&mut x, applied, controller.i_cmd, tau_current, h, &actual);
        history.push(x[5]);
    }
    if let Some(fine) = &fine {
        record.read_skewed(fine, &sensors, config, motors);
    }
    if let MotorSensor::Speed(sensor) = &config.noise.motor_sensor {
        if sensor.drift > 0.0 {
            for (column, speeds) in record.speeds.iter_mut().enumerate() {
                let drift = sensors::random_walk_drift(speeds.len(), sensor.drift, config.seed, column as u64);
                speeds.iter_mut().zip(drift).for_each(|(speed, d)| *speed += d);
            }
        }
    }
    record.into_run(config, motors)
}

/// How the log's sensors read the true signals: quantisation steps, the load encoder's error
/// harmonics and the current's form.
struct Sensors {
    load_step: f64,
    motor_step: f64,
    current_step: f64,
    current_log: CurrentLog,
    encoder_terms: Vec<Harmonic>,
}

/// `x` rounded to the nearest multiple of `step`.
fn quantise(x: f64, step: f64) -> f64 {
    (x / step).round() * step
}

impl Sensors {
    fn new(config: &TruthConfig) -> Sensors {
        let two_pi = 2.0 * std::f64::consts::PI;
        Sensors {
            load_step: two_pi / config.noise.load_encoder_counts,
            motor_step: two_pi / (config.noise.motor_encoder_counts * config.plant.gear_ratio),
            current_step: config.noise.current_step,
            current_log: config.noise.current_log,
            encoder_terms: config.noise.load_encoder_error.terms(config.seed),
        }
    }

    /// The load encoder's reading of the true load angle `q` with the white `noise` (rad).
    fn load(&self, q: f64, noise: f64) -> f64 {
        // Without an error the sum is left out, so the default logs keep every bit.
        let read = if self.encoder_terms.is_empty() { q } else { q + sensors::encoder_error(&self.encoder_terms, q) };
        quantise(read + noise, self.load_step)
    }

    /// The motor encoder's reading of the motor angle (axis side).
    fn motor(&self, q: f64) -> f64 {
        quantise(q, self.motor_step)
    }

    /// One motor's logged current: its share of the `actual` current with `bias` and `noise`,
    /// or its share of the `command` with the bias.
    fn current(&self, actual: f64, command: f64, motors: usize, bias: f64, noise: f64) -> f64 {
        match self.current_log {
            CurrentLog::Measured => quantise(actual / motors as f64 + bias + noise, self.current_step),
            CurrentLog::Command => quantise(command / motors as f64 + bias, self.current_step),
        }
    }
}

/// The true load angle, actual current and current command at every internal step, for
/// readings at instants skewed against the log's time stamps.
struct FineTrace {
    load: Vec<f64>,
    current: Vec<f64>,
    command: Vec<f64>,
}

impl FineTrace {
    fn with_capacity(samples: usize) -> FineTrace {
        FineTrace {
            load: Vec::with_capacity(samples),
            current: Vec::with_capacity(samples),
            command: Vec::with_capacity(samples),
        }
    }

    fn push(&mut self, load: f64, current: f64, command: f64) {
        self.load.push(load);
        self.current.push(current);
        self.command.push(command);
    }
}

/// The applied torque now: the actual current `delay_steps` internal steps ago (interpolated),
/// times the true torque constant and gear ratio.
fn applied_torque(history: &[f64], head: usize, delay_steps: f64, gain: f64) -> f64 {
    let len = history.len();
    let whole = delay_steps.floor() as usize;
    let frac = delay_steps - whole as f64;
    let at = |back: usize| history[(head + len - (back % len)) % len];
    gain * ((1.0 - frac) * at(whole) + frac * at(whole + 1))
}

/// The length of the state vector: the two-mass drive's six and the intermediate inertia's
/// angle and speed.
const STATES: usize = 8;

fn add(x: &[f64; STATES], k: &[f64; STATES], h: f64) -> [f64; STATES] {
    let mut out = *x;
    for i in 0..STATES {
        out[i] += h * k[i];
    }
    out
}

/// The units the generated logs use, like a drive's own logging.
pub const LOG_UNITS: [(Signal, &str); 7] = [
    (Signal::Time, "s"),
    (Signal::RefPos, "deg"),
    (Signal::MotorCurrent, "A"),
    (Signal::MotorCurrentCommand, "A"),
    (Signal::MotorPos, "deg"),
    (Signal::LoadPos, "deg"),
    (Signal::MotorVel, "deg_s"),
];

/// The units of a linear axis's logs: metres (an axis of unit radius), as a linear drive logs.
pub const LINEAR_LOG_UNITS: [(Signal, &str); 7] = [
    (Signal::Time, "s"),
    (Signal::RefPos, "mm"),
    (Signal::MotorCurrent, "A"),
    (Signal::MotorCurrentCommand, "A"),
    (Signal::MotorPos, "mm"),
    (Signal::LoadPos, "mm"),
    (Signal::MotorVel, "mm_s"),
];

impl TruthConfig {
    /// The units this configuration's logs are written in.
    pub fn log_units(&self) -> &'static [(Signal, &'static str)] {
        if self.linear {
            &LINEAR_LOG_UNITS
        } else {
            &LOG_UNITS
        }
    }

    /// The starting parameter set the model is given: the nominal plant, and the current
    /// loop's bandwidth when the log holds its command.
    pub fn starting_parameters(&self) -> ParameterSet {
        let mut set = self.plant.starting_parameters();
        if self.noise.current_log == CurrentLog::Command {
            set.set(names::CURRENT_LOOP_BANDWIDTH, self.current_bandwidth);
        }
        set
    }

    /// The log's hidden conditions beyond its effects, for the `.truth` sidecar: every
    /// option that is on and that the parameter set has no name for (the load encoder's
    /// error harmonics, skews, a drifting speed signal, the cogging's cycles per motor
    /// revolution, a three-mass drive). Empty with every such option off, so the default
    /// sidecars are what they were.
    pub fn hidden_conditions(&self) -> Vec<(String, String)> {
        let mut out = Vec::new();
        let mut put = |key: &str, value: String| out.push((key.to_string(), value));
        let noise = &self.noise;
        if noise.load_encoder_error.is_on() {
            put("load_encoder_error_rms", format!("{:e}", noise.load_encoder_error.rms));
            let terms = noise.load_encoder_error.terms(self.seed);
            let listed: Vec<String> =
                terms.iter().map(|t| format!("{}:{:e}:{:e}", t.order, t.amplitude, t.phase)).collect();
            put("load_encoder_harmonics", listed.join(" "));
        }
        if noise.load_encoder_skew != 0.0 {
            put("load_encoder_skew", format!("{:e}", noise.load_encoder_skew));
        }
        if noise.current_skew != 0.0 {
            put("current_skew", format!("{:e}", noise.current_skew));
        }
        if let MotorSensor::Speed(sensor) = &noise.motor_sensor {
            if sensor.drift > 0.0 {
                put("tacho_drift", format!("{:e}", sensor.drift));
                put("tacho_bias", format!("{:e}", sensor.bias));
                put("tacho_scale_error", format!("{:e}", sensor.scale_error));
            }
        }
        if let (Some(k), Some(period)) = (self.plant.cogging_per_motor_rev, self.plant.cogging_period()) {
            put("cogging_per_motor_rev", k.to_string());
            put("cogging_period", format!("{period:e}"));
        }
        if let Some(three) = &self.plant.three_mass {
            put("three_mass_inertia_fraction", format!("{:e}", three.inertia_fraction));
            put("three_mass_gearbox_compliance_share", format!("{:e}", three.gearbox_compliance_share));
            put("three_mass_second_mode_hz", format!("{:e}", three.second_mode(&self.plant)));
        }
        if self.controller_rate != TruthConfig::default().controller_rate {
            put("controller_rate", format!("{:e}", self.controller_rate));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sensor_variants_log_their_own_columns_and_leave_the_physics_alone() {
        let plain = TruthConfig { duration: 4.0, ..TruthConfig::default() };
        let mut variant = plain.clone();
        variant.noise.motor_sensor = MotorSensor::Speed(SpeedSensor::default());
        variant.noise.motors = 2;
        variant.noise.current_bias = 1.5;
        let (a, b) = (simulate(&plain), simulate(&variant));
        // The same motion, measured by the same load encoder with the same noise.
        assert_eq!(a.log.signal(Signal::LoadPos), b.log.signal(Signal::LoadPos));
        assert!(b.log.signal(Signal::MotorPos).is_none());
        let speeds = b.log.signals(Signal::MotorVel);
        let currents = b.log.signals(Signal::MotorCurrent);
        assert_eq!((speeds.len(), currents.len()), (2, 2));
        assert_eq!((currents[0].motor, currents[1].motor), (Some(1), Some(2)));
        // Two half currents with their own noise sum to the one current within that noise.
        let single = a.log.signal(Signal::MotorCurrent).unwrap();
        let sigma = plain.noise.current_sigma;
        let worst = (0..single.len())
            .map(|k| (currents[0].values[k] + currents[1].values[k] - single[k]).abs())
            .fold(0.0, f64::max);
        assert!(worst < 12.0 * sigma, "{worst}");
        // The bias is in each current and cancels in their sum.
        let mean_difference =
            (0..single.len()).map(|k| currents[0].values[k] - currents[1].values[k]).sum::<f64>() / single.len() as f64;
        assert!((mean_difference - 3.0).abs() < 0.01, "{mean_difference}");
        // The speed signal is the true motor speed with its scale error, bias and noise.
        let sensor = SpeedSensor::default();
        let errors: Vec<f64> = speeds[0]
            .values
            .iter()
            .zip(&b.clean.motor_vel)
            .map(|(m, v)| m - (1.0 + sensor.scale_error) * v - sensor.bias)
            .collect();
        let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
        assert!((rms / sensor.sigma - 1.0).abs() < 0.1, "speed noise {rms:e}");
        // With no motor sensor the load encoder is the only position.
        variant.noise.motor_sensor = MotorSensor::None;
        let c = simulate(&variant);
        assert!(c.log.signal(Signal::MotorPos).is_none() && c.log.signal(Signal::MotorVel).is_none());
    }

    fn short(effects: Vec<Effect>) -> TruthConfig {
        TruthConfig { duration: 8.0, effects, ..TruthConfig::default() }
    }

    fn rms(x: &[f64]) -> f64 {
        (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
    }

    #[test]
    fn setting_the_anti_resonance_keeps_the_path_damping_ratio() {
        let mut plant = TruthPlant::default();
        let ratio = |p: &TruthPlant| p.damping / (2.0 * (p.stiffness * p.load_inertia).sqrt());
        let before = ratio(&plant);
        assert!((plant.anti_resonance() - 4.0).abs() < 1e-12);
        plant.set_anti_resonance(6.5);
        assert!((plant.anti_resonance() - 6.5).abs() < 1e-12);
        assert!((ratio(&plant) - before).abs() < 1e-15);
        assert!(
            (plant.stiffness - plant.load_inertia * (2.0 * std::f64::consts::PI * 6.5).powi(2)).abs()
                < 1e-6 * plant.stiffness
        );
    }

    #[test]
    fn clean_run_tracks_the_reference() {
        let run = simulate(&short(vec![]));
        let reference = run.log.signal(Signal::RefPos).unwrap();
        let error: Vec<f64> = reference.iter().zip(&run.clean.load_pos).map(|(r, y)| r - y).collect();
        // A 1 Hz position loop with velocity and acceleration feed-forward keeps the tracking
        // error a small fraction of a degree on a trajectory of tens of degrees.
        assert!(rms(&error) < 0.2_f64.to_radians(), "rms tracking error {} deg", rms(&error).to_degrees());
        assert!(run.clean.motor_vel.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn total_torque_balances_the_motion_in_steady_sliding() {
        // The sum of both equations of motion: applied = J_m' a_m + J_L a_L + friction. With no
        // effects, the residual against the nominal steady-state friction curve is only the
        // LuGre transient, so it must be small in RMS compared with the torque.
        let run = simulate(&TruthConfig { duration: 20.0, ..TruthConfig::default() });
        let p = TruthPlant::default();
        let c = &run.clean;
        let dt = 1.0 / 500.0;
        let mut residual = Vec::new();
        let mut torque = Vec::new();
        for i in 1..c.motor_vel.len() - 1 {
            let v = c.motor_vel[i];
            if v.abs() < 2.0 * p.stribeck_velocity {
                continue;
            }
            let a_m = (c.motor_vel[i + 1] - c.motor_vel[i - 1]) / (2.0 * dt);
            let friction = p.viscous * v + p.coulomb * v.signum();
            residual.push(
                c.applied_torque[i] - p.reflected_motor_inertia() * a_m - p.load_inertia * c.load_acc[i] - friction,
            );
            torque.push(c.applied_torque[i]);
        }
        assert!(residual.len() > 1000);
        assert!(rms(&residual) < 0.1 * rms(&torque), "residual {} of torque {}", rms(&residual), rms(&torque));
    }

    #[test]
    fn stiff_bristles_cost_no_accuracy_beyond_that_of_the_base_rate() {
        // The physical bristles relax in microseconds at full speed. With the substeps, going
        // from the 20 kHz base rate to 200 kHz must change the motion no more with them than
        // with bristles 100 times softer (which need no substeps): what is left is the hold
        // of the applied torque over a base step, the same in both.
        let change_with_finer_rate = |presliding: f64| -> (f64, f64) {
            let mut config = short(vec![]);
            config.plant.presliding_displacement = presliding;
            let coarse = simulate(&config).clean;
            let fine = simulate(&TruthConfig { internal_rate: 200_000.0, ..config }).clean;
            let worst = |a: &dyn Fn(&CleanSignals, usize) -> f64| {
                (0..coarse.motor_pos.len()).map(|i| (a(&coarse, i) - a(&fine, i)).abs()).fold(0.0, f64::max)
            };
            (worst(&|c, i| c.motor_pos[i]), worst(&|c, i| c.motor_pos[i] - c.load_pos[i]))
        };
        let (stiff_motor, stiff_twist) = change_with_finer_rate(1e-7);
        let (soft_motor, soft_twist) = change_with_finer_rate(1e-5);
        assert!(
            stiff_motor < 1.5 * soft_motor && stiff_twist < 1.5 * soft_twist,
            "stiff: {stiff_motor:e}, {stiff_twist:e} rad; soft: {soft_motor:e}, {soft_twist:e} rad"
        );
        // Both below the load encoder's 1e-7 rad noise.
        assert!(stiff_motor < 1e-7 && stiff_twist < 1e-7);
        let quiet = Actual::new(&short(vec![]));
        assert!(quiet.fastest_rate(0.03) * 5e-5 > 10.0, "the default bristles must need substeps at full speed");
    }

    /// FNV-1a, a hash whose value no library or compiler version changes.
    fn fnv1a(bytes: &[u8]) -> u64 {
        bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3))
    }

    #[test]
    fn the_default_log_is_bit_for_bit_that_of_the_generator_before_the_options() {
        // The hash and length of `truthgen one --seed 7 --duration 2` written by the generator
        // of commit 8df7695, before the encoder error, skews, drift, pole cogging and three
        // masses existed.
        let config = TruthConfig { duration: 2.0, seed: 7, ..TruthConfig::default() };
        let text = simulate(&config).log.to_csv(config.log_units());
        assert_eq!((fnv1a(text.as_bytes()), text.len()), (0x7e0b_526e_1d77_cbd8, 76479));
        assert!(config.hidden_conditions().is_empty());
    }

    #[test]
    fn a_noise_seed_draws_other_sensor_noise_on_the_same_excitation() {
        let run = |noise_seed| {
            let config = TruthConfig { duration: 2.0, seed: 7, noise_seed, ..TruthConfig::default() };
            simulate(&config).log.channels
        };
        let (a, b, default) = (run(Some(1)), run(Some(2)), run(None));
        // Channel 0 is the position reference (the trajectory), 1 the current, the last the
        // load encoder.
        assert_eq!(a[0].values, b[0].values, "the trajectory must not depend on the noise seed");
        assert_eq!(a[0].values, default[0].values);
        assert_ne!(a[1].values, b[1].values, "another noise seed must draw another current noise");
        assert_ne!(a[1].values, default[1].values);
        let (load_a, load_b) = (&a[a.len() - 1].values, &b[b.len() - 1].values);
        let rms =
            |x: &[f64], y: &[f64]| (x.iter().zip(y).map(|(p, q)| (p - q).powi(2)).sum::<f64>() / x.len() as f64).sqrt();
        // The loop closes through the noisy load encoder, so the axis moves a little
        // differently; the excitation is the same, so by far less than the trajectory's stroke.
        assert!(rms(load_a, load_b) > 0.0 && rms(load_a, load_b) < 1e-3 * rms(&a[0].values, &vec![0.0; load_a.len()]));
    }

    /// A run without load-encoder noise and with a fine count, so what the log adds to the
    /// load angle is the encoder error alone.
    fn exact_load_encoder(duration: f64) -> TruthConfig {
        let mut config = TruthConfig { duration, ..TruthConfig::default() };
        config.noise.load_encoder_sigma = 0.0;
        config.noise.load_encoder_counts = 2f64.powi(40);
        config
    }

    #[test]
    fn the_load_encoder_error_is_in_the_logged_load_position_with_its_rms() {
        let mut config = exact_load_encoder(8.0);
        let rms_asked = 3.0_f64.to_radians() / 3600.0;
        config.noise.load_encoder_error = EncoderError { rms: rms_asked, ..EncoderError::default() };
        let run = simulate(&config);
        let logged = run.log.signal(Signal::LoadPos).unwrap();
        let terms = config.noise.load_encoder_error.terms(config.seed);
        assert!((sensors::harmonics_rms(&terms) / rms_asked - 1.0).abs() < 1e-12);
        let error: Vec<f64> = logged.iter().zip(&run.clean.load_pos).map(|(m, q)| m - q).collect();
        let miss: Vec<f64> =
            error.iter().zip(&run.clean.load_pos).map(|(e, q)| e - sensors::encoder_error(&terms, *q)).collect();
        // The logged error is the harmonics' sum at the true angle, up to the fine count.
        assert!(rms(&miss) < 1e-3 * rms(&error), "miss {:e} of {:e}", rms(&miss), rms(&error));
        // Over the log's part of a revolution the low orders need not average to the RMS of a
        // whole one, but the size is the asked one's.
        assert!(rms(&error) > 0.3 * rms_asked && rms(&error) < 2.0 * rms_asked, "{:e}", rms(&error));
    }

    /// The lag (log samples, within +-`span`) at which the first differences of `a` and `b`
    /// correlate best: `a[k]` is most like `b[k + lag]`.
    fn best_lag(a: &[f64], b: &[f64], span: i64) -> i64 {
        let (da, db): (Vec<f64>, Vec<f64>) =
            (a.windows(2).map(|w| w[1] - w[0]).collect(), b.windows(2).map(|w| w[1] - w[0]).collect());
        let n = da.len() as i64;
        let correlation =
            |lag: i64| -> f64 { (span..n - span).map(|k| da[k as usize] * db[(k + lag) as usize]).sum::<f64>() };
        (-span..=span).max_by(|x, y| correlation(*x).total_cmp(&correlation(*y))).unwrap()
    }

    #[test]
    fn a_load_encoder_skew_reads_the_load_angle_that_much_later() {
        let plain = exact_load_encoder(4.0);
        let mut skewed = plain.clone();
        skewed.noise.load_encoder_skew = 0.006;
        let (a, b) = (simulate(&plain), simulate(&skewed));
        let (a_load, b_load) = (a.log.signal(Signal::LoadPos).unwrap(), b.log.signal(Signal::LoadPos).unwrap());
        // Six milliseconds are three rows at 500 Hz: row k of the skewed log is row k + 3 of
        // the plain one (up to the fine count, the interpolation between internal steps).
        let worst = (0..a_load.len() - 3).map(|k| (b_load[k] - a_load[k + 3]).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-9, "{worst:e}");
        // The position is smooth: its acceleration (the differences of its differences)
        // carries the noise injection's sharp structure.
        let speed = |x: &[f64]| -> Vec<f64> { x.windows(2).map(|w| w[1] - w[0]).collect() };
        assert_eq!(best_lag(&speed(b_load), &speed(&a.clean.load_pos), 8), 3);
        // The motion and the other columns are those of the plain run.
        assert_eq!(a.log.signal(Signal::MotorPos), b.log.signal(Signal::MotorPos));
        assert_eq!(a.log.signal(Signal::MotorCurrent), b.log.signal(Signal::MotorCurrent));
        assert_eq!(a.clean.load_pos, b.clean.load_pos);
    }

    #[test]
    fn a_current_skew_moves_the_cross_correlation_peak_by_its_time() {
        // With the suite's current noise, against the true applied torque (no delay effect,
        // so the torque is the actual current times the gear and the torque constant).
        for (skew, lag) in [(0.004, 2), (-0.006, -3), (0.0, 0)] {
            let mut config = TruthConfig { duration: 6.0, ..TruthConfig::default() };
            config.noise.current_skew = skew;
            let run = simulate(&config);
            let current = run.log.signal(Signal::MotorCurrent).unwrap();
            assert_eq!(best_lag(current, &run.clean.applied_torque, 8), lag, "skew {skew}");
        }
    }

    #[test]
    fn a_drifting_tacho_adds_a_slow_bias_with_the_asked_rms() {
        let mut plain = TruthConfig { duration: 6.0, ..TruthConfig::default() };
        plain.noise.motor_sensor = MotorSensor::Speed(SpeedSensor::default());
        let mut drifting = plain.clone();
        let asked = 3.0e-6;
        drifting.noise.motor_sensor = MotorSensor::Speed(SpeedSensor { drift: asked, ..SpeedSensor::default() });
        let (a, b) = (simulate(&plain), simulate(&drifting));
        let (a_speed, b_speed) = (a.log.signal(Signal::MotorVel).unwrap(), b.log.signal(Signal::MotorVel).unwrap());
        let drift: Vec<f64> = b_speed.iter().zip(a_speed).map(|(b, a)| b - a).collect();
        assert!((rms(&drift) / asked - 1.0).abs() < 1e-6, "{:e}", rms(&drift));
        // Slow: successive samples differ by a small part of the drift's size.
        let steps: Vec<f64> = drift.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(rms(&steps) < 0.1 * asked);
        assert_eq!(a.log.signal(Signal::LoadPos), b.log.signal(Signal::LoadPos));
        assert_eq!(b.clean.motor_vel, a.clean.motor_vel);
    }

    #[test]
    fn the_cogging_period_is_two_pi_over_the_gear_ratio_times_the_cycles_per_motor_rev() {
        let mut config = TruthConfig { duration: 2.0, ..TruthConfig::default() };
        assert_eq!(config.plant.cogging_period(), None);
        config.plant.cogging_per_motor_rev = Some(5);
        let expected = 2.0 * std::f64::consts::PI / (1200.0 * 5.0);
        assert_eq!(config.plant.cogging_period(), Some(expected));
        let clean = simulate(&config).clean;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
        let Ok(Effect::Cogging { period, .. }) = suite::sized_effect("cogging", 10.0, &clean, &config, &mut rng) else {
            panic!("no cogging")
        };
        assert_eq!(period, expected);
        // The hidden logs' drive: 5 cycles per motor revolution on a 9000:1 gear.
        config.plant.gear_ratio = 9000.0;
        assert!((config.plant.cogging_period().unwrap() - 1.396e-4).abs() < 1e-7);
        let conditions = config.hidden_conditions();
        assert!(conditions.contains(&("cogging_per_motor_rev".to_string(), "5".to_string())));
    }

    #[test]
    fn a_three_mass_drive_with_a_rigid_second_compliance_is_the_two_mass_drive() {
        let two = TruthConfig { duration: 8.0, ..TruthConfig::default() };
        let with = |share: f64| {
            let mut config = two.clone();
            config.plant.three_mass =
                Some(ThreeMass { inertia_fraction: 0.2, gearbox_compliance_share: share, second_damping_ratio: 0.04 });
            simulate(&config).clean
        };
        let reference = simulate(&two).clean;
        let worst = |c: &CleanSignals| {
            (0..c.load_pos.len())
                .map(|i| {
                    (c.load_pos[i] - reference.load_pos[i]).abs().max((c.motor_pos[i] - reference.motor_pos[i]).abs())
                })
                .fold(0.0, f64::max)
        };
        // A second compliance 1e5 times stiffer than the path: the intermediate inertia moves
        // with the load, and the drive is the two-mass one to well below the encoder noise.
        let rigid = worst(&with(1.0 - 1e-5));
        assert!(rigid < 1e-8, "{rigid:e} rad");
        // A real second mode (30 Hz) moves the drive by more than that.
        let three = ThreeMass::with_second_mode(&two.plant, 0.2, 30.0).unwrap();
        assert!((three.second_mode(&two.plant) - 30.0).abs() < 1e-9);
        let soft = worst(&with(three.gearbox_compliance_share));
        assert!(soft > 100.0 * rigid.max(1e-12), "{soft:e} rad");
        assert!(ThreeMass::with_second_mode(&two.plant, 0.2, 10.0).is_err());
    }

    #[test]
    fn two_khz_logs_hold_a_row_per_controller_sample() {
        let config = TruthConfig { duration: 1.0, log_rate: 2000.0, ..TruthConfig::default() };
        let run = simulate(&config);
        assert_eq!(run.log.time.len(), 2001);
        assert!(run.log.time.windows(2).all(|w| (w[1] - w[0] - 5e-4).abs() < 1e-12));
        let current = run.log.signal(Signal::MotorCurrent).unwrap();
        assert_eq!(current.len(), 2001);
        assert!(current.iter().all(|c| c.is_finite()));
    }

    #[test]
    fn a_noiseless_current_at_2_khz_takes_a_sub_millisecond_delay() {
        let mut config = TruthConfig { duration: 6.0, log_rate: 2000.0, ..TruthConfig::default() };
        config.noise.current_sigma = 0.0;
        config.noise.size_current_sigma = Some(0.0125);
        let clean = simulate(&config).clean;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let Ok(Effect::Delay(delay)) = suite::sized_effect("delay", 1.0, &clean, &config, &mut rng) else {
            panic!("no delay")
        };
        // Once the suite's current noise is a delay of a few tenths of a millisecond.
        assert!(delay > 1e-4 && delay < 8e-4, "{delay:e} s");
        config.effects = vec![Effect::Delay(delay)];
        let run = simulate(&config);
        let current = run.log.signal(Signal::MotorCurrent).unwrap();
        // No noise: every logged current is a whole number of 1 mA steps.
        assert!(current.iter().all(|c| ((c / 1e-3) - (c / 1e-3).round()).abs() < 1e-6));
        assert!(run.clean.applied_torque.iter().zip(&clean.applied_torque).any(|(a, b)| a != b));
    }

    #[test]
    fn an_unbalance_raises_the_torque_by_its_size() {
        let clean = simulate(&short(vec![]));
        let with = simulate(&short(vec![Effect::Unbalance { amplitude: 5000.0, phase: 0.0 }]));
        let difference: Vec<f64> =
            with.clean.applied_torque.iter().zip(&clean.clean.applied_torque).map(|(a, b)| a - b).collect();
        let expected: Vec<f64> = with.clean.load_pos.iter().map(|q| 5000.0 * q.cos()).collect();
        let miss: Vec<f64> = difference.iter().zip(&expected).map(|(d, e)| d - e).collect();
        // Closed-loop tracking makes the drive supply the unbalance torque, apart from the
        // noise injection (same seed, so largely the same) and small trajectory differences.
        assert!(rms(&miss) < 0.1 * rms(&expected), "miss {} of {}", rms(&miss), rms(&expected));
    }
}
