//! The identification trajectory: a smooth multi-segment position command with constant-velocity
//! runs over two decades of speed in both directions, reversals and dwells, like a drive
//! commissioning test. Velocity changes follow half-cosine ramps, so the acceleration is
//! continuous and bounded. The segment sequence is drawn from the seed.

use rand::{RngExt, SeedableRng};

/// Bounds of the trajectory (axis side, SI).
#[derive(Debug, Clone)]
pub struct TrajectoryConfig {
    pub min_position: f64,
    pub max_position: f64,
    pub min_speed: f64,
    pub max_speed: f64,
    pub max_acceleration: f64,
    /// Probability that a segment is a dwell at standstill.
    pub dwell_probability: f64,
}

impl Default for TrajectoryConfig {
    /// An elevation-like range (15 to 85 deg), 0.01 to 2 deg/s, 1 deg/s^2.
    fn default() -> Self {
        TrajectoryConfig {
            min_position: 15f64.to_radians(),
            max_position: 85f64.to_radians(),
            min_speed: 0.01f64.to_radians(),
            max_speed: 2f64.to_radians(),
            max_acceleration: 1f64.to_radians(),
            dwell_probability: 0.15,
        }
    }
}

/// One piece: a half-cosine ramp from `v0` to `v1` over `duration` (a cruise when equal).
#[derive(Debug, Clone, Copy)]
struct Piece {
    start: f64,
    duration: f64,
    p0: f64,
    v0: f64,
    v1: f64,
}

impl Piece {
    fn evaluate(&self, t: f64) -> (f64, f64, f64) {
        let tau = (t - self.start).clamp(0.0, self.duration);
        let dv = self.v1 - self.v0;
        if dv == 0.0 || self.duration <= 0.0 {
            return (self.p0 + self.v0 * tau, self.v0, 0.0);
        }
        let w = std::f64::consts::PI / self.duration;
        let position = self.p0 + self.v0 * tau + 0.5 * dv * (tau - (w * tau).sin() / w);
        let velocity = self.v0 + 0.5 * dv * (1.0 - (w * tau).cos());
        let acceleration = 0.5 * dv * w * (w * tau).sin();
        (position, velocity, acceleration)
    }

    fn end_position(&self) -> f64 {
        self.p0 + 0.5 * (self.v0 + self.v1) * self.duration
    }
}

/// A generated trajectory, evaluated analytically at any time.
#[derive(Debug, Clone)]
pub struct Trajectory {
    pieces: Vec<Piece>,
}

impl Trajectory {
    pub fn generate(config: &TrajectoryConfig, duration: f64, seed: u64) -> Trajectory {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x7261_6a65_6374);
        let span = config.max_position - config.min_position;
        let mut position = config.min_position + span * rng.random_range(0.3..0.7);
        let mut velocity = 0.0;
        let mut t = 0.0;
        let mut pieces = vec![Piece { start: 0.0, duration: 1.0, p0: position, v0: 0.0, v1: 0.0 }];
        t += 1.0;
        // Room needed to stop from full speed, kept free at each end.
        let margin = std::f64::consts::PI * config.max_speed * config.max_speed / (2.0 * config.max_acceleration)
            + config.max_speed;
        while t < duration {
            let dwell = rng.random_bool(config.dwell_probability);
            let speed = if dwell {
                0.0
            } else {
                let (lo, hi) = (config.min_speed.ln(), config.max_speed.ln());
                rng.random_range(lo..hi).exp()
            };
            let forward = if position > config.max_position - margin {
                false
            } else if position < config.min_position + margin {
                true
            } else {
                rng.random_bool(0.5)
            };
            let target = if forward { speed } else { -speed };
            let ramp = (std::f64::consts::PI * (target - velocity).abs() / (2.0 * config.max_acceleration)).max(0.05);
            let piece = Piece { start: t, duration: ramp, p0: position, v0: velocity, v1: target };
            position = piece.end_position();
            pieces.push(piece);
            t += ramp;
            let mut cruise: f64 = if dwell { rng.random_range(0.5..1.5) } else { rng.random_range(1.0..5.0) };
            if target != 0.0 {
                let room = if target > 0.0 {
                    config.max_position - margin * 0.5 - position
                } else {
                    position - config.min_position - margin * 0.5
                };
                cruise = cruise.min((room / target.abs()).max(0.2));
            }
            let piece = Piece { start: t, duration: cruise, p0: position, v0: target, v1: target };
            position = piece.end_position();
            pieces.push(piece);
            t += cruise;
            velocity = target;
        }
        Trajectory { pieces }
    }

    fn piece(&self, t: f64) -> &Piece {
        let index = self.pieces.partition_point(|p| p.start <= t).saturating_sub(1);
        &self.pieces[index]
    }

    pub fn position(&self, t: f64) -> f64 {
        self.piece(t).evaluate(t).0
    }

    pub fn velocity(&self, t: f64) -> f64 {
        self.piece(t).evaluate(t).1
    }

    pub fn acceleration(&self, t: f64) -> f64 {
        self.piece(t).evaluate(t).2
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trajectory_is_continuous_and_stays_in_range() {
        let config = TrajectoryConfig::default();
        let trajectory = Trajectory::generate(&config, 120.0, 3);
        let dt = 1e-3;
        let mut previous = trajectory.position(0.0);
        let mut reversals = 0;
        let mut last_sign = 0.0;
        for k in 1..120_000 {
            let t = k as f64 * dt;
            let p = trajectory.position(t);
            let v = trajectory.velocity(t);
            assert!((p - previous - v * dt).abs() < 1e-6, "jump at {t}");
            assert!(
                p > config.min_position - 1e-9 && p < config.max_position + 1e-9,
                "out of range at {t}: {}",
                p.to_degrees()
            );
            assert!(trajectory.acceleration(t).abs() <= config.max_acceleration * 1.0001);
            if v.abs() > 1e-9 {
                if last_sign != 0.0 && v.signum() != last_sign {
                    reversals += 1;
                }
                last_sign = v.signum();
            }
            previous = p;
        }
        assert!(reversals >= 3, "only {reversals} reversals");
    }
}
