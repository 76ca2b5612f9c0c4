//! `floor` and `ceil` without the library call, for the encoders, the parameter cells and the
//! integrator's sub-step count, which pay for them at every step.

/// `x.floor()`, the same result for every `f64`, without the library call. The baseline
/// x86-64 target has no rounding instruction (SSE4.1), so `f64::floor` is a software routine
/// of about 25 instructions, paid at every step by the encoders and the parameter cells. Below
/// 2^52 in magnitude a truncating cast to `i64` is exact, and floor is the truncation, or one
/// less for a negative non-integer; larger numbers, infinities and NaN are already integral
/// (or NaN) and come back unchanged. Integers, `-0.0` included, are returned as they are.
#[inline]
pub(crate) fn floor(x: f64) -> f64 {
    if x.is_nan() || x.abs() >= 4_503_599_627_370_496.0 {
        return x;
    }
    let truncated = x as i64 as f64;
    if truncated == x {
        x
    } else if truncated > x {
        truncated - 1.0
    } else {
        truncated
    }
}

/// `x.ceil()`, the same result for every `f64` (NaN apart, whose sign may differ), without the
/// library call: `ceil x = -floor(-x)` exactly, negation being exact and `-0.0` coming out
/// where the library's gives it.
#[inline]
pub(crate) fn ceil(x: f64) -> f64 {
    -floor(-x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn branch_free_floor_and_ceil_give_the_library_results_bit_for_bit() {
        let mut samples =
            vec![0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 1.5, -1.5, 2.0f64.powi(52) - 0.5, -(2.0f64.powi(52) - 0.5)];
        samples.extend([
            2.0f64.powi(52),
            -(2.0f64.powi(52)),
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
        ]);
        samples.extend([
            f64::EPSILON,
            -f64::EPSILON,
            1.0 - f64::EPSILON / 2.0,
            -(1.0 - f64::EPSILON / 2.0),
            1.0 + f64::EPSILON,
            -1.0 - f64::EPSILON,
        ]);
        let mut x = 0x1234_5678_9abc_def0u64;
        for _ in 0..100_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let value = f64::from_bits(x);
            samples.push(value);
            // Also angles in encoder counts, where the plants use it.
            samples.push((x >> 11) as f64 / (1u64 << 40) as f64 * if x & 1 == 0 { 1.0 } else { -1.0 });
        }
        for value in samples {
            for (name, got, expected) in [("floor", floor(value), value.floor()), ("ceil", ceil(value), value.ceil())] {
                assert!(
                    got.to_bits() == expected.to_bits() || (got.is_nan() && expected.is_nan()),
                    "{name}({value:e}) = {got:e}, expected {expected:e}"
                );
            }
        }
    }
}
