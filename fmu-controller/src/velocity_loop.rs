//! The velocity loop: a PI controller on the motor speed whose output is the total motor
//! torque, with the feedforward torques added in front of the torque limit and anti-windup by
//! conditional integration.
//!
//! The integral is kept in torque units (N m), so that gains can change from sample to sample
//! (the elevation gains follow the angle-dependent inertia) without bumping the output. The PI
//! is discretised with a forward-Euler integral, `C(z) = Kv (1 + w_i Ts / (z - 1))`, exactly
//! what [`crate::linear`] models.

/// The velocity loop's gains at a sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VelocityGains {
    /// Proportional gain `Kv`, N m per motor rad/s.
    pub proportional_nm_s_per_rad: f64,
    /// Integral corner `w_i`, rad/s: the integral gain is `Kv w_i`.
    pub integral_corner_rad_per_s: f64,
}

impl VelocityGains {
    /// Gains designed for a rigid-body crossover `crossover_hz` on `total_inertia` (kg m^2 at the
    /// motor) with the integral corner `ratio` times lower, unless overridden.
    pub fn design(
        crossover_hz: f64,
        ratio: f64,
        total_inertia_kg_m2: f64,
        proportional_override: Option<f64>,
        integral_corner_override_hz: Option<f64>,
    ) -> Self {
        let omega_c = std::f64::consts::TAU * crossover_hz;
        Self {
            proportional_nm_s_per_rad: proportional_override.unwrap_or(omega_c * total_inertia_kg_m2),
            integral_corner_rad_per_s: integral_corner_override_hz
                .map_or(omega_c / ratio, |f| std::f64::consts::TAU * f),
        }
    }
}

/// What the velocity loop produced at one sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct VelocityLoopOutput {
    /// Torque command after the limit, N m at the motor (sum over motors).
    pub torque: f64,
    /// True when the torque limit cut the command.
    pub limited: bool,
}

/// See the module documentation.
#[derive(Debug, Clone, PartialEq)]
pub struct VelocityLoop {
    sample_time: f64,
    torque_limit: f64,
    integrator_enabled: bool,
    anti_windup_enabled: bool,
    /// Integral term, N m.
    integral: f64,
}

impl VelocityLoop {
    pub fn new(sample_time_s: f64, torque_limit_nm: f64, integrator_enabled: bool, anti_windup_enabled: bool) -> Self {
        Self {
            sample_time: sample_time_s,
            torque_limit: torque_limit_nm,
            integrator_enabled,
            anti_windup_enabled,
            integral: 0.0,
        }
    }

    /// The integral term, N m.
    pub fn integral(&self) -> f64 {
        self.integral
    }

    /// Sets the integral so that this sample's unlimited output equals `torque` (N m):
    /// bumpless transfer from open-loop current mode and at start-up.
    pub fn match_output(&mut self, torque: f64, gains: &VelocityGains, speed_error: f64, feedforward: f64) {
        if self.integrator_enabled {
            let integral = torque - gains.proportional_nm_s_per_rad * speed_error - feedforward;
            self.integral = integral.clamp(-self.torque_limit, self.torque_limit);
        }
    }

    /// One sample: `speed_error` is reference minus measured motor speed (rad/s),
    /// `feedforward` the feedforward torque (N m), and `freeze` stops the integral (the
    /// anti-limit-cycle hold).
    pub fn update(
        &mut self,
        gains: &VelocityGains,
        speed_error: f64,
        feedforward: f64,
        freeze: bool,
    ) -> VelocityLoopOutput {
        let integral = if self.integrator_enabled { self.integral } else { 0.0 };
        let unlimited = gains.proportional_nm_s_per_rad * speed_error + integral + feedforward;
        let torque = unlimited.clamp(-self.torque_limit, self.torque_limit);
        let limited = torque != unlimited;
        if self.integrator_enabled && !freeze {
            let pushing_further = (unlimited > self.torque_limit && speed_error > 0.0)
                || (unlimited < -self.torque_limit && speed_error < 0.0);
            if !(self.anti_windup_enabled && pushing_further) {
                self.integral +=
                    gains.proportional_nm_s_per_rad * gains.integral_corner_rad_per_s * speed_error * self.sample_time;
            }
            if self.anti_windup_enabled {
                self.integral = self.integral.clamp(-self.torque_limit, self.torque_limit);
            }
        }
        VelocityLoopOutput { torque, limited }
    }

    /// The loop's state, its integral term.
    pub(crate) fn saved_state(&self) -> f64 {
        self.integral
    }

    pub(crate) fn restore(&mut self, integral: f64) {
        self.integral = integral;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TS: f64 = 1e-3;
    const INERTIA: f64 = 0.0225;
    const LIMIT: f64 = 24.0;

    fn gains() -> VelocityGains {
        VelocityGains::design(10.0, 5.0, INERTIA, None, None)
    }

    /// A rigid inertia under the PI with a one-sample delay: returns the speed trajectory for
    /// a speed step of `target` rad/s and the largest |integral| seen.
    fn step_response(anti_windup: bool, target: f64, seconds: f64) -> (Vec<f64>, f64) {
        let g = gains();
        let mut l = VelocityLoop::new(TS, LIMIT, true, anti_windup);
        let (mut speed, mut applied) = (0.0, 0.0);
        let mut speeds = Vec::new();
        let mut peak_integral: f64 = 0.0;
        for _ in 0..(seconds / TS) as usize {
            let out = l.update(&g, target - speed, 0.0, false);
            speed += applied / INERTIA * TS;
            applied = out.torque;
            speeds.push(speed);
            peak_integral = peak_integral.max(l.integral().abs());
        }
        (speeds, peak_integral)
    }

    #[test]
    fn designed_gains_follow_the_crossover_and_inertia() {
        let g = gains();
        assert!((g.proportional_nm_s_per_rad - std::f64::consts::TAU * 10.0 * INERTIA).abs() < 1e-12);
        assert!((g.integral_corner_rad_per_s - std::f64::consts::TAU * 2.0).abs() < 1e-12);
        let o = VelocityGains::design(10.0, 5.0, INERTIA, Some(2.5), Some(3.0));
        assert_eq!(o.proportional_nm_s_per_rad, 2.5);
        assert!((o.integral_corner_rad_per_s - std::f64::consts::TAU * 3.0).abs() < 1e-12);
    }

    #[test]
    fn anti_windup_keeps_the_integral_bounded_and_recovers_without_overshoot() {
        // 300 rad/s needs 1.2 s at the torque limit (24 N m on 0.0225 kg m^2).
        let target = 300.0;
        let (with, peak_with) = step_response(true, target, 3.0);
        let (without, peak_without) = step_response(false, target, 3.0);
        assert!(peak_with <= LIMIT, "integral {peak_with} beyond the torque limit");
        let overshoot_with = with.iter().cloned().fold(0.0, f64::max) / target - 1.0;
        let overshoot_without = without.iter().cloned().fold(0.0, f64::max) / target - 1.0;
        assert!(overshoot_with < 0.01, "overshoot {overshoot_with} with anti-windup");
        // Without it the integral winds up far beyond the limit and the speed overshoots: the
        // comparison shows that the test above can fail.
        assert!(peak_without > 10.0 * LIMIT);
        assert!(overshoot_without > 0.1, "{overshoot_without}");
        let settled = with.last().unwrap();
        assert!((settled - target).abs() < 1e-3 * target);
    }

    #[test]
    fn frozen_integral_stays_put() {
        let g = gains();
        let mut l = VelocityLoop::new(TS, LIMIT, true, true);
        l.update(&g, 1.0, 0.0, false);
        let held = l.integral();
        for _ in 0..100 {
            l.update(&g, 1.0, 0.0, true);
        }
        assert_eq!(l.integral(), held);
    }

    #[test]
    fn match_output_makes_the_next_output_continuous() {
        let g = gains();
        let mut l = VelocityLoop::new(TS, LIMIT, true, true);
        l.match_output(3.25, &g, 0.4, 0.5);
        let out = l.update(&g, 0.4, 0.5, false);
        assert!((out.torque - 3.25).abs() < 1e-12);
    }
}
