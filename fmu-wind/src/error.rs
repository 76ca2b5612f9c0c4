//! Why a wind unit model could not be built: the typed errors of the spectrum, admittance,
//! shaping filter and torque constructors.
//!
//! The FMI layer ([`crate::fmi`]) wraps these in its `WindFmuError`, whose Display text
//! `fmu-runtime` reports to the importer; the texts below are therefore what a user of the FMU
//! reads.

/// Why a part of the wind model refused its parameters.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum WindError {
    /// The mean wind speed is zero, negative or not finite.
    #[error("mean wind speed must be positive and finite, got {v_mean} m/s")]
    MeanSpeed { v_mean: f64 },

    /// The reference height of the spectrum is zero, negative or not finite.
    #[error("reference height z must be positive and finite, got {z} m")]
    ReferenceHeight { z: f64 },

    /// The roughness length is not between zero and the reference height.
    #[error("roughness length z0 must satisfy 0 < z0 < z = {z} m, got {z0} m")]
    RoughnessLength { z: f64, z0: f64 },

    /// No roughness length in the searched range gives the requested gust factor.
    #[error(
        "gust factor {target} is outside the range {reachable_lo:.3}..{reachable_hi:.3} reachable \
         with 1e-6 m <= z0 <= z/e at v_m = {v_mean} m/s"
    )]
    GustFactorOutOfRange { target: f64, reachable_lo: f64, reachable_hi: f64, v_mean: f64 },

    /// The admittance was asked for a mean speed or length scale that is not positive.
    #[error("the admittance needs a positive mean speed and length scale, got {v_mean} m/s and {length} m")]
    AdmittanceScale { v_mean: f64, length: f64 },

    /// The admittance prototype is not strictly proper.
    #[error("an admittance prototype must have more poles than zeros, got {poles} poles and {zeros} zeros")]
    AdmittanceNotProper { poles: usize, zeros: usize },

    /// The admittance prototype has more poles than the generator's state can hold.
    #[error("an admittance prototype may have at most {max} poles, got {poles}")]
    AdmittanceOrder { poles: usize, max: usize },

    /// The coherence decay constant of Davenport's size factor is not positive.
    #[error("the coherence decay constant must be positive, got {decay}")]
    CoherenceDecay { decay: f64 },

    /// The paper's filters were asked for a mean speed they were not fitted for.
    #[error(
        "spectrum mode 'paper' has filters only for v_m = 3 m/s (H3) and 9.5 m/s (H10); got v_m = {v_mean} m/s. \
         Use the default Davenport mode for other mean speeds."
    )]
    PaperSpeed { v_mean: f64 },

    /// The paper's filters were asked for a site other than the one they were fitted for.
    #[error(
        "spectrum mode 'paper': H3 and H10 are the paper's fits for reference height z = {paper_z} m \
         and roughness length z0 = {paper_z0} m; got z = {z} m, z0 = {z0} m. \
         Use the default Davenport mode for another site."
    )]
    PaperSite { z: f64, z0: f64, paper_z: f64, paper_z0: f64 },

    /// A shaping filter's denominator has complex roots.
    #[error("denominator has complex roots: the modal realisation needs real poles")]
    ComplexPoles,

    /// A shaping filter's denominator has a root in the right half plane or at the origin.
    #[error("denominator has a root at {root}: the filter is not stable")]
    UnstablePole { root: f64 },

    /// A shaping filter's denominator has two roots too close to tell apart.
    #[error("denominator has repeated roots: the modal realisation needs distinct poles")]
    RepeatedPoles,

    /// The air density is zero, negative or not finite.
    #[error("air density must be positive and finite, got {density} kg/m^3")]
    AirDensity { density: f64 },

    /// The dish diameter is zero, negative or not finite.
    #[error("dish diameter must be positive and finite, got {diameter} m")]
    DishDiameter { diameter: f64 },

    /// A force coefficient is not finite.
    #[error("force coefficients must be finite, got drag {drag_face_on} and lift {lift_max}")]
    ForceCoefficients { drag_face_on: f64, lift_max: f64 },

    /// The feed-support drag is not finite, or its drag area is negative.
    #[error("the feed-support drag must be finite with a drag area not negative, got drag area {drag_area} m^2, boresight distance {boresight_distance} m, offset {offset} m")]
    FeedDrag { drag_area: f64, boresight_distance: f64, offset: f64 },
}
