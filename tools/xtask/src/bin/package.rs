//! Builds the release shared libraries and writes every `.fmu` into `target/fmu/`.
//!
//! `--reproducibility-check` also builds a second copy of the sources in another folder and
//! another target directory and checks that every `.fmu` is byte-identical.

use std::path::Path;
use std::process::ExitCode;


fn main() -> ExitCode {
    let check = std::env::args().any(|a| a == "--reproducibility-check");
    let written = match xtask::build_and_package() {
        Ok(w) => w,
        Err(e) => {
            eprintln!("packaging failed: {e}");
            return ExitCode::FAILURE;
        }
    };
    for path in &written {
        let size = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
        println!("{} ({} bytes)", path.display(), size);
    }
    if check {
        match reproducibility_check(&written) {
            Ok(()) => println!("reproducible: a build from another checkout path gives byte-identical .fmu files"),
            Err(e) => {
                eprintln!("reproducibility check failed: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    ExitCode::SUCCESS
}

/// Copies the tracked sources to a temporary folder, builds there with its own target
/// directory, packages, and compares byte for byte.
fn reproducibility_check(reference: &[std::path::PathBuf]) -> Result<(), String> {
    let root = antenna_fmus::workspace_root();
    let copy = std::env::temp_dir().join(format!("meerkat-repro-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&copy);
    let files = std::process::Command::new("git")
        .current_dir(&root)
        .args(["ls-files", "--cached", "--others", "--exclude-standard"])
        .output()
        .map_err(|e| format!("git ls-files: {e}"))?;
    for file in String::from_utf8_lossy(&files.stdout).lines() {
        let from = root.join(file);
        if !from.is_file() {
            continue;
        }
        let to = copy.join("checkout").join(file);
        std::fs::create_dir_all(to.parent().unwrap()).map_err(|e| e.to_string())?;
        std::fs::copy(&from, &to).map_err(|e| format!("copy {file}: {e}"))?;
    }
    // Only the shared libraries are built from the copy (they are what a checkout path could
    // leak into); they are packaged by this binary's own code, as the first build was.
    let target = copy.join("target");
    let out = copy.join("fmu");
    xtask::build_libraries_from(&copy.join("checkout"), &target)
        .map_err(|e| format!("the second build failed: {e}"))?;
    xtask::package_all(&target, &out)?;
    for path in reference {
        let name = path.file_name().unwrap();
        let a = std::fs::read(path).map_err(|e| e.to_string())?;
        let b = std::fs::read(out.join(name)).map_err(|e| format!("{}: {e}", Path::new(name).display()))?;
        if a != b {
            return Err(format!("{} differs between the two builds", Path::new(name).display()));
        }
    }
    let _ = std::fs::remove_dir_all(&copy);
    Ok(())
}
