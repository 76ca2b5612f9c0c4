//! The checks a restored FMU state passes before any of it is used: every variable value finite
//! and, for what a master may set (parameters and inputs), inside its declared range; and every
//! floating-point number of the model's own part finite, found by walking its serde form.

use serde::ser::{self, Serialize};

use crate::variables::{Causality, Kind, Values, VariableSet};

/// Why restored variable values cannot be used: a value that is not finite, or a parameter or
/// input outside what a master could have set.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CheckError {
    #[error("'{name}' = {value} is not finite")]
    NotFinite { name: &'static str, value: f64 },
    #[error("'{name}' = {value:e} is subnormal")]
    Subnormal { name: &'static str, value: f64 },
    #[error("'{name}' = {value} {unit} is outside its declared range [{}, {}]", real_bound(*.min, "-inf"), real_bound(*.max, "inf"))]
    OutOfRange { name: &'static str, value: f64, unit: &'static str, min: Option<f64>, max: Option<f64> },
    #[error("'{name}' = {value} is outside its declared range")]
    IntegerOutOfRange { name: &'static str, value: i32 },
    #[error("'{name}' = {value} is not an item of {type_name}")]
    NotAnItem { name: &'static str, value: i32, type_name: &'static str },
}

/// A Real bound as the messages show it, `-inf` or `inf` when there is none.
fn real_bound(bound: Option<f64>, none: &str) -> String {
    bound.map_or(none.into(), |v| v.to_string())
}

/// Every Real finite; parameters and inputs inside their declared ranges (Integers and
/// enumerations included).
pub fn check_values<V: VariableSet>(values: &Values<V>) -> Result<(), CheckError> {
    for (index, var) in V::TABLE.iter().enumerate() {
        let settable = matches!(var.causality, Causality::Parameter | Causality::Input);
        let typed = V::from_index(index).expect("index from the table");
        let name = var.name;
        match var.kind {
            Kind::Real { min, max, unit, .. } => {
                let value = values.real(typed);
                if !value.is_finite() {
                    return Err(CheckError::NotFinite { name, value });
                }
                if settable && crate::variables::is_subnormal(value) {
                    return Err(CheckError::Subnormal { name, value });
                }
                if settable && (min.is_some_and(|lo| value < lo) || max.is_some_and(|hi| value > hi)) {
                    return Err(CheckError::OutOfRange { name, value, unit, min, max });
                }
            }
            Kind::Integer { min, max, .. } if settable => {
                let value = values.integer(typed);
                if min.is_some_and(|lo| value < lo) || max.is_some_and(|hi| value > hi) {
                    return Err(CheckError::IntegerOutOfRange { name, value });
                }
            }
            Kind::Enumeration { declared_type, .. } => {
                let value = values.integer(typed);
                if declared_type.name_of(value).is_none() {
                    return Err(CheckError::NotAnItem { name, value, type_name: declared_type.name });
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Every `f32`/`f64` in `value`'s serde form is finite; the error names the path to the first
/// that is not (`cascade.velocity_loop.integral[1]`).
pub fn check_finite_numbers<T: Serialize + ?Sized>(value: &T) -> Result<(), NumberError> {
    let mut walker = FiniteWalker { path: Vec::new() };
    value.serialize(&mut walker)
}

/// Why a model's state is not all finite numbers.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NumberError {
    /// The number at `path` (`the value` for the top level) is NaN or infinite.
    #[error("{path} = {value} is not finite")]
    NotFinite { path: String, value: f64 },
    /// The state's own serialisation failed, with serde's message.
    #[error("{0}")]
    Serialize(String),
}

impl ser::Error for NumberError {
    fn custom<T: std::fmt::Display>(msg: T) -> Self {
        NumberError::Serialize(msg.to_string())
    }
}

/// A serde serializer that writes nothing and only looks at the numbers.
struct FiniteWalker {
    path: Vec<String>,
}

impl FiniteWalker {
    fn number(&self, x: f64) -> Result<(), NumberError> {
        if x.is_finite() {
            Ok(())
        } else {
            let path = if self.path.is_empty() { "the value".to_string() } else { self.path.join("") };
            Err(NumberError::NotFinite { path, value: x })
        }
    }

    fn nested<T: Serialize + ?Sized>(&mut self, segment: String, value: &T) -> Result<(), NumberError> {
        self.path.push(segment);
        let result = value.serialize(&mut *self);
        self.path.pop();
        result
    }
}

macro_rules! ignore_scalars {
    ($($method:ident($ty:ty)),*) => {
        $(fn $method(self, _v: $ty) -> Result<(), NumberError> { Ok(()) })*
    };
}

impl<'a> ser::Serializer for &'a mut FiniteWalker {
    type Ok = ();
    type Error = NumberError;
    type SerializeSeq = Compound<'a>;
    type SerializeTuple = Compound<'a>;
    type SerializeTupleStruct = Compound<'a>;
    type SerializeTupleVariant = Compound<'a>;
    type SerializeMap = Compound<'a>;
    type SerializeStruct = Compound<'a>;
    type SerializeStructVariant = Compound<'a>;

    ignore_scalars!(
        serialize_bool(bool),
        serialize_i8(i8),
        serialize_i16(i16),
        serialize_i32(i32),
        serialize_i64(i64),
        serialize_i128(i128),
        serialize_u8(u8),
        serialize_u16(u16),
        serialize_u32(u32),
        serialize_u64(u64),
        serialize_u128(u128),
        serialize_char(char),
        serialize_str(&str),
        serialize_bytes(&[u8])
    );

    fn serialize_f32(self, v: f32) -> Result<(), NumberError> {
        self.number(f64::from(v))
    }
    fn serialize_f64(self, v: f64) -> Result<(), NumberError> {
        self.number(v)
    }
    fn serialize_none(self) -> Result<(), NumberError> {
        Ok(())
    }
    fn serialize_some<T: Serialize + ?Sized>(self, value: &T) -> Result<(), NumberError> {
        value.serialize(self)
    }
    fn serialize_unit(self) -> Result<(), NumberError> {
        Ok(())
    }
    fn serialize_unit_struct(self, _name: &'static str) -> Result<(), NumberError> {
        Ok(())
    }
    fn serialize_unit_variant(
        self,
        _name: &'static str,
        _index: u32,
        _variant: &'static str,
    ) -> Result<(), NumberError> {
        Ok(())
    }
    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        _name: &'static str,
        value: &T,
    ) -> Result<(), NumberError> {
        value.serialize(self)
    }
    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        _name: &'static str,
        _index: u32,
        variant: &'static str,
        value: &T,
    ) -> Result<(), NumberError> {
        self.nested(format!("::{variant}"), value)
    }
    fn serialize_seq(self, _len: Option<usize>) -> Result<Compound<'a>, NumberError> {
        Ok(Compound { walker: self, index: 0 })
    }
    fn serialize_tuple(self, _len: usize) -> Result<Compound<'a>, NumberError> {
        Ok(Compound { walker: self, index: 0 })
    }
    fn serialize_tuple_struct(self, _name: &'static str, _len: usize) -> Result<Compound<'a>, NumberError> {
        Ok(Compound { walker: self, index: 0 })
    }
    fn serialize_tuple_variant(
        self,
        _name: &'static str,
        _index: u32,
        _variant: &'static str,
        _len: usize,
    ) -> Result<Compound<'a>, NumberError> {
        Ok(Compound { walker: self, index: 0 })
    }
    fn serialize_map(self, _len: Option<usize>) -> Result<Compound<'a>, NumberError> {
        Ok(Compound { walker: self, index: 0 })
    }
    fn serialize_struct(self, _name: &'static str, _len: usize) -> Result<Compound<'a>, NumberError> {
        Ok(Compound { walker: self, index: 0 })
    }
    fn serialize_struct_variant(
        self,
        _name: &'static str,
        _index: u32,
        _variant: &'static str,
        _len: usize,
    ) -> Result<Compound<'a>, NumberError> {
        Ok(Compound { walker: self, index: 0 })
    }
}

/// The walker inside a sequence, tuple, map or struct, counting elements for the path.
struct Compound<'a> {
    walker: &'a mut FiniteWalker,
    index: usize,
}

impl Compound<'_> {
    fn element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), NumberError> {
        let segment = format!("[{}]", self.index);
        self.index += 1;
        self.walker.nested(segment, value)
    }
}

impl ser::SerializeSeq for Compound<'_> {
    type Ok = ();
    type Error = NumberError;
    fn serialize_element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), NumberError> {
        self.element(value)
    }
    fn end(self) -> Result<(), NumberError> {
        Ok(())
    }
}

impl ser::SerializeTuple for Compound<'_> {
    type Ok = ();
    type Error = NumberError;
    fn serialize_element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), NumberError> {
        self.element(value)
    }
    fn end(self) -> Result<(), NumberError> {
        Ok(())
    }
}

impl ser::SerializeTupleStruct for Compound<'_> {
    type Ok = ();
    type Error = NumberError;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), NumberError> {
        self.element(value)
    }
    fn end(self) -> Result<(), NumberError> {
        Ok(())
    }
}

impl ser::SerializeTupleVariant for Compound<'_> {
    type Ok = ();
    type Error = NumberError;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), NumberError> {
        self.element(value)
    }
    fn end(self) -> Result<(), NumberError> {
        Ok(())
    }
}

impl ser::SerializeMap for Compound<'_> {
    type Ok = ();
    type Error = NumberError;
    fn serialize_key<T: Serialize + ?Sized>(&mut self, key: &T) -> Result<(), NumberError> {
        self.element(key)
    }
    fn serialize_value<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), NumberError> {
        self.element(value)
    }
    fn end(self) -> Result<(), NumberError> {
        Ok(())
    }
}

impl ser::SerializeStruct for Compound<'_> {
    type Ok = ();
    type Error = NumberError;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, key: &'static str, value: &T) -> Result<(), NumberError> {
        self.walker.nested(format!(".{key}"), value)
    }
    fn end(self) -> Result<(), NumberError> {
        Ok(())
    }
}

impl ser::SerializeStructVariant for Compound<'_> {
    type Ok = ();
    type Error = NumberError;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, key: &'static str, value: &T) -> Result<(), NumberError> {
        self.walker.nested(format!(".{key}"), value)
    }
    fn end(self) -> Result<(), NumberError> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Serialize)]
    struct Inner {
        x: [f64; 2],
    }

    #[derive(serde::Serialize)]
    struct Outer {
        n: u64,
        inner: Option<Inner>,
        list: Vec<(u64, f64)>,
    }

    #[test]
    fn the_first_non_finite_number_is_named_by_its_path() {
        let fine = Outer { n: 3, inner: Some(Inner { x: [1.0, 2.0] }), list: vec![(1, 0.5)] };
        assert!(check_finite_numbers(&fine).is_ok());
        let bad = Outer { n: 3, inner: Some(Inner { x: [1.0, f64::NAN] }), list: vec![] };
        assert_eq!(check_finite_numbers(&bad).unwrap_err().to_string(), ".inner.x[1] = NaN is not finite");
        let bad = Outer { n: 3, inner: None, list: vec![(1, 0.5), (2, f64::INFINITY)] };
        assert_eq!(check_finite_numbers(&bad).unwrap_err().to_string(), ".list[1][1] = inf is not finite");
    }
}
