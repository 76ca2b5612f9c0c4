//! The output-error route: simulate the plant over windows re-initialised from the measured
//! state and compare its outputs with the measured ones.
//!
//! One long open-loop run of a drive driven by measured torque is a double integrator fed with
//! noise: it drifts, and the drift would inflate the "before" error. Short windows started
//! from the measured state keep the comparison about the dynamics. The simulator is a trait so
//! that the plant FMU, loaded through the C ABI by `fmu_runtime::import`, plugs in (phase 2);
//! [`RigidReferenceSimulator`] is a small native stand-in for tests.

use super::equation_error::static_friction_curve;
use super::parameters::{names, ParameterSet};
use super::signals::SavitzkyGolay;
use crate::measured_log::{MeasuredLog, Signal};
use std::ops::Range;

/// The measured state a window starts from (axis side, SI).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InitialState {
    pub motor_pos: f64,
    pub motor_vel: f64,
    pub load_pos: f64,
    pub load_vel: f64,
}

/// Simulated outputs over a window, one value per log sample of the window.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SimulatedOutputs {
    pub motor_pos: Vec<f64>,
    pub motor_vel: Vec<f64>,
    pub load_pos: Vec<f64>,
    pub load_vel: Vec<f64>,
}

/// A plant that can be simulated with a log's measured inputs (torque or current, and the
/// optional disturbance, elevation and wind columns) over a window of samples.
pub trait PlantSimulator {
    fn simulate(&self, params: &ParameterSet, log: &MeasuredLog, window: Range<usize>, initial: InitialState) -> Result<SimulatedOutputs, String>;
}

/// Output-error residual statistics over all windows.
#[derive(Debug, Clone)]
pub struct OutputError {
    pub windows: usize,
    /// RMS position error of the axis (load) encoder and of the motor encoder (rad).
    pub load_pos_rms: f64,
    pub motor_pos_rms: f64,
    /// The load position residual, concatenated over windows (rad).
    pub load_pos_residual: Vec<f64>,
}

/// Measured state at every sample: positions as logged, speeds from a zero-phase
/// Savitzky-Golay derivative (logged speeds may come from a lagging drive filter).
pub fn measured_states(log: &MeasuredLog) -> Vec<InitialState> {
    let n = log.len();
    let dt = log.sample_interval();
    let motor = log.signal(Signal::MotorPos).or(log.signal(Signal::LoadPos)).map(<[f64]>::to_vec).unwrap_or_else(|| vec![0.0; n]);
    let load = log.signal(Signal::LoadPos).or(log.signal(Signal::MotorPos)).map(<[f64]>::to_vec).unwrap_or_else(|| vec![0.0; n]);
    let h = 5.min(n.saturating_sub(1) / 2).max(1);
    let sg = SavitzkyGolay::new(3, h, dt);
    let speed = |x: &[f64]| -> Vec<f64> {
        let inner = SavitzkyGolay::apply(&sg.first, x);
        (0..n).map(|i| inner.get(i.saturating_sub(h).min(inner.len().saturating_sub(1))).copied().unwrap_or(0.0)).collect()
    };
    let (mv, lv) = (speed(&motor), speed(&load));
    (0..n).map(|i| InitialState { motor_pos: motor[i], motor_vel: mv[i], load_pos: load[i], load_vel: lv[i] }).collect()
}

/// Simulates every window of `window_len` samples from its measured initial state and
/// collects the position errors.
pub fn windowed_output_error(simulator: &dyn PlantSimulator, params: &ParameterSet, log: &MeasuredLog, window_len: usize) -> Result<OutputError, String> {
    let states = measured_states(log);
    let n = log.len();
    let window_len = window_len.max(2);
    let (mut load_sum, mut motor_sum, mut count, mut windows) = (0.0, 0.0, 0usize, 0usize);
    let mut residual = Vec::new();
    let mut start = 0;
    while start + window_len <= n {
        let window = start..start + window_len;
        let outputs = simulator.simulate(params, log, window.clone(), states[start])?;
        for (k, i) in window.enumerate() {
            let load_error = states[i].load_pos - outputs.load_pos.get(k).copied().unwrap_or(f64::NAN);
            let motor_error = states[i].motor_pos - outputs.motor_pos.get(k).copied().unwrap_or(f64::NAN);
            load_sum += load_error * load_error;
            motor_sum += motor_error * motor_error;
            residual.push(load_error);
            count += 1;
        }
        windows += 1;
        start += window_len;
    }
    if count == 0 {
        return Err("the log is shorter than one window".into());
    }
    Ok(OutputError { windows, load_pos_rms: (load_sum / count as f64).sqrt(), motor_pos_rms: (motor_sum / count as f64).sqrt(), load_pos_residual: residual })
}

/// A native rigid-body stand-in for the plant FMU: total inertia, the model's friction law
/// (with the sign smoothed over a hundredth of the Stribeck velocity, so the integration stays
/// stable), offset, unbalance and the torque-constant scale; no compliance, no delay. For
/// tests of the output-error machinery only.
#[derive(Debug, Clone, Copy, Default)]
pub struct RigidReferenceSimulator;

impl PlantSimulator for RigidReferenceSimulator {
    fn simulate(&self, params: &ParameterSet, log: &MeasuredLog, window: Range<usize>, initial: InitialState) -> Result<SimulatedOutputs, String> {
        let gear = params.value(names::GEAR_RATIO);
        let inertia = params.value(names::MOTOR_INERTIA) * gear * gear + params.value(names::LOAD_INERTIA);
        if inertia <= 0.0 {
            return Err("the parameter set has no inertia".into());
        }
        let torque = log.total_motor_torque(params.value(names::TORQUE_CONSTANT));
        let scale = params.value(names::TORQUE_CONSTANT_SCALE) * gear;
        let vs = params.value(names::STRIBECK_VELOCITY).max(1e-9);
        let dt = log.sample_interval();
        let substeps = 20;
        let h = dt / substeps as f64;
        let (mut q, mut v) = (initial.load_pos, initial.load_vel);
        let mut out = SimulatedOutputs::default();
        for i in window {
            out.motor_pos.push(q);
            out.motor_vel.push(v);
            out.load_pos.push(q);
            out.load_vel.push(v);
            for _ in 0..substeps {
                let friction = params.value(names::VISCOUS) * v + static_friction_curve(params, v) * (v / (0.01 * vs)).tanh().abs();
                let unbalance = params.value(names::UNBALANCE_TORQUE) * (q + params.value(names::UNBALANCE_PHASE)).cos();
                let acc = (scale * torque[i] - friction - params.value(names::TORQUE_OFFSET) - unbalance) / inertia;
                v += h * acc;
                q += h * v;
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measured_log::Channel;

    #[test]
    fn windows_restarted_from_the_measured_state_reproduce_a_consistent_log() {
        // A log made by the reference simulator itself: the output error must be tiny, and a
        // wrong inertia must make it larger.
        let mut params = ParameterSet::new();
        params.set(names::GEAR_RATIO, 10.0);
        params.set(names::MOTOR_INERTIA, 0.0);
        params.set(names::LOAD_INERTIA, 2.0);
        params.set(names::TORQUE_CONSTANT, 1.0);
        let n = 2000;
        let dt = 1e-3;
        let time: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let torque: Vec<f64> = time.iter().map(|t| (2.0 * t).sin()).collect();
        let mut log = MeasuredLog {
            metadata: Default::default(),
            time,
            channels: vec![Channel { signal: Signal::MotorTorque, motor: None, column: "motor_torque_Nm".into(), unit: "Nm".into(), values: torque }],
            notes: Vec::new(),
        };
        let initial = InitialState { motor_pos: 0.0, motor_vel: 0.0, load_pos: 0.0, load_vel: 0.0 };
        let sim = RigidReferenceSimulator.simulate(&params, &log, 0..n, initial).unwrap();
        log.channels.push(Channel { signal: Signal::LoadPos, motor: None, column: "load_pos_rad".into(), unit: "rad".into(), values: sim.load_pos.clone() });
        let right = windowed_output_error(&RigidReferenceSimulator, &params, &log, 200).unwrap();
        let mut wrong = params.clone();
        wrong.set(names::LOAD_INERTIA, 3.0);
        let off = windowed_output_error(&RigidReferenceSimulator, &wrong, &log, 200).unwrap();
        assert_eq!(right.windows, 10);
        assert!(right.load_pos_rms < 0.02 * off.load_pos_rms, "{} vs {}", right.load_pos_rms, off.load_pos_rms);
    }
}
