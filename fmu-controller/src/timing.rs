//! Runs a sampled controller inside a master's communication steps: which sample instants
//! fall into a step, and which computed output is being applied at the step's end, given the
//! computation/transport delay.
//!
//! Sample `k` happens at `t_k = t_0 + k Ts` (computed from the integer `k`, so the grid does not
//! drift). A communication step `[t, t + h)` executes every sample with `t_k` in it, in order,
//! all with the inputs the master set for the step (co-simulation holds inputs over a step).
//! Output `u_k` takes effect at `t_k + d Ts`; at the end of the step the output is the newest
//! `u_k` that has taken effect by `t + h`. Consequences, for `Ts` = 1 ms and `d` = 1:
//!
//! * `h = Ts`: one sample per step at its start; the output at `t + h` is that sample's. The
//!   plant sees currents computed from its own outputs one sample earlier: exactly the
//!   one-sample delay, as in the real ACU.
//! * `h = m Ts`: `m` samples per step, all from the measurement at `t`; the output at the end
//!   is from the last of them. The feedback effectively runs at the master's rate with up to
//!   `h` of extra delay; the loops are designed for `h = Ts` and lose phase margin as `h`
//!   grows (see `docs/controller.md`).
//! * `h` not a multiple of `Ts`: the samples stay on their own grid; a step may contain no
//!   sample (the output is held) or a varying number of them. Nothing is interpolated.
//! * `h < Ts`: some steps contain no sample; the output changes only when a sample's effect
//!   time falls inside the step, so with `d = 0` an output appears `h` after its sample at the
//!   earliest (the master cannot see it sooner), and with `d >= 1` it appears exactly on time
//!   when `Ts` is a multiple of `h`.
//!
//! A time within `1e-6 Ts` of a grid point counts as on it, so that a master accumulating
//! `t += h` in floating point does not lose or duplicate samples.
//!
//! Memory does not grow with the step: each output is queued only until it takes effect, and
//! outputs that take effect within the step are applied as soon as they are computed, so the
//! queue never holds more than `delay + 1` outputs (at most
//! [`SamplingParams::MAX_DELAY_SAMPLES`] + 1), whatever the communication step. The work of a
//! step is one sample per `Ts` in it, which the runtime bounds before the step starts
//! ([`SampleScheduler::samples_in`]).

use std::collections::VecDeque;

use fmu_runtime::state::StateError;
use fmu_runtime::state_error::SampleClockError;
use serde::{Deserialize, Serialize};

use crate::params::SamplingParams;

/// A sample clock that lies before the step it is asked to run (restored from a state of
/// another time): catching up would take an unbounded number of samples.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("the controller's next sample is at {next} s, before the step that starts at {time} s: the sample clock does not belong to this time")]
pub struct ClockError {
    /// The next sample instant, s.
    pub next: f64,
    /// The start of the refused step, s.
    pub time: f64,
}

/// A discrete-time controller that executes one sample at a time.
pub trait SampledController {
    type Inputs;
    type Outputs: Clone;

    fn sampling(&self) -> SamplingParams;

    /// Executes one sample with the measurements taken at its instant.
    fn sample(&mut self, inputs: &Self::Inputs) -> Self::Outputs;

    /// The outputs in force before the first computed output takes effect (zero currents).
    fn idle_outputs(&self) -> Self::Outputs;
}

/// See the module documentation.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleScheduler<O> {
    start_time: f64,
    sample_time: f64,
    delay_samples: u32,
    next_sample: u64,
    /// Outputs computed but not yet in effect, with the index of the sample that computed them.
    pending: VecDeque<(u64, O)>,
    applied: O,
}

impl<O: Clone> SampleScheduler<O> {
    /// A scheduler whose sample 0 is at `start_time`; `idle` is in force until the first
    /// output takes effect.
    pub fn new(start_time: f64, sampling: &SamplingParams, idle: O) -> Self {
        Self {
            start_time,
            sample_time: sampling.sample_time_s,
            delay_samples: sampling.delay_samples,
            next_sample: 0,
            pending: VecDeque::with_capacity(
                sampling.delay_samples.min(SamplingParams::MAX_DELAY_SAMPLES) as usize + 1,
            ),
            applied: idle,
        }
    }

    /// Instant of sample `k`, s.
    pub fn sample_instant(&self, k: u64) -> f64 {
        self.start_time + k as f64 * self.sample_time
    }

    /// Instant of the next sample to execute, s.
    pub fn next_sample_instant(&self) -> f64 {
        self.sample_instant(self.next_sample)
    }

    /// The output in force now.
    pub fn applied(&self) -> &O {
        &self.applied
    }

    /// How many samples a step of `step` seconds executes at most, for a sample time `ts`:
    /// the work of a step, which the runtime bounds before the step starts.
    pub fn samples_in(step: f64, ts: f64) -> f64 {
        step / ts + 2.0
    }

    /// Whether the sample clock belongs to a step that starts at `time`: a scheduler whose next
    /// sample lies before it (restored from a state of another time) would have to catch up an
    /// unbounded number of samples, so the FMU refuses the step.
    pub fn check_clock(&self, time: f64) -> Result<(), ClockError> {
        let next = self.sample_instant(self.next_sample);
        let slack = 1e-6 * self.sample_time + 1e-9 * time.abs() + self.sample_time;
        if next < time - slack {
            return Err(ClockError { next, time });
        }
        Ok(())
    }

    /// Executes the samples of the communication step `[time, time + step)` with the given
    /// inputs and returns the output in force at `time + step` (after [`Self::check_clock`]).
    pub fn do_step<C>(&mut self, controller: &mut C, time: f64, step: f64, inputs: &C::Inputs) -> &O
    where
        C: SampledController<Outputs = O>,
    {
        let end = time + step;
        let tolerance = 1e-6 * self.sample_time;
        while self.sample_instant(self.next_sample) < end - tolerance {
            let out = controller.sample(inputs);
            self.pending.push_back((self.next_sample, out));
            self.next_sample += 1;
            // Apply what takes effect within the step at once, so that the queue holds only
            // outputs still waiting for their delay.
            while let Some((k, _)) = self.pending.front() {
                if self.sample_instant(k + u64::from(self.delay_samples)) <= end + tolerance {
                    self.applied = self.pending.pop_front().expect("front exists").1;
                } else {
                    break;
                }
            }
        }
        while let Some((k, _)) = self.pending.front() {
            if self.sample_instant(k + u64::from(self.delay_samples)) <= end + tolerance {
                self.applied = self.pending.pop_front().expect("front exists").1;
            } else {
                break;
            }
        }
        &self.applied
    }

    /// Everything that determines the future outputs: the grid's start, the next sample, the
    /// outputs not yet in effect and the one in force.
    pub fn saved_state(&self) -> SchedulerState<O> {
        SchedulerState {
            start_time: self.start_time,
            next_sample: self.next_sample,
            pending: self.pending.iter().cloned().collect(),
            applied: self.applied.clone(),
        }
    }

    /// [`saved_state`](Self::saved_state) written over `state`, reusing its pending list.
    pub fn save_into(&self, state: &mut SchedulerState<O>) {
        state.start_time = self.start_time;
        state.next_sample = self.next_sample;
        state.pending.clear();
        state.pending.extend(self.pending.iter().cloned());
        state.applied.clone_from(&self.applied);
    }

    /// A scheduler restored from what [`saved_state`](Self::saved_state) returned, for the
    /// given sampling.
    pub fn restored(sampling: &SamplingParams, state: SchedulerState<O>) -> Result<Self, StateError> {
        let SchedulerState { start_time, next_sample, pending, applied } = state;
        if !start_time.is_finite() {
            return Err(StateError::SampleClock(SampleClockError::StartNotFinite(start_time)));
        }
        if pending.iter().any(|(k, _)| *k >= next_sample) {
            return Err(StateError::SampleClock(SampleClockError::PendingAhead));
        }
        let allowed = sampling.delay_samples as usize + 1;
        if pending.len() > allowed {
            return Err(StateError::SampleClock(SampleClockError::TooManyPending { pending: pending.len(), allowed }));
        }
        let mut scheduler = Self::new(start_time, sampling, applied);
        scheduler.next_sample = next_sample;
        scheduler.pending = pending.into();
        Ok(scheduler)
    }
}

/// What an FMU state holds of a [`SampleScheduler`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SchedulerState<O> {
    /// Instant of sample 0, s.
    pub start_time: f64,
    /// Index of the next sample to execute.
    pub next_sample: u64,
    /// Outputs computed but not yet in effect, with the index of the sample that computed them.
    pub pending: Vec<(u64, O)>,
    /// The output in force.
    pub applied: O,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Outputs the index of the sample and the input it saw.
    struct Counter {
        sampling: SamplingParams,
        count: u64,
    }

    #[derive(Debug, Clone, Copy, PartialEq)]
    struct Out {
        sample: i64,
        input: f64,
    }

    impl SampledController for Counter {
        type Inputs = f64;
        type Outputs = Out;
        fn sampling(&self) -> SamplingParams {
            self.sampling
        }
        fn sample(&mut self, inputs: &f64) -> Out {
            let out = Out { sample: self.count as i64, input: *inputs };
            self.count += 1;
            out
        }
        fn idle_outputs(&self) -> Out {
            Out { sample: -1, input: f64::NAN }
        }
    }

    /// Steps from 0 with step `h` (accumulating time in floating point like a master) and
    /// returns the sample index in force at the end of each step.
    fn applied_indices(ts: f64, delay: u32, h: f64, steps: usize) -> Vec<i64> {
        let sampling = SamplingParams { sample_time_s: ts, delay_samples: delay };
        let mut c = Counter { sampling, count: 0 };
        let mut s = SampleScheduler::new(0.0, &sampling, c.idle_outputs());
        let mut t = 0.0;
        let mut out = Vec::new();
        for _ in 0..steps {
            out.push(s.do_step(&mut c, t, h, &t).sample);
            t += h;
        }
        out
    }

    #[test]
    fn one_sample_per_step_applies_each_output_one_step_later() {
        let got = applied_indices(1e-3, 1, 1e-3, 2000);
        // At the end of step j (time (j + 1) Ts) the output of sample j is in force.
        for (j, &k) in got.iter().enumerate() {
            assert_eq!(k, j as i64, "step {j}");
        }
    }

    #[test]
    fn longer_delays_shift_the_applied_output() {
        let got = applied_indices(1e-3, 3, 1e-3, 100);
        assert_eq!(&got[..3], &[-1, -1, 0]);
        for (j, &k) in got.iter().enumerate().skip(2) {
            assert_eq!(k, j as i64 - 2);
        }
    }

    #[test]
    fn steps_longer_than_the_sample_time_run_several_samples_on_held_inputs() {
        let ts = 1e-3;
        let sampling = SamplingParams { sample_time_s: ts, delay_samples: 1 };
        let mut c = Counter { sampling, count: 0 };
        let mut s = SampleScheduler::new(0.0, &sampling, c.idle_outputs());
        let out = *s.do_step(&mut c, 0.0, 4e-3, &7.0);
        assert_eq!(c.count, 4);
        assert_eq!(out, Out { sample: 3, input: 7.0 });
    }

    #[test]
    fn steps_that_are_not_multiples_keep_the_sample_grid() {
        // h = 2.5 Ts: samples 0,1,2 in the first step, 3,4 in the second, 5,6,7 in the third...
        let ts = 1e-3;
        let sampling = SamplingParams { sample_time_s: ts, delay_samples: 1 };
        let mut c = Counter { sampling, count: 0 };
        let mut s = SampleScheduler::new(0.0, &sampling, c.idle_outputs());
        let mut t = 0.0;
        let mut counts = Vec::new();
        let mut applied = Vec::new();
        for _ in 0..4 {
            let before = c.count;
            applied.push(s.do_step(&mut c, t, 2.5e-3, &t).sample);
            counts.push(c.count - before);
            t += 2.5e-3;
        }
        assert_eq!(counts, vec![3, 2, 3, 2]);
        // Output k is in force from (k + 1) Ts: at 2.5 ms sample 1, at 5 ms sample 4, ...
        assert_eq!(applied, vec![1, 4, 6, 9]);
    }

    #[test]
    fn steps_shorter_than_the_sample_time_hold_the_output_between_samples() {
        let got = applied_indices(1e-3, 1, 0.25e-3, 16);
        // Sample k runs in the step starting at k Ts and takes effect at (k + 1) Ts, which is
        // the end of the fourth step after it.
        assert_eq!(got, vec![-1, -1, -1, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3]);
        let immediate = applied_indices(1e-3, 0, 0.25e-3, 8);
        assert_eq!(immediate, vec![0, 0, 0, 0, 1, 1, 1, 1]);
    }

    #[test]
    fn a_long_step_queues_no_more_outputs_than_the_delay() {
        let sampling = SamplingParams { sample_time_s: 1e-3, delay_samples: 3 };
        let mut c = Counter { sampling, count: 0 };
        let mut s = SampleScheduler::new(0.0, &sampling, c.idle_outputs());
        let capacity = s.pending.capacity();
        let out = *s.do_step(&mut c, 0.0, 100.0, &1.0);
        assert_eq!(c.count, 100_000);
        assert_eq!(out.sample, 99_997);
        // The queue never grew: outputs were applied as they were computed.
        assert_eq!(s.pending.capacity(), capacity);
        assert!(s.pending.len() <= 4);
    }

    #[test]
    fn a_sample_clock_behind_the_step_is_refused() {
        let sampling = SamplingParams { sample_time_s: 1e-3, delay_samples: 1 };
        let c = Counter { sampling, count: 0 };
        let s = SampleScheduler::new(-1e6, &sampling, c.idle_outputs());
        let error = s.check_clock(0.0).unwrap_err().to_string();
        assert!(error.contains("does not belong to this time"), "{error}");
        assert!(SampleScheduler::new(0.0, &sampling, c.idle_outputs()).check_clock(0.0).is_ok());
    }

    #[test]
    fn a_state_saved_over_a_kept_one_equals_a_fresh_save() {
        let ts = 1e-3;
        let sampling = SamplingParams { sample_time_s: ts, delay_samples: 2 };
        let mut c = Counter { sampling, count: 0 };
        let mut s = SampleScheduler::new(0.0, &sampling, c.idle_outputs());
        let mut kept = s.saved_state();
        let mut t = 0.0;
        // Steps of one, several and a fraction of a sample: the pending list grows and shrinks.
        for (k, h) in [1.0, 0.5, 3.0, 0.25, 1.0, 2.0, 0.75].iter().cycle().take(40).enumerate() {
            s.do_step(&mut c, t, h * ts, &t);
            t += h * ts;
            s.save_into(&mut kept);
            // Compared as text: the idle output holds a NaN, which is not equal to itself.
            assert_eq!(format!("{kept:?}"), format!("{:?}", s.saved_state()), "step {k}");
        }
    }

    #[test]
    fn state_round_trip_resumes_identically() {
        let ts = 1e-3;
        let sampling = SamplingParams { sample_time_s: ts, delay_samples: 2 };
        let mut c = Counter { sampling, count: 0 };
        let mut s = SampleScheduler::new(0.0, &sampling, c.idle_outputs());
        s.do_step(&mut c, 0.0, 3.5e-3, &1.0);
        let mut restored = SampleScheduler::restored(&sampling, s.saved_state()).unwrap();
        let mut c2 = Counter { sampling, count: c.count };
        for j in 0..10 {
            let t = 3.5e-3 + j as f64 * 1e-3;
            assert_eq!(s.do_step(&mut c, t, 1e-3, &2.0), restored.do_step(&mut c2, t, 1e-3, &2.0));
        }
    }
}
