//! The sensors the controller reads: the axis encoder between the true load angle and the
//! encoder reading, and the motor speed signals.
//!
//! # Encoder
//!
//! The reading is `count(theta + e(theta) + n_k)`: the true axis angle `theta`, plus the
//! position-periodic errors `e(theta)` (graduation harmonics, interpolation error at the signal
//! period and its second harmonic, once-per-revolution eccentricity), each
//! `A sin(c theta + phi)` with `c` cycles per turn, plus the reading noise `n_k`, then counted
//! to whole counts of a `bits`-bit encoder by truncation (rounding down, the plant's behaviour
//! before the sensor model) or by rounding to the nearest count.
//!
//! # Noise and its sample clock
//!
//! Reading noise and speed-signal noise are white Gaussian sequences sampled at a fixed sensor
//! sample period `T_s` (default 1 ms, the controller's sample period), each sample held until
//! the next sample instant. Sample `k` of a channel is a pure function of the seed, the channel
//! and `k`: ChaCha12 keyed by the seed (the SplitMix64 expansion of `fmu-wind`), one stream per
//! channel; samples `2j` and `2j + 1` are the two normals (cosine and sine) that Box-Muller
//! makes of words `4j .. 4j + 3`, so one logarithm and one `sin_cos` give two samples. The value a master
//! reads at time `t` is therefore the same whatever communication steps led to `t`: 0.5 ms, 1 ms
//! or 2 ms steps all read sample `k` at `t = k T_s`, and a restored FMU state replays the same
//! sequence. The alternative, one draw per communication step, would make the noise's
//! bandwidth and its samples depend on the master's step size.
//!
//! The sample index comes from a [`SampleClock`] that counts whole sample periods and keeps
//! only the time since the last sample instant, so its rounding stays at the level of one
//! sample period's ulp and does not grow with the run's length (the accumulated time of a
//! drive, a sum of step sizes, drifts by up to 1e-2 sample periods in two hours of 0.1 ms
//! steps). A sample instant is reached when the time since the previous one is within 1e-6
//! of a sample period of `T_s`.
//!
//! All errors default to zero and the count to truncation, which reproduces the readings of
//! the plant before this model bit for bit: the ideal encoder path does not add zeros.

use fmu_runtime::seed::seed_key;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha12Rng;
use serde::{Deserialize, Serialize};

use crate::floor::floor;
use libm::sincos as sin_cos;

/// One arcsecond in radians.
pub const ARCSEC: f64 = std::f64::consts::PI / (180.0 * 3600.0);

/// The fraction of a sample period within which a sample instant counts as reached.
const SAMPLE_SNAP: f64 = 1e-6;

/// Signal periods per turn of the default encoder: 32768, a ring encoder of the RCN 8000 class
/// (a signal period of 39.6 arcsec).
pub const DEFAULT_LINE_COUNT: f64 = 32768.0;

/// How the encoder turns an angle into whole counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CountMode {
    /// Round down to whole counts (mean error minus half a count).
    #[default]
    Truncate,
    /// Round to the nearest count (mean error zero).
    Round,
}

impl CountMode {
    /// The mode of an FMI enumeration value (1 truncate, 2 round).
    pub fn from_index(index: i32) -> Option<CountMode> {
        match index {
            1 => Some(CountMode::Truncate),
            2 => Some(CountMode::Round),
            _ => None,
        }
    }
}

/// A position-periodic error `A sin(c theta + phi)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeriodicError {
    /// Amplitude `A`, arcsec; 0 is off.
    pub amplitude_arcsec: f64,
    /// Cycles per turn `c` (the harmonic number; 1 is once per revolution).
    pub cycles_per_turn: f64,
    /// Phase `phi` at angle 0, deg.
    pub phase_deg: f64,
}

impl PeriodicError {
    pub const NONE: PeriodicError = PeriodicError { amplitude_arcsec: 0.0, cycles_per_turn: 1.0, phase_deg: 0.0 };

    /// The error at an axis angle, rad.
    pub fn error_rad(&self, angle_rad: f64) -> f64 {
        if self.amplitude_arcsec == 0.0 {
            return 0.0;
        }
        self.amplitude_arcsec * ARCSEC * (self.cycles_per_turn * angle_rad + self.phase_deg.to_radians()).sin()
    }

    fn validate(&self, name: &str, errors: &mut Vec<String>) {
        if !self.amplitude_arcsec.is_finite() {
            errors.push(format!("{name}.amplitude_arcsec ({}) must be finite", self.amplitude_arcsec));
        }
        if !(self.cycles_per_turn.is_finite() && self.cycles_per_turn >= 0.0) {
            errors.push(format!("{name}.cycles_per_turn ({}) must be finite and non-negative", self.cycles_per_turn));
        }
        if !self.phase_deg.is_finite() {
            errors.push(format!("{name}.phase_deg ({}) must be finite", self.phase_deg));
        }
    }
}

/// The encoder's errors between the true axis angle and its reading (the resolution itself
/// stays in the axis parameters as `encoder_bits`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EncoderErrors {
    pub count_mode: CountMode,
    /// Graduation error: harmonics of the ring's long-period error (whole cycles per turn).
    pub graduation: [PeriodicError; 3],
    /// Interpolation error within one signal period: at the signal period (cycles per turn =
    /// line count) and at half of it (twice the line count).
    pub interpolation: [PeriodicError; 2],
    /// Eccentricity of the graduation on the axis: once per revolution.
    pub eccentricity: PeriodicError,
    /// White reading noise, arcsec RMS, one sample per sensor sample period.
    pub noise_rms_arcsec: f64,
}

impl EncoderErrors {
    /// An ideal encoder: no error, truncating count. The switched-off terms keep the FMUs'
    /// default harmonic numbers (graduation 2, 3 and 4 per turn; interpolation at
    /// [`DEFAULT_LINE_COUNT`] and twice it), so that the variable tables' start values are
    /// exactly these parameters.
    pub const NONE: EncoderErrors = EncoderErrors {
        count_mode: CountMode::Truncate,
        graduation: [
            PeriodicError { cycles_per_turn: 2.0, ..PeriodicError::NONE },
            PeriodicError { cycles_per_turn: 3.0, ..PeriodicError::NONE },
            PeriodicError { cycles_per_turn: 4.0, ..PeriodicError::NONE },
        ],
        interpolation: [
            PeriodicError { cycles_per_turn: DEFAULT_LINE_COUNT, ..PeriodicError::NONE },
            PeriodicError { cycles_per_turn: 2.0 * DEFAULT_LINE_COUNT, ..PeriodicError::NONE },
        ],
        eccentricity: PeriodicError::NONE,
        noise_rms_arcsec: 0.0,
    };

    fn periodic(&self) -> impl Iterator<Item = &PeriodicError> {
        self.graduation.iter().chain(&self.interpolation).chain(std::iter::once(&self.eccentricity))
    }

    /// True when the reading is the counted true angle (no periodic error, no noise).
    fn is_exact(&self) -> bool {
        self.noise_rms_arcsec == 0.0 && self.periodic().all(|p| p.amplitude_arcsec == 0.0)
    }

    /// The sum of the position-periodic errors at an axis angle, rad: the definition, one
    /// sine per term ([`PeriodicSum`] evaluates the same sum with fewer).
    pub fn periodic_error_rad(&self, angle_rad: f64) -> f64 {
        self.periodic().map(|p| p.error_rad(angle_rad)).sum()
    }
}

/// Whole harmonics up to this one are evaluated by rotating the first harmonic.
const MAX_ROTATED_HARMONIC: usize = 16;

/// The encoder's position-periodic errors prepared so that a reading takes at most a few
/// `sin_cos` calls (fdlibm's, from the `libm` crate: about 90 instructions a call against the
/// system library's 130) instead of one sine per term: the plants
/// read the encoder every step, and six sines were a tenth of the coupled antenna's time. Each
/// term `A sin(c theta + phi)` is `A cos(phi) sin(c theta) + A sin(phi) cos(c theta)`. Terms with a whole `c` up to
/// [`MAX_ROTATED_HARMONIC`] (graduation harmonics, eccentricity) come from `sin_cos(theta)` by
/// the angle-addition recurrence (its rounding grows by about one ulp per harmonic); a term at
/// twice another's `c` (the interpolation error's second harmonic) by the double-angle formula;
/// any other term has its own `sin_cos`. The sum agrees with
/// [`EncoderErrors::periodic_error_rad`] to about 1e-12 of the amplitudes, the rounding of the
/// definition's own argument `c theta + phi` at the signal period (some 1e5 rad).
#[derive(Debug, Clone, PartialEq)]
struct PeriodicSum {
    /// Weights `(A cos phi, A sin phi)` in rad of harmonics 1 to `rotated`, summed over terms.
    harmonic_weights: [(f64, f64); MAX_ROTATED_HARMONIC],
    /// How many whole harmonics are evaluated (0: none).
    rotated: usize,
    /// The other terms, each with a term at twice its cycles if there is one.
    others: Vec<OwnSineTerm>,
}

/// A term of [`PeriodicSum`] with its own `sin_cos`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct OwnSineTerm {
    cycles_per_turn: f64,
    /// `(A cos phi, A sin phi)`, rad.
    weights: (f64, f64),
    /// The weights of the term at twice the cycles (zero if there is none).
    double_weights: (f64, f64),
}

impl PeriodicSum {
    fn new(errors: &EncoderErrors) -> Self {
        let mut sum =
            PeriodicSum { harmonic_weights: [(0.0, 0.0); MAX_ROTATED_HARMONIC], rotated: 0, others: Vec::new() };
        let terms: Vec<&PeriodicError> = errors.periodic().filter(|p| p.amplitude_arcsec != 0.0).collect();
        let weights = |p: &PeriodicError| {
            let (sin_phi, cos_phi) = p.phase_deg.to_radians().sin_cos();
            (p.amplitude_arcsec * ARCSEC * cos_phi, p.amplitude_arcsec * ARCSEC * sin_phi)
        };
        let whole = |c: f64| c >= 1.0 && c <= MAX_ROTATED_HARMONIC as f64 && c.fract() == 0.0;
        let mut doubled = vec![false; terms.len()];
        for (i, term) in terms.iter().enumerate() {
            let c = term.cycles_per_turn;
            if whole(c) {
                let n = c as usize;
                let (a, b) = weights(term);
                sum.harmonic_weights[n - 1].0 += a;
                sum.harmonic_weights[n - 1].1 += b;
                sum.rotated = sum.rotated.max(n);
                continue;
            }
            if doubled[i] {
                continue;
            }
            let double = terms.iter().enumerate().position(|(j, other)| {
                j != i && !doubled[j] && !whole(other.cycles_per_turn) && other.cycles_per_turn == 2.0 * c
            });
            let double_weights = match double {
                Some(j) => {
                    doubled[j] = true;
                    weights(terms[j])
                }
                None => (0.0, 0.0),
            };
            sum.others.push(OwnSineTerm { cycles_per_turn: c, weights: weights(term), double_weights });
        }
        sum
    }

    fn error_rad(&self, angle_rad: f64) -> f64 {
        let mut total = 0.0;
        if self.rotated > 0 {
            let (s1, c1) = sin_cos(angle_rad);
            let (mut s, mut c) = (s1, c1);
            for &(a, b) in &self.harmonic_weights[..self.rotated] {
                total += a * s + b * c;
                (s, c) = (s * c1 + c * s1, c * c1 - s * s1);
            }
        }
        for &OwnSineTerm { cycles_per_turn, weights: (a, b), double_weights: (a2, b2) } in &self.others {
            let (s, c) = sin_cos(cycles_per_turn * angle_rad);
            total += a * s + b * c + a2 * (2.0 * s * c) + b2 * (c * c - s * s);
        }
        total
    }
}

/// The sensor parameters of an axis with `P` motors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorParams<const P: usize> {
    pub encoder: EncoderErrors,
    /// White noise on each motor's speed signal, rad/s RMS at the motor.
    pub motor_speed_noise_rms_rad_per_s: [f64; P],
    /// Seed of the noise sequences.
    pub seed: u64,
    /// Sensor sample period, s: each noise sample is held for this long.
    pub sample_period_s: f64,
}

impl<const P: usize> Default for SensorParams<P> {
    /// Ideal sensors: the plant's behaviour before the sensor model.
    fn default() -> Self {
        Self { encoder: EncoderErrors::NONE, motor_speed_noise_rms_rad_per_s: [0.0; P], seed: 1, sample_period_s: 1e-3 }
    }
}

impl<const P: usize> SensorParams<P> {
    pub fn validate(&self, errors: &mut Vec<String>) {
        let e = &self.encoder;
        for (k, g) in e.graduation.iter().enumerate() {
            g.validate(&format!("sensors.encoder.graduation[{k}]"), errors);
        }
        for (k, i) in e.interpolation.iter().enumerate() {
            i.validate(&format!("sensors.encoder.interpolation[{k}]"), errors);
        }
        e.eccentricity.validate("sensors.encoder.eccentricity", errors);
        let noises = std::iter::once(("sensors.encoder.noise_rms_arcsec".to_string(), e.noise_rms_arcsec)).chain(
            self.motor_speed_noise_rms_rad_per_s
                .iter()
                .enumerate()
                .map(|(k, &n)| (format!("sensors.motor_speed_noise_rms_rad_per_s[{k}]"), n)),
        );
        for (name, rms) in noises {
            if !(rms.is_finite() && rms >= 0.0) {
                errors.push(format!("{name} ({rms}) must be finite and non-negative"));
            }
        }
        if !(self.sample_period_s.is_finite() && self.sample_period_s > 0.0) {
            errors.push(format!("sensors.sample_period_s ({}) must be finite and positive", self.sample_period_s));
        }
    }
}

/// Counts whole sensor sample periods since the start (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct SampleClock {
    /// Index of the latest sample instant reached.
    pub sample: u64,
    /// Time since that instant, s (may be below zero by at most 1e-6 of a sample period when
    /// the instant was reached within the snap tolerance).
    pub since_sample_s: f64,
}

impl SampleClock {
    /// Advances by `h` seconds.
    pub fn advance(&mut self, h: f64, period: f64) {
        let total = self.since_sample_s + h;
        let whole = floor(total / period + SAMPLE_SNAP);
        if whole >= 1.0 {
            self.sample = self.sample.wrapping_add(whole as u64);
            self.since_sample_s = total - whole * period;
        } else {
            self.since_sample_s = total;
        }
    }
}

/// One white Gaussian noise channel with random access by sample index.
#[derive(Debug, Clone)]
struct NoiseChannel {
    rms: f64,
    rng: Option<ChaCha12Rng>,
    /// The index of the Box-Muller pair last drawn and its two samples.
    current: Option<(u64, [f64; 2])>,
    /// The pair whose words the generator gives next: asking the generator for its word
    /// position costs more than the pair's arithmetic.
    next_pair: u64,
}

impl NoiseChannel {
    fn new(rms: f64, seed: u64, stream: u64) -> Self {
        let rng = (rms != 0.0).then(|| {
            let mut rng = ChaCha12Rng::from_seed(seed_key(seed));
            rng.set_stream(stream);
            rng
        });
        Self { rms, rng, current: None, next_pair: 0 }
    }

    /// Sample `k` of the channel (0 when the channel is off).
    fn sample(&mut self, k: u64) -> f64 {
        let Some(rng) = &mut self.rng else { return 0.0 };
        let pair = k / 2;
        let half = (k % 2) as usize;
        if let Some((index, values)) = self.current {
            if index == pair {
                return values[half];
            }
        }
        // Four 32-bit words per pair of samples: sequential reading needs no seek.
        if self.next_pair != pair {
            rng.set_word_pos(u128::from(pair) * 4);
        }
        let (a, b) = (rng.next_u64(), rng.next_u64());
        self.next_pair = pair.wrapping_add(1);
        // Box-Muller: u1 in (0, 1], u2 in [0, 1), 53 random bits each; the cosine and the sine
        // give two independent normals.
        let scale = 1.0 / (1u64 << 53) as f64;
        let u1 = ((a >> 11) + 1) as f64 * scale;
        let u2 = (b >> 11) as f64 * scale;
        let radius = self.rms * (-2.0 * u1.ln()).sqrt();
        let (sine, cosine) = sin_cos(std::f64::consts::TAU * u2);
        let values = [radius * cosine, radius * sine];
        self.current = Some((pair, values));
        values[half]
    }
}

/// The noise channel streams of an axis: encoder, then motor speeds. Axes get separate
/// blocks of streams so that the two plants' noise differs for the same seed.
pub(crate) const AZIMUTH_STREAMS: u64 = 0x100;
pub(crate) const ELEVATION_STREAMS: u64 = 0x200;

/// The sensors of an axis with `P` motors: parameters, sample clock and noise channels.
#[derive(Debug, Clone)]
pub(crate) struct Sensors<const P: usize> {
    params: SensorParams<P>,
    bits: u32,
    /// True when the reading is the counted true angle: then nothing is added to it, so the
    /// reading is bit for bit that of the plant before the sensor model.
    exact_encoder: bool,
    periodic: PeriodicSum,
    clock: SampleClock,
    encoder_noise: NoiseChannel,
    speed_noise: [NoiseChannel; P],
    /// Noise values at the current sample: encoder (rad), motor speeds (rad/s).
    encoder_noise_rad: f64,
    speed_noise_rad_per_s: [f64; P],
}

impl<const P: usize> Sensors<P> {
    pub fn new(params: SensorParams<P>, bits: u32, streams: u64) -> Self {
        let encoder_noise = NoiseChannel::new(params.encoder.noise_rms_arcsec * ARCSEC, params.seed, streams);
        let speed_noise = std::array::from_fn(|k| {
            NoiseChannel::new(params.motor_speed_noise_rms_rad_per_s[k], params.seed, streams + 1 + k as u64)
        });
        let mut sensors = Self {
            params,
            bits,
            exact_encoder: params.encoder.is_exact(),
            periodic: PeriodicSum::new(&params.encoder),
            clock: SampleClock::default(),
            encoder_noise,
            speed_noise,
            encoder_noise_rad: 0.0,
            speed_noise_rad_per_s: [0.0; P],
        };
        sensors.draw();
        sensors
    }

    fn has_noise(&self) -> bool {
        self.encoder_noise.rng.is_some() || self.speed_noise.iter().any(|c| c.rng.is_some())
    }

    fn draw(&mut self) {
        if !self.has_noise() {
            return;
        }
        let k = self.clock.sample;
        self.encoder_noise_rad = self.encoder_noise.sample(k);
        for (value, channel) in self.speed_noise_rad_per_s.iter_mut().zip(&mut self.speed_noise) {
            *value = channel.sample(k);
        }
    }

    /// Advances the sample clock after a step of `h` seconds.
    pub fn advance(&mut self, h: f64) {
        self.clock.advance(h, self.params.sample_period_s);
        self.draw();
    }

    pub fn clock(&self) -> SampleClock {
        self.clock
    }

    /// Sets the clock (start, or a restored state).
    pub fn set_clock(&mut self, clock: SampleClock) {
        self.clock = clock;
        self.draw();
    }

    /// The encoder reading of a true axis angle, rad.
    pub fn encoder_reading_rad(&self, angle_rad: f64) -> f64 {
        let e = &self.params.encoder;
        let sensed = if self.exact_encoder {
            angle_rad
        } else {
            angle_rad + self.periodic.error_rad(angle_rad) + self.encoder_noise_rad
        };
        count(sensed, self.bits, e.count_mode)
    }

    /// A motor's speed signal for its true speed, rad/s.
    pub fn motor_speed_signal(&self, k: usize, speed_rad_per_s: f64) -> f64 {
        if self.speed_noise[k].rng.is_none() {
            return speed_rad_per_s;
        }
        speed_rad_per_s + self.speed_noise_rad_per_s[k]
    }
}

/// An angle in whole counts of a `bits`-bit-per-turn encoder; 0 bits is exact.
pub(crate) fn count(angle_rad: f64, bits: u32, mode: CountMode) -> f64 {
    if bits == 0 {
        return angle_rad;
    }
    let count = std::f64::consts::TAU / (1u64 << bits) as f64;
    match mode {
        CountMode::Truncate => floor(angle_rad / count) * count,
        CountMode::Round => floor(angle_rad / count + 0.5) * count,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sample_clock_reaches_the_same_instants_for_half_whole_and_double_steps() {
        let period = 1e-3;
        for (h, steps) in [(0.5e-3, 14_400_000u64), (1e-3, 7_200_000), (2e-3, 3_600_000)] {
            let mut clock = SampleClock::default();
            for _ in 0..steps {
                clock.advance(h, period);
            }
            assert_eq!(clock.sample, 7_200_000, "h = {h}");
            assert!(clock.since_sample_s.abs() < 1e-12, "h = {h}: {}", clock.since_sample_s);
        }
    }

    #[test]
    fn the_sample_clock_does_not_drift_with_tenth_of_a_period_steps() {
        let mut clock = SampleClock::default();
        for _ in 0..1_000_000 {
            clock.advance(1e-4, 1e-3);
        }
        assert_eq!(clock.sample, 100_000);
        assert!(clock.since_sample_s.abs() < 1e-9 * 1e-3);
    }

    #[test]
    fn a_noise_sample_depends_only_on_seed_channel_and_index() {
        let mut sequential = NoiseChannel::new(1.0, 7, 3);
        let forward: Vec<f64> = (0..100).map(|k| sequential.sample(k)).collect();
        let mut random_access = NoiseChannel::new(1.0, 7, 3);
        for k in (0..100).rev() {
            assert_eq!(random_access.sample(k).to_bits(), forward[k as usize].to_bits());
        }
        let mut other_seed = NoiseChannel::new(1.0, 8, 3);
        let mut other_stream = NoiseChannel::new(1.0, 7, 4);
        assert!((0..100).all(|k| other_seed.sample(k) != forward[k as usize]));
        assert!((0..100).all(|k| other_stream.sample(k) != forward[k as usize]));
    }

    #[test]
    fn noise_samples_are_standard_normal_to_sampling_accuracy() {
        let n = 200_000u64;
        let mut channel = NoiseChannel::new(2.0, 1, 0);
        let samples: Vec<f64> = (0..n).map(|k| channel.sample(k)).collect();
        let mean = samples.iter().sum::<f64>() / n as f64;
        let rms = (samples.iter().map(|x| x * x).sum::<f64>() / n as f64).sqrt();
        // Standard errors: 2 / sqrt(n) = 0.0045 for the mean, 2 / sqrt(2 n) = 0.0032 for the RMS.
        assert!(mean.abs() < 4.0 * 0.0045, "mean {mean}");
        assert!((rms - 2.0).abs() < 4.0 * 0.0032, "rms {rms}");
        let beyond_three_sigma = samples.iter().filter(|x| x.abs() > 6.0).count() as f64 / n as f64;
        assert!((beyond_three_sigma - 0.0027).abs() < 0.0006, "{beyond_three_sigma}");
    }

    #[test]
    fn the_prepared_periodic_sum_equals_one_sine_per_term() {
        let term = |amplitude_arcsec, cycles_per_turn, phase_deg| PeriodicError {
            amplitude_arcsec,
            cycles_per_turn,
            phase_deg,
        };
        let mut errors = EncoderErrors::NONE;
        errors.graduation = [term(0.6, 2.0, 10.0), term(0.4, 3.0, -70.0), term(0.3, 16.0, 200.0)];
        errors.interpolation = [term(0.2, 32768.0, 33.0), term(0.1, 65536.0, -5.0)];
        errors.eccentricity = term(1.5, 1.0, 120.0);
        // A non-whole harmonic, a second term on the same harmonic, and a lone high one.
        let mut odd = errors;
        odd.graduation[1] = term(0.4, 2.5, 15.0);
        odd.eccentricity = term(1.5, 2.0, 40.0);
        odd.interpolation[1] = term(0.1, 40000.0, 0.0);
        for e in [errors, odd] {
            let sum = PeriodicSum::new(&e);
            let amplitude: f64 = e.periodic().map(|p| p.amplitude_arcsec * ARCSEC).sum();
            for k in 0..2000 {
                let angle = -7.0 + 14.0 * k as f64 / 2000.0;
                let (fast, reference) = (sum.error_rad(angle), e.periodic_error_rad(angle));
                // The definition rounds c theta + phi, some 1e5 rad at the signal period, to its
                // ulp (3e-11 rad): that, not the recurrence, sets the tolerance.
                assert!((fast - reference).abs() < 1e-11 * amplitude, "{angle}: {fast} vs {reference}");
            }
        }
        assert_eq!(PeriodicSum::new(&EncoderErrors::NONE).error_rad(1.0), 0.0);
    }

    #[test]
    fn rounding_counts_to_the_nearest_and_truncation_rounds_down() {
        let c = std::f64::consts::TAU / 16.0;
        assert_eq!(count(0.7 * c, 4, CountMode::Truncate), 0.0);
        assert_eq!(count(0.7 * c, 4, CountMode::Round), c);
        assert_eq!(count(-0.3 * c, 4, CountMode::Truncate), -c);
        assert_eq!(count(-0.3 * c, 4, CountMode::Round), 0.0);
        assert_eq!(count(0.123, 0, CountMode::Round), 0.123);
    }
}
