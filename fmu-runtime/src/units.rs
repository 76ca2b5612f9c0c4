//! The units the models use, with their SI base-unit exponents for `<UnitDefinitions>`.
//!
//! Every Real variable names one of these units; generating a model description with a unit
//! that is not listed here is an error, so a typo cannot reach a master silently.

/// Exponents of kg, m, s, A, K, mol, cd, rad, and the factor and offset to the SI base units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnitDefinition {
    pub name: &'static str,
    pub kg: i32,
    pub m: i32,
    pub s: i32,
    pub a: i32,
    pub rad: i32,
    pub factor: f64,
}

const fn unit(name: &'static str, kg: i32, m: i32, s: i32, a: i32, rad: i32, factor: f64) -> UnitDefinition {
    UnitDefinition { name, kg, m, s, a, rad, factor }
}

const DEG: f64 = std::f64::consts::PI / 180.0;

/// Known units. Angles are radians in SI; degrees and arcseconds are declared with their factor
/// so a master can convert.
pub const UNITS: &[UnitDefinition] = &[
    unit("1", 0, 0, 0, 0, 0, 1.0),
    unit("s", 0, 0, 1, 0, 0, 1.0),
    unit("Hz", 0, 0, -1, 0, 0, 1.0),
    unit("m", 0, 1, 0, 0, 0, 1.0),
    unit("m/s", 0, 1, -1, 0, 0, 1.0),
    unit("m2", 0, 2, 0, 0, 0, 1.0),
    unit("kg", 1, 0, 0, 0, 0, 1.0),
    unit("kg/m3", 1, -3, 0, 0, 0, 1.0),
    unit("N", 1, 1, -2, 0, 0, 1.0),
    unit("N/m", 1, 0, -2, 0, 0, 1.0),
    unit("N.s/m", 1, 0, -1, 0, 0, 1.0),
    unit("A", 0, 0, 0, 1, 0, 1.0),
    unit("rad", 0, 0, 0, 0, 1, 1.0),
    unit("deg", 0, 0, 0, 0, 1, DEG),
    unit("arcsec", 0, 0, 0, 0, 1, DEG / 3600.0),
    unit("rad/s", 0, 0, -1, 0, 1, 1.0),
    unit("deg/s", 0, 0, -1, 0, 1, DEG),
    unit("rad/s2", 0, 0, -2, 0, 1, 1.0),
    unit("deg/s2", 0, 0, -2, 0, 1, DEG),
    unit("deg/s3", 0, 0, -3, 0, 1, DEG),
    unit("rpm", 0, 0, -1, 0, 1, 2.0 * std::f64::consts::PI / 60.0),
    unit("N.m", 1, 2, -2, 0, 0, 1.0),
    unit("N.m/A", 1, 2, -2, -1, 0, 1.0),
    unit("N.m/rad", 1, 2, -2, 0, -1, 1.0),
    unit("N.m.s/rad", 1, 2, -1, 0, -1, 1.0),
    unit("N.m.s2/rad", 1, 2, 0, 0, -1, 1.0),
    unit("kg.m2", 1, 2, 0, 0, 0, 1.0),
    unit("A/(rad/s)", 0, 0, 1, 1, -1, 1.0),
    unit("A/rad", 0, 0, 0, 1, -1, 1.0),
    unit("A.s/rad", 0, 0, 1, 1, -1, 1.0),
    unit("1/s", 0, 0, -1, 0, 0, 1.0),
    unit("rad/(s.A)", 0, 0, -1, -1, 1, 1.0),
];

pub fn lookup(name: &str) -> Option<&'static UnitDefinition> {
    UNITS.iter().find(|u| u.name == name)
}
