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
    #[error("{} not found: install LLVM's tools for this toolchain with `rustup component add llvm-tools`", .0.display())]
    ProfdataMissing(PathBuf),
    #[error("the profile's training run `{what}` failed ({status})")]
    Training { what: String, status: std::process::ExitStatus },
    #[error("the training runs wrote no profile into {}", .0.display())]
    NoProfile(PathBuf),
    #[error("--pgo: there is no profile at {}; record one with `cargo xtask pgo`", .0.display())]
    ProfileMissing(PathBuf),
    #[error(
        "--pgo: the profile ({PGO_PROFILE_ARCHIVE}) was recorded by another compiler ({} against this {}); run `cargo xtask pgo` to record it with this one",
        release_line(.recorded),
        release_line(.current)
    )]
    ProfileOtherToolchain { recorded: String, current: String },
    #[error(
        "win64 binaries need a compiler with the standard library's sources and the mingw-w64 linker: {0} (on Debian: apt install rustc-web rust-web-src gcc-mingw-w64-x86-64)"
    )]
    Win64ToolchainMissing(String),
    #[error("the second build (from a copy of the sources) failed")]
    SecondBuild(#[source] Box<XtaskError>),
}

/// Where the profile that the FMUs' libraries are optimised with is committed (profile-guided
/// optimisation, PGO): the counts of every branch and call in the libraries over the main job's
/// runs, recorded by `cargo xtask pgo`, zipped.
pub const PGO_PROFILE_ARCHIVE: &str = "tools/xtask/pgo/fmus.profdata.zip";

/// The entries of [`PGO_PROFILE_ARCHIVE`]: LLVM's indexed profile, as `llvm-profdata merge`
/// writes it, and the `rustc -vV` of the compiler that recorded it.
const PGO_PROFILE_ENTRY: &str = "fmus.profdata";
const PGO_TOOLCHAIN_ENTRY: &str = "rustc-version.txt";

/// Whether a build of the FMUs' libraries used the committed profile.
#[derive(Debug, Clone, Default, PartialEq)]
pub enum ProfileUse {
    /// There is no profile: the libraries are built without one.
    #[default]
    Absent,
    /// The libraries are optimised with the profile.
    Used,
}

/// What a build of the FMUs' libraries reported about the committed profile.
#[derive(Debug, Clone, Default)]
pub struct LibraryBuild {
    pub profile: ProfileUse,
    /// How many functions changed their code since the profile was recorded (the compiler
    /// warns of each): they are built without their counts (correct, but not as fast as they
    /// could be) until `cargo xtask pgo` records the profile again.
    pub functions_with_changed_code: usize,
    /// How many functions the profile has no counts for. Each is built as if without a profile:
    /// new functions, or every function when the build's settings rename the symbols (another
    /// `[profile.fmu-release]`, say), which the compiler does not otherwise report.
    pub functions_without_counts: usize,
}

impl LibraryBuild {
    /// Why the libraries are not fully optimised with the committed profile, if they were to
    /// be and are not (what `package --pgo` warns of).
    pub fn profile_problem(&self) -> Option<String> {
        if self.functions_with_changed_code == 0 && self.functions_without_counts == 0 {
            return None;
        }
        let mut misfits = Vec::new();
        if self.functions_with_changed_code > 0 {
            misfits.push(format!("predates the code of {} function(s)", self.functions_with_changed_code));
        }
        if self.functions_without_counts > 0 {
            misfits.push(format!(
                "has no counts for {} function(s) (new code, or build settings that rename the symbols)",
                self.functions_without_counts
            ));
        }
        Some(format!(
            "xtask: the PGO profile ({PGO_PROFILE_ARCHIVE}) {}; they are built without counts: run `cargo xtask pgo` to record it again",
            misfits.join(" and ")
        ))
    }
}

/// Whether the FMUs' libraries are built with the committed PGO profile.
///
/// Off by default: the profile fits one compiler release and one state of the models' code, so
/// a default build that used it would depend on both. `cargo xtask package --pgo` opts in for a
/// release build on the compiler that recorded it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Pgo {
    #[default]
    Off,
    On,
}

/// Builds the shared libraries of the model crates with cargo, in [`LIBRARY_PROFILE`].
pub fn build_libraries(target_dir: &Path, pgo: Pgo) -> Result<LibraryBuild, XtaskError> {
    build_libraries_from(&workspace_root(), target_dir, pgo)
}

/// The `release:` line of `rustc -vV`'s output, which names the compiler release.
fn release_line(version: &str) -> &str {
    version.lines().find(|line| line.starts_with("release:")).unwrap_or("?")
}

/// Builds the FMUs' shared libraries from the sources checked out at `source_root` (the same
/// package set every time: building one library alone may unify features differently and give
/// other bytes). With [`Pgo::On`] they are optimised with the profile committed at
/// [`PGO_PROFILE_ARCHIVE`], which must be there and recorded by this compiler (an error names
/// both releases otherwise).
pub fn build_libraries_from(source_root: &Path, target_dir: &Path, pgo: Pgo) -> Result<LibraryBuild, XtaskError> {
    if pgo == Pgo::Off {
        cargo_build_libraries(source_root, target_dir, &[])?;
        return Ok(LibraryBuild::default());
    }
    let archive = source_root.join(PGO_PROFILE_ARCHIVE);
    if !archive.is_file() {
        return Err(XtaskError::ProfileMissing(PathBuf::from(PGO_PROFILE_ARCHIVE)));
    }
    let recorded = read_archive_entry(&archive, PGO_TOOLCHAIN_ENTRY)?;
    let recorded = String::from_utf8_lossy(&recorded).to_string();
    let current = rustc_output(source_root, &["-vV"])?;
    if recorded != current {
        return Err(XtaskError::ProfileOtherToolchain { recorded, current });
    }
    let profile = unpack_profile(&archive, &target_dir.join("pgo"))?;
    // The compiler reports functions without counts only when asked; the option changes no
    // code (tried: byte-identical libraries with and without it).
    let flags = [format!("-Cprofile-use={}", profile.display()), MISSING_COUNTS_OPTION.to_string()];
    let stderr = cargo_build_libraries(source_root, target_dir, &flags)?;
    Ok(LibraryBuild {
        profile: ProfileUse::Used,
        functions_with_changed_code: count_lines_with(&stderr, CHANGED_CODE_WARNING),
        functions_without_counts: count_lines_with(&stderr, MISSING_COUNTS_WARNING),
    })
}

/// Asks LLVM to warn of each function the profile has no counts for.
const MISSING_COUNTS_OPTION: &str = "-Cllvm-args=-pgo-warn-missing-function";

/// The text of LLVM's warning for a function without counts.
const MISSING_COUNTS_WARNING: &str = "no profile data available for function";

/// The text of LLVM's warning for a function whose recorded counts no longer fit its code (it
/// compares a hash of each function's control flow).
const CHANGED_CODE_WARNING: &str = "(hash mismatch)";

/// How many lines of a build's stderr hold `warning` (the compiler writes one per function).
fn count_lines_with(stderr: &str, warning: &str) -> usize {
    stderr.lines().filter(|line| line.contains(warning)).count()
}

/// The bytes of one entry of a zip archive.
fn read_archive_entry(archive: &Path, entry: &str) -> Result<Vec<u8>, XtaskError> {
    let file =
        std::fs::File::open(archive).map_err(|source| XtaskError::Read { path: archive.to_path_buf(), source })?;
    let mut zip = zip::ZipArchive::new(file)?;
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(&mut zip.by_name(entry)?, &mut bytes)
        .map_err(|source| XtaskError::Read { path: archive.to_path_buf(), source })?;
    Ok(bytes)
}

/// What the compiler that cargo runs in `dir` prints for `args` (`rustup` may pick the
/// toolchain by folder).
fn rustc_output(dir: &Path, args: &[&str]) -> Result<String, XtaskError> {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".to_string());
    let output = Command::new(rustc).current_dir(dir).args(args).output().map_err(XtaskError::CargoNotRunnable)?;
    Ok(String::from_utf8_lossy(&output.stdout).to_string())
}

/// Unpacks the profile into `folder` and returns its path. The file is rewritten only when its
/// bytes change: the compiler tracks it as an input, and a new timestamp alone would rebuild
/// every library.
fn unpack_profile(archive: &Path, folder: &Path) -> Result<PathBuf, XtaskError> {
    let bytes = read_archive_entry(archive, PGO_PROFILE_ENTRY)?;
    let path = folder.join(PGO_PROFILE_ENTRY);
    if std::fs::read(&path).ok().as_deref() != Some(bytes.as_slice()) {
        std::fs::create_dir_all(folder).map_err(|source| XtaskError::Write { path: folder.to_path_buf(), source })?;
        std::fs::write(&path, &bytes).map_err(|source| XtaskError::Write { path: path.clone(), source })?;
    }
    Ok(path)
}

/// The cargo packages that build the FMUs' shared libraries, each once.
fn library_packages() -> Vec<&'static str> {
    let mut packages: Vec<&str> = all_fmus().iter().map(|s| package_of(s.library_name)).collect();
    packages.sort();
    packages.dedup();
    packages
}

/// Runs `cargo build` of the model crates with `extra_rustflags` added to the caller's own, and
/// returns what the compiler wrote to stderr (also passed on to this process's stderr).
fn cargo_build_libraries(
    source_root: &Path,
    target_dir: &Path,
    extra_rustflags: &[String],
) -> Result<String, XtaskError> {
    let packages = library_packages();
    let mut command = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string()));
    command
        .current_dir(source_root)
        .args(["build", "--profile", LIBRARY_PROFILE, "--quiet"])
        .arg("--target-dir")
        .arg(target_dir);
    for p in &packages {
        command.args(["-p", p]);
    }
    if !extra_rustflags.is_empty() {
        // CARGO_ENCODED_RUSTFLAGS (flags separated by 0x1f) keeps a path with spaces in one
        // flag, and takes precedence over RUSTFLAGS, whose flags it carries over.
        let mut flags: Vec<String> = match std::env::var("CARGO_ENCODED_RUSTFLAGS") {
            Ok(encoded) if !encoded.is_empty() => encoded.split('\x1f').map(str::to_string).collect(),
            _ => std::env::var("RUSTFLAGS").unwrap_or_default().split_whitespace().map(str::to_string).collect(),
        };
        flags.extend(extra_rustflags.iter().cloned());
        command.env("CARGO_ENCODED_RUSTFLAGS", flags.join("\x1f")).env_remove("RUSTFLAGS");
    }
    let output = command.stderr(std::process::Stdio::piped()).output().map_err(XtaskError::CargoNotRunnable)?;
    let stderr = String::from_utf8_lossy(&output.stderr).to_string();
    // Passed on, but for the warnings of functions without counts: a build whose settings
    // rename the symbols gets one per function (some 1,300), and the count says enough.
    let mut after_missing = false;
    for line in stderr.lines() {
        if line.contains(MISSING_COUNTS_WARNING) || (after_missing && line.trim().is_empty()) {
            after_missing = true;
            continue;
        }
        after_missing = false;
        eprintln!("{line}");
    }
    if !output.status.success() {
        return Err(XtaskError::BuildFailed { packages: packages.join(", "), status: output.status });
    }
    Ok(stderr)
}

/// Packages every FMU from the libraries in `target_dir/<LIBRARY_PROFILE>` into `output`.
pub fn package_all(target_dir: &Path, output: &Path) -> Result<Vec<PathBuf>, XtaskError> {
    package_all_platforms(target_dir, None, output)
}

/// [`package_all`], with each FMU's win64 library from `win64_target_dir` (built by
/// [`build_win64_libraries`]) beside its linux64 one when given.
pub fn package_all_platforms(
    target_dir: &Path,
    win64_target_dir: Option<&Path>,
    output: &Path,
) -> Result<Vec<PathBuf>, XtaskError> {
    std::fs::create_dir_all(output).map_err(|source| XtaskError::Write { path: output.to_path_buf(), source })?;
    let mut written = Vec::new();
    for spec in all_fmus() {
        let library = target_dir.join(LIBRARY_PROFILE).join(format!("lib{}.so", spec.library_name));
        let windows = win64_target_dir
            .map(|dir| dir.join(WIN64_TARGET).join(LIBRARY_PROFILE).join(format!("{}.dll", spec.library_name)));
        let path = output.join(format!("{}.fmu", spec.model_identifier));
        write_fmu_platforms(&spec, &library, windows.as_deref(), &path)?;
        written.push(path);
    }
    Ok(written)
}

/// The Rust target of the win64 binaries: Windows on x86-64 with the GNU tools (mingw-w64),
/// which a Linux machine can link.
pub const WIN64_TARGET: &str = "x86_64-pc-windows-gnu";

/// The compiler of the win64 binaries: `MEERKAT_WIN64_RUSTC`, or Debian's rustc-web
/// (`/usr/bin/rustc`). It must have its standard library's sources (Debian's rust-web-src),
/// from which cargo builds the standard library for the target: the project's machines cannot
/// fetch rustup's prebuilt one.
fn win64_rustc() -> Result<PathBuf, XtaskError> {
    let rustc = std::env::var_os("MEERKAT_WIN64_RUSTC").map(PathBuf::from).unwrap_or_else(|| "/usr/bin/rustc".into());
    let sysroot = Command::new(&rustc)
        .args(["--print", "sysroot"])
        .output()
        .map_err(|e| XtaskError::Win64ToolchainMissing(format!("cannot run {}: {e}", rustc.display())))?;
    let sysroot = PathBuf::from(String::from_utf8_lossy(&sysroot.stdout).trim());
    let sources = sysroot.join("lib/rustlib/src/rust/library/std");
    if !sources.is_dir() {
        return Err(XtaskError::Win64ToolchainMissing(format!(
            "{} has no standard library sources at {}",
            rustc.display(),
            sources.display()
        )));
    }
    let linker = Command::new("x86_64-w64-mingw32-gcc").arg("--version").output();
    if !linker.is_ok_and(|o| o.status.success()) {
        return Err(XtaskError::Win64ToolchainMissing("x86_64-w64-mingw32-gcc cannot be run".into()));
    }
    Ok(rustc)
}

/// Builds the FMUs' win64 libraries into `target_dir/x86_64-pc-windows-gnu/fmu-release/` with
/// the compiler of [`win64_rustc`], the standard library built from its sources
/// (`-Z build-std`, allowed on a stable compiler by `RUSTC_BOOTSTRAP`), linked by mingw-w64
/// without a time stamp in the PE header, so that the same sources give the same bytes.
pub fn build_win64_libraries(target_dir: &Path) -> Result<(), XtaskError> {
    let rustc = win64_rustc()?;
    let packages = library_packages();
    let mut command = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string()));
    command
        .current_dir(workspace_root())
        .args(["build", "--quiet", "--profile", LIBRARY_PROFILE, "--target", WIN64_TARGET])
        .args(["-Z", "build-std=std,panic_unwind"])
        .arg("--target-dir")
        .arg(target_dir)
        .env("RUSTC", &rustc)
        .env("RUSTC_BOOTSTRAP", "1")
        .env("CARGO_TARGET_X86_64_PC_WINDOWS_GNU_LINKER", "x86_64-w64-mingw32-gcc")
        .env("CARGO_TARGET_X86_64_PC_WINDOWS_GNU_RUSTFLAGS", "-Clink-arg=-Wl,--no-insert-timestamp")
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS");
    for p in &packages {
        command.args(["-p", p]);
    }
    let status = command.status().map_err(XtaskError::CargoNotRunnable)?;
    if !status.success() {
        return Err(XtaskError::BuildFailed {
            packages: format!("{} for {WIN64_TARGET}", packages.join(", ")),
            status,
        });
    }
    Ok(())
}

/// The packaged FMUs and what their build reported.
#[derive(Debug, Clone)]
pub struct Packaged {
    pub files: Vec<PathBuf>,
    pub build: LibraryBuild,
}

/// Builds and packages into the documented folder; what the main job and the tests rely on.
pub fn build_and_package(pgo: Pgo) -> Result<Packaged, XtaskError> {
    let stale = codegen(true)?;
    if !stale.is_empty() {
        return Err(XtaskError::StaleGeneratedFiles(stale));
    }
    let target = workspace_root().join("target");
    let build = build_libraries(&target, pgo)?;
    Ok(Packaged { files: package_all(&target, &fmu_directory())?, build })
}

/// Where `cargo xtask package --win64` writes the FMUs with both platforms' binaries; the
/// linux64-only ones stay in [`fmu_directory`], which the main job and the tests repackage.
pub fn multi_platform_directory() -> PathBuf {
    workspace_root().join("target").join("fmu-linux64-win64")
}

/// Builds the win64 libraries (into `target/win64/`) and packages every FMU with its linux64
/// and win64 binaries into [`multi_platform_directory`]; the linux64 libraries must have been
/// built by [`build_and_package`].
pub fn package_win64() -> Result<Vec<PathBuf>, XtaskError> {
    let target = workspace_root().join("target");
    let win64_target = target.join("win64");
    build_win64_libraries(&win64_target)?;
    package_all_platforms(&target, Some(&win64_target), &multi_platform_directory())
}

/// Records the profile that the FMUs' libraries are optimised with and writes it zipped to
/// [`PGO_PROFILE_ARCHIVE`] (returned): builds the libraries instrumented (exact counts, also
/// from several threads), packages them, runs the main job with them (the requirement
/// scenarios of the realistic antenna with their gust seeds, then of the paper's model) and
/// merges the counts with the toolchain's `llvm-profdata`.
///
/// The profile only steers how the compiler lays out and inlines the code: the FMUs compute
/// the same numbers with or without it. Record it again when the models' code changes
/// (`cargo xtask package --pgo` warns until then) or with another compiler (`--pgo` refuses
/// a profile another compiler recorded).
pub fn record_pgo_profile() -> Result<PathBuf, XtaskError> {
    let root = workspace_root();
    let profdata = llvm_profdata()?;
    let target = root.join("target").join("pgo-generate");
    let raw = target.join("profraw");
    let _ = std::fs::remove_dir_all(&raw);
    std::fs::create_dir_all(&raw).map_err(|source| XtaskError::Write { path: raw.clone(), source })?;
    cargo_build_libraries(
        &root,
        &target,
        &[
            format!("-Cprofile-generate={}", raw.join("build").display()),
            "-Cllvm-args=-instrprof-atomic-counter-update-all".to_string(),
        ],
    )?;
    let fmus = target.join("fmu");
    package_all(&target, &fmus)?;
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    let trainings: [&[&str]; 2] = [&[], &["--config", "paper", "--seeds", "1"]];
    for (k, extra) in trainings.iter().enumerate() {
        let out = target.join(format!("out-{k}"));
        let mut command = Command::new(&cargo);
        command
            .current_dir(&root)
            .args(["run", "--release", "--quiet", "-p", "antenna-cli", "--bin", "antenna", "--", "--no-build", "--out"])
            .arg(&out)
            .args(*extra)
            .env("MEERKAT_FMU_DIR", &fmus)
            // One file per library (%m), to which every run adds its counts.
            .env("LLVM_PROFILE_FILE", raw.join("fmu-%m.profraw"))
            .stdout(std::process::Stdio::null());
        let status = command.status().map_err(XtaskError::CargoNotRunnable)?;
        if !status.success() {
            return Err(XtaskError::Training { what: format!("antenna {}", extra.join(" ")), status });
        }
    }
    let mut inputs: Vec<PathBuf> = std::fs::read_dir(&raw)
        .map_err(|source| XtaskError::Read { path: raw.clone(), source })?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "profraw"))
        .collect();
    if inputs.is_empty() {
        return Err(XtaskError::NoProfile(raw));
    }
    inputs.sort();
    let merged = target.join(PGO_PROFILE_ENTRY);
    let status = Command::new(&profdata)
        .arg("merge")
        .arg("-o")
        .arg(&merged)
        .args(&inputs)
        .status()
        .map_err(XtaskError::CargoNotRunnable)?;
    if !status.success() {
        return Err(XtaskError::Training { what: "llvm-profdata merge".to_string(), status });
    }
    let bytes = std::fs::read(&merged).map_err(|source| XtaskError::Read { path: merged.clone(), source })?;
    let archive = root.join(PGO_PROFILE_ARCHIVE);
    if let Some(parent) = archive.parent() {
        std::fs::create_dir_all(parent).map_err(|source| XtaskError::Write { path: parent.to_path_buf(), source })?;
    }
    let file = std::fs::File::create(&archive).map_err(|source| XtaskError::Write { path: archive.clone(), source })?;
    let mut zip = ZipWriter::new(file);
    let options = SimpleFileOptions::default()
        .compression_method(CompressionMethod::Deflated)
        .compression_level(Some(9))
        .last_modified_time(DateTime::default())
        .unix_permissions(0o644);
    let toolchain = rustc_output(&root, &["-vV"])?;
    for (entry, contents) in [(PGO_PROFILE_ENTRY, bytes.as_slice()), (PGO_TOOLCHAIN_ENTRY, toolchain.as_bytes())] {
        zip.start_file(entry, options)?;
        zip.write_all(contents).map_err(|source| XtaskError::Write { path: archive.clone(), source })?;
    }
    zip.finish()?;
    Ok(archive)
}

/// The toolchain's own `llvm-profdata` (rustup's `llvm-tools` component): its LLVM is the
/// compiler's, so it reads the counts the instrumented libraries write.
fn llvm_profdata() -> Result<PathBuf, XtaskError> {
    let root = workspace_root();
    let sysroot = rustc_output(&root, &["--print", "sysroot"])?.trim().to_string();
    let version = rustc_output(&root, &["-vV"])?;
    let host = version.lines().find_map(|l| l.strip_prefix("host: ")).unwrap_or("x86_64-unknown-linux-gnu");
    let path = Path::new(&sysroot).join("lib/rustlib").join(host).join("bin/llvm-profdata");
    if path.is_file() {
        Ok(path)
    } else {
        Err(XtaskError::ProfdataMissing(path))
    }
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
    write_fmu_platforms(spec, shared_library, None, output)
}

/// [`write_fmu`] with the win64 library (`binaries/win64/<id>.dll`) when given.
pub fn write_fmu_platforms(
    spec: &FmuSpec,
    shared_library: &Path,
    win64_library: Option<&Path>,
    output: &Path,
) -> Result<(), XtaskError> {
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
    if let Some(path) = win64_library {
        let bytes = std::fs::read(path).map_err(|source| XtaskError::Read { path: path.to_path_buf(), source })?;
        entries.push((format!("binaries/win64/{}.dll", spec.model_identifier), bytes, 0o755));
    }
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
pub fn reproducibility_differences(reference: &[PathBuf], pgo: Pgo) -> Result<Vec<String>, XtaskError> {
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
    build_libraries_from(&copy.join("checkout"), &target, pgo).map_err(|e| XtaskError::SecondBuild(Box::new(e)))?;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_used_profile_that_fits_the_code_is_no_problem() {
        let build = LibraryBuild { profile: ProfileUse::Used, ..LibraryBuild::default() };
        assert_eq!(build.profile_problem(), None);
        assert_eq!(LibraryBuild::default().profile_problem(), None, "no profile committed: nothing to check");
    }

    #[test]
    fn functions_the_profile_no_longer_fits_are_a_problem_counted_in_the_message() {
        let warning =
            "warning: fmu_controller.cgu.0: function control flow change detected (hash mismatch) _ZN3fooE Hash = 1";
        let stderr = format!("{warning}\n\n{warning}\n");
        let build = LibraryBuild {
            profile: ProfileUse::Used,
            functions_with_changed_code: count_lines_with(&stderr, CHANGED_CODE_WARNING),
            ..LibraryBuild::default()
        };
        let problem = build.profile_problem().expect("stale counts are a problem");
        assert!(problem.contains("2 function(s)") && problem.contains("cargo xtask pgo"), "{problem}");
    }

    #[test]
    fn functions_the_profile_has_no_counts_for_are_a_problem_counted_in_the_message() {
        // What a build whose settings rename every symbol gives: no function has counts, and
        // the compiler says nothing unless asked.
        let build =
            LibraryBuild { profile: ProfileUse::Used, functions_without_counts: 1347, ..LibraryBuild::default() };
        let problem = build.profile_problem().expect("functions without counts are a problem");
        assert!(problem.contains("no counts for 1347 function(s)") && problem.contains("cargo xtask pgo"), "{problem}");
    }

    #[test]
    fn a_profile_from_another_compiler_is_refused_naming_both_releases() {
        let recorded = "rustc 1.95.0\nrelease: 1.95.0\nLLVM version: 22.1.2\n".to_string();
        let current = "rustc 1.96.0\nrelease: 1.96.0\nLLVM version: 22.1.8\n".to_string();
        let problem = XtaskError::ProfileOtherToolchain { recorded, current }.to_string();
        assert!(problem.contains("release: 1.95.0") && problem.contains("release: 1.96.0"), "{problem}");
    }
}
