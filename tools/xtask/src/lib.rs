//! Builds the FMU shared libraries and packages every FMU into `target/fmu/`, and generates
//! (or checks) the committed model descriptions under `modelDescription/`.
//!
//! This is the project's xtask: the same variable tables that drive the FMUs at run time drive
//! the generated files, and `--check` turns "someone forgot to regenerate" into a failing test.

use std::path::{Path, PathBuf};
use std::io::Write;
use std::process::Command;

use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, DateTime, ZipWriter};

use antenna_fmus::{all_fmus, fmu_directory, model_description_directory, package_of, workspace_root};
use fmu_runtime::package::FmuSpec;

/// The cargo profile the FMUs' shared libraries are built with (see the workspace Cargo.toml).
pub const LIBRARY_PROFILE: &str = "fmu-release";

/// Builds the shared libraries of the model crates with cargo, in [`LIBRARY_PROFILE`].
pub fn build_libraries(target_dir: &Path) -> Result<(), String> {
    build_libraries_from(&workspace_root(), target_dir)
}

/// Builds the FMUs' shared libraries from the sources checked out at `source_root` (the same
/// package set every time: building one library alone may unify features differently and give
/// other bytes).
pub fn build_libraries_from(source_root: &Path, target_dir: &Path) -> Result<(), String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    let mut packages: Vec<&str> = all_fmus().iter().map(|s| package_of(s.library_name)).collect();
    packages.sort();
    packages.dedup();
    let mut command = Command::new(cargo);
    command
        .current_dir(source_root)
        .args(["build", "--profile", LIBRARY_PROFILE, "--quiet"])
        .arg("--target-dir")
        .arg(target_dir);
    for p in &packages {
        command.args(["-p", p]);
    }
    let status = command.status().map_err(|e| format!("cannot run cargo: {e}"))?;
    if !status.success() {
        return Err(format!("cargo build of {} failed ({status})", packages.join(", ")));
    }
    Ok(())
}

/// Packages every FMU from the libraries in `target_dir/<LIBRARY_PROFILE>` into `output`.
pub fn package_all(target_dir: &Path, output: &Path) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(output).map_err(|e| format!("cannot create {}: {e}", output.display()))?;
    let mut written = Vec::new();
    for spec in all_fmus() {
        let library = target_dir.join(LIBRARY_PROFILE).join(format!("lib{}.so", spec.library_name));
        let path = output.join(format!("{}.fmu", spec.model_identifier));
        write_fmu(&spec, &library, &path)?;
        written.push(path);
    }
    Ok(written)
}

/// Builds and packages into the documented folder; what the main job and the tests rely on.
pub fn build_and_package() -> Result<Vec<PathBuf>, String> {
    let stale = codegen(true)?;
    if !stale.is_empty() {
        return Err(format!(
            "generated files are stale: {}; run `cargo run -p xtask --bin codegen`",
            stale.join(", ")
        ));
    }
    let target = workspace_root().join("target");
    build_libraries(&target)?;
    package_all(&target, &fmu_directory())
}

/// Writes `modelDescription/<id>.xml` for every FMU, or with `check` only lists those whose
/// committed file differs from what the code generates now.
pub fn codegen(check: bool) -> Result<Vec<String>, String> {
    let directory = model_description_directory();
    let mut stale = Vec::new();
    for spec in all_fmus() {
        (spec.validate)().map_err(|e| format!("{}: {e}", spec.model_identifier))?;
        let path = directory.join(format!("{}.xml", spec.model_identifier));
        let generated = (spec.model_description)();
        let committed = std::fs::read_to_string(&path).unwrap_or_default();
        if committed != generated {
            stale.push(path.display().to_string());
            if !check {
                std::fs::create_dir_all(&directory).map_err(|e| e.to_string())?;
                std::fs::write(&path, generated).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
            }
        }
    }
    // A file for an FMU that no longer exists is stale too.
    if let Ok(entries) = std::fs::read_dir(&directory) {
        let known: Vec<String> = all_fmus().iter().map(|s| format!("{}.xml", s.model_identifier)).collect();
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().to_string();
            if name.ends_with(".xml") && !known.contains(&name) {
                stale.push(entry.path().display().to_string());
                if !check {
                    std::fs::remove_file(entry.path()).map_err(|e| e.to_string())?;
                }
            }
        }
    }
    Ok(stale)
}

/// Writes one `.fmu`: `modelDescription.xml`, `binaries/linux64/<id>.so` and the resources.
///
/// The archive is byte-for-byte reproducible: entries are sorted, every timestamp is 1980-01-01
/// 00:00 (the zip epoch), permissions are fixed, and nothing about the build machine (paths,
/// user, clock) goes in.
pub fn write_fmu(spec: &FmuSpec, shared_library: &Path, output: &Path) -> Result<(), String> {
    (spec.validate)().map_err(|e| format!("{}: invalid variable table: {e}", spec.model_identifier))?;
    let binary = std::fs::read(shared_library).map_err(|e| format!("cannot read {}: {e}", shared_library.display()))?;
    let mut entries: Vec<(String, Vec<u8>, u32)> = vec![
        ("modelDescription.xml".to_string(), (spec.model_description)().into_bytes(), 0o644),
        (format!("binaries/linux64/{}.so", spec.model_identifier), binary, 0o755),
    ];
    for (path, bytes) in (spec.resources)() {
        if path.contains("..") || path.starts_with('/') {
            return Err(format!("resource path '{path}' must be relative and stay inside resources/"));
        }
        entries.push((format!("resources/{path}"), bytes, 0o644));
    }
    entries.sort_by(|a, b| a.0.cmp(&b.0));
    let file = std::fs::File::create(output).map_err(|e| format!("cannot create {}: {e}", output.display()))?;
    let mut zip = ZipWriter::new(file);
    for (path, bytes, mode) in entries {
        let options = SimpleFileOptions::default()
            .compression_method(CompressionMethod::Deflated)
            .compression_level(Some(6))
            .last_modified_time(DateTime::default())
            .unix_permissions(mode);
        zip.start_file(path.as_str(), options).map_err(|e| format!("zip: {e}"))?;
        zip.write_all(&bytes).map_err(|e| format!("zip: {e}"))?;
    }
    zip.finish().map_err(|e| format!("zip: {e}"))?;
    Ok(())
}
