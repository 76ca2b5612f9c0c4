//! Finite-value checks. A NaN or an infinity in a log, a parameter or an intermediate result
//! compares false with every threshold, so a test on it silently says "not significant": the
//! validation would report "no significant missing effect" on data it could not use. Every
//! stage therefore checks what it takes in and what it hands on, and a non-finite value is an
//! error that names where it appeared.

use crate::parameters::ParameterSet;

/// A NaN or an infinity, with where it appeared.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NonFinite {
    /// A logged signal (log sample index, from 0).
    #[error("the log's {signal} is {value} at sample {sample}")]
    Signal { signal: String, sample: usize, value: f64 },
    /// A parameter of the set being validated or fitted.
    #[error("parameter {name} is {value}")]
    Parameter { name: String, value: f64 },
    /// A computed quantity; its inputs were finite, so a value out of range overflowed it.
    #[error("{quantity} is {value} {location} (the log and the parameters are finite: a value out of range overflows the computation)")]
    Result { quantity: String, location: String, value: f64 },
}

/// The first sample that is not finite, with its value.
pub fn first_non_finite(values: &[f64]) -> Option<(usize, f64)> {
    values.iter().copied().enumerate().find(|(_, v)| !v.is_finite())
}

/// Checks a logged signal.
pub fn check_signal(signal: &str, values: &[f64]) -> Result<(), NonFinite> {
    match first_non_finite(values) {
        Some((sample, value)) => Err(NonFinite::Signal { signal: signal.to_string(), sample, value }),
        None => Ok(()),
    }
}

/// Checks every parameter of a set.
pub fn check_parameters(params: &ParameterSet) -> Result<(), NonFinite> {
    match params.names().map(|name| (name, params.value(name))).find(|(_, v)| !v.is_finite()) {
        Some((name, value)) => Err(NonFinite::Parameter { name: name.to_string(), value }),
        None => Ok(()),
    }
}

/// Checks a computed series; `location` turns the index of the first bad value into words.
pub fn check_series(quantity: &str, values: &[f64], location: impl Fn(usize) -> String) -> Result<(), NonFinite> {
    match first_non_finite(values) {
        Some((index, value)) => {
            Err(NonFinite::Result { quantity: quantity.to_string(), location: location(index), value })
        }
        None => Ok(()),
    }
}

/// Checks one computed value.
pub fn check_value(quantity: &str, value: f64, location: &str) -> Result<(), NonFinite> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(NonFinite::Result { quantity: quantity.to_string(), location: location.to_string(), value })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_non_finite_sample_is_named_with_its_index() {
        let error = check_signal("motor torque", &[1.0, 2.0, f64::NAN, f64::INFINITY]).unwrap_err();
        assert!(
            matches!(&error, NonFinite::Signal { signal, sample: 2, value } if signal == "motor torque" && value.is_nan())
        );
        assert!(error.to_string().contains("motor torque is NaN at sample 2"), "{error}");
        assert!(check_signal("x", &[0.0, -1e308]).is_ok());
    }

    #[test]
    fn an_infinite_result_names_the_quantity_and_where() {
        let error =
            check_series("the model side", &[0.0, f64::NEG_INFINITY], |i| format!("at sample {i}")).unwrap_err();
        let text = error.to_string();
        assert!(text.starts_with("the model side is -inf at sample 1"), "{text}");
    }
}
