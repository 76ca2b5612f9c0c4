//! `sin_cos` without the library call, for the encoder's periodic errors and the sensor noise,
//! which the plants evaluate at every step.
//!
//! The system library's `sincos` costs some 130 instructions per call for arguments beyond
//! pi/4, and the plants made 6.5 such calls a step: 5.5 % of the coupled antenna's
//! instructions. This is the FreeBSD msun / musl algorithm (Sun's fdlibm), inlined: Cody-Waite
//! reduction by pi/2 with a three-part constant, good to at least 85 bits of the reduced
//! argument, then degree-13 and degree-14 polynomials on [-pi/4, pi/4], each with an error
//! below one unit in the last place; about 90 instructions a call. It differs from the
//! library's result by less than one unit in the last place, and is equal to it for most
//! arguments (tested). Beyond about 1.6e6 in magnitude, where this reduction would need a
//! longer constant, and for infinities and NaN, it calls the library.
//!
//! The constants and the polynomials are fdlibm's, whose notice follows:
//! Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved. Developed at SunPro, a Sun
//! Microsystems, Inc. business. Permission to use, copy, modify, and distribute this software
//! is freely granted, provided that this notice is preserved.

/// `1.5 / EPSILON`: adding and subtracting it rounds a number below 2^51 to an integer.
const TO_INT: f64 = 1.5 / f64::EPSILON;
/// `2 / pi`.
const INV_PIO2: f64 = std::f64::consts::FRAC_2_PI;
/// `pi / 2` in three parts: the first 33 bits of each, so that `n * part` is exact for
/// `n < 2^20`, and each part's remainder. These and the polynomials' coefficients are fdlibm's,
/// given by their bits as fdlibm gives them.
const PIO2_1: f64 = f64::from_bits(0x3ff9_21fb_5440_0000);
const PIO2_1T: f64 = f64::from_bits(0x3dd0_b461_1a62_6331);
const PIO2_2: f64 = f64::from_bits(0x3dd0_b461_1a60_0000);
const PIO2_2T: f64 = f64::from_bits(0x3ba3_198a_2e03_7073);
const PIO2_3: f64 = f64::from_bits(0x3ba3_198a_2e00_0000);
const PIO2_3T: f64 = f64::from_bits(0x397b_839a_2520_49c1);

/// Upper 32 bits of `|x|` below which [`sin_cos`] reduces the argument itself: about
/// `2^20 pi / 2`, where `n * PIO2_1` stops being exact.
const MEDIUM_LIMIT_HIGH_WORD: u32 = 0x4139_21fb;
/// Upper 32 bits of `pi / 4`: no reduction at or below.
const PIO4_HIGH_WORD: u32 = 0x3fe9_21fb;
/// Upper 32 bits of `2^-27 sqrt 2`: below it `sin x = x` and `cos x = 1` to the last bit.
const TINY_HIGH_WORD: u32 = 0x3e46_a09e;

/// `sin x = x + S1 x^3 + ... + S6 x^13` on [-pi/4, pi/4].
const S1: f64 = f64::from_bits(0xbfc5_5555_5555_5549);
const S2: f64 = f64::from_bits(0x3f81_1111_1110_f8a6);
const S3: f64 = f64::from_bits(0xbf2a_01a0_19c1_61d5);
const S4: f64 = f64::from_bits(0x3ec7_1de3_57b1_fe7d);
const S5: f64 = f64::from_bits(0xbe5a_e5e6_8a2b_9ceb);
const S6: f64 = f64::from_bits(0x3de5_d93a_5acf_d57c);

/// `cos x = 1 - x^2/2 + C1 x^4 + ... + C6 x^14` on [-pi/4, pi/4].
const C1: f64 = f64::from_bits(0x3fa5_5555_5555_554c);
const C2: f64 = f64::from_bits(0xbf56_c16c_16c1_5177);
const C3: f64 = f64::from_bits(0x3efa_01a0_19cb_1590);
const C4: f64 = f64::from_bits(0xbe92_7e4f_809c_52ad);
const C5: f64 = f64::from_bits(0x3e21_ee9e_bdb4_b1c4);
const C6: f64 = f64::from_bits(0xbda8_fae9_be88_38d4);

fn high_word(x: f64) -> u32 {
    ((x.to_bits() >> 32) as u32) & 0x7fff_ffff
}

/// `(sin x, cos x)`, within a unit in the last place of the library's `x.sin_cos()`.
#[inline]
pub(crate) fn sin_cos(x: f64) -> (f64, f64) {
    let ix = high_word(x);
    if ix <= PIO4_HIGH_WORD {
        if ix < TINY_HIGH_WORD {
            return (x, 1.0);
        }
        return (kernel_sin(x, 0.0, false), kernel_cos(x, 0.0));
    }
    if ix >= MEDIUM_LIMIT_HIGH_WORD {
        // Large, infinite or NaN: the library's reduction.
        return x.sin_cos();
    }
    let (n, y0, y1) = reduce_medium(x, ix);
    let (s, c) = (kernel_sin(y0, y1, true), kernel_cos(y0, y1));
    match n & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// `x = n pi/2 + (y0 + y1)` with `|y0 + y1| <= pi/4` (to rounding), for `|x| < 2^20 pi/2`
/// whose upper word is `ix`: fdlibm's `__rem_pio2` for medium arguments.
#[inline]
fn reduce_medium(x: f64, ix: u32) -> (i32, f64, f64) {
    let pio4 = std::f64::consts::FRAC_PI_4;
    let mut n_f = x * INV_PIO2 + TO_INT - TO_INT;
    let mut r = x - n_f * PIO2_1;
    let mut w = n_f * PIO2_1T;
    // Only with directed rounding can the rounded quotient be off by one; kept for fidelity.
    if r - w < -pio4 {
        n_f -= 1.0;
        r = x - n_f * PIO2_1;
        w = n_f * PIO2_1T;
    } else if r - w > pio4 {
        n_f += 1.0;
        r = x - n_f * PIO2_1;
        w = n_f * PIO2_1T;
    }
    let n = n_f as i32;
    let mut y0 = r - w;
    let ex = (ix >> 20) as i32;
    let exponent = |v: f64| ((v.to_bits() >> 52) & 0x7ff) as i32;
    if ex - exponent(y0) > 16 {
        // Cancellation: a second round, good to 118 bits.
        let t = r;
        w = n_f * PIO2_2;
        r = t - w;
        w = n_f * PIO2_2T - ((t - r) - w);
        y0 = r - w;
        if ex - exponent(y0) > 49 {
            // A third, good to 151 bits: enough for every double.
            let t = r;
            w = n_f * PIO2_3;
            r = t - w;
            w = n_f * PIO2_3T - ((t - r) - w);
            y0 = r - w;
        }
    }
    let y1 = (r - y0) - w;
    (n, y0, y1)
}

/// `sin(x + y)` for `|x| <= pi/4`, `y` the tail of the reduced argument (used when `tail`).
#[inline]
fn kernel_sin(x: f64, y: f64, tail: bool) -> f64 {
    let z = x * x;
    let w = z * z;
    let r = S2 + z * (S3 + z * S4) + z * w * (S5 + z * S6);
    let v = z * x;
    if tail {
        x - ((z * (0.5 * y - v * r) - y) - v * S1)
    } else {
        x + v * (S1 + z * r)
    }
}

/// `cos(x + y)` for `|x| <= pi/4`, `y` the tail of the reduced argument.
#[inline]
fn kernel_cos(x: f64, y: f64) -> f64 {
    let z = x * x;
    let w = z * z;
    let r = z * (C1 + z * (C2 + z * C3)) + w * w * (C4 + z * (C5 + z * C6));
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    w + (((1.0 - w) - hz) + (z * r - x * y))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units in the last place of the larger magnitude.
    fn ulps(a: f64, b: f64) -> f64 {
        let scale = a.abs().max(b.abs()).max(f64::MIN_POSITIVE);
        (a - b).abs() / (scale * f64::EPSILON)
    }

    /// The largest distance from the library seen, and how many results were its bits.
    #[derive(Default)]
    struct Tally {
        worst_ulps: f64,
        equal: usize,
        all: usize,
    }

    impl Tally {
        fn check(&mut self, x: f64) {
            let (s, c) = sin_cos(x);
            let (rs, rc) = x.sin_cos();
            let e = ulps(s, rs).max(ulps(c, rc));
            assert!(e <= 1.0, "sin_cos({x:e}) = ({s:e}, {c:e}), library ({rs:e}, {rc:e}): {e} ulp");
            self.worst_ulps = self.worst_ulps.max(e);
            self.all += 1;
            self.equal += usize::from(s.to_bits() == rs.to_bits() && c.to_bits() == rc.to_bits());
        }
    }

    #[test]
    fn sin_cos_is_within_one_ulp_of_the_library_and_mostly_equal_to_it() {
        let mut tally = Tally::default();
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut uniform = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for scale in [1e-9, 0.5, 1.0, 4.0, 10.0, 1e3, 1e5, 1.6e6, 1e7, 1e300] {
            for _ in 0..20_000 {
                tally.check(scale * (2.0 * uniform() - 1.0));
            }
        }
        // Near multiples of pi/2, where the reduction cancels most of the argument.
        for n in (1..2_000_000i64).step_by(997).chain(1..64) {
            let near = n as f64 * std::f64::consts::FRAC_PI_2;
            for k in -3i64..=3 {
                let x = f64::from_bits((near.to_bits() as i64 + k) as u64);
                tally.check(x);
                tally.check(-x);
            }
        }
        // The edges of the branches.
        for x in [
            0.0,
            -0.0,
            1e-300,
            f64::MIN_POSITIVE,
            std::f64::consts::FRAC_PI_4,
            f64::from_bits(std::f64::consts::FRAC_PI_4.to_bits() + 1),
            2.0f64.powi(-27),
        ] {
            tally.check(x);
        }
        assert!(sin_cos(f64::NAN).0.is_nan() && sin_cos(f64::INFINITY).1.is_nan());
        // Both are accurate to within a unit in the last place, so they mostly agree exactly
        // (96 % of these arguments when this was written).
        assert!(tally.equal as f64 > 0.9 * tally.all as f64, "{} of {} equal", tally.equal, tally.all);
        eprintln!("worst {} ulp; {} of {} equal to the library", tally.worst_ulps, tally.equal, tally.all);
    }
}
