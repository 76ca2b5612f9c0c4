//! The closed velocity loop identified like the seed paper's Figs. 7 and 9: a packaged
//! controller FMU in velocity mode, coupled to its packaged plant FMU (default friction,
//! backlash and torque bias) through the C ABI, driven by a Gaussian white-noise velocity
//! command on top of a constant velocity that keeps the axis sliding in one direction; the H1
//! estimate (Welch) from the commanded axis velocity to the measured one (motor speed over the
//! ratio) with its coherence, beside the analytic closed loop of `fmu_controller::linear` on the
//! plant crate's two-mass model.
//!
//! Why the experiment is linear although the plant is not: the offset keeps every motor turning
//! one way, so Coulomb friction is a constant torque (which the loop's integrator absorbs and the
//! linear detrending removes); in azimuth the controller's torque bias keeps each pinion on its
//! own flank as long as the total torque stays below the bias's fade start.
//! [`VelocityBode::linear_regime_held`] checks all three conditions on the recorded run.
//!
//! Parameters the controller FMU gets besides its defaults, and why:
//!
//! * `mode` = velocity: `command.velocity_mode` is the velocity reference;
//! * `feedforward.acceleration` = false: in velocity mode it would add `J N dv/dt`, a path the
//!   analytic closed loop (reference to speed through the PI) does not contain;
//! * `position_loop.max_acceleration` = 1e6 deg/s^2: the reference's rate limiter (2 and
//!   1 deg/s^2 by default) would clip a white-noise command, whose sample-to-sample change is
//!   thousands of deg/s^2. The FMU does not expose the library's
//!   `velocity_mode_acceleration_limited` switch, so the limit is raised instead;
//! * elevation `friction_feedforward.enabled` = false: not needed while the direction does not
//!   change, but it would switch sign if the reference ever crossed zero.

use std::f64::consts::TAU;
use std::path::Path;

use fmu_controller::linear::{bandwidth_hz, VelocityLoopModel, C64};
use fmu_controller::{
    AzimuthController, AzimuthControllerParams, ControlMode, ElevationController, ElevationControllerParams,
};
use fmu_import::{Fmu, Instance};
use fmu_plant::analytic::current_loop_response;
use fmu_plant::{AzimuthParams, ElevationParams};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use antenna_dsp::{Complex64, ResponseComparison};
use antenna_plot::{measured_against_model, Figure, Panel};

use super::{read_real, welch_h1, Axis, FlankWatch, IdentificationError, MeasuredResponse};

/// The experiment; [`VelocityBodeConfig::paper`] gives the settings of the figures and tests.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VelocityBodeConfig {
    pub axis: Axis,
    /// Elevation, deg: the azimuth plant's elevation input, or where the elevation axis starts
    /// (it moves up from there at the offset speed).
    pub elevation_deg: f64,
    /// Communication step and controller sample time, s.
    pub step_s: f64,
    /// From rest to the start of the record, s: the axis breaks away and the integrator takes
    /// up the friction.
    pub settle_s: f64,
    pub record_s: f64,
    /// Welch segment, s (frequency resolution 1/segment).
    pub segment_s: f64,
    /// Constant part of the velocity command, deg/s.
    pub offset_deg_per_s: f64,
    /// Standard deviation of the white-noise part, deg/s.
    pub noise_deg_per_s: f64,
    pub seed: u64,
}

impl VelocityBodeConfig {
    /// 15 deg elevation as in Figs. 7 and 9, 1 ms steps, 200 s of record in 4 s segments (99
    /// segments at 50 % overlap; 0.25 Hz resolution, 12 bins across the 10-15 Hz band).
    ///
    /// Amplitudes: the closed loop passes the command's white noise to the torque through the
    /// proportional gain, `Kv N sigma`: 222 sigma N m per deg/s in azimuth (Kv 1.41 N m s/rad,
    /// N 9000) and 59 sigma in elevation. In azimuth that must stay, with the friction torque
    /// (about 0.8 N m), below the bias's fade start (3.6 N m) at four standard deviations:
    /// sigma = 0.002 deg/s gives 0.44 N m RMS. The motor speed fluctuates by about a fifth of
    /// `N sigma` (the loop passes some 15 Hz of the 500 Hz noise band), so an offset of ten
    /// times sigma keeps the motors far from reversing. The elevation offset is small so that
    /// the axis moves only 2 deg during the run (the ratio changes 1 % over it).
    pub fn paper(axis: Axis) -> Self {
        let (offset, noise, seed) = match axis {
            Axis::Azimuth => (0.02, 0.002, 20_260_711),
            Axis::Elevation => (0.01, 0.002, 20_260_911),
        };
        VelocityBodeConfig {
            axis,
            elevation_deg: 15.0,
            step_s: 1e-3,
            settle_s: 5.0,
            record_s: 200.0,
            segment_s: 4.0,
            offset_deg_per_s: offset,
            noise_deg_per_s: noise,
            seed,
        }
    }
}

/// The identified and the analytic closed velocity loop.
#[derive(Debug, Clone)]
pub struct VelocityBode {
    pub config: VelocityBodeConfig,
    /// Bin frequencies, Hz (DC excluded).
    pub frequency_hz: Vec<f64>,
    /// H1 from the commanded axis velocity to the measured one (motor speed over the ratio).
    pub measured: Vec<Complex64>,
    pub coherence: Vec<f64>,
    /// `VelocityLoopModel::closed_loop` on the plant crate's two-mass model with its current
    /// loop, at the mean elevation of the record.
    pub analytic: Vec<Complex64>,
    /// Where the analytic model is evaluated, deg (the elevation axis moves during the run).
    pub model_elevation_deg: f64,
    /// -3 dB bandwidths (relative to the gain at the lowest bin), Hz.
    pub measured_bandwidth_hz: Option<f64>,
    pub analytic_bandwidth_hz: Option<f64>,
    /// Smallest motor speed over the record, rad/s (positive: no motor reversed).
    pub min_motor_speed_rad_per_s: f64,
    /// Largest |total torque command| over the record, N m, and the bias's fade start (azimuth;
    /// infinite in elevation).
    pub max_torque_nm: f64,
    pub bias_fade_start_nm: f64,
    /// Pinion flank changes over the record (azimuth).
    pub flank_changes: usize,
    pub segments: usize,
    pub simulation_wall_s: f64,
    pub analysis_wall_s: f64,
}

/// The analytic velocity-loop model of the library controller with the parameters the FMU
/// reports, refusing to go on if the FMU's loop parameters differ from the library defaults the
/// model is built from (the model would describe another controller).
fn analytic_model(
    axis: Axis,
    fmu: &Fmu,
    instance: &mut Instance,
    step_s: f64,
    elevation_deg: f64,
) -> Result<VelocityLoopModel, IdentificationError> {
    let (cascade, own): (_, Vec<(&str, f64)>) = match axis {
        Axis::Azimuth => {
            let p = AzimuthControllerParams::default();
            (
                p.cascade,
                vec![
                    ("drive.motor_inertia", p.drive.motor_inertia_kg_m2),
                    ("drive.axis_inertia", p.drive.axis_inertia_kg_m2),
                    ("drive.gear_ratio", p.drive.gear_ratio),
                ],
            )
        }
        Axis::Elevation => {
            let p = ElevationControllerParams::default();
            (
                p.cascade,
                vec![
                    ("drive.motor_inertia", p.drive.motor_inertia_kg_m2),
                    ("drive.dish_inertia", p.drive.dish_inertia_kg_m2),
                ],
            )
        }
    };
    let v = &cascade.velocity_loop;
    let mut expected = vec![
        ("velocity_loop.crossover", v.crossover_hz),
        ("velocity_loop.integral_corner_ratio", v.integral_corner_ratio),
        ("velocity_loop.gain_override", v.proportional_gain_override_nm_s_per_rad.unwrap_or(0.0)),
        ("velocity_loop.integral_corner_override", v.integral_corner_override_hz.unwrap_or(0.0)),
        ("velocity_loop.speed_low_pass", v.speed_low_pass_hz),
        ("velocity_loop.notch_frequency", v.speed_notch.frequency_hz),
    ];
    expected.extend(own);
    for (parameter, library) in expected {
        let reported = read_real(fmu, instance, parameter)?;
        if reported != library {
            return Err(IdentificationError::ControllerParameter { parameter, reported, library });
        }
    }
    let mut integrator = [false];
    instance.get_boolean(&[fmu.description.vr("velocity_loop.integrator")?], &mut integrator)?;
    if integrator[0] != v.integrator_enabled {
        return Err(IdentificationError::IntegratorSetting);
    }
    let delay = {
        let mut value = [0];
        instance.get_integer(&[fmu.description.vr("sampling.delay_samples")?], &mut value)?;
        value[0]
    };
    if i64::from(delay) != i64::from(cascade.sampling.delay_samples) {
        return Err(IdentificationError::ControllerDelay {
            fmu: i64::from(delay),
            library: i64::from(cascade.sampling.delay_samples),
        });
    }
    match axis {
        Axis::Azimuth => {
            let mut p = AzimuthControllerParams::default();
            p.cascade.sampling.sample_time_s = step_s;
            Ok(AzimuthController::new(p).map_err(IdentificationError::Controller)?.velocity_loop_model())
        }
        Axis::Elevation => {
            let mut p = ElevationControllerParams::default();
            p.cascade.sampling.sample_time_s = step_s;
            Ok(ElevationController::new(p)
                .map_err(IdentificationError::Controller)?
                .velocity_loop_model_at(elevation_deg))
        }
    }
}

/// Motor speed (the mean of the motors in azimuth) per total motor torque command of the plant
/// crate's default two-mass model with its current loop, at `s = j omega`.
pub fn plant_motor_speed_per_torque(axis: Axis, elevation_deg: f64, omega: f64) -> C64 {
    let s = C64::new(0.0, omega);
    match axis {
        Axis::Azimuth => {
            let p = AzimuthParams::default();
            current_loop_response(s, p.motors[0].current_loop_bandwidth_hz)
                * p.two_mass_at(elevation_deg).motor_speed_per_torque(s)
        }
        Axis::Elevation => {
            let p = ElevationParams::default();
            current_loop_response(s, p.motor.current_loop_bandwidth_hz)
                * p.two_mass_at(elevation_deg).motor_speed_per_torque(s)
        }
    }
}

/// The -3 dB point of a sampled magnitude response: the first bin below `1/sqrt(2)` of the
/// first bin's magnitude, interpolated linearly in dB against log frequency.
pub fn sampled_bandwidth_hz(frequency_hz: &[f64], magnitude: &[f64]) -> Option<f64> {
    let level_db = 20.0 * (magnitude.first()? / 2f64.sqrt()).log10();
    let db: Vec<f64> = magnitude.iter().map(|m| 20.0 * m.log10()).collect();
    (1..db.len()).find(|&i| db[i - 1] >= level_db && db[i] < level_db).map(|i| {
        let (f0, f1) = (frequency_hz[i - 1].ln(), frequency_hz[i].ln());
        let x = (db[i - 1] - level_db) / (db[i - 1] - db[i]);
        (f0 + x * (f1 - f0)).exp()
    })
}

/// Runs the experiment on the packaged FMUs in `fmu_directory`.
pub fn identify_velocity_loop(
    fmu_directory: &Path,
    config: &VelocityBodeConfig,
) -> Result<VelocityBode, IdentificationError> {
    let started = std::time::Instant::now();
    let axis = config.axis;
    let plant_fmu = Fmu::open(fmu_directory.join(format!("{}.fmu", axis.model_identifier())))?;
    let controller_fmu = Fmu::open(fmu_directory.join(format!("{}.fmu", axis.controller_model_identifier())))?;
    let start_position = match axis {
        Axis::Azimuth => 0.0,
        Axis::Elevation => config.elevation_deg,
    };
    let mut plant = initialised_plant(&plant_fmu, config, start_position)?;
    let mut controller = initialised_controller(&controller_fmu, config, start_position)?;
    let bias_fade_start_nm = match axis {
        Axis::Azimuth => read_real(&controller_fmu, &mut controller, "torque_bias.fade_start")?,
        Axis::Elevation => f64::INFINITY,
    };
    let record = record(&plant_fmu, &mut plant, &controller_fmu, &mut controller, config)?;
    let model_elevation_deg = record.elevation_sum / record.input.len() as f64;
    let h = config.step_s;
    let model = analytic_model(axis, &controller_fmu, &mut controller, h, model_elevation_deg)?;
    let simulation_wall_s = started.elapsed().as_secs_f64();

    let analysis_started = std::time::Instant::now();
    let estimate = welch_h1(&record.input, &record.output, h, config.segment_s)?;
    let frequency_hz = estimate.frequency_hz;
    let closed = |omega: f64| model.closed_loop(omega, plant_motor_speed_per_torque(axis, model_elevation_deg, omega));
    let analytic: Vec<Complex64> = frequency_hz.iter().map(|&f| closed(TAU * f)).collect();
    let measured_bandwidth_hz =
        sampled_bandwidth_hz(&frequency_hz, &estimate.measured.iter().map(|h| h.norm()).collect::<Vec<_>>());
    let sample_rate = 1.0 / h;
    let analytic_bandwidth_hz = bandwidth_hz(closed, frequency_hz[0], 0.4 * sample_rate, 4000);
    Ok(VelocityBode {
        config: *config,
        measured: estimate.measured,
        coherence: estimate.coherence,
        frequency_hz,
        analytic,
        model_elevation_deg,
        measured_bandwidth_hz,
        analytic_bandwidth_hz,
        min_motor_speed_rad_per_s: record.min_motor_speed,
        max_torque_nm: record.max_torque,
        bias_fade_start_nm,
        flank_changes: record.flank_changes,
        segments: estimate.segments,
        simulation_wall_s,
        analysis_wall_s: analysis_started.elapsed().as_secs_f64(),
    })
}

/// The plant instance at rest at `start_position` (and, in azimuth, at the experiment's
/// elevation).
fn initialised_plant(
    fmu: &Fmu,
    config: &VelocityBodeConfig,
    start_position: f64,
) -> Result<Instance, IdentificationError> {
    let pd = &fmu.description;
    let mut plant = fmu.instantiate(&format!("{}-plant", config.axis.name()), false)?;
    plant.setup_experiment(0.0, None)?;
    plant.enter_initialization_mode()?;
    plant.set_real(&[pd.vr("initial_position")?], &[start_position])?;
    if config.axis == Axis::Azimuth {
        plant.set_real(&[pd.vr("elevation")?], &[config.elevation_deg])?;
    }
    plant.exit_initialization_mode()?;
    Ok(plant)
}

/// The controller instance in velocity mode with the parameters the module header explains.
fn initialised_controller(
    fmu: &Fmu,
    config: &VelocityBodeConfig,
    start_position: f64,
) -> Result<Instance, IdentificationError> {
    let cd = &fmu.description;
    let mut controller = fmu.instantiate(&format!("{}-controller", config.axis.name()), false)?;
    controller.setup_experiment(0.0, None)?;
    controller.enter_initialization_mode()?;
    controller.set_real(
        &cd.vrs(&["sampling.sample_time", "position_loop.max_acceleration", "command.position", "measured.position"])?,
        &[config.step_s, 1e6, start_position, start_position],
    )?;
    controller.set_boolean(&[cd.vr("feedforward.acceleration")?], &[false])?;
    if config.axis == Axis::Elevation {
        controller.set_boolean(&[cd.vr("friction_feedforward.enabled")?], &[false])?;
    }
    controller.set_integer(&[cd.vr("mode")?], &[ControlMode::Velocity.index()])?;
    controller.exit_initialization_mode()?;
    Ok(controller)
}

/// What the run recorded after the settling time.
struct Record {
    /// The velocity command, deg/s.
    input: Vec<f64>,
    /// The measured axis velocity (motor speed over the ratio), deg/s.
    output: Vec<f64>,
    min_motor_speed: f64,
    max_torque: f64,
    /// Sum of the elevation over the record, for the model's elevation.
    elevation_sum: f64,
    flank_changes: usize,
}

/// Couples the two instances step by step with the seeded command, through the settling time
/// and the record, and keeps the record with the linear-regime checks.
fn record(
    plant_fmu: &Fmu,
    plant: &mut Instance,
    controller_fmu: &Fmu,
    controller: &mut Instance,
    config: &VelocityBodeConfig,
) -> Result<Record, IdentificationError> {
    let axis = config.axis;
    let (pd, cd) = (&plant_fmu.description, &controller_fmu.description);
    // Ports: plant outputs (encoder, motor speeds, ratio) -> controller inputs; controller
    // currents -> plant.
    let (plant_out, plant_in, ctrl_in, ctrl_out) = match axis {
        Axis::Azimuth => (
            pd.vrs(&["axis.encoder_position", "motor1.speed", "motor2.speed"])?,
            pd.vrs(&["motor1.current_command", "motor2.current_command"])?,
            cd.vrs(&["measured.position", "measured.motor1_speed", "measured.motor2_speed", "command.velocity_mode"])?,
            cd.vrs(&["motor1.current_command", "motor2.current_command", "status.torque_command"])?,
        ),
        Axis::Elevation => (
            pd.vrs(&["axis.encoder_position", "motor.speed", "drive.ratio"])?,
            pd.vrs(&["motor.current_command"])?,
            cd.vrs(&["measured.position", "measured.motor_speed", "command.velocity_mode"])?,
            cd.vrs(&["motor.current_command", "status.torque_command"])?,
        ),
    };
    let azimuth_ratio = match axis {
        Axis::Azimuth => read_real(plant_fmu, plant, "gear.ratio")?,
        Axis::Elevation => f64::NAN,
    };
    let mut flanks = FlankWatch::new(plant_fmu, axis)?;

    let h = config.step_s;
    let settle_steps = (config.settle_s / h).round() as usize;
    let record_steps = (config.record_s / h).round() as usize;
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
    let mut record = Record {
        input: Vec::with_capacity(record_steps),
        output: Vec::with_capacity(record_steps),
        min_motor_speed: f64::INFINITY,
        max_torque: 0.0,
        elevation_sum: 0.0,
        flank_changes: 0,
    };
    let mut plant_values = vec![0.0; plant_out.len()];
    let mut ctrl_values = vec![0.0; ctrl_out.len()];
    for k in 0..settle_steps + record_steps {
        let t = k as f64 * h;
        plant.get_real(&plant_out, &mut plant_values)?;
        let noise: f64 = StandardNormal.sample(&mut rng);
        let command = config.offset_deg_per_s + config.noise_deg_per_s * noise;
        let (motor_speed, ratio) = match axis {
            Axis::Azimuth => (0.5 * (plant_values[1] + plant_values[2]), azimuth_ratio),
            Axis::Elevation => (plant_values[1], plant_values[2]),
        };
        // Encoder and motor speed(s), then the command.
        let mut inputs = plant_values[..ctrl_in.len() - 1].to_vec();
        inputs.push(command);
        controller.set_real(&ctrl_in, &inputs)?;
        controller.get_real(&ctrl_out, &mut ctrl_values)?;
        let (currents, torque) = ctrl_values.split_at(plant_in.len());
        let torque = torque[0];
        plant.set_real(&plant_in, currents)?;
        if k >= settle_steps {
            // The output at t_k with the command the controller samples at t_k: the pair of the
            // sampled closed loop, whose delay and hold the analytic model contains.
            record.input.push(command);
            record.output.push((motor_speed / ratio).to_degrees());
            let speeds = match axis {
                Axis::Azimuth => vec![plant_values[1], plant_values[2]],
                Axis::Elevation => vec![plant_values[1]],
            };
            record.min_motor_speed = speeds.into_iter().fold(record.min_motor_speed, f64::min);
            record.max_torque = record.max_torque.max(torque.abs());
            record.elevation_sum += match axis {
                Axis::Azimuth => config.elevation_deg,
                Axis::Elevation => plant_values[0],
            };
            flanks.sample(plant)?;
        }
        plant.do_step(t, h)?;
        controller.do_step(t, h)?;
    }
    record.flank_changes = flanks.changes;
    Ok(record)
}

impl VelocityBode {
    /// The run stayed in the regime where the loop is linear: no motor reversed, no pinion
    /// changed flank, the torque stayed below the bias's fade start.
    pub fn linear_regime_held(&self) -> bool {
        self.min_motor_speed_rad_per_s > 0.0 && self.flank_changes == 0 && self.max_torque_nm < self.bias_fade_start_nm
    }

    /// Magnitude (dB), phase and coherence from the first bin to `max_frequency_hz`, measured
    /// against analytic, with the -3 dB points.
    pub fn figure(&self, max_frequency_hz: f64) -> Figure {
        let title = format!(
            "Closed velocity loop of the {} axis at {} deg elevation (controller and plant FMUs, velocity mode)",
            self.config.axis.name(),
            self.config.elevation_deg
        );
        let model = format!(
            "analytic: fmu_controller::linear closed loop on the two-mass model at {:.1} deg",
            self.model_elevation_deg
        );
        let magnitude = Panel::new("Magnitude").x_label("Frequency (Hz)").y_label("|v / v_cmd| (dB)");
        measured_against_model(
            &title,
            &self.comparison(),
            max_frequency_hz,
            magnitude,
            "measured H1 (Welch)",
            &model,
            |mut magnitude| {
                magnitude = magnitude.horizontal_line("-3 dB", -3.0);
                if let Some(b) = self.measured_bandwidth_hz {
                    magnitude = magnitude.vertical_line(&format!("measured -3 dB {b:.2} Hz"), b);
                }
                if let Some(b) = self.analytic_bandwidth_hz {
                    magnitude = magnitude.vertical_line(&format!("analytic -3 dB {b:.2} Hz"), b);
                }
                magnitude
            },
        )
    }
}

impl MeasuredResponse for VelocityBode {
    /// The estimate beside the analytic loop, bin by bin.
    fn comparison(&self) -> ResponseComparison<'_> {
        ResponseComparison {
            frequency_hz: &self.frequency_hz,
            measured: &self.measured,
            analytic: &self.analytic,
            coherence: &self.coherence,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sampled_bandwidth_of_a_first_order_lag_is_its_corner() {
        let corner = 12.0;
        let f: Vec<f64> = (1..400).map(|k| 0.25 * k as f64).collect();
        let m: Vec<f64> = f.iter().map(|x| 1.0 / (1.0 + (x / corner).powi(2)).sqrt()).collect();
        // Relative to the first bin (0.25 Hz): 1 + x^2 = 2 (1 + x0^2).
        let x0 = 0.25 / corner;
        let expected = corner * (1.0 + 2.0 * x0 * x0).sqrt();
        let b = sampled_bandwidth_hz(&f, &m).unwrap();
        // Linear interpolation in dB over log f between bins 0.25 Hz apart.
        assert!((b - expected).abs() < 0.01, "{b} vs {expected}");
        assert!(sampled_bandwidth_hz(&f, &vec![1.0; f.len()]).is_none());
    }
}
