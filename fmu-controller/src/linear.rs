//! Linear frequency-domain models of the controller's loops, for Bode plots, margins and
//! bandwidths that can be set beside a simulated identification (the paper's Figs. 7 and 9).
//!
//! The controller is discrete; the plant is continuous. The models use the usual
//! sampled-data approximation, exact for the controller and accurate well below the Nyquist
//! frequency (500 Hz at 1 kHz): a sinusoid of frequency `omega` meets the controller as
//! `C(z)` at `z = exp(j omega Ts)`, the computation delay as `z^-d`, and the zero-order hold
//! that turns the sample sequence back into a staircase as `(1 - exp(-j omega Ts)) / (j omega
//! Ts)`. Aliasing of plant resonances above Nyquist is neglected.
//!
//! The plant enters as numbers at `s = j omega`, so any model can be used: for the azimuth,
//! `fmu_plant::analytic::current_loop_response(s, 100.0) *
//! fmu_plant::AzimuthParams::two_mass_at(el).motor_speed_per_torque(s)` is the motor speed per
//! total torque command of the doubled two-mass model.

use nalgebra::Complex;

use crate::filters::SpeedFilter;
use crate::params::CascadeParams;
use crate::velocity_loop::VelocityGains;

/// A complex number.
pub type C64 = Complex<f64>;

/// The plant as the position loop sees it at one frequency, both per unit of total torque
/// command (N m at the motor), including the current loop and everything else between the
/// controller's output and its measurements.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisPlantResponse {
    /// Measured motor speed (the mean of the motors for azimuth), rad/s per N m.
    pub motor_speed_per_torque: C64,
    /// Axis (load) angle, axis rad per N m.
    pub axis_angle_per_torque: C64,
}

/// The velocity loop: PI controller, measurement filter, delay and hold.
#[derive(Debug, Clone, PartialEq)]
pub struct VelocityLoopModel {
    pub sample_time_s: f64,
    pub delay_samples: u32,
    pub gains: VelocityGains,
    pub integrator_enabled: bool,
    pub speed_filter: SpeedFilter,
}

impl VelocityLoopModel {
    pub(crate) fn new(params: &CascadeParams, gains: VelocityGains, speed_filter: SpeedFilter) -> Self {
        Self {
            sample_time_s: params.sampling.sample_time_s,
            delay_samples: params.sampling.delay_samples,
            gains,
            integrator_enabled: params.velocity_loop.integrator_enabled,
            speed_filter,
        }
    }

    fn z(&self, omega: f64) -> C64 {
        C64::from_polar(1.0, omega * self.sample_time_s)
    }

    /// The PI controller `Kv (1 + w_i Ts / (z - 1))`, N m per rad/s.
    pub fn controller(&self, omega: f64) -> C64 {
        let kv = self.gains.proportional_nm_s_per_rad;
        if !self.integrator_enabled {
            return C64::new(kv, 0.0);
        }
        let z = self.z(omega);
        kv * (1.0 + self.gains.integral_corner_rad_per_s * self.sample_time_s / (z - 1.0))
    }

    /// Delay and zero-order hold between the controller and the plant: `z^-d (1 - z^-1) / (j
    /// omega Ts)`.
    pub fn actuation(&self, omega: f64) -> C64 {
        let x = omega * self.sample_time_s;
        let hold =
            if x.abs() < 1e-9 { C64::new(1.0, 0.0) } else { (1.0 - C64::from_polar(1.0, -x)) / C64::new(0.0, x) };
        C64::from_polar(1.0, -x * f64::from(self.delay_samples)) * hold
    }

    /// The speed-measurement filter.
    pub fn filter(&self, omega: f64) -> C64 {
        self.speed_filter.response(omega)
    }

    /// The loop gain broken at the torque command, for margins.
    pub fn open_loop(&self, omega: f64, motor_speed_per_torque: C64) -> C64 {
        self.controller(omega) * self.actuation(omega) * motor_speed_per_torque * self.filter(omega)
    }

    /// Velocity reference (motor rad/s) to motor speed: the closed velocity loop.
    pub fn closed_loop(&self, omega: f64, motor_speed_per_torque: C64) -> C64 {
        let forward = self.controller(omega) * self.actuation(omega) * motor_speed_per_torque;
        forward / (1.0 + self.open_loop(omega, motor_speed_per_torque))
    }

    /// Sensitivity `1 / (1 + L)`: output disturbance to speed error.
    pub fn sensitivity(&self, omega: f64, motor_speed_per_torque: C64) -> C64 {
        1.0 / (1.0 + self.open_loop(omega, motor_speed_per_torque))
    }
}

/// The position loop around the velocity loop, with the feedforward paths.
#[derive(Debug, Clone, PartialEq)]
pub struct PositionLoopModel {
    pub velocity: VelocityLoopModel,
    /// Position loop proportional gain, 1/s.
    pub proportional_gain_per_s: f64,
    /// Position loop integral gain, 1/s^2.
    pub integral_gain_per_s2: f64,
    /// Gear ratio, motor rad per axis rad.
    pub gear_ratio: f64,
    /// Total inertia at the motor used by the acceleration feedforward, kg m^2.
    pub total_inertia_kg_m2: f64,
    pub velocity_feedforward: bool,
    pub acceleration_feedforward: bool,
}

impl PositionLoopModel {
    /// The position controller `Kp + Ki Ts / (z - 1)`, axis rad/s per rad.
    pub fn controller(&self, omega: f64) -> C64 {
        let ts = self.velocity.sample_time_s;
        let z = C64::from_polar(1.0, omega * ts);
        self.proportional_gain_per_s + self.integral_gain_per_s2 * ts / (z - 1.0)
    }

    /// The position loop gain broken at the encoder measurement, with the velocity loop
    /// closed.
    pub fn open_loop(&self, omega: f64, plant: &AxisPlantResponse) -> C64 {
        let v = &self.velocity;
        let d_c = v.actuation(omega) * v.controller(omega);
        d_c * self.gear_ratio * self.controller(omega) * plant.axis_angle_per_torque
            / (1.0 + d_c * v.filter(omega) * plant.motor_speed_per_torque)
    }

    /// Position command to axis position with the feedforward paths that are switched on
    /// (the velocity feedforward being the command's derivative).
    pub fn closed_loop(&self, omega: f64, plant: &AxisPlantResponse) -> C64 {
        self.closed_loop_with(omega, plant, self.velocity_feedforward, self.acceleration_feedforward)
    }

    /// Position command to axis position of the feedback alone (no feedforward): its -3 dB
    /// point is the position loop's bandwidth.
    pub fn feedback_closed_loop(&self, omega: f64, plant: &AxisPlantResponse) -> C64 {
        self.closed_loop_with(omega, plant, false, false)
    }

    fn closed_loop_with(&self, omega: f64, plant: &AxisPlantResponse, velocity_ff: bool, acceleration_ff: bool) -> C64 {
        let v = &self.velocity;
        let s = C64::new(0.0, omega);
        let n = self.gear_ratio;
        let c = v.controller(omega);
        let d = v.actuation(omega);
        let k = self.controller(omega);
        let mut demand = c * n * k;
        if velocity_ff {
            demand += c * n * s;
        }
        if acceleration_ff {
            demand += self.total_inertia_kg_m2 * n * s * s;
        }
        plant.axis_angle_per_torque * d * demand
            / (1.0 + d * c * (n * k * plant.axis_angle_per_torque + v.filter(omega) * plant.motor_speed_per_torque))
    }
}

/// Stability margins of a loop gain `L(j omega)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Margins {
    /// Smallest `-20 log10 |L|` over the frequencies where `L` crosses the negative real axis,
    /// dB; infinite when it never does.
    pub gain_margin_db: f64,
    /// Where that happens, Hz (NaN when it never does).
    pub gain_margin_frequency_hz: f64,
    /// Smallest angular distance from `-1` over the frequencies where `|L| = 1`, deg.
    pub phase_margin_deg: f64,
    /// Where that happens, Hz.
    pub phase_margin_frequency_hz: f64,
    /// Every frequency where `|L| = 1`, Hz, ascending.
    pub gain_crossovers_hz: Vec<f64>,
    /// Smallest distance `|1 + L|` from the critical point (the inverse of the sensitivity
    /// peak), over the grid.
    pub modulus_margin: f64,
    /// Where that happens, Hz.
    pub modulus_margin_frequency_hz: f64,
}

/// Margins of `open_loop` (a function of omega in rad/s) scanned on `points` logarithmically
/// spaced frequencies between `min_hz` and `max_hz`, crossings refined by bisection.
pub fn margins(open_loop: impl Fn(f64) -> C64, min_hz: f64, max_hz: f64, points: usize) -> Margins {
    let grid = log_grid(min_hz, max_hz, points);
    let at = |f: f64| open_loop(std::f64::consts::TAU * f);
    let mut result = Margins {
        gain_margin_db: f64::INFINITY,
        gain_margin_frequency_hz: f64::NAN,
        phase_margin_deg: f64::INFINITY,
        phase_margin_frequency_hz: f64::NAN,
        gain_crossovers_hz: Vec::new(),
        modulus_margin: f64::INFINITY,
        modulus_margin_frequency_hz: f64::NAN,
    };
    let mut previous = (grid[0], at(grid[0]));
    for &f in &grid {
        let l = at(f);
        let distance = (1.0 + l).norm();
        if distance < result.modulus_margin {
            result.modulus_margin = distance;
            result.modulus_margin_frequency_hz = f;
        }
        let (f0, l0) = previous;
        if f > f0 {
            if (l0.norm() - 1.0) * (l.norm() - 1.0) < 0.0 {
                let fc = bisect(f0, f, |x| at(x).norm() - 1.0);
                result.gain_crossovers_hz.push(fc);
                let margin = (-at(fc)).arg().abs().to_degrees();
                if margin < result.phase_margin_deg {
                    result.phase_margin_deg = margin;
                    result.phase_margin_frequency_hz = fc;
                }
            }
            if l0.im * l.im < 0.0 && (l0.re < 0.0 || l.re < 0.0) {
                let fp = bisect(f0, f, |x| at(x).im);
                let lp = at(fp);
                if lp.re < 0.0 {
                    let margin = -20.0 * lp.norm().log10();
                    if margin < result.gain_margin_db {
                        result.gain_margin_db = margin;
                        result.gain_margin_frequency_hz = fp;
                    }
                }
            }
        }
        previous = (f, l);
    }
    result
}

/// The lowest frequency (Hz) at which `|closed_loop|` falls below `1/sqrt(2)` of its value at
/// `min_hz`, or `None` if it stays above up to `max_hz`.
pub fn bandwidth_hz(closed_loop: impl Fn(f64) -> C64, min_hz: f64, max_hz: f64, points: usize) -> Option<f64> {
    let at = |f: f64| closed_loop(std::f64::consts::TAU * f).norm();
    let level = at(min_hz) / 2f64.sqrt();
    let grid = log_grid(min_hz, max_hz, points);
    grid.windows(2).find(|w| at(w[0]) >= level && at(w[1]) < level).map(|w| bisect(w[0], w[1], |f| at(f) - level))
}

/// `points` frequencies spaced evenly in log between `min` and `max` inclusive.
pub fn log_grid(min: f64, max: f64, points: usize) -> Vec<f64> {
    let (a, b) = (min.ln(), max.ln());
    (0..points).map(|k| (a + (b - a) * k as f64 / (points - 1) as f64).exp()).collect()
}

/// A root of `g` between `lo` and `hi` (where it changes sign), by bisection in log frequency.
fn bisect(mut lo: f64, mut hi: f64, g: impl Fn(f64) -> f64) -> f64 {
    let g_lo = g(lo);
    for _ in 0..60 {
        let mid = (lo * hi).sqrt();
        if (g(mid) < 0.0) == (g_lo < 0.0) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (lo * hi).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pure integrator with a known crossover and delay: phase margin 90 deg minus the delay's
    /// phase at crossover, gain margin where the delay adds another 90 deg.
    #[test]
    fn margins_of_a_delayed_integrator_match_the_closed_form() {
        let (wc, delay) = (2.0 * std::f64::consts::PI * 10.0, 2e-3);
        let l = |w: f64| C64::new(wc, 0.0) / C64::new(0.0, w) * C64::from_polar(1.0, -w * delay);
        let m = margins(l, 0.1, 1000.0, 2000);
        let expected_pm = 90.0 - (wc * delay).to_degrees();
        assert!((m.phase_margin_deg - expected_pm).abs() < 1e-6, "{} vs {expected_pm}", m.phase_margin_deg);
        assert!((m.phase_margin_frequency_hz - 10.0).abs() < 1e-9);
        // Phase -180 deg where w delay = pi/2; |L| = wc / w there.
        let w180 = std::f64::consts::FRAC_PI_2 / delay;
        let expected_gm = 20.0 * (w180 / wc).log10();
        assert!((m.gain_margin_db - expected_gm).abs() < 1e-6, "{} vs {expected_gm}", m.gain_margin_db);
        assert_eq!(m.gain_crossovers_hz.len(), 1);
    }

    #[test]
    fn bandwidth_of_a_first_order_lag_is_its_corner() {
        let corner_hz = 3.0;
        let t = |w: f64| 1.0 / C64::new(1.0, w / (std::f64::consts::TAU * corner_hz));
        let min_hz = 0.01;
        let bw = bandwidth_hz(t, min_hz, 100.0, 500).unwrap();
        // The level is 1/sqrt(2) of the gain at min_hz: 1 + x^2 = 2 (1 + x0^2) with x = f/corner.
        let x0 = min_hz / corner_hz;
        let expected = corner_hz * (1.0 + 2.0 * x0 * x0).sqrt();
        assert!((bw - expected).abs() < 1e-9, "{bw} vs {expected}");
        assert!(bandwidth_hz(|_| C64::new(1.0, 0.0), 0.01, 100.0, 50).is_none());
    }
}
