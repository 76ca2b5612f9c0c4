//! The modes file: the structure's modes with their frequency, damping, modal stiffness and
//! participation factors, in the project's `name = value` format (read by
//! `fmu_runtime::params`), and the static compliance they imply.
//!
//! A mode `k` with coordinate `q_k` obeys
//! `(1 / w_k^2) q_k'' + (2 zeta_k / w_k) q_k' + q_k = (p . u) / K_k`
//! with `w_k = 2 pi f_k` and `u` the six loads of [`LOADS`] (the torques about the axes, the
//! drag whatever its direction, and the wind force resolved in the antenna's frame), and moves
//! the beam by `b_az q_k` (on-sky azimuth) and `b_el q_k` (elevation). The scale of `q_k` is free (a finite-element export with mass-normalised mode
//! shapes gives `K_k = w_k^2` and the mode-shape values as `p` and `b`); the static compliance
//! from a load to a beam offset, `b p / K` summed over the modes, does not depend on it.

use std::path::Path;

use fmu_runtime::files::FileError;
use fmu_runtime::params::{self, ParameterValue, ParamsError};

/// The modes file shipped in the FMU's resources, also built in so that the FMU works without
/// a resources folder.
pub const DEFAULT_MODES: &str = include_str!("../resources/structure_modes.params");

/// Its file name in the resources folder.
pub const DEFAULT_MODES_FILE: &str = "structure_modes.params";

/// The fields of a mode, in file order: frequency (Hz), damping ratio (1), modal stiffness (N m
/// per unit of the modal coordinate), the participations of the azimuth torque, the elevation
/// torque (modal load per N m) and the dish force (per N), the beam offsets (rad, on-sky
/// azimuth and elevation) per unit of the modal coordinate, and the participations of the
/// wind force resolved in the antenna's frame (per N: axial, lateral, lift), and the frequency
/// at the horizon (Hz) of a mode whose frequency changes with elevation, and the beam's rotation
/// about the azimuth axis (rad) per unit of the modal coordinate, which moves the beam on the
/// sky by that angle times cos(elevation). The first
/// [`REQUIRED_FIELDS`] are required; the others came later and are optional, so that a modes
/// file written before them reads as it did: the resolved forces' participations default to
/// zero, the horizon frequency to the frequency (a mode that does not change with elevation),
/// the rotation about the azimuth axis to zero.
pub const FIELDS: [&str; 13] = [
    "frequency",
    "damping",
    "stiffness",
    "azimuth_torque",
    "elevation_torque",
    "dish_force",
    "beam_azimuth",
    "beam_elevation",
    "axial_force",
    "lateral_force",
    "lift_force",
    "horizon_frequency",
    "beam_azimuth_rotation",
];

/// The index of `beam_azimuth_rotation` in [`FIELDS`].
const BEAM_AZIMUTH_ROTATION: usize = 12;

/// The index of `horizon_frequency` in [`FIELDS`].
const HORIZON_FREQUENCY: usize = 11;

/// How many of [`FIELDS`], from the first, every mode must give.
pub const REQUIRED_FIELDS: usize = 8;

/// The loads a mode takes, in the order of [`Mode::participation`]: torque about azimuth and
/// about elevation (N m), the drag on the dish along the wind whatever its direction (N), and
/// the wind force on the dish resolved in the antenna's frame (N): axial (along the horizontal
/// projection of the boresight, positive from the dish's face towards its back), lateral
/// (horizontal, positive towards increasing azimuth) and lift (vertical, positive up).
pub const LOADS: usize = 6;

/// A modes file with more modes is refused: the FMU discretises each mode on every new step
/// size, and thousands of modes would be an error in the file, not a structure.
pub const MAX_MODES: usize = 1000;

/// One structural mode.
#[derive(Debug, Clone, PartialEq)]
pub struct Mode {
    /// Undamped natural frequency, Hz: at the zenith (elevation 90 deg) for a mode with a
    /// [`horizon_frequency_hz`](Self::horizon_frequency_hz), at every elevation otherwise.
    pub frequency_hz: f64,
    /// Undamped natural frequency with the dish at the horizon (elevation 0), Hz, for a mode
    /// whose frequency changes with elevation; `None` for one that does not. Its stiffness
    /// stays, and the inertia its moving part carries, `K / w^2`, turns between the zenith's and
    /// the horizon's as a rigid body's inertia about the vertical axis does when it tips about
    /// the elevation axis: `J(el) = J_horizon cos^2(el) + J_zenith sin^2(el)`, so
    /// `1 / f(el)^2 = cos^2(el) / f_horizon^2 + sin^2(el) / f_zenith^2`
    /// ([`Self::frequency_at`]).
    pub horizon_frequency_hz: Option<f64>,
    /// Damping ratio (fraction of critical).
    pub damping_ratio: f64,
    /// Modal stiffness K: the load on the modal coordinate per unit of it.
    pub stiffness: f64,
    /// Modal load per unit of each load of [`LOADS`]: azimuth torque (N m), elevation torque
    /// (N m), dish force (N), axial, lateral and lift force (N).
    pub participation: [f64; LOADS],
    /// Beam offset (rad) per unit of the modal coordinate: on-sky azimuth (cross-elevation),
    /// elevation. What a finite-element model's beam sensitivity gives directly.
    pub beam: [f64; 2],
    /// Rotation of the beam about the azimuth axis (rad) per unit of the modal coordinate: a
    /// twist of the azimuth structure. On the sky it moves the beam by the angle times
    /// cos(elevation), none at the zenith ([`Self::beam_on_sky`]).
    pub beam_azimuth_rotation: f64,
}

impl Mode {
    /// Beam offset on the sky (rad; cross-elevation, elevation) per unit of the modal
    /// coordinate, with the dish at an elevation whose cosine is `cos_elevation`: the on-sky
    /// offset plus the rotation about the azimuth axis projected on the sky.
    pub fn beam_on_sky(&self, cos_elevation: f64) -> [f64; 2] {
        [self.beam[0] + self.beam_azimuth_rotation * cos_elevation, self.beam[1]]
    }

    /// Angular frequency, rad/s (at the zenith for a mode that changes with elevation: the
    /// structure steps [`Self::at_elevation`]).
    pub fn omega(&self) -> f64 {
        2.0 * std::f64::consts::PI * self.frequency_hz
    }

    /// Whether the mode's frequency changes with elevation.
    pub fn varies_with_elevation(&self) -> bool {
        self.horizon_frequency_hz.is_some_and(|h| h != self.frequency_hz)
    }

    /// The undamped natural frequency at an elevation, Hz: `1 / f^2 = cos^2(el) / f_horizon^2 +
    /// sin^2(el) / f_zenith^2` (the modal inertia `K / w^2` as a rigid body's about the vertical
    /// axis); exactly `frequency_hz` for a mode that does not change with elevation.
    pub fn frequency_at(&self, elevation_deg: f64) -> f64 {
        match self.horizon_frequency_hz {
            Some(horizon) if horizon != self.frequency_hz => {
                let (s, c) = elevation_deg.to_radians().sin_cos();
                1.0 / (c * c / (horizon * horizon) + s * s / (self.frequency_hz * self.frequency_hz)).sqrt()
            }
            _ => self.frequency_hz,
        }
    }

    /// The mode as it is at an elevation: its frequency there, the rest unchanged (a mode that
    /// does not change with elevation is returned as it is).
    pub fn at_elevation(&self, elevation_deg: f64) -> Mode {
        if !self.varies_with_elevation() {
            return self.clone();
        }
        Mode { frequency_hz: self.frequency_at(elevation_deg), horizon_frequency_hz: None, ..self.clone() }
    }

    /// The modal load (in units of the modal coordinate times K) for the given loads.
    ///
    /// The three resolved forces are added only where the mode takes them: a zero participation
    /// times a load is a signed zero, which could flip the sign of a zero modal load, and the
    /// modes written before those forces existed must give the same bits as they did.
    pub fn modal_load(&self, loads: &[f64; LOADS]) -> f64 {
        let first: f64 = self.participation[..3].iter().zip(&loads[..3]).map(|(p, u)| p * u).sum();
        let resolved = [self.participation[3], self.participation[4], self.participation[5]];
        // Most modes take none of them (the shipped ones): one test, at every step.
        if resolved == [0.0; 3] {
            return first;
        }
        resolved.iter().zip(&loads[3..]).filter(|(p, _)| **p != 0.0).fold(first, |sum, (p, u)| sum + p * u)
    }

    /// The modal load of the axes' angular accelerations (rad/s^2, azimuth and elevation): the
    /// inertia of the mode's moving part resisting them, `-(K / w^2) (p_az a_az + p_el a_el)`. A
    /// mode's modal mass `K / w^2` is carried by an axis through the same participation as a
    /// torque about it (one rigid outer body on the mode's spring: the dish and the elevation
    /// structure twisting against the gear). A constant acceleration `a` of an axis with
    /// participation 1 therefore deflects the coordinate by `-a / w^2`, whatever the stiffness.
    pub fn inertial_load(&self, accelerations: &[f64; 2]) -> f64 {
        -self.inertia() * (self.participation[0] * accelerations[0] + self.participation[1] * accelerations[1])
    }

    /// The modal mass `K / w^2`: the inertia of the mode's moving part per unit participation
    /// (at the zenith for a mode that changes with elevation).
    pub fn inertia(&self) -> f64 {
        let w = self.omega();
        self.stiffness / (w * w)
    }

    /// The modal mass with the dish at the horizon: [`Self::inertia`] at the horizon frequency
    /// (the same for a mode that does not change with elevation).
    pub fn horizon_inertia(&self) -> f64 {
        match self.horizon_frequency_hz {
            Some(horizon) => Mode { frequency_hz: horizon, ..self.clone() }.inertia(),
            None => self.inertia(),
        }
    }

    /// The static deflection of the modal coordinate under constant loads.
    pub fn static_coordinate(&self, loads: &[f64; LOADS]) -> f64 {
        self.modal_load(loads) / self.stiffness
    }
}

/// What is wrong with a modes file; every message names the file and, where there is one, the
/// line.
#[derive(Debug, thiserror::Error)]
pub enum ModesError {
    #[error("cannot read modes file {path}: {reason}")]
    Unreadable { path: String, reason: FileError },
    #[error("{0}")]
    Syntax(ParamsError),
    #[error("{origin}:{line}: `{name}` is not a mode field: expected mode<k>.<field> with k = 1, 2, ... and field one of {fields}")]
    UnknownName { origin: String, line: usize, name: String, fields: String },
    #[error("{origin}:{line}: `{name}` needs a number, the file gives {value}")]
    NotANumber { origin: String, line: usize, name: String, value: String },
    #[error("{origin}: no modes (expected lines such as `mode1.frequency = 6.0`)")]
    Empty { origin: String },
    #[error("{origin}:{line}: mode {mode} is beyond the {max} modes a modes file may hold")]
    TooMany { origin: String, line: usize, mode: usize, max: usize },
    #[error(
        "{origin}: mode {mode} is missing (modes are numbered 1, 2, ... without gaps; the file has mode {highest})"
    )]
    Gap { origin: String, mode: usize, highest: usize },
    #[error("{origin}: mode{mode}.{field} is missing (every mode needs {fields}; axial_force, lateral_force and lift_force default to 0, horizon_frequency to the frequency)")]
    MissingField { origin: String, mode: usize, field: &'static str, fields: String },
    #[error("{origin}:{line}: mode{mode}.{field} = {value}: {reason}")]
    Invalid { origin: String, line: usize, mode: usize, field: &'static str, value: f64, reason: &'static str },
}

fn field_list() -> String {
    FIELDS.join(", ")
}

fn required_field_list() -> String {
    FIELDS[..REQUIRED_FIELDS].join(", ")
}

/// Splits `mode<k>.<field>` into the mode number and the field's index in [`FIELDS`].
fn mode_field(name: &str) -> Option<(usize, usize)> {
    let (mode, field) = name.strip_prefix("mode")?.split_once('.')?;
    if mode.is_empty() || !mode.bytes().all(|b| b.is_ascii_digit()) || mode.starts_with('0') {
        return None;
    }
    let mode: usize = mode.parse().ok()?;
    let field = FIELDS.iter().position(|f| *f == field)?;
    Some((mode, field))
}

/// A value as read: the number and its line.
type Slot = Option<(f64, usize)>;

/// Reads a modes file's text; `origin` names it in the errors.
pub fn parse_modes(text: &str, origin: &str) -> Result<Vec<Mode>, ModesError> {
    let assignments = params::parse(text, origin).map_err(ModesError::Syntax)?;
    let mut slots: Vec<[Slot; FIELDS.len()]> = Vec::new();
    for a in &assignments {
        let unknown = || ModesError::UnknownName {
            origin: origin.into(),
            line: a.line,
            name: a.name.clone(),
            fields: field_list(),
        };
        let (mode, field) = mode_field(&a.name).ok_or_else(unknown)?;
        if mode > MAX_MODES {
            return Err(ModesError::TooMany { origin: origin.into(), line: a.line, mode, max: MAX_MODES });
        }
        let ParameterValue::Number(value) = a.value else {
            return Err(ModesError::NotANumber {
                origin: origin.into(),
                line: a.line,
                name: a.name.clone(),
                value: a.value.to_string(),
            });
        };
        if slots.len() < mode {
            slots.resize(mode, [None; FIELDS.len()]);
        }
        slots[mode - 1][field] = Some((value, a.line));
    }
    if slots.is_empty() {
        return Err(ModesError::Empty { origin: origin.into() });
    }
    slots.iter().enumerate().map(|(index, fields)| mode_from_fields(origin, index + 1, fields, slots.len())).collect()
}

/// Checks one mode's fields and builds it.
fn mode_from_fields(
    origin: &str,
    mode: usize,
    fields: &[Slot; FIELDS.len()],
    highest: usize,
) -> Result<Mode, ModesError> {
    if fields.iter().all(Option::is_none) {
        return Err(ModesError::Gap { origin: origin.into(), mode, highest });
    }
    let mut values = [0.0; FIELDS.len()];
    for (i, slot) in fields.iter().enumerate() {
        values[i] = match slot {
            Some((value, _)) => *value,
            None if i >= REQUIRED_FIELDS => 0.0,
            None => {
                return Err(ModesError::MissingField {
                    origin: origin.into(),
                    mode,
                    field: FIELDS[i],
                    fields: required_field_list(),
                })
            }
        };
    }
    let invalid = |i: usize, reason| {
        let (value, line) = fields[i].expect("checked above");
        ModesError::Invalid { origin: origin.into(), line, mode, field: FIELDS[i], value, reason }
    };
    if values[0] <= 0.0 {
        return Err(invalid(0, "the frequency must be positive"));
    }
    if fields[HORIZON_FREQUENCY].is_some() && values[HORIZON_FREQUENCY] <= 0.0 {
        return Err(invalid(HORIZON_FREQUENCY, "the frequency at the horizon must be positive"));
    }
    if values[1] < 0.0 {
        return Err(invalid(1, "the damping ratio must not be negative"));
    }
    if values[2] <= 0.0 {
        return Err(invalid(2, "the modal stiffness must be positive"));
    }
    if values[3..6].iter().chain(&values[8..11]).all(|p| *p == 0.0) {
        return Err(invalid(
            3,
            "the mode takes no load (azimuth_torque, elevation_torque, dish_force, axial_force, lateral_force and lift_force are all zero)",
        ));
    }
    if values[6..8].iter().chain(&values[BEAM_AZIMUTH_ROTATION..]).all(|b| *b == 0.0) {
        return Err(invalid(
            6,
            "the mode does not move the beam (beam_azimuth, beam_elevation and beam_azimuth_rotation are all zero)",
        ));
    }
    // `dish_force` weighs the drag whatever its direction; `axial_force` and `lateral_force`
    // weigh the same drag resolved in the antenna's frame. A master connects both, so a mode
    // taking both would feel the drag twice.
    if values[5] != 0.0 {
        if let Some(i) = [8, 9].into_iter().find(|i| values[*i] != 0.0) {
            return Err(invalid(
                i,
                "a mode takes the drag either through dish_force (whatever its direction) or resolved through axial_force and lateral_force, not both (a master connects both, and the drag would count twice)",
            ));
        }
    }
    Ok(Mode {
        frequency_hz: values[0],
        horizon_frequency_hz: fields[HORIZON_FREQUENCY].map(|(value, _)| value),
        damping_ratio: values[1],
        stiffness: values[2],
        participation: [values[3], values[4], values[5], values[8], values[9], values[10]],
        beam: [values[6], values[7]],
        beam_azimuth_rotation: values[BEAM_AZIMUTH_ROTATION],
    })
}

/// The largest modes file read, bytes (1 MiB): [`MAX_MODES`] modes of twelve fields take about
/// 600 kB written out with comments.
pub const MAX_MODES_FILE_BYTES: u64 = 1 << 20;

/// Reads a modes file from disk: only a regular file of at most [`MAX_MODES_FILE_BYTES`]
/// (`fmu_runtime::files`), so that a FIFO or a device cannot block or flood the FMU.
pub fn read_modes(path: &Path) -> Result<Vec<Mode>, ModesError> {
    let text = fmu_runtime::files::read_regular_file(path, MAX_MODES_FILE_BYTES, "modes file")
        .map_err(|reason| ModesError::Unreadable { path: path.display().to_string(), reason })?;
    parse_modes(&text, &path.display().to_string())
}

/// The static compliance of a set of modes with the dish at an elevation whose cosine is
/// `cos_elevation`: beam offset (rad; on-sky cross-elevation, elevation) per unit of each load
/// of [`LOADS`] (azimuth torque N m, elevation torque N m, dish, axial, lateral and lift force N).
pub fn static_compliance(modes: &[Mode], cos_elevation: f64) -> [[f64; LOADS]; 2] {
    let mut compliance = [[0.0; LOADS]; 2];
    for mode in modes {
        for (row, b) in compliance.iter_mut().zip(mode.beam_on_sky(cos_elevation)) {
            for (entry, p) in row.iter_mut().zip(mode.participation) {
                *entry += b * p / mode.stiffness;
            }
        }
    }
    compliance
}

impl Mode {
    /// The value of one field (a name of [`FIELDS`]); the horizon frequency of a mode that
    /// does not change with elevation is its frequency.
    pub fn field(&self, field: &str) -> Option<f64> {
        Some(match FIELDS.iter().position(|f| *f == field)? {
            0 => self.frequency_hz,
            HORIZON_FREQUENCY => self.horizon_frequency_hz.unwrap_or(self.frequency_hz),
            BEAM_AZIMUTH_ROTATION => self.beam_azimuth_rotation,
            1 => self.damping_ratio,
            2 => self.stiffness,
            i @ 3..=5 => self.participation[i - 3],
            i @ 6..=7 => self.beam[i - 6],
            i => self.participation[i - 5],
        })
    }

    /// Sets one field (a name of [`FIELDS`]); `false` if there is no such field.
    pub fn set_field(&mut self, field: &str, value: f64) -> bool {
        let Some(index) = FIELDS.iter().position(|f| *f == field) else { return false };
        match index {
            0 => self.frequency_hz = value,
            HORIZON_FREQUENCY => self.horizon_frequency_hz = Some(value),
            BEAM_AZIMUTH_ROTATION => self.beam_azimuth_rotation = value,
            1 => self.damping_ratio = value,
            2 => self.stiffness = value,
            i @ 3..=5 => self.participation[i - 3] = value,
            i @ 6..=7 => self.beam[i - 6] = value,
            i => self.participation[i - 5] = value,
        }
        true
    }
}

/// A modes file holding `modes`, every value with all its digits, which [`parse_modes`] reads
/// back to the same modes (so that a master can hand a varied set to the FMU).
pub fn write_modes(modes: &[Mode], heading: &str) -> String {
    let mut text = String::new();
    for line in heading.lines() {
        text.push_str(&format!("# {line}\n"));
    }
    for (k, mode) in modes.iter().enumerate() {
        for field in FIELDS {
            // A mode that does not change with elevation is written without a horizon
            // frequency, so that it reads back as one (and a file of such modes as before).
            if field == FIELDS[HORIZON_FREQUENCY] && mode.horizon_frequency_hz.is_none() {
                continue;
            }
            let value = mode.field(field).expect("FIELDS names every field");
            text.push_str(&format!("mode{}.{field} = {value:e}\n", k + 1));
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_modes_read_back_to_the_same_modes() {
        let mut modes = parse_modes(DEFAULT_MODES, DEFAULT_MODES_FILE).unwrap();
        assert!(modes[1].set_field("frequency", 1.0 / 3.0));
        assert!(!modes[1].set_field("mass", 1.0));
        let text = write_modes(&modes, "varied\nfor a test");
        assert!(text.starts_with("# varied\n# for a test\n"));
        assert_eq!(parse_modes(&text, "written").unwrap(), modes);
    }

    #[test]
    fn the_default_file_has_one_six_hertz_mode_per_axis_with_stiffness_4e8() {
        let modes = parse_modes(DEFAULT_MODES, DEFAULT_MODES_FILE).unwrap();
        assert_eq!(modes.len(), 2);
        for mode in &modes {
            assert_eq!((mode.frequency_hz, mode.damping_ratio, mode.stiffness), (6.0, 0.015, 4e8));
        }
        // At the horizon the azimuth twist is all on the sky; at 60 deg half of it.
        let c = static_compliance(&modes, 1.0);
        assert_eq!(c, [[2.5e-9, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, 2.5e-9, 0.0, 0.0, 0.0, 0.0]]);
        let c = static_compliance(&modes, 0.5);
        assert_eq!(c, [[1.25e-9, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, 2.5e-9, 0.0, 0.0, 0.0, 0.0]]);
    }

    #[test]
    fn static_compliance_is_beam_times_participation_over_stiffness_whatever_the_modal_scale() {
        let mode = Mode {
            frequency_hz: 4.0,
            horizon_frequency_hz: None,
            damping_ratio: 0.01,
            stiffness: 2e8,
            participation: [0.5, -0.25, 3.0, 0.0, -1.5, 0.75],
            beam: [2.0, 1.0],
            beam_azimuth_rotation: 0.0,
        };
        // The same mode with its coordinate scaled by s: K / s^2, p / s, b / s.
        let s = 7.5;
        let scaled = Mode {
            stiffness: mode.stiffness / (s * s),
            participation: mode.participation.map(|p| p / s),
            beam: mode.beam.map(|b| b / s),
            ..mode.clone()
        };
        let (a, b) = (static_compliance(&[mode], 1.0), static_compliance(&[scaled], 1.0));
        assert!((a[0][2] - 2.0 * 3.0 / 2e8).abs() < 1e-22);
        assert!((a[1][4] + 1.0 * 1.5 / 2e8).abs() < 1e-22);
        for (ra, rb) in a.iter().zip(&b) {
            for (x, y) in ra.iter().zip(rb) {
                assert!((x - y).abs() <= 1e-15 * x.abs().max(1e-30), "{x} against {y}");
            }
        }
    }

    #[test]
    fn a_file_without_the_resolved_forces_reads_them_as_zero_and_a_file_with_them_sets_them() {
        let modes = parse_modes(DEFAULT_MODES, DEFAULT_MODES_FILE).unwrap();
        assert!(modes.iter().all(|m| m.participation[3..] == [0.0; 3]));
        let text = format!(
            "{DEFAULT_MODES}\nmode1.lateral_force = 2e-3\nmode2.lift_force = -4e-3\nmode2.axial_force = 1e-3\n"
        );
        let modes = parse_modes(&text, "f.params").unwrap();
        assert_eq!(modes[0].participation, [1.0, 0.0, 0.0, 0.0, 2e-3, 0.0]);
        assert_eq!(modes[1].participation, [0.0, 1.0, 0.0, 1e-3, 0.0, -4e-3]);
        assert_eq!((modes[0].field("lateral_force"), modes[1].field("lift_force")), (Some(2e-3), Some(-4e-3)));
        // A mode may take only a resolved force.
        let lateral_only = DEFAULT_MODES.replace("mode1.azimuth_torque = 1", "mode1.azimuth_torque = 0")
            + "mode1.lateral_force = 1e-3\n";
        assert_eq!(parse_modes(&lateral_only, "f.params").unwrap()[0].participation[4], 1e-3);
    }

    #[test]
    fn a_mode_without_the_resolved_forces_gives_the_three_load_sum_bit_for_bit() {
        // The sum as it was before the resolved forces existed: the default antenna's results
        // must not move by a bit, signed zeros included.
        let mode = Mode {
            frequency_hz: 6.0,
            horizon_frequency_hz: None,
            damping_ratio: 0.015,
            stiffness: 4e8,
            participation: [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            beam: [1.0, 0.0],
            beam_azimuth_rotation: 0.0,
        };
        for first in [-0.0, 0.0, 1.0e4, -3.3e3, 1e-300] {
            for resolved in [0.0, -0.0, 7.0, -7.0] {
                let loads = [first, -0.0, -0.0, resolved, resolved, resolved];
                let three: f64 = mode.participation[..3].iter().zip(&loads[..3]).map(|(p, u)| p * u).sum();
                assert_eq!(mode.modal_load(&loads).to_bits(), three.to_bits(), "{loads:?}");
            }
        }
        let resolved = Mode { participation: [1.0, 0.0, 0.0, 2.0, -3.0, 0.5], ..mode };
        assert_eq!(resolved.modal_load(&[10.0, 0.0, 0.0, 1.0, 2.0, 4.0]), 10.0 + 2.0 - 6.0 + 2.0);
    }

    #[test]
    fn a_horizon_frequency_turns_the_modal_inertia_as_a_rigid_body_tipping_about_the_elevation_axis() {
        let text = format!("{DEFAULT_MODES}\nmode1.horizon_frequency = 4.0\n");
        let modes = parse_modes(&text, "f.params").unwrap();
        let (azimuth, elevation) = (&modes[0], &modes[1]);
        assert!(azimuth.varies_with_elevation() && !elevation.varies_with_elevation());
        assert_eq!((azimuth.frequency_at(0.0), azimuth.frequency_at(90.0)), (4.0, 6.0));
        // The inertia K / w^2 at any elevation is J_horizon cos^2 + J_zenith sin^2.
        let inertia = |f: f64| azimuth.stiffness / (2.0 * std::f64::consts::PI * f).powi(2);
        for elevation_deg in [15.0, 45.0, 60.0, 88.0] {
            let (s, c) = f64::to_radians(elevation_deg).sin_cos();
            let expected = inertia(4.0) * c * c + inertia(6.0) * s * s;
            let at = azimuth.at_elevation(elevation_deg);
            assert!((at.inertia() / expected - 1.0).abs() < 1e-13, "{elevation_deg} deg");
            assert!(!at.varies_with_elevation());
        }
        // A mode without one is the same at every elevation, bit for bit.
        assert_eq!(elevation.at_elevation(15.0), *elevation);
        assert_eq!(elevation.field("horizon_frequency"), Some(6.0));
        // Written out, each reads back as it was: with and without a horizon frequency.
        assert_eq!(parse_modes(&write_modes(&modes, "h"), "w").unwrap(), modes);
        assert!(!write_modes(&modes[1..], "h").contains("horizon_frequency"));
        let error = parse_modes(&format!("{DEFAULT_MODES}\nmode2.horizon_frequency = 0\n"), "f.params").unwrap_err();
        assert!(error
            .to_string()
            .contains("mode2.horizon_frequency = 0: the frequency at the horizon must be positive"));
    }

    fn with_line(line: &str, replaced: &str) -> String {
        DEFAULT_MODES.replace(replaced, line)
    }

    #[test]
    fn bad_files_are_errors_naming_the_file_line_and_cause() {
        let line = 1 + DEFAULT_MODES.lines().position(|l| l.starts_with("mode1.frequency")).unwrap();
        let at_line = |rest: &str| format!("f.params:{line}: {rest}");
        let negative = at_line("mode1.frequency = -6: the frequency must be positive");
        let not_a_number = at_line("mode1.frequency: `six` is not a number");
        let cases = [
            (with_line("mode1.frequency = -6.0", "mode1.frequency = 6.0"), negative.as_str()),
            (
                with_line("mode2.damping = -0.1", "mode2.damping = 0.015"),
                "mode2.damping = -0.1: the damping ratio must not be negative",
            ),
            (with_line("mode1.stiffnes = 4e8", "mode1.stiffness = 4e8"), "`mode1.stiffnes` is not a mode field"),
            (with_line("mode1.frequency = \"six\"", "mode1.frequency = 6.0"), "needs a number"),
            (with_line("mode1.frequency = six", "mode1.frequency = 6.0"), not_a_number.as_str()),
            (with_line("mode4.frequency = 6.0", "mode1.frequency = 6.0"), "mode1.frequency is missing"),
            (DEFAULT_MODES.replace("mode2.", "mode3."), "mode 2 is missing"),
            (String::from("# nothing\n"), "f.params: no modes"),
            (with_line("mode1.azimuth_torque = 0", "mode1.azimuth_torque = 1"), "takes no load"),
            (with_line("mode2.beam_elevation = 0", "mode2.beam_elevation = 1"), "does not move the beam"),
            (String::from("mode0.frequency = 1"), "`mode0.frequency` is not a mode field"),
            (String::from("mode01.frequency = 1"), "is not a mode field"),
            (String::from("mode5000.frequency = 1"), "mode 5000 is beyond the 1000 modes"),
            (
                DEFAULT_MODES.replace("mode1.dish_force = 0", "mode1.dish_force = 2") + "mode1.axial_force = 1\n",
                "mode1.axial_force = 1: a mode takes the drag either through dish_force",
            ),
            (
                DEFAULT_MODES.replace("mode2.dish_force = 0", "mode2.dish_force = 2") + "mode2.lateral_force = -1\n",
                "mode2.lateral_force = -1: a mode takes the drag either",
            ),
            (
                with_line("mode1.azimuth_torque = 0", "mode1.azimuth_torque = 1") + "mode1.lift_force = 0\n",
                "takes no load",
            ),
        ];
        for (text, needle) in cases {
            let error = parse_modes(&text, "f.params").unwrap_err().to_string();
            assert!(error.contains(needle), "expected {needle:?} in {error:?}");
        }
    }

    #[test]
    fn a_missing_file_is_an_error_naming_it() {
        let error = read_modes(Path::new("/nonexistent/modes.params")).unwrap_err().to_string();
        assert!(error.starts_with("cannot read modes file /nonexistent/modes.params"), "{error}");
    }
}
