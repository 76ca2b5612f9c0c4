//! A simple local model of the drive trains for closed-loop tests of the controller, written
//! independently of the plant crate: rigid load plus compliant paths to one or two motors,
//! first-order current loops with saturation, Coulomb and static friction with sticking,
//! optional dead-zone backlash. Everything is reflected to the motor side and integrated with
//! semi-implicit Euler on a fine sub-step, which is ample for tests of a 1 kHz controller.
//!
//! Also here: the loop that couples a controller to a plant through the controller's
//! [`SampleScheduler`] (one communication step per sample), and the requirement measures.

#![allow(dead_code)]

use fmu_controller::linear::{AxisPlantResponse, C64};
use fmu_controller::timing::{SampleScheduler, SampledController};
use fmu_controller::{
    AzimuthController, AzimuthInputs, AzimuthOutputs, ControlMode, ElevationController, ElevationInputs,
    ElevationOutputs,
};

pub const ARCSEC: f64 = 1.0 / 3600.0;

/// Physical parameters of a local axis model, axis-side values as in the plant crate.
#[derive(Debug, Clone, Copy)]
pub struct LocalAxisParams {
    pub gear_ratio: f64,
    pub motors: usize,
    pub motor_inertia: f64,
    pub motor_viscous: f64,
    pub axis_inertia: f64,
    /// Per path, N m/rad about the axis.
    pub path_stiffness_axis: f64,
    /// Per path, N m s/rad about the axis.
    pub path_damping_axis: f64,
    pub torque_constant: f64,
    pub current_limit: f64,
    pub current_bandwidth_hz: f64,
    /// Per motor, N m.
    pub motor_coulomb: f64,
    pub motor_static: f64,
    /// About the axis, N m.
    pub load_coulomb_axis: f64,
    pub load_static_axis: f64,
    /// Total free play per path, rad about the axis.
    pub backlash_axis: f64,
}

impl LocalAxisParams {
    /// The plant crate's default azimuth values at an elevation.
    pub fn azimuth(elevation_deg: f64) -> Self {
        let (s, c) = elevation_deg.to_radians().sin_cos();
        Self {
            gear_ratio: 9000.0,
            motors: 2,
            motor_inertia: 0.006,
            motor_viscous: 1e-3,
            axis_inertia: 5.5e5 + 2.0e5 * c * c + 4.0e5 * s * s,
            path_stiffness_axis: 7.3e9,
            path_damping_axis: 5.3e6,
            torque_constant: 0.8,
            current_limit: 15.0,
            current_bandwidth_hz: 100.0,
            motor_coulomb: 0.3,
            motor_static: 0.4,
            load_coulomb_axis: 1500.0,
            load_static_axis: 2000.0,
            backlash_axis: 1e-4,
        }
    }

    /// The plant crate's default elevation values, with the jackscrew frozen at one angle.
    pub fn elevation(elevation_deg: f64) -> Self {
        let el = elevation_deg.to_radians();
        let (rd, ry) = (2.0f64, 3.6f64);
        let angle = 20f64.to_radians() + el;
        let length = (rd * rd + ry * ry - 2.0 * rd * ry * angle.cos()).sqrt();
        let lever = rd * ry * angle.sin() / length;
        let ns = std::f64::consts::TAU * 28.0 / 0.02;
        let nut = length - 1.57;
        let ea = 1.65e9;
        let screw = ea / nut + ea / (3.5 - nut);
        let axial = 1.0 / (1.0 / screw + 1.0 / 5.0e9);
        let n = ns * lever;
        Self {
            gear_ratio: n,
            motors: 1,
            motor_inertia: 0.002,
            motor_viscous: 5e-4,
            axis_inertia: 3.5e5,
            path_stiffness_axis: axial * lever * lever,
            path_damping_axis: 1.4e6 * lever * lever,
            torque_constant: 0.8,
            current_limit: 15.0,
            current_bandwidth_hz: 100.0,
            // Motor 0.15/0.2 plus the screw's 8/10 N m through the 28:1 gearbox.
            motor_coulomb: 0.15 + 8.0 / 28.0,
            motor_static: 0.2 + 10.0 / 28.0,
            load_coulomb_axis: 500.0,
            load_static_axis: 650.0,
            backlash_axis: 0.0,
        }
    }

    /// Without friction and backlash: the linear two-mass model.
    pub fn linear(self) -> Self {
        Self {
            motor_coulomb: 0.0,
            motor_static: 0.0,
            load_coulomb_axis: 0.0,
            load_static_axis: 0.0,
            backlash_axis: 0.0,
            ..self
        }
    }

    /// The linear model's response at `s = j omega` per total torque command (N m), with the
    /// current loop: motor speed and axis angle. Written from the two-mass equations of motion
    /// with all motors lumped (`n J_m`, `n K`, `n c`).
    pub fn response(&self, omega: f64) -> AxisPlantResponse {
        let s = C64::new(0.0, omega);
        let n = self.gear_ratio;
        let m = self.motors as f64;
        let jm = m * self.motor_inertia;
        let bm = m * self.motor_viscous;
        let k = m * self.path_stiffness_axis / (n * n);
        let c = m * self.path_damping_axis / (n * n);
        let jl = self.axis_inertia / (n * n);
        // [jm s^2 + (bm + c) s + k, -(c s + k); -(c s + k), jl s^2 + c s + k] [pm; pl] = [T; 0]
        let a11 = jm * s * s + (bm + c) * s + k;
        let a12 = -(c * s + k);
        let a22 = jl * s * s + c * s + k;
        let det = a11 * a22 - a12 * a12;
        let wc = std::f64::consts::TAU * self.current_bandwidth_hz;
        let current_loop = wc / (s + wc);
        let pm = a22 / det * current_loop;
        let pl = -a12 / det * current_loop;
        AxisPlantResponse { motor_speed_per_torque: s * pm, axis_angle_per_torque: pl / n }
    }
}

/// One simulated axis. Angles and speeds are at the motor side (load angle times `N`).
#[derive(Debug, Clone)]
pub struct LocalAxis {
    pub p: LocalAxisParams,
    load_angle: f64,
    load_speed: f64,
    load_stuck: bool,
    motor_angle: Vec<f64>,
    motor_speed: Vec<f64>,
    motor_stuck: Vec<bool>,
    current: Vec<f64>,
    /// Disturbance torque about the axis, N m.
    pub disturbance_axis: f64,
}

pub const SUBSTEP: f64 = 2e-5;

impl LocalAxis {
    /// At rest at `axis_deg`, paths untwisted and centred in their backlash.
    pub fn new(p: LocalAxisParams, axis_deg: f64) -> Self {
        let theta = axis_deg.to_radians() * p.gear_ratio;
        Self {
            p,
            load_angle: theta,
            load_speed: 0.0,
            load_stuck: true,
            motor_angle: vec![theta; p.motors],
            motor_speed: vec![0.0; p.motors],
            motor_stuck: vec![true; p.motors],
            current: vec![0.0; p.motors],
            disturbance_axis: 0.0,
        }
    }

    pub fn axis_deg(&self) -> f64 {
        (self.load_angle / self.p.gear_ratio).to_degrees()
    }

    pub fn motor_speeds(&self) -> Vec<f64> {
        self.motor_speed.clone()
    }

    /// Sets one motor's speed, for example to excite the motors' differential mode.
    pub fn set_motor_speed(&mut self, k: usize, speed: f64) {
        self.motor_speed[k] = speed;
        self.motor_stuck[k] = false;
    }

    fn path_torque(&self, k: usize) -> f64 {
        let n2 = self.p.gear_ratio * self.p.gear_ratio;
        let half_gap = 0.5 * self.p.backlash_axis * self.p.gear_ratio;
        let twist = self.motor_angle[k] - self.load_angle;
        let deflection = twist - twist.clamp(-half_gap, half_gap);
        if deflection == 0.0 && half_gap > 0.0 {
            return 0.0;
        }
        self.p.path_stiffness_axis / n2 * deflection
            + self.p.path_damping_axis / n2 * (self.motor_speed[k] - self.load_speed)
    }

    /// Advances by `h` with the current commands held.
    pub fn step(&mut self, current_commands: &[f64], h: f64) {
        let substeps = (h / SUBSTEP).round().max(1.0) as usize;
        let dt = h / substeps as f64;
        let lag = 1.0 - (-std::f64::consts::TAU * self.p.current_bandwidth_hz * dt).exp();
        let n = self.p.gear_ratio;
        for _ in 0..substeps {
            let paths: Vec<f64> = (0..self.p.motors).map(|k| self.path_torque(k)).collect();
            for k in 0..self.p.motors {
                let command = current_commands[k].clamp(-self.p.current_limit, self.p.current_limit);
                self.current[k] += (command - self.current[k]) * lag;
                let drive =
                    self.p.torque_constant * self.current[k] - paths[k] - self.p.motor_viscous * self.motor_speed[k];
                advance_speed(
                    &mut self.motor_speed[k],
                    &mut self.motor_stuck[k],
                    self.p.motor_inertia,
                    drive,
                    self.p.motor_coulomb,
                    self.p.motor_static,
                    dt,
                );
            }
            let load_drive = paths.iter().sum::<f64>() + self.disturbance_axis / n;
            advance_speed(
                &mut self.load_speed,
                &mut self.load_stuck,
                self.p.axis_inertia / (n * n),
                load_drive,
                self.p.load_coulomb_axis / n,
                self.p.load_static_axis / n,
                dt,
            );
            for k in 0..self.p.motors {
                self.motor_angle[k] += self.motor_speed[k] * dt;
            }
            self.load_angle += self.load_speed * dt;
        }
    }
}

/// Semi-implicit Euler speed update of a body with Coulomb and static friction: a sticking
/// body stays at rest until the other torques on it exceed the static level; a sliding body
/// that would reverse within the sub-step stops and sticks.
fn advance_speed(speed: &mut f64, stuck: &mut bool, inertia: f64, drive: f64, coulomb: f64, static_: f64, dt: f64) {
    let has_friction = coulomb > 0.0 || static_ > 0.0;
    if *stuck && has_friction {
        if drive.abs() <= static_ {
            *speed = 0.0;
            return;
        }
        *stuck = false;
        *speed += (drive - coulomb * drive.signum()) / inertia * dt;
        return;
    }
    let direction = if *speed != 0.0 { speed.signum() } else { drive.signum() };
    let next = *speed + (drive - coulomb * direction) / inertia * dt;
    if has_friction && next * *speed < 0.0 {
        *speed = 0.0;
        *stuck = true;
    } else {
        *speed = next;
    }
}

/// Commands for one sample, in the controller's units.
#[derive(Debug, Clone, Copy, Default)]
pub struct Commands {
    pub mode: ControlMode,
    pub position_deg: f64,
    pub velocity_deg_per_s: f64,
    pub velocity_mode_deg_per_s: f64,
    pub open_loop_current_a: f64,
}

/// A plant the rig can drive.
pub trait Plant {
    fn encoder_deg(&self) -> f64;
    fn axis_deg(&self) -> f64;
    fn motor_speeds(&self) -> Vec<f64>;
    fn apply(&mut self, currents: &[f64], h: f64);
}

impl Plant for LocalAxis {
    fn encoder_deg(&self) -> f64 {
        self.axis_deg()
    }
    fn axis_deg(&self) -> f64 {
        LocalAxis::axis_deg(self)
    }
    fn motor_speeds(&self) -> Vec<f64> {
        LocalAxis::motor_speeds(self)
    }
    fn apply(&mut self, currents: &[f64], h: f64) {
        self.step(currents, h)
    }
}

/// A controller the rig can drive.
pub trait AxisController: SampledController + Clone
where
    Self::Outputs: Clone,
{
    fn inputs(commands: &Commands, encoder_deg: f64, motor_speeds: &[f64]) -> Self::Inputs;
    fn currents(outputs: &Self::Outputs) -> Vec<f64>;
    fn status(outputs: &Self::Outputs) -> fmu_controller::AxisStatus;
}

impl AxisController for AzimuthController {
    fn inputs(c: &Commands, encoder_deg: f64, speeds: &[f64]) -> AzimuthInputs {
        AzimuthInputs {
            mode: c.mode,
            position_command_deg: c.position_deg,
            command_velocity_deg_per_s: c.velocity_deg_per_s,
            velocity_mode_command_deg_per_s: c.velocity_mode_deg_per_s,
            open_loop_current_a: c.open_loop_current_a,
            encoder_position_deg: encoder_deg,
            motor_speed_rad_per_s: [speeds[0], speeds[1]],
        }
    }
    fn currents(o: &AzimuthOutputs) -> Vec<f64> {
        o.current_command_a.to_vec()
    }
    fn status(o: &AzimuthOutputs) -> fmu_controller::AxisStatus {
        o.status
    }
}

impl AxisController for ElevationController {
    fn inputs(c: &Commands, encoder_deg: f64, speeds: &[f64]) -> ElevationInputs {
        ElevationInputs {
            mode: c.mode,
            position_command_deg: c.position_deg,
            command_velocity_deg_per_s: c.velocity_deg_per_s,
            velocity_mode_command_deg_per_s: c.velocity_mode_deg_per_s,
            open_loop_current_a: c.open_loop_current_a,
            encoder_position_deg: encoder_deg,
            motor_speed_rad_per_s: speeds[0],
        }
    }
    fn currents(o: &ElevationOutputs) -> Vec<f64> {
        vec![o.current_command_a]
    }
    fn status(o: &ElevationOutputs) -> fmu_controller::AxisStatus {
        o.status
    }
}

/// One record per sample.
#[derive(Debug, Clone, Copy)]
pub struct Record {
    pub time: f64,
    pub command_deg: f64,
    pub axis_deg: f64,
    pub encoder_deg: f64,
    pub motor_speed_mean: f64,
    pub motor_speed_difference: f64,
    pub status: fmu_controller::AxisStatus,
    pub currents: [f64; 2],
}

/// Controller and plant coupled with one communication step per sample.
pub struct Rig<C: AxisController, P: Plant>
where
    C::Outputs: Clone,
{
    pub controller: C,
    pub plant: P,
    pub scheduler: SampleScheduler<C::Outputs>,
    pub time: f64,
}

impl<C: AxisController, P: Plant> Rig<C, P>
where
    C::Outputs: Clone,
{
    pub fn new(controller: C, plant: P) -> Self {
        let scheduler = SampleScheduler::new(0.0, &controller.sampling(), controller.idle_outputs());
        Self { controller, plant, scheduler, time: 0.0 }
    }

    /// Runs for `seconds`, the commands a function of time, one communication step per
    /// sample; returns one record per step.
    pub fn run(&mut self, seconds: f64, commands: impl Fn(f64) -> Commands) -> Vec<Record> {
        let ts = self.controller.sampling().sample_time_s;
        self.run_with_step(seconds, ts, commands)
    }

    /// Runs for `seconds` with communication step `ts` (the master's), the inputs held over
    /// each step; returns one record per step.
    pub fn run_with_step(&mut self, seconds: f64, ts: f64, commands: impl Fn(f64) -> Commands) -> Vec<Record> {
        let samples = (seconds / ts).round() as usize;
        let mut records = Vec::with_capacity(samples);
        for _ in 0..samples {
            let c = commands(self.time);
            let speeds = self.plant.motor_speeds();
            let inputs = C::inputs(&c, self.plant.encoder_deg(), &speeds);
            // The output in force now (reported at the end of the previous step) drives the
            // plant over this step; the one computed now takes effect at the end of the step.
            let in_force = C::currents(self.scheduler.applied());
            let out = self.scheduler.do_step(&mut self.controller, self.time, ts, &inputs).clone();
            records.push(Record {
                time: self.time,
                command_deg: c.position_deg,
                axis_deg: self.plant.axis_deg(),
                encoder_deg: self.plant.encoder_deg(),
                motor_speed_mean: speeds.iter().sum::<f64>() / speeds.len() as f64,
                motor_speed_difference: if speeds.len() > 1 { speeds[0] - speeds[1] } else { 0.0 },
                status: C::status(&out),
                currents: [in_force[0], *in_force.get(1).unwrap_or(&0.0)],
            });
            self.plant.apply(&in_force, ts);
            self.time += ts;
        }
        records
    }
}

/// Pointing error (command minus true axis position) at each record, deg.
pub fn pointing_errors(records: &[Record]) -> Vec<f64> {
    records.iter().map(|r| r.command_deg - r.axis_deg).collect()
}

/// The time after which the pointing error stays within `band` (deg) for the rest of the
/// records, measured from `from` (s); `None` if it is still outside at the end or the records
/// after that time are shorter than `hold` (s).
pub fn settling_time(records: &[Record], from: f64, band: f64, hold: f64) -> Option<f64> {
    let last_outside = records.iter().rposition(|r| (r.command_deg - r.axis_deg).abs() > band)?;
    let settled_at = records.get(last_outside + 1)?.time;
    let end = records.last()?.time;
    (end - settled_at >= hold).then_some((settled_at - from).max(0.0))
}

/// Largest excursion of the axis beyond a fixed target, in the direction of travel, deg.
pub fn overshoot(records: &[Record], start_deg: f64, target_deg: f64) -> f64 {
    let direction = (target_deg - start_deg).signum();
    records.iter().map(|r| direction * (r.axis_deg - target_deg)).fold(0.0, f64::max)
}

/// Root mean square of a slice.
pub fn rms(values: &[f64]) -> f64 {
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}
