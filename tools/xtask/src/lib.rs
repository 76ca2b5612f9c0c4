//! Builds the FMU shared libraries and packages every FMU into `target/fmu/`, and generates
//! (or checks) the committed model descriptions under `modelDescription/`.
//!
//! This is the project's xtask (`cargo xtask package`, `cargo xtask codegen`, see
//! `src/main.rs`): the same variable tables that drive the FMUs at run time drive the generated
//! files, and `codegen --check` turns "someone forgot to regenerate" into a failing test.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, DateTime, ZipWriter};

use antenna_fmus::{all_fmus, fmu_directory, model_description_directory, package_of, workspace_root};
use fmu_runtime::package::FmuSpec;

/// The cargo profile the FMUs' shared libraries are built with (see the workspace Cargo.toml).
pub const LIBRARY_PROFILE: &str = "fmu-release";

/// Why a build task could not be done.
#[derive(Debug, thiserror::Error)]
pub enum XtaskError {
    #[error("cannot run cargo")]
    CargoNotRunnable(#[source] std::io::Error),
    #[error("cargo build of {packages} failed ({status})")]
    BuildFailed { packages: String, status: std::process::ExitStatus },
    #[error("cannot read {}", path.display())]
    Read { path: PathBuf, source: std::io::Error },
    #[error("cannot write {}", path.display())]
    Write { path: PathBuf, source: std::io::Error },
    #[error("{model_identifier}: invalid variable table: {message}")]
    InvalidVariableTable { model_identifier: String, message: String },
    #[error("resource path '{0}' must be relative and stay inside resources/")]
    ResourceOutsideFolder(String),
    #[error("zip")]
    Zip(#[from] zip::result::ZipError),
    #[error("generated files are stale: {}; run `cargo xtask codegen`", .0.join(", "))]
    StaleGeneratedFiles(Vec<String>),
    #[error("cannot run git ls-files")]
    Git(#[source] std::io::Error),
    #[error("the second build (from a copy of the sources) failed")]
    SecondBuild(#[source] Box<XtaskError>),
}

/// Builds the shared libraries of the model crates with cargo, in [`LIBRARY_PROFILE`].
pub fn build_libraries(target_dir: &Path) -> Result<(), XtaskError> {
    build_libraries_from(&workspace_root(), target_dir)
}

/// Builds the FMUs' shared libraries from the sources checked out at `source_root` (the same
/// package set every time: building one library alone may unify features differently and give
/// other bytes).
pub fn build_libraries_from(source_root: &Path, target_dir: &Path) -> Result<(), XtaskError> {
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
    let status = command.status().map_err(XtaskError::CargoNotRunnable)?;
    if !status.success() {
        return Err(XtaskError::BuildFailed { packages: packages.join(", "), status });
    }
    Ok(())
}

/// Packages every FMU from the libraries in `target_dir/<LIBRARY_PROFILE>` into `output`.
pub fn package_all(target_dir: &Path, output: &Path) -> Result<Vec<PathBuf>, XtaskError> {
    std::fs::create_dir_all(output).map_err(|source| XtaskError::Write { path: output.to_path_buf(), source })?;
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
pub fn build_and_package() -> Result<Vec<PathBuf>, XtaskError> {
    let stale = codegen(true)?;
    if !stale.is_empty() {
        return Err(XtaskError::StaleGeneratedFiles(stale));
    }
    let target = workspace_root().join("target");
    build_libraries(&target)?;
    package_all(&target, &fmu_directory())
}

/// Writes `modelDescription/<id>.xml` for every FMU and `docs/parameters.md`, or with `check` only lists those whose
/// committed file differs from what the code generates now.
pub fn codegen(check: bool) -> Result<Vec<String>, XtaskError> {
    let directory = model_description_directory();
    let mut stale = Vec::new();
    for spec in all_fmus() {
        (spec.validate)().map_err(|e| XtaskError::InvalidVariableTable {
            model_identifier: spec.model_identifier.to_string(),
            message: e.to_string(),
        })?;
        let path = directory.join(format!("{}.xml", spec.model_identifier));
        let generated = (spec.model_description)();
        let committed = std::fs::read_to_string(&path).unwrap_or_default();
        if committed != generated {
            stale.push(path.display().to_string());
            if !check {
                std::fs::create_dir_all(&directory)
                    .map_err(|source| XtaskError::Write { path: directory.clone(), source })?;
                std::fs::write(&path, generated).map_err(|source| XtaskError::Write { path: path.clone(), source })?;
            }
        }
    }
    // The human table of the uncertain parameters is generated from their one CSV.
    let table_path = antenna_fmus::workspace_root().join("docs").join("parameters.md");
    let table = antenna_fmus::parameters::render_markdown(&antenna_fmus::parameters::parameters());
    if std::fs::read_to_string(&table_path).unwrap_or_default() != table {
        stale.push(table_path.display().to_string());
        if !check {
            std::fs::write(&table_path, table)
                .map_err(|source| XtaskError::Write { path: table_path.clone(), source })?;
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
                    std::fs::remove_file(entry.path())
                        .map_err(|source| XtaskError::Write { path: entry.path(), source })?;
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
pub fn write_fmu(spec: &FmuSpec, shared_library: &Path, output: &Path) -> Result<(), XtaskError> {
    (spec.validate)().map_err(|e| XtaskError::InvalidVariableTable {
        model_identifier: spec.model_identifier.to_string(),
        message: e.to_string(),
    })?;
    let binary = std::fs::read(shared_library)
        .map_err(|source| XtaskError::Read { path: shared_library.to_path_buf(), source })?;
    let mut entries: Vec<(String, Vec<u8>, u32)> = vec![
        ("modelDescription.xml".to_string(), (spec.model_description)().into_bytes(), 0o644),
        (format!("binaries/linux64/{}.so", spec.model_identifier), binary, 0o755),
    ];
    let mut resources = (spec.resources)();
    if let Some(text) = antenna_fmus::parameters::realistic_parameter_file(spec.model_identifier) {
        resources.push((antenna_fmus::parameters::REALISTIC_PARAMETER_FILE.to_string(), text.into_bytes()));
    }
    for (path, bytes) in resources {
        if path.contains("..") || path.starts_with('/') {
            return Err(XtaskError::ResourceOutsideFolder(path));
        }
        entries.push((format!("resources/{path}"), bytes, 0o644));
    }
    entries.sort_by(|a, b| a.0.cmp(&b.0));
    let file =
        std::fs::File::create(output).map_err(|source| XtaskError::Write { path: output.to_path_buf(), source })?;
    let mut zip = ZipWriter::new(file);
    for (path, bytes, mode) in entries {
        let options = SimpleFileOptions::default()
            .compression_method(CompressionMethod::Deflated)
            .compression_level(Some(6))
            .last_modified_time(DateTime::default())
            .unix_permissions(mode);
        zip.start_file(path.as_str(), options)?;
        zip.write_all(&bytes).map_err(|source| XtaskError::Write { path: output.to_path_buf(), source })?;
    }
    zip.finish()?;
    Ok(())
}

/// The files whose bytes differ between the `reference` packages and a second build from a
/// copy of the tracked sources at another path, with its own target directory (empty: the
/// packages are reproducible).
///
/// Only the shared libraries are built from the copy (they are what a checkout path could
/// leak into); they are packaged by this crate's code, as the first build was.
pub fn reproducibility_differences(reference: &[PathBuf]) -> Result<Vec<String>, XtaskError> {
    let root = workspace_root();
    let copy = std::env::temp_dir().join(format!("meerkat-repro-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&copy);
    let files = Command::new("git")
        .current_dir(&root)
        .args(["ls-files", "--cached", "--others", "--exclude-standard"])
        .output()
        .map_err(XtaskError::Git)?;
    for file in String::from_utf8_lossy(&files.stdout).lines() {
        let from = root.join(file);
        if !from.is_file() {
            continue;
        }
        let to = copy.join("checkout").join(file);
        if let Some(parent) = to.parent() {
            std::fs::create_dir_all(parent)
                .map_err(|source| XtaskError::Write { path: parent.to_path_buf(), source })?;
        }
        std::fs::copy(&from, &to).map_err(|source| XtaskError::Write { path: to.clone(), source })?;
    }
    let target = copy.join("target");
    let out = copy.join("fmu");
    build_libraries_from(&copy.join("checkout"), &target).map_err(|e| XtaskError::SecondBuild(Box::new(e)))?;
    package_all(&target, &out)?;
    let mut differing = Vec::new();
    for path in reference {
        let Some(name) = path.file_name() else { continue };
        let a = std::fs::read(path).map_err(|source| XtaskError::Read { path: path.clone(), source })?;
        let second = out.join(name);
        let b = std::fs::read(&second).map_err(|source| XtaskError::Read { path: second.clone(), source })?;
        if a != b {
            differing.push(Path::new(name).display().to_string());
        }
    }
    let _ = std::fs::remove_dir_all(&copy);
    Ok(differing)
}
