//! The seed paper's frequency-domain identification, run on a packaged plant FMU through the C
//! ABI: Gaussian white-noise current on top of a constant offset that keeps the axis moving,
//! sensor noise on the measured motor speed, an H1 estimate (Welch) with its coherence, and a
//! comparison with the corrected Eq. 1 (times the current loop and the torque constant).
//!
//! The paper drove the real antenna in open loop with the velocity controller off, injected
//! white noise superimposed on a constant command "which would overcome the static friction of
//! the system and ensure that the system was in a linear regime", and read the motor speed from
//! the servo amplifiers (Figs. 6 and 8). Here the plant keeps all its nonlinear effects
//! (friction, backlash, saturation): the offset keeps every body sliding in one direction, so
//! Coulomb friction is a constant torque, and in azimuth a torque bias (motor 1 +, motor 2 -)
//! keeps each pinion on its flank, as on the antenna. [`Identification::linear_regime_held`]
//! checks both conditions on the recorded run.
//!
//! The FMU holds its inputs constant over a communication step and its outputs are samples, so
//! the sampled system is the continuous one behind a zero-order hold. The reference is
//! therefore `sum_m H(j w_m) (1 - exp(-j w_m h)) / (j w_m h)`, `w_m = w + m 2 pi / h`, the exact
//! frequency response of the held and sampled plant. The hold alone takes 0.14 dB and 18 deg
//! at 100 Hz; the images `m != 0` add 0.003 dB there and 0.09 dB at 200 Hz, and are summed.
//! `H` itself is the analytic transfer function of `fmu_plant::analytic`, built from
//! parameters read back from the FMU.
//!
//! Used by the integration test `plant_identification` and by the `plant-bode` tool that draws
//! the README figures.

use std::f64::consts::TAU;
use std::path::Path;

use fmu_import::{Fmu, Instance};
use fmu_plant::analytic::{current_loop_response, TwoMassParameters, C64};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use antenna_dsp::{Complex64, ResponseComparison};
use antenna_plot::{measured_against_model, Figure, Panel};

use super::{read_real, welch_h1, Axis, FlankWatch, IdentificationError, MeasuredResponse};
use crate::coupled::leave_out_carried_inertia;

/// The experiment. [`IdentificationConfig::paper`] gives the settings of the figures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdentificationConfig {
    pub axis: Axis,
    /// Elevation of the experiment, deg: the azimuth plant's elevation input, or the angle at
    /// which the elevation plant's geometry is frozen (and where it starts).
    pub elevation_deg: f64,
    /// Communication step, s; also the sample interval of the record.
    pub step_s: f64,
    /// Time from rest to the start of the record, s: the axis breaks away and the start
    /// transients decay.
    pub settle_s: f64,
    /// Length of the record, s.
    pub record_s: f64,
    /// Welch segment length, s (frequency resolution 1/segment).
    pub segment_s: f64,
    /// Constant current command on each motor that keeps the axis moving, A.
    pub offset_current_a: f64,
    /// Standard deviation of the white-noise current command (common to both azimuth motors), A.
    pub noise_current_a: f64,
    /// Azimuth torque bias: +bias on motor 1 and -bias on motor 2, A (ignored in elevation).
    pub bias_current_a: f64,
    /// Standard deviation of the white sensor noise added to the measured motor speed, rad/s.
    pub sensor_noise_rad_per_s: f64,
    /// Axis angle at which the experiment starts from rest, deg.
    pub initial_position_deg: f64,
    /// Seed of the excitation and the sensor noise.
    pub seed: u64,
    /// Run the plant in its linear configuration (exactly the paper's Eq. 1 with the current
    /// loop: no friction but the viscous B_M, no backlash, saturation or quantisation) instead
    /// of the default nonlinear plant.
    pub linear_configuration: bool,
    /// Couple the packaged `Structure` FMU (its shipped modes, beside the plant's `.fmu`) both
    /// ways, as the antenna master does: the plant takes the structure's drive torque on its
    /// load side and leaves the inertia the axis's mode carries out of its own, the structure
    /// takes the axis's speed. The mode then shows in the drive's response as a second
    /// anti-resonance, at the frequency of the mode with the motor held
    /// ([`StructuralAntiResonance`]).
    pub structure: bool,
}

impl IdentificationConfig {
    /// The settings of the figures and of the test: 15 deg elevation, 1 ms steps, 875 s of
    /// record after 60 s of settling, in 10 s segments (0.1 Hz bins; 174 segments, 330
    /// equivalent degrees of freedom), so that at a coherence of 0.9 the random error of |H1|
    /// is 0.47 dB at three standard deviations, well inside the 1 dB bound. The offsets keep
    /// the motors at about 57 rad/s (azimuth, 0.36 deg/s at the axis) and 26 rad/s (elevation,
    /// 0.095 deg/s), so the azimuth record (-150 to about +190 deg) stays inside the travel;
    /// the noise never reverses a motor. The sensor noise (0.01 rad/s) makes the coherence dip
    /// in the anti-resonance trough, as in the paper's measurements, and fall below 0.9 above
    /// about 150 Hz, where the response has rolled off.
    pub fn paper(axis: Axis) -> Self {
        match axis {
            Axis::Azimuth => IdentificationConfig {
                axis,
                elevation_deg: 15.0,
                step_s: 1e-3,
                settle_s: 60.0,
                record_s: 875.0,
                segment_s: 10.0,
                offset_current_a: 0.55,
                noise_current_a: 0.5,
                bias_current_a: 2.0,
                sensor_noise_rad_per_s: 0.01,
                initial_position_deg: -150.0,
                seed: 20_260_001,
                linear_configuration: false,
                structure: false,
            },
            Axis::Elevation => IdentificationConfig {
                axis,
                elevation_deg: 15.0,
                step_s: 1e-3,
                settle_s: 60.0,
                record_s: 875.0,
                segment_s: 10.0,
                offset_current_a: 0.6,
                noise_current_a: 0.3,
                bias_current_a: 0.0,
                sensor_noise_rad_per_s: 0.01,
                initial_position_deg: 15.0,
                seed: 20_260_002,
                linear_configuration: false,
                structure: false,
            },
        }
    }
}

/// What the experiment measured and what the analytic model predicts at the same bins.
#[derive(Debug, Clone)]
pub struct Identification {
    pub config: IdentificationConfig,
    /// Bin frequencies, Hz (DC excluded).
    pub frequency_hz: Vec<f64>,
    /// H1 estimate from the common current command (A) to the measured motor speed (rad/s).
    pub measured: Vec<Complex64>,
    pub coherence: Vec<f64>,
    /// Corrected Eq. 1 times current loop and torque constant, behind the zero-order hold.
    pub analytic: Vec<Complex64>,
    /// Equivalent degrees of freedom of a bin of the Welch estimate.
    pub dof: f64,
    pub segments: usize,
    /// The reflected two-mass parameters the reference uses (both azimuth motors together).
    pub two_mass: TwoMassParameters,
    /// Motor torque per commanded ampere of common current (azimuth: both motors), N m/A.
    pub torque_per_amp: f64,
    pub current_loop_bandwidth_hz: f64,
    /// `drive.anti_resonance_frequency` as the FMU reports it, Hz.
    pub reported_anti_resonance_hz: f64,
    /// Smallest motor speed in the record (must stay positive: no reversal), rad/s.
    pub min_motor_speed_rad_per_s: f64,
    /// Mean motor speed and axis speed over the record.
    pub mean_motor_speed_rad_per_s: f64,
    pub mean_axis_speed_deg_per_s: f64,
    /// Number of pinion flank changes during the record (azimuth; must be zero).
    pub flank_changes: usize,
    /// Wall-clock time of the simulation and of the analysis, s.
    pub simulation_wall_s: f64,
    pub analysis_wall_s: f64,
    /// With the structure coupled: its mode's anti-resonance as predicted from the parameters.
    pub structural: Option<StructuralAntiResonance>,
}

/// The structural mode as the drive sees it when the mode pushes back on it.
///
/// With the motor held, the load side is two bodies: what the plant keeps of the load inertia,
/// `J_r`, on the drive's stiffness `K_d = J_r (2 pi f_AR)^2`, and the mode's body `J_m` on the
/// mode's stiffness `K = J_m w_s^2`, `w_s` the mode's frequency with the axis clamped (the
/// modes file's). The drive's response from current to motor speed has its anti-resonances at
/// that system's natural frequencies; the lower one is the structure's,
/// `w^2 = ((a + b + c) - sqrt((a + b + c)^2 - 4 a c)) / 2` with `a = K_d / J_r`, `b = K / J_r`,
/// `c = K / J_m`: below `w_s`, because the drive's compliance is in series with the mode's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StructuralAntiResonance {
    /// The mode's frequency with the axis clamped at the encoder (the modes file's), Hz.
    pub clamped_hz: f64,
    /// The inertia the mode carries about the axis, kg m^2.
    pub modal_inertia: f64,
    /// The load inertia the plant keeps, kg m^2.
    pub remaining_inertia: f64,
    /// The predicted anti-resonance with the motor held, Hz.
    pub predicted_hz: f64,
}

impl StructuralAntiResonance {
    fn predict(clamped_hz: f64, modal_inertia: f64, remaining_inertia: f64, drive_anti_resonance_hz: f64) -> Self {
        let a = (TAU * drive_anti_resonance_hz).powi(2);
        let c = (TAU * clamped_hz).powi(2);
        let b = c * modal_inertia / remaining_inertia;
        let sum = a + b + c;
        let lower = 0.5 * (sum - (sum * sum - 4.0 * a * c).sqrt());
        StructuralAntiResonance { clamped_hz, modal_inertia, remaining_inertia, predicted_hz: lower.sqrt() / TAU }
    }
}

impl MeasuredResponse for Identification {
    /// The estimate beside the corrected Eq. 1, bin by bin.
    fn comparison(&self) -> ResponseComparison<'_> {
        ResponseComparison {
            frequency_hz: &self.frequency_hz,
            measured: &self.measured,
            analytic: &self.analytic,
            coherence: &self.coherence,
        }
    }
}

/// The anti-resonance trough of a frequency response.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trough {
    pub frequency_hz: f64,
    pub magnitude_db: f64,
}

impl Identification {
    /// Both linear-regime conditions of the experiment held: no motor reversed and (azimuth)
    /// no pinion left its flank.
    pub fn linear_regime_held(&self) -> bool {
        self.min_motor_speed_rad_per_s > 0.0 && self.flank_changes == 0
    }

    /// The undamped anti-resonance `sqrt(K_s/J_L)` of the reference parameters, Hz.
    pub fn undamped_anti_resonance_hz(&self) -> f64 {
        self.two_mass.anti_resonance_hz()
    }

    /// The trough of the analytic response (held and sampled): the smallest magnitude on a
    /// 4000-point grid over the search band, refined by golden-section search between the
    /// grid points on either side.
    pub fn analytic_trough(&self) -> Trough {
        let magnitude = |f: f64| {
            held_response(&self.two_mass, self.torque_per_amp, self.current_loop_bandwidth_hz, f, self.config.step_s)
                .norm()
        };
        let (lo, hi) = self.search_band();
        let n = 4000;
        let grid: Vec<f64> = (0..=n).map(|i| lo + (hi - lo) * i as f64 / n as f64).collect();
        let best = grid.iter().copied().fold((lo, f64::INFINITY), |(bf, bm), f| {
            let m = magnitude(f);
            if m < bm {
                (f, m)
            } else {
                (bf, bm)
            }
        });
        let width = (hi - lo) / n as f64;
        let (mut a, mut b) = (best.0 - width, best.0 + width);
        let ratio = (5f64.sqrt() - 1.0) / 2.0;
        for _ in 0..100 {
            let c = b - ratio * (b - a);
            let d = a + ratio * (b - a);
            if magnitude(c) < magnitude(d) {
                b = d;
            } else {
                a = c;
            }
        }
        let f = 0.5 * (a + b);
        Trough { frequency_hz: f, magnitude_db: 20.0 * magnitude(f).log10() }
    }

    /// The trough of the measured response: the smallest |H1| between 0.7 and 1.3 times the
    /// undamped anti-resonance, refined by a parabola through log|H1| at the bin and its two
    /// neighbours (the bin spacing alone is 1/segment).
    pub fn measured_trough(&self) -> Trough {
        let (lo, hi) = self.search_band();
        self.trough_between(lo, hi)
    }

    /// With the structure coupled, the trough of the measured response near the structural
    /// anti-resonance (between 0.7 and 1.3 times the predicted one), as [`Self::measured_trough`].
    pub fn structural_trough(&self) -> Option<Trough> {
        let predicted = self.structural?.predicted_hz;
        Some(self.trough_between(0.7 * predicted, 1.3 * predicted))
    }

    fn trough_between(&self, lo: f64, hi: f64) -> Trough {
        let db: Vec<f64> = self.measured.iter().map(|h| 20.0 * h.norm().log10()).collect();
        let candidates =
            (1..self.frequency_hz.len() - 1).filter(|&i| self.frequency_hz[i] >= lo && self.frequency_hz[i] <= hi);
        let i = candidates.min_by(|&a, &b| db[a].total_cmp(&db[b])).expect("the search band contains bins");
        let (y0, y1, y2) = (db[i - 1], db[i], db[i + 1]);
        let curvature = y0 - 2.0 * y1 + y2;
        let offset = if curvature > 0.0 { (0.5 * (y0 - y2) / curvature).clamp(-0.5, 0.5) } else { 0.0 };
        let spacing = self.frequency_hz[i + 1] - self.frequency_hz[i];
        Trough { frequency_hz: self.frequency_hz[i] + offset * spacing, magnitude_db: y1 - 0.25 * (y0 - y2) * offset }
    }

    fn nearest_bin(&self, frequency_hz: f64) -> usize {
        (0..self.frequency_hz.len())
            .min_by(|&a, &b| {
                (self.frequency_hz[a] - frequency_hz).abs().total_cmp(&(self.frequency_hz[b] - frequency_hz).abs())
            })
            .unwrap_or(0)
    }

    fn search_band(&self) -> (f64, f64) {
        let f = self.undamped_anti_resonance_hz();
        (0.7 * f, 1.3 * f)
    }

    /// Normalised random error of |H1| (one standard deviation) at a bin, Bendat & Piersol
    /// eq. 9.90 with the Welch estimate's equivalent averages.
    pub fn random_error(&self, bin: usize) -> f64 {
        let g2 = self.coherence[bin];
        let averages = 0.5 * self.dof;
        (1.0 - g2).max(0.0).sqrt() / (g2.sqrt() * (2.0 * averages).sqrt())
    }

    /// The Bode figure: measured H1 against the corrected Eq. 1 (magnitude, phase), and the
    /// coherence, over 0.1 Hz to `max_frequency_hz`.
    pub fn figure(&self, max_frequency_hz: f64) -> Figure {
        let measured_trough = self.measured_trough();
        let analytic_trough = self.analytic_trough();
        let title = format!(
            "{} plant FMU at {} deg elevation: motor speed per current command (open loop)",
            capitalise(self.config.axis.name()),
            self.config.elevation_deg
        );
        let model = "corrected Eq. 1 x current loop x K_phi (held, sampled)";
        let magnitude = Panel::new("Magnitude").x_label("Frequency (Hz)").y_label("|V_M / I_C| (dB re 1 rad/s/A)");
        measured_against_model(
            &title,
            &self.comparison(),
            max_frequency_hz,
            magnitude,
            "measured H1 (FMU, Welch)",
            model,
            |magnitude| {
                magnitude
                    .vertical_line(
                        &format!("measured trough {:.2} Hz", measured_trough.frequency_hz),
                        measured_trough.frequency_hz,
                    )
                    .vertical_line(
                        &format!("analytic trough {:.2} Hz", analytic_trough.frequency_hz),
                        analytic_trough.frequency_hz,
                    )
            },
        )
    }
}

fn capitalise(s: &str) -> String {
    let mut c = s.chars();
    c.next().map(|first| first.to_uppercase().chain(c).collect()).unwrap_or_default()
}

/// Motor speed per commanded current of the continuous model: `K C(s) V_M/T_E(s)`.
pub fn continuous_response(
    two_mass: &TwoMassParameters,
    torque_per_amp: f64,
    bandwidth_hz: f64,
    frequency_hz: f64,
) -> C64 {
    let s = C64::new(0.0, TAU * frequency_hz);
    two_mass.motor_speed_per_torque(s) * current_loop_response(s, bandwidth_hz) * torque_per_amp
}

/// The same behind a zero-order hold of `step_s` and sampled: the sum over the images,
/// `sum_m H(j w_m) (1 - exp(-j w_m h)) / (j w_m h)`. Terms fall as 1/m^4 (the plant and the
/// current loop roll off as 1/s^3 together with the hold), so +/-200 images leave an error far
/// below 1e-9 relative.
pub fn held_response(
    two_mass: &TwoMassParameters,
    torque_per_amp: f64,
    bandwidth_hz: f64,
    frequency_hz: f64,
    step_s: f64,
) -> C64 {
    let sample_rate = 1.0 / step_s;
    let mut total = C64::new(0.0, 0.0);
    for m in -200i32..=200 {
        let f = frequency_hz + f64::from(m) * sample_rate;
        let w = TAU * f;
        let hold = if w == 0.0 {
            C64::new(1.0, 0.0)
        } else {
            (C64::new(1.0, 0.0) - C64::new(0.0, -w * step_s).exp()) / C64::new(0.0, w * step_s)
        };
        total += continuous_response(two_mass, torque_per_amp, bandwidth_hz, f) * hold;
    }
    total
}

/// Reads the reflected two-mass parameters, the torque per common ampere and the current-loop
/// bandwidth back from an initialised plant instance.
fn reference_parameters(
    axis: Axis,
    instance: &mut Instance,
    fmu: &Fmu,
) -> Result<(TwoMassParameters, f64, f64, f64), IdentificationError> {
    let mut r = |name: &str| read_real(fmu, instance, name);
    match axis {
        Axis::Azimuth => {
            // The reference doubles one motor (the paper's "double each motor parameter"), which
            // is exact only for identical drives: refuse anything else.
            for name in
                ["inertia", "viscous_friction", "torque_constant", "torque_constant_scale", "current_loop_bandwidth"]
            {
                let (motor1, motor2) = (r(&format!("motor1.{name}"))?, r(&format!("motor2.{name}"))?);
                if motor1 != motor2 {
                    return Err(IdentificationError::MotorsDiffer { parameter: name, motor1, motor2 });
                }
            }
            let (k1, k2, c1, c2) =
                (r("pinion1.stiffness")?, r("pinion2.stiffness")?, r("pinion1.damping")?, r("pinion2.damping")?);
            if k1 != k2 || c1 != c2 {
                return Err(IdentificationError::PinionPathsDiffer);
            }
            let n = r("gear.ratio")?;
            let n2 = n * n;
            let two_mass = TwoMassParameters::two_identical_motors(
                r("motor1.inertia")?,
                r("motor1.viscous_friction")?,
                k1 / n2,
                c1 / n2,
                r("load.inertia")? / n2,
            );
            let torque_per_amp = 2.0 * r("motor1.torque_constant")? * r("motor1.torque_constant_scale")?;
            Ok((two_mass, torque_per_amp, r("motor1.current_loop_bandwidth")?, r("drive.anti_resonance_frequency")?))
        }
        Axis::Elevation => {
            // The FMU does not expose the jackscrew's stiffness; it reports the ratio and the
            // undamped anti-resonance sqrt(K_s/J_L) of the drive, which give K_s = w_AR^2 J_L.
            let n = r("drive.ratio")?;
            let load_inertia = r("load.inertia")? / (n * n);
            let f_ar = r("drive.anti_resonance_frequency")?;
            let motor_rad_per_m = TAU * r("jackscrew.gearbox_ratio")? / r("jackscrew.lead")?;
            let two_mass = TwoMassParameters {
                motor_inertia: r("motor.inertia")?,
                motor_friction: r("motor.viscous_friction")?,
                shaft_stiffness: (TAU * f_ar).powi(2) * load_inertia,
                cross_coupled_damping: r("jackscrew.axial_damping")? / (motor_rad_per_m * motor_rad_per_m),
                load_inertia,
            };
            let torque_per_amp = r("motor.torque_constant")? * r("motor.torque_constant_scale")?;
            Ok((two_mass, torque_per_amp, r("motor.current_loop_bandwidth")?, f_ar))
        }
    }
}

/// Runs the experiment on the packaged FMU at `fmu_path` and estimates the frequency response.
pub fn identify(fmu_path: &Path, config: &IdentificationConfig) -> Result<Identification, IdentificationError> {
    let started = std::time::Instant::now();
    let fmu = Fmu::open(fmu_path)?;
    let mut structure =
        if config.structure { Some(coupled_structure(fmu_path, config.axis, config.elevation_deg)?) } else { None };
    let carried = structure.as_ref().map_or((0.0, 0.0), |s| s.carried_zenith_and_horizon);
    let mut instance = initialised_plant(&fmu, config, carried)?;
    let (two_mass, torque_per_amp, bandwidth_hz, reported_anti_resonance_hz) =
        reference_parameters(config.axis, &mut instance, &fmu)?;
    let structural = match &structure {
        Some(s) => Some(StructuralAntiResonance::predict(
            s.clamped_hz,
            s.modal_inertia,
            read_real(&fmu, &mut instance, "load.inertia")?,
            reported_anti_resonance_hz,
        )),
        None => None,
    };
    let record = record(&fmu, &mut instance, config, structure.as_mut())?;
    let simulation_wall_s = started.elapsed().as_secs_f64();

    let analysis_started = std::time::Instant::now();
    let h = config.step_s;
    let estimate = welch_h1(&record.input, &record.output, h, config.segment_s)?;
    let analytic =
        estimate.frequency_hz.iter().map(|&f| held_response(&two_mass, torque_per_amp, bandwidth_hz, f, h)).collect();
    let record_steps = record.input.len() as f64;
    Ok(Identification {
        config: *config,
        measured: estimate.measured,
        coherence: estimate.coherence,
        frequency_hz: estimate.frequency_hz,
        analytic,
        dof: estimate.dof,
        segments: estimate.segments,
        two_mass,
        torque_per_amp,
        current_loop_bandwidth_hz: bandwidth_hz,
        reported_anti_resonance_hz,
        min_motor_speed_rad_per_s: record.min_motor_speed,
        mean_motor_speed_rad_per_s: record.speed_sum / record_steps,
        mean_axis_speed_deg_per_s: record.axis_speed_sum / record_steps,
        flank_changes: record.flank_changes,
        simulation_wall_s,
        analysis_wall_s: analysis_started.elapsed().as_secs_f64(),
        structural,
    })
}

/// The structure coupled to one axis's plant for the identification.
struct CoupledStructure {
    instance: Instance,
    /// The structure's inputs: the two axes' speeds (deg/s); the loads stay zero.
    speed_vrs: [u32; 2],
    /// `drive_torque.<axis>`.
    drive_vr: u32,
    /// Which of the speeds is this axis's.
    axis_index: usize,
    /// The inertia the modes carry about the axis at the experiment's elevation, kg m^2.
    modal_inertia: f64,
    /// The same with the dish at the zenith and at the horizon, which the plant leaves out.
    carried_zenith_and_horizon: (f64, f64),
    clamped_hz: f64,
}

/// The packaged Structure FMU beside the plant's, initialised with its shipped modes at the
/// experiment's elevation.
fn coupled_structure(
    plant_path: &Path,
    axis: Axis,
    elevation_deg: f64,
) -> Result<CoupledStructure, IdentificationError> {
    let fmu = Fmu::open(plant_path.with_file_name("Structure.fmu"))?;
    let mut instance = fmu.instantiate("structure-identification", false)?;
    instance.setup_experiment(0.0, None)?;
    instance.enter_initialization_mode()?;
    instance.set_real(&[fmu.description.vr("axis.elevation")?], &[elevation_deg])?;
    instance.exit_initialization_mode()?;
    let (axis_index, name) = match axis {
        Axis::Azimuth => (0, "azimuth"),
        Axis::Elevation => (1, "elevation"),
    };
    let zenith = read_real(&fmu, &mut instance, &format!("modal_inertia.{name}"))?;
    let horizon = read_real(&fmu, &mut instance, &format!("modal_inertia.{name}_horizon"))?;
    let (sin_el, cos_el) = elevation_deg.to_radians().sin_cos();
    let modal_inertia = if zenith == horizon { zenith } else { horizon * cos_el * cos_el + zenith * sin_el * sin_el };
    // The axis's mode in the shipped file: the first that its torque drives.
    let modes = fmu_structure::modes::parse_modes(fmu_structure::modes::DEFAULT_MODES, "structure_modes.params")
        .map_err(IdentificationError::Modes)?;
    let mode = modes
        .iter()
        .find(|m| m.participation[axis_index] != 0.0)
        .ok_or(IdentificationError::NoModeAbout { axis: name })?;
    let md = &fmu.description;
    Ok(CoupledStructure {
        speed_vrs: [md.vr("axis.azimuth_speed")?, md.vr("axis.elevation_speed")?],
        drive_vr: md.vr(&format!("drive_torque.{name}"))?,
        axis_index,
        modal_inertia,
        carried_zenith_and_horizon: (zenith, horizon),
        clamped_hz: mode.frequency_at(elevation_deg),
        instance,
    })
}

/// The plant instance set up for the experiment: at its elevation (the azimuth plant's input;
/// the elevation plant's geometry frozen there) and start position, linear if asked.
fn initialised_plant(
    fmu: &Fmu,
    config: &IdentificationConfig,
    carried: (f64, f64),
) -> Result<Instance, IdentificationError> {
    let md = &fmu.description;
    let mut instance = fmu.instantiate(&format!("{}-identification", config.axis.name()), false)?;
    instance.setup_experiment(0.0, None)?;
    instance.enter_initialization_mode()?;
    // The structure's mode carries this much of the load: the plant keeps the rest, of the part
    // the antenna master takes it from.
    let axis = match config.axis {
        Axis::Azimuth => 0,
        Axis::Elevation => 1,
    };
    leave_out_carried_inertia(&mut instance, md, axis, carried.0, carried.1)?;
    if config.linear_configuration {
        instance.set_boolean(&[md.vr("linear_configuration")?], &[true])?;
    }
    match config.axis {
        Axis::Azimuth => {
            instance.set_real(
                &md.vrs(&["elevation", "initial_position"])?,
                &[config.elevation_deg, config.initial_position_deg],
            )?;
        }
        Axis::Elevation => {
            // Freeze the jackscrew geometry at the experiment's angle and start there, so the
            // drive is the one "at 15 deg" for the whole record although the dish moves.
            instance.set_boolean(&[md.vr("geometry.frozen")?], &[true])?;
            instance.set_real(
                &md.vrs(&["geometry.frozen_elevation", "initial_position"])?,
                &[config.elevation_deg, config.initial_position_deg],
            )?;
        }
    }
    instance.exit_initialization_mode()?;
    Ok(instance)
}

/// What the run recorded after the settling time.
struct Record {
    /// The common current command, A.
    input: Vec<f64>,
    /// The measured motor speed (motor 1) with sensor noise, rad/s.
    output: Vec<f64>,
    min_motor_speed: f64,
    speed_sum: f64,
    axis_speed_sum: f64,
    flank_changes: usize,
}

/// Drives the plant with the seeded excitation, from rest through the settling time and the
/// record, and keeps the record with the linear-regime checks.
fn record(
    fmu: &Fmu,
    instance: &mut Instance,
    config: &IdentificationConfig,
    mut structure: Option<&mut CoupledStructure>,
) -> Result<Record, IdentificationError> {
    let md = &fmu.description;
    let load_torque_vr = md.vr("load.disturbance_torque")?;
    let (input_vrs, speed_vrs, axis_speed_vr) = match config.axis {
        Axis::Azimuth => (
            md.vrs(&["motor1.current_command", "motor2.current_command"])?,
            md.vrs(&["motor1.speed", "motor2.speed"])?,
            md.vr("axis.speed")?,
        ),
        Axis::Elevation => (md.vrs(&["motor.current_command"])?, md.vrs(&["motor.speed"])?, md.vr("axis.speed")?),
    };
    let mut flanks = FlankWatch::new(fmu, config.axis)?;
    let h = config.step_s;
    let settle_steps = (config.settle_s / h).round() as usize;
    let record_steps = (config.record_s / h).round() as usize;
    let mut excitation_rng = ChaCha8Rng::seed_from_u64(config.seed);
    let mut sensor_rng = ChaCha8Rng::seed_from_u64(config.seed ^ 0x5EED_5E25_0000_0001);
    let mut record = Record {
        input: Vec::with_capacity(record_steps),
        output: Vec::with_capacity(record_steps),
        min_motor_speed: f64::INFINITY,
        speed_sum: 0.0,
        axis_speed_sum: 0.0,
        flank_changes: 0,
    };
    let mut speeds = vec![0.0; speed_vrs.len()];
    let mut axis_speed = [0.0];
    for k in 0..settle_steps + record_steps {
        let t = k as f64 * h;
        // The output at t_k comes before the input held over [t_k, t_k+1): paired this way the
        // estimate is the held-and-sampled response, which is strictly proper.
        instance.get_real(&speed_vrs, &mut speeds)?;
        let noise: f64 = StandardNormal.sample(&mut excitation_rng);
        let common = config.offset_current_a + config.noise_current_a * noise;
        let sensor: f64 = StandardNormal.sample(&mut sensor_rng);
        if k >= settle_steps {
            record.input.push(common);
            record.output.push(speeds[0] + config.sensor_noise_rad_per_s * sensor);
            record.min_motor_speed = speeds.iter().copied().fold(record.min_motor_speed, f64::min);
            record.speed_sum += speeds[0];
            instance.get_real(&[axis_speed_vr], &mut axis_speed)?;
            record.axis_speed_sum += axis_speed[0];
            flanks.sample(instance)?;
        }
        let commands: Vec<f64> = match config.axis {
            Axis::Azimuth => vec![common + config.bias_current_a, common - config.bias_current_a],
            Axis::Elevation => vec![common],
        };
        instance.set_real(&input_vrs, &commands)?;
        if let Some(s) = structure.as_deref_mut() {
            // The structure swung by the axis, and its torque back on the axis.
            instance.get_real(&[axis_speed_vr], &mut axis_speed)?;
            let mut speeds = [0.0; 2];
            speeds[s.axis_index] = axis_speed[0];
            s.instance.set_real(&s.speed_vrs, &speeds)?;
            let mut torque = [0.0];
            s.instance.get_real(&[s.drive_vr], &mut torque)?;
            instance.set_real(&[load_torque_vr], &torque)?;
            s.instance.do_step(t, h)?;
        }
        instance.do_step(t, h)?;
    }
    record.flank_changes = flanks.changes;
    Ok(record)
}

/// The figures of merit of one identification, as the summary and the test state them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    pub measured_trough: Trough,
    pub analytic_trough: Trough,
    /// (measured - analytic) / analytic trough frequency.
    pub trough_error: f64,
    pub undamped_anti_resonance_hz: f64,
    /// Coherence at the bin nearest the measured trough.
    pub trough_coherence: f64,
    /// Bins with coherence above [`COHERENCE_THRESHOLD`], out of all bins.
    pub coherent_bins: usize,
    pub bins: usize,
    /// Largest magnitude error over the coherent bins, dB, and where.
    pub max_db_error: f64,
    pub max_db_error_at_hz: f64,
    /// The same from bin [`LEAKAGE_BINS`] up, where the window's bias is negligible and what
    /// is left is the random error of the estimate.
    pub max_db_error_above_leakage: f64,
    pub max_phase_error_deg: f64,
    /// Three standard deviations of the random error of |H1| at the least coherent of the
    /// coherent bins, dB: what the record length and averaging buy.
    pub random_error_3_sigma_db: f64,
}

/// Coherence above which the magnitude is compared.
pub const COHERENCE_THRESHOLD: f64 = 0.9;

/// The lowest bins, where the Hann window's main lobe (+/-2 bins) averages the steep
/// rigid-body slope (|H| ~ 1/f above the 0.015 Hz rigid-body corner) and biases |H1| upwards:
/// by about 0.5 dB at bin 3, falling as 1/bin^2. Coherence does not flag this bias, so the
/// summary states the largest error with and without these bins.
pub const LEAKAGE_BINS: usize = 5;

/// Upper frequency of the figures: the current loop's bandwidth is 100 Hz and the sensor noise
/// hides the response above about 150 Hz.
pub const FIGURE_MAX_FREQUENCY_HZ: f64 = 200.0;

impl Identification {
    pub fn summary(&self) -> Summary {
        let measured_trough = self.measured_trough();
        let analytic_trough = self.analytic_trough();
        let bins = self.coherent_bins(COHERENCE_THRESHOLD, f64::INFINITY);
        let (max_db_error, max_db_error_at_hz) = self.max_magnitude_error_db(&bins);
        // Bin 1 is the first entry (DC is not kept), so bin LEAKAGE_BINS is index LEAKAGE_BINS - 1.
        let above: Vec<usize> = bins.iter().copied().filter(|&i| i + 1 >= LEAKAGE_BINS).collect();
        let worst_random = bins.iter().map(|&i| self.random_error(i)).fold(0.0, f64::max);
        Summary {
            trough_error: (measured_trough.frequency_hz - analytic_trough.frequency_hz) / analytic_trough.frequency_hz,
            measured_trough,
            analytic_trough,
            undamped_anti_resonance_hz: self.undamped_anti_resonance_hz(),
            trough_coherence: self.coherence[self.nearest_bin(measured_trough.frequency_hz)],
            coherent_bins: bins.len(),
            bins: self.frequency_hz.len(),
            max_db_error,
            max_db_error_at_hz,
            max_db_error_above_leakage: self.max_magnitude_error_db(&above).0,
            max_phase_error_deg: self.max_phase_error_deg(&bins),
            random_error_3_sigma_db: 20.0 * (1.0 + 3.0 * worst_random).log10(),
        }
    }
}

/// A markdown table of the results, one row per identification, with the figures embedded
/// (`figure_names` are paths relative to the markdown file).
pub fn markdown_summary(results: &[(&Identification, &str)]) -> String {
    let mut out = String::from(
        "# Frequency-domain identification of the packaged plant FMUs\n\n\
         Generated by `cargo run --release -p antenna-cli --bin plant-bode` from `target/fmu/*.fmu` \
         (package first). The seed paper's experiment (Figs. 6 and 8): white-noise current on a \
         constant offset that keeps the axis moving, sensor noise on the measured motor speed, H1 \
         estimate (Welch, Hann, 50 % overlap) and coherence, compared with the corrected Eq. 1 times \
         the current loop and the torque constant, behind the FMU's zero-order hold. All nonlinear \
         effects of the plant are on; the offset keeps every body sliding and, in azimuth, a torque \
         bias keeps each pinion on its flank.\n\n",
    );
    out.push_str("| axis | record | segments (dof) | offset / noise / bias current | sensor noise | mean axis speed | trough measured | trough analytic | error | sqrt(K_s/J_L) | bins with coherence > 0.9 | max magnitude error there (from bin 5) | 3 sigma random error | max phase error |\n");
    out.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (r, _) in results {
        let s = r.summary();
        let c = &r.config;
        out.push_str(&format!(
            "| {} at {} deg | {} s at {} ms | {} ({:.0}) | {} / {} / {} A | {} rad/s | {:.3} deg/s | {:.3} Hz | {:.3} Hz | {:+.2} % | {:.3} Hz | {} of {} | {:.2} dB at {:.1} Hz ({:.2} dB) | {:.2} dB | {:.1} deg |\n",
            r.config.axis.name(),
            c.elevation_deg,
            c.record_s,
            c.step_s * 1e3,
            r.segments,
            r.dof,
            c.offset_current_a,
            c.noise_current_a,
            if c.axis == Axis::Azimuth { c.bias_current_a.to_string() } else { "-".into() },
            c.sensor_noise_rad_per_s,
            r.mean_axis_speed_deg_per_s,
            s.measured_trough.frequency_hz,
            s.analytic_trough.frequency_hz,
            100.0 * s.trough_error,
            s.undamped_anti_resonance_hz,
            s.coherent_bins,
            s.bins,
            s.max_db_error,
            s.max_db_error_at_hz,
            s.max_db_error_above_leakage,
            s.random_error_3_sigma_db,
            s.max_phase_error_deg,
        ));
    }
    out.push('\n');
    for (r, figure) in results {
        out.push_str(&format!(
            "![{} at {} deg]({figure})\n\n",
            capitalise(r.config.axis.name()),
            r.config.elevation_deg
        ));
    }
    out
}
