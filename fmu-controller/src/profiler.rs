//! The command profiler of the seed paper's Fig. 3: it turns position steps into trajectories
//! the loops can follow, so that the high-gain loops do not overshoot, and stays out of the way
//! while the antenna tracks.
//!
//! While tracking, the reference is the command itself (position, command velocity, and the
//! acceleration from the change of the command velocity). A command that departs from the
//! reference's one-sample prediction by more than a threshold, in position or in velocity,
//! starts a profile from the reference's current position and velocity, so the reference stays
//! continuous. The profile drives the distance to go `e = p_target - r` to zero with a
//! proximate-time-optimal law (Workman's PTOS) in coordinates relative to the possibly moving
//! target:
//!
//! ```text
//! w(e)  = a_b e                                  (linear final approach, |e| <= e_l)
//!       = sign(e) (sqrt(c^2 + 2 a_b |e|) - c - s)  (braking curve, |e| > e_l)
//! v_des = clamp(v_target + w(e), -v_max, v_max)
//! a     = clamp(k (v_des - v), -a_max, a_max)     (growth then jerk-limited, if set)
//! ```
//!
//! with `a_b = alpha a_max` the planned braking deceleration, `g` the approach gain, `k` the
//! velocity gain, `c = a_b^2 / (2 j)` the braking-distance allowance for the jerk ramp (0
//! without a jerk limit), and `e_l`, `s` chosen so that the two pieces of `w` meet with equal
//! value and slope. The position and velocity are integrated exactly for a piecewise-constant
//! acceleration. Braking below the limit (`alpha < 1`) leaves acceleration in reserve to absorb
//! the velocity gain's lag and the target's motion; with `k >= 4 g` the final approach is a
//! critically damped or slower second-order system entered slower than its fast eigenline, so
//! the distance to go never changes sign. The profile hands back to tracking when it is within
//! a tolerance of the target in both position and velocity.

use serde::{Deserialize, Serialize};

use crate::params::ProfilerParams;

/// The reference handed to the position loop and the feedforward paths, axis units (rad).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Reference {
    /// Reference position, rad.
    pub position: f64,
    /// Reference velocity, rad/s.
    pub velocity: f64,
    /// Reference acceleration over the coming sample interval, rad/s^2.
    pub acceleration: f64,
    /// True while a profile is running (a step is being executed), false while tracking.
    pub stepping: bool,
}

/// The profiler's settings in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Settings {
    enabled: bool,
    sample_time: f64,
    max_velocity: f64,
    max_acceleration: f64,
    /// Planned braking deceleration `alpha a_max`.
    braking: f64,
    approach_gain: f64,
    velocity_gain: f64,
    /// Largest change of acceleration per sample, or infinity.
    max_acceleration_change: f64,
    /// Braking-distance allowance for the jerk ramp, `a_b^2 / (2 j)`, rad/s.
    jerk_allowance: f64,
    /// Half-width of the linear final approach, rad.
    linear_zone: f64,
    /// Offset that joins the braking curve to the linear approach, rad/s.
    curve_offset: f64,
    step_threshold: f64,
    velocity_step_threshold: f64,
    handover_position: f64,
    handover_velocity: f64,
    /// Limit on the tracking acceleration derived from command-velocity changes, rad/s^2.
    tracking_acceleration_limit: f64,
}

/// See the module documentation.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandProfiler {
    settings: Settings,
    /// Reference position at the current sample, rad.
    position: f64,
    /// Reference velocity at the current sample, rad/s.
    velocity: f64,
    /// Acceleration applied over the coming sample interval, rad/s^2 (0 while tracking).
    acceleration: f64,
    stepping: bool,
    /// Set by [`restart_from`](Self::restart_from): the state is already the current
    /// sample's, so the next update must not propagate it.
    fresh: bool,
}

impl CommandProfiler {
    /// A profiler for the given parameters; `tracking_acceleration_limit_rad_per_s2` bounds the
    /// acceleration derived from command-velocity changes while tracking (the position
    /// loop's acceleration limit, so that the feedforward never asks for more than the loop
    /// may do).
    pub fn new(params: &ProfilerParams, sample_time_s: f64, tracking_acceleration_limit_rad_per_s2: f64) -> Self {
        let braking = params.deceleration_fraction * params.max_acceleration_deg_per_s2.to_radians();
        let approach_gain = params.approach_gain_per_s;
        let jerk = params.jerk_limit_deg_per_s3.to_radians();
        let jerk_allowance = if jerk > 0.0 { braking * braking / (2.0 * jerk) } else { 0.0 };
        // The braking curve sqrt(c^2 + 2 a_b e) - c has slope a_b / sqrt(c^2 + 2 a_b e), which
        // equals the approach gain g where c^2 + 2 a_b e = (a_b / g)^2.
        let linear_zone = ((braking / approach_gain).powi(2) - jerk_allowance.powi(2)) / (2.0 * braking);
        let curve_offset = (braking / approach_gain - jerk_allowance) - approach_gain * linear_zone;
        let settings = Settings {
            enabled: params.enabled,
            sample_time: sample_time_s,
            max_velocity: params.max_velocity_deg_per_s.to_radians(),
            max_acceleration: params.max_acceleration_deg_per_s2.to_radians(),
            braking,
            approach_gain,
            velocity_gain: params.velocity_gain_per_s,
            max_acceleration_change: if jerk > 0.0 { jerk * sample_time_s } else { f64::INFINITY },
            jerk_allowance,
            linear_zone,
            curve_offset,
            step_threshold: params.step_threshold_deg.to_radians(),
            velocity_step_threshold: params.velocity_step_threshold_deg_per_s.to_radians(),
            handover_position: params.handover_position_tolerance_deg.to_radians(),
            handover_velocity: params.handover_velocity_tolerance_deg_per_s.to_radians(),
            tracking_acceleration_limit: tracking_acceleration_limit_rad_per_s2,
        };
        Self { settings, position: 0.0, velocity: 0.0, acceleration: 0.0, stepping: false, fresh: true }
    }

    /// Restarts the reference from a measured state (at mode changes and at start-up): the next
    /// update begins a profile from here unless the command is already within the step
    /// thresholds.
    pub fn restart_from(&mut self, position_rad: f64, velocity_rad_per_s: f64) {
        self.position = position_rad;
        self.velocity = velocity_rad_per_s;
        self.acceleration = 0.0;
        self.stepping = false;
        self.fresh = true;
    }

    /// True while a profile runs.
    pub fn is_stepping(&self) -> bool {
        self.stepping
    }

    /// Executes one sample for the command position (rad) and command velocity (rad/s) and
    /// returns the reference at this sample.
    pub fn update(&mut self, command_position: f64, command_velocity: f64) -> Reference {
        let s = self.settings;
        let previous_velocity = self.velocity;
        let was_fresh = std::mem::replace(&mut self.fresh, false);
        if !was_fresh {
            // Propagate the reference to this sample with the acceleration planned last time.
            self.position += self.velocity * s.sample_time + 0.5 * self.acceleration * s.sample_time * s.sample_time;
            self.velocity += self.acceleration * s.sample_time;
        }
        if s.enabled && !self.stepping {
            // While tracking, `position` is now the one-sample prediction of the reference.
            let jump = (command_position - self.position).abs();
            let velocity_jump = (command_velocity - self.velocity).abs();
            self.stepping = jump > s.step_threshold || velocity_jump > s.velocity_step_threshold;
            if self.stepping {
                self.acceleration = 0.0;
            }
        }
        let handing_back = self.stepping
            && (command_position - self.position).abs() <= s.handover_position
            && (command_velocity - self.velocity).abs() <= s.handover_velocity;
        if handing_back {
            self.stepping = false;
        }
        if !self.stepping {
            // Tracking: the reference is the command. The acceleration comes from the change
            // of the command velocity; after a restart there is no previous value to use, and
            // at the hand-back the change is only the hand-over tolerance, not motion.
            let acceleration = if was_fresh || handing_back {
                0.0
            } else {
                ((command_velocity - previous_velocity) / s.sample_time)
                    .clamp(-s.tracking_acceleration_limit, s.tracking_acceleration_limit)
            };
            self.position = command_position;
            self.velocity = command_velocity;
            self.acceleration = 0.0;
            return Reference { position: command_position, velocity: command_velocity, acceleration, stepping: false };
        }
        let wanted = self.profile_acceleration(command_position, command_velocity);
        self.acceleration = limit_growth(self.acceleration, wanted, s.max_acceleration_change);
        Reference { position: self.position, velocity: self.velocity, acceleration: self.acceleration, stepping: true }
    }

    /// The wanted relative velocity towards a target `distance` away (signed like it), rad/s.
    fn approach_velocity(&self, distance: f64) -> f64 {
        let s = &self.settings;
        let magnitude = distance.abs();
        if magnitude <= s.linear_zone {
            s.approach_gain * distance
        } else {
            let c = s.jerk_allowance;
            distance.signum() * ((c * c + 2.0 * s.braking * magnitude).sqrt() - c - s.curve_offset)
        }
    }

    /// The PTOS acceleration for the current reference state and target, rad/s^2.
    fn profile_acceleration(&self, target_position: f64, target_velocity: f64) -> f64 {
        let s = &self.settings;
        let distance = target_position - self.position;
        let wanted_velocity =
            (target_velocity + self.approach_velocity(distance)).clamp(-s.max_velocity, s.max_velocity);
        (s.velocity_gain * (wanted_velocity - self.velocity)).clamp(-s.max_acceleration, s.max_acceleration)
    }

    pub(crate) fn saved_state(&self) -> ProfilerState {
        ProfilerState {
            position: self.position,
            velocity: self.velocity,
            acceleration: self.acceleration,
            stepping: self.stepping,
            fresh: self.fresh,
        }
    }

    pub(crate) fn restore(&mut self, state: ProfilerState) {
        let ProfilerState { position, velocity, acceleration, stepping, fresh } = state;
        self.position = position;
        self.velocity = velocity;
        self.acceleration = acceleration;
        self.stepping = stepping;
        self.fresh = fresh;
    }
}

/// What an FMU state holds of a [`CommandProfiler`] (the fields are the profiler's, same
/// units).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ProfilerState {
    pub position: f64,
    pub velocity: f64,
    pub acceleration: f64,
    pub stepping: bool,
    pub fresh: bool,
}

/// The jerk limit: the acceleration's magnitude may grow by at most `max_change` per sample,
/// while it may shrink (or reverse through zero down to zero) at once. Limiting only growth
/// softens the start of each acceleration and of each braking phase, the latter allowed for by
/// the braking curve's jerk allowance, without ever delaying the law's reduction of an
/// acceleration, which is what would carry the profile past its target.
fn limit_growth(previous: f64, wanted: f64, max_change: f64) -> f64 {
    if wanted * previous < 0.0 {
        // Reversal: drop to zero at once, then grow in the new direction within the limit.
        wanted.clamp(-max_change, max_change)
    } else if wanted.abs() > previous.abs() {
        previous + (wanted - previous).clamp(-max_change, max_change)
    } else {
        wanted
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::{AzimuthControllerParams, ElevationControllerParams, ARCSEC_DEG};

    const TS: f64 = 1e-3;

    fn azimuth_params() -> ProfilerParams {
        AzimuthControllerParams::default().cascade.profiler
    }

    fn elevation_params() -> ProfilerParams {
        ElevationControllerParams::default().cascade.profiler
    }

    fn profiler(params: &ProfilerParams) -> CommandProfiler {
        CommandProfiler::new(params, TS, 2.0 * params.max_acceleration_deg_per_s2.to_radians())
    }

    /// Runs a profile from rest at 0 towards a target moving as `target(t) = (position, velocity)`
    /// and returns the references, one per sample.
    fn run(p: &mut CommandProfiler, seconds: f64, target: impl Fn(f64) -> (f64, f64)) -> Vec<Reference> {
        p.restart_from(0.0, 0.0);
        (0..(seconds / TS).round() as usize)
            .map(|k| {
                let (position, velocity) = target(k as f64 * TS);
                p.update(position, velocity)
            })
            .collect()
    }

    fn step_sizes_deg() -> Vec<f64> {
        vec![ARCSEC_DEG, 10.0 * ARCSEC_DEG, 0.01, 0.5, 1.0, 4.0, 20.0, 90.0, 180.0]
    }

    #[test]
    fn steps_from_one_arcsec_to_180_deg_never_overshoot_and_arrive_monotonically() {
        for params in
            [azimuth_params(), elevation_params(), ProfilerParams { jerk_limit_deg_per_s3: 5.0, ..azimuth_params() }]
        {
            // A zero threshold sends even the smallest step through the profile law.
            let params = ProfilerParams { step_threshold_deg: 0.0, ..params };
            for step_deg in step_sizes_deg() {
                for sign in [1.0, -1.0] {
                    let target = sign * step_deg.to_radians();
                    let mut p = profiler(&params);
                    let seconds = 5.0 + 2.0 * step_deg / params.max_velocity_deg_per_s;
                    let refs = run(&mut p, seconds, |_| (target, 0.0));
                    let mut previous = 0.0;
                    for (k, r) in refs.iter().enumerate() {
                        let beyond = sign * (r.position - target);
                        assert!(
                            beyond <= 1e-12 * target.abs(),
                            "step {step_deg} deg (jerk {}): overshoot {beyond} rad at sample {k}",
                            params.jerk_limit_deg_per_s3
                        );
                        assert!(
                            sign * (r.position - previous) >= -1e-15,
                            "step {step_deg} deg: moved backwards at {k}"
                        );
                        previous = r.position;
                    }
                    let last = refs.last().unwrap();
                    assert!(!last.stepping, "step {step_deg} deg: still profiling after {seconds} s");
                    assert_eq!(last.position, target);
                }
            }
        }
    }

    #[test]
    fn jerk_limit_bounds_every_growth_of_the_acceleration_without_causing_overshoot() {
        for jerk in [2.0, 5.0, 20.0, 100.0] {
            let params = ProfilerParams { jerk_limit_deg_per_s3: jerk, step_threshold_deg: 0.0, ..azimuth_params() };
            let max_growth = jerk.to_radians() * TS * (1.0 + 1e-12);
            for step_deg in step_sizes_deg() {
                let target = step_deg.to_radians();
                let mut p = profiler(&params);
                let refs = run(&mut p, 10.0 + 2.0 * step_deg / params.max_velocity_deg_per_s, |_| (target, 0.0));
                let mut previous = 0.0f64;
                for r in &refs {
                    if r.acceleration.abs() > previous.abs() && r.acceleration * previous >= 0.0 {
                        assert!(r.acceleration.abs() - previous.abs() <= max_growth, "jerk {jerk}, step {step_deg}");
                    }
                    assert!(r.position <= target * (1.0 + 1e-12), "jerk {jerk}, step {step_deg}: overshoot");
                    previous = r.acceleration;
                }
                assert!(!refs.last().unwrap().stepping, "jerk {jerk}, step {step_deg}: not converged");
            }
        }
    }

    #[test]
    fn profile_respects_the_velocity_and_acceleration_limits() {
        for params in [azimuth_params(), elevation_params()] {
            let mut p = profiler(&params);
            let refs = run(&mut p, 100.0, |_| (30f64.to_radians(), 0.0));
            let v_max = params.max_velocity_deg_per_s.to_radians();
            let a_max = params.max_acceleration_deg_per_s2.to_radians();
            let peak_velocity = refs.iter().map(|r| r.velocity.abs()).fold(0.0, f64::max);
            let peak_acceleration = refs.iter().map(|r| r.acceleration.abs()).fold(0.0, f64::max);
            assert!(peak_velocity <= v_max * (1.0 + 1e-12), "{peak_velocity} > {v_max}");
            assert!(peak_velocity >= 0.999 * v_max, "a 30 deg step should reach the slew speed");
            assert!(peak_acceleration <= a_max * (1.0 + 1e-12));
        }
    }

    #[test]
    fn reference_is_continuous_and_its_velocity_is_the_derivative_of_its_position() {
        let params = azimuth_params();
        let mut p = profiler(&params);
        let target = 4f64.to_radians();
        let refs = run(&mut p, 10.0, |_| (target, 0.0));
        let a_max = params.max_acceleration_deg_per_s2.to_radians();
        for pair in refs.windows(2) {
            let dp = pair[1].position - pair[0].position;
            let expected = pair[0].velocity * TS + 0.5 * pair[0].acceleration * TS * TS;
            // Exact integration, except at the hand-back to tracking, where the reference joins
            // the command within the hand-over tolerance.
            let tolerance = params.handover_position_tolerance_deg.to_radians();
            assert!((dp - expected).abs() <= 1e-15 + tolerance, "{dp} vs {expected}");
            assert!((pair[1].velocity - pair[0].velocity).abs() <= a_max * TS * (1.0 + 1e-9));
        }
    }

    #[test]
    fn step_is_about_as_fast_as_the_time_optimal_bang_bang_profile() {
        // Bang-bang with the full acceleration and the planned braking: t = v (1/a + 1/a_b),
        // with v from d = v^2 (1/a + 1/a_b) / 2. The final linear approach adds a little.
        let params = elevation_params();
        let a = params.max_acceleration_deg_per_s2;
        let a_b = params.deceleration_fraction * a;
        let d = 0.5; // 30 arcmin.
        let v = (2.0 * d / (1.0 / a + 1.0 / a_b)).sqrt();
        let bang_bang = v * (1.0 / a + 1.0 / a_b);
        let mut p = profiler(&params);
        let target = d.to_radians();
        let refs = run(&mut p, 10.0, |_| (target, 0.0));
        let arrival = refs.iter().position(|r| (target - r.position).abs() < (1.0 * ARCSEC_DEG).to_radians()).unwrap();
        let arrival_s = arrival as f64 * TS;
        assert!(arrival_s > bang_bang, "faster than time-optimal? {arrival_s} s vs {bang_bang} s");
        assert!(arrival_s < bang_bang + 1.0, "{arrival_s} s vs bang-bang {bang_bang} s");
    }

    #[test]
    fn converges_onto_a_moving_target_without_passing_it() {
        for rate_deg_per_s in [0.04, -0.04, 0.004178, -0.004178] {
            for step_deg in [0.5f64, 4.0] {
                let params = azimuth_params();
                let mut p = profiler(&params);
                let rate = f64::to_radians(rate_deg_per_s);
                let start = step_deg.to_radians();
                let target = |t: f64| (start + rate * t, rate);
                let refs = run(&mut p, 30.0, target);
                for (k, r) in refs.iter().enumerate() {
                    let (position, _) = target(k as f64 * TS);
                    assert!(
                        r.position - position <= 1e-12,
                        "rate {rate_deg_per_s}, step {step_deg}: passed the target at {k}"
                    );
                }
                let handover = refs.iter().position(|r| !r.stepping).expect("never handed back to tracking");
                assert!(handover as f64 * TS < 10.0, "took {} s to converge", handover as f64 * TS);
                let last = refs.last().unwrap();
                assert!(!last.stepping);
                assert_eq!(last.velocity, rate);
            }
        }
    }

    #[test]
    fn tracking_commands_pass_through_unprofiled() {
        let params = azimuth_params();
        let mut p = profiler(&params);
        let rate = 0.04f64.to_radians();
        p.restart_from(0.0, rate);
        for k in 0..5000 {
            let t = k as f64 * TS;
            // A slowly accelerating track: the reference must be the command exactly.
            let position = rate * t + 1e-4 * t * t;
            let velocity = rate + 2e-4 * t;
            let r = p.update(position, velocity);
            assert!(!r.stepping, "tracking started a profile at sample {k}");
            assert_eq!((r.position, r.velocity), (position, velocity));
            if k > 0 {
                assert!((r.acceleration - 2e-4).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn a_jump_during_tracking_starts_a_profile_from_the_current_reference() {
        let params = azimuth_params();
        let mut p = profiler(&params);
        let rate = 0.01f64.to_radians();
        p.restart_from(0.0, rate);
        let mut last = Reference::default();
        for k in 0..1000 {
            last = p.update(rate * k as f64 * TS, rate);
        }
        let jump = 0.5f64.to_radians();
        let t = 1000.0 * TS;
        let r = p.update(rate * t + jump, rate);
        assert!(r.stepping);
        // The reference continues from where it was, not from the new command.
        assert!((r.position - (last.position + rate * TS)).abs() < 1e-15);
        assert!((r.velocity - rate).abs() < 1e-15);
    }

    #[test]
    fn disabled_profiler_passes_steps_straight_through() {
        let params = ProfilerParams { enabled: false, ..azimuth_params() };
        let mut p = profiler(&params);
        let refs = run(&mut p, 0.01, |_| (1.0, 0.0));
        assert!(refs.iter().all(|r| !r.stepping && r.position == 1.0));
    }

    #[test]
    fn restart_from_a_moving_state_brakes_continuously() {
        // Entering position mode while slewing at full speed towards a target just ahead: the
        // profile must start at the measured speed and brake, not jump.
        let params = azimuth_params();
        let mut p = profiler(&params);
        let v0 = 2f64.to_radians();
        p.restart_from(0.0, v0);
        let first = p.update(0.1f64.to_radians(), 0.0);
        assert!(first.stepping);
        assert_eq!(first.velocity, v0);
        assert!(first.acceleration < 0.0);
    }

    #[test]
    fn state_round_trip_resumes_bitwise() {
        let params = azimuth_params();
        let mut a = profiler(&params);
        a.restart_from(0.0, 0.0);
        for _ in 0..700 {
            a.update(0.3, 0.0);
        }
        let mut b = profiler(&params);
        b.restore(a.saved_state());
        for _ in 0..1000 {
            let (ra, rb) = (a.update(0.3, 0.0), b.update(0.3, 0.0));
            assert_eq!(ra.position.to_bits(), rb.position.to_bits());
            assert_eq!(ra.acceleration.to_bits(), rb.acceleration.to_bits());
        }
    }
}
