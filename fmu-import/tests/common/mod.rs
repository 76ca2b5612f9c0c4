//! What the tests of the real, packaged FMUs share: finding the `.fmu` files, an instance
//! ready to step, and the functions the importer keeps no pointer to (model exchange,
//! derivatives), looked up with `dlsym` in the library the importer loaded.
//!
//! The FMUs are the ones `cargo xtask package` writes to
//! `target/fmu/`, or those in the folder named by `MEERKAT_FMU_DIR` (as for the tools and the
//! other integration tests); every `.fmu` there is tested, since all share this runtime.

#![allow(dead_code)]

use std::ffi::{c_void, CString};
use std::path::{Path, PathBuf};

use fmi2_ffi::*;
use fmu_import::{Fmu, Instance};

/// Every packaged FMU, opened; fails (never skips) when the folder or a plant is missing.
pub fn packaged_fmus() -> Vec<Fmu> {
    let directory = match std::env::var_os("MEERKAT_FMU_DIR") {
        Some(dir) => PathBuf::from(dir),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace").join("target").join("fmu"),
    };
    let hint = "package the FMUs first (cargo xtask package)";
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&directory)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}; {hint}", directory.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "fmu"))
        .collect();
    paths.sort();
    for plant in ["AzimuthPlant.fmu", "ElevationPlant.fmu"] {
        assert!(
            paths.iter().any(|p| p.file_name().is_some_and(|n| n == plant)),
            "{plant} is missing in {}: {hint}",
            directory.display()
        );
    }
    paths.iter().map(|p| Fmu::open(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))).collect()
}

/// An instance through initialisation, in the StepComplete phase.
pub fn ready(fmu: &Fmu) -> Instance {
    let mut instance = fmu.instantiate("runtime-test", false).expect("instantiate");
    instance.initialize(0.0, &[]).expect("initialise");
    instance
}

pub type FnDirectionalDerivative =
    unsafe extern "C" fn(fmi2Component, *const u32, usize, *const u32, usize, *const f64, *mut f64) -> fmi2Status;
pub type FnNewDiscreteStates = unsafe extern "C" fn(fmi2Component, *mut c_void) -> fmi2Status;
pub type FnComponent = unsafe extern "C" fn(fmi2Component) -> fmi2Status;
pub type FnCompletedIntegratorStep =
    unsafe extern "C" fn(fmi2Component, fmi2Boolean, *mut fmi2Boolean, *mut fmi2Boolean) -> fmi2Status;
pub type FnSetTime = unsafe extern "C" fn(fmi2Component, f64) -> fmi2Status;
pub type FnSetArray = unsafe extern "C" fn(fmi2Component, *const f64, usize) -> fmi2Status;
pub type FnGetArray = unsafe extern "C" fn(fmi2Component, *mut f64, usize) -> fmi2Status;
pub type FnSetInputDerivatives =
    unsafe extern "C" fn(fmi2Component, *const u32, usize, *const fmi2Integer, *const f64) -> fmi2Status;
pub type FnGetOutputDerivatives =
    unsafe extern "C" fn(fmi2Component, *const u32, usize, *const fmi2Integer, *mut f64) -> fmi2Status;

/// The functions the importer does not keep a pointer to (model exchange, derivatives),
/// looked up in the FMU's already loaded library.
pub struct Others {
    handle: *mut c_void,
    pub get_directional_derivative: FnDirectionalDerivative,
    pub new_discrete_states: FnNewDiscreteStates,
    pub enter_continuous_time_mode: FnComponent,
    pub completed_integrator_step: FnCompletedIntegratorStep,
    pub set_time: FnSetTime,
    pub set_continuous_states: FnSetArray,
    pub get_arrays: [(&'static str, FnGetArray); 4],
    pub set_real_input_derivatives: FnSetInputDerivatives,
    pub get_real_output_derivatives: FnGetOutputDerivatives,
}

impl Others {
    pub fn load(fmu: &Fmu) -> Others {
        let path = CString::new(fmu.library.path.as_os_str().as_encoded_bytes()).unwrap();
        // SAFETY: the library is already loaded by the importer, so dlopen only raises its
        // reference count and returns the same handle; it is closed again on drop.
        let handle = unsafe { libc::dlopen(path.as_ptr(), libc::RTLD_NOW | libc::RTLD_LOCAL) };
        assert!(!handle.is_null(), "dlopen {}", fmu.library.path.display());
        let symbol = |name: &str| -> *mut c_void {
            let c = CString::new(name).unwrap();
            // SAFETY: a valid handle and a NUL-terminated name.
            let p = unsafe { libc::dlsym(handle, c.as_ptr()) };
            assert!(!p.is_null(), "{} does not export {name}", fmu.library.path.display());
            p
        };
        macro_rules! function {
            ($name:literal, $type:ty) => {
                // SAFETY: the symbol exists and has this signature by the FMI 2.0 standard
                // (fmi2FunctionTypes.h); function and data pointers have the same size here.
                unsafe { std::mem::transmute::<*mut c_void, $type>(symbol($name)) }
            };
        }
        Others {
            handle,
            get_directional_derivative: function!("fmi2GetDirectionalDerivative", FnDirectionalDerivative),
            new_discrete_states: function!("fmi2NewDiscreteStates", FnNewDiscreteStates),
            enter_continuous_time_mode: function!("fmi2EnterContinuousTimeMode", FnComponent),
            completed_integrator_step: function!("fmi2CompletedIntegratorStep", FnCompletedIntegratorStep),
            set_time: function!("fmi2SetTime", FnSetTime),
            set_continuous_states: function!("fmi2SetContinuousStates", FnSetArray),
            get_arrays: [
                ("fmi2GetDerivatives", function!("fmi2GetDerivatives", FnGetArray)),
                ("fmi2GetEventIndicators", function!("fmi2GetEventIndicators", FnGetArray)),
                ("fmi2GetContinuousStates", function!("fmi2GetContinuousStates", FnGetArray)),
                ("fmi2GetNominalsOfContinuousStates", function!("fmi2GetNominalsOfContinuousStates", FnGetArray)),
            ],
            set_real_input_derivatives: function!("fmi2SetRealInputDerivatives", FnSetInputDerivatives),
            get_real_output_derivatives: function!("fmi2GetRealOutputDerivatives", FnGetOutputDerivatives),
        }
    }
}

impl Drop for Others {
    fn drop(&mut self) {
        // SAFETY: the handle came from dlopen above; the importer keeps its own reference.
        unsafe { libc::dlclose(self.handle) };
    }
}
