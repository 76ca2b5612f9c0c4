//! The repository's rules, checked on its sources (after rust-analyzer's "repo rules as tests"):
//! crates depend only on what ARCHITECTURE.md allows, `unsafe` stays on the FMI boundary with a
//! reason at every block, every crate opts into the workspace lints, every module says what it
//! is for, and the model crates never print.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("tests/ lives in the workspace root").to_path_buf()
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

/// The workspace members' folders, from the root Cargo.toml.
fn members() -> Vec<String> {
    let manifest = read(&workspace_root().join("Cargo.toml"));
    let start = manifest.find("members = [").expect("a members list in the root Cargo.toml");
    let end = start + manifest[start..].find(']').expect("the end of the members list");
    manifest[start..end]
        .lines()
        .filter_map(|line| line.trim().strip_prefix('"').and_then(|l| l.split('"').next()))
        .map(str::to_string)
        .collect()
}

/// A member's package name and the names of its normal and build dependencies.
fn package_and_dependencies(member: &str) -> (String, BTreeSet<String>) {
    let manifest = read(&workspace_root().join(member).join("Cargo.toml"));
    let mut name = None;
    let mut section = String::new();
    let mut dependencies = BTreeSet::new();
    for line in manifest.lines().map(str::trim) {
        if line.starts_with('[') {
            section = line.to_string();
            continue;
        }
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let key = line.split(['=', '.', ' ']).next().unwrap_or("").trim().to_string();
        if section == "[package]" && key == "name" {
            name = line.split('"').nth(1).map(str::to_string);
        }
        if section == "[dependencies]" || section == "[build-dependencies]" {
            dependencies.insert(key);
        }
    }
    (name.unwrap_or_else(|| panic!("{member}/Cargo.toml has no package name")), dependencies)
}

/// The crate table of ARCHITECTURE.md: crate name -> the workspace crates it may depend on
/// (`None` for "any").
fn documented_layers() -> BTreeMap<String, Option<BTreeSet<String>>> {
    let text = read(&workspace_root().join("ARCHITECTURE.md"));
    let mut layers = BTreeMap::new();
    for line in text.lines().filter(|l| l.starts_with("| `")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() < 6 {
            continue;
        }
        let crate_cell = cells[2];
        let allowed_cell = cells[4];
        let names = |cell: &str| -> BTreeSet<String> {
            cell.split('`').skip(1).step_by(2).map(str::to_string).collect::<BTreeSet<_>>()
        };
        let allowed = if allowed_cell == "any" { None } else { Some(names(allowed_cell)) };
        for name in names(crate_cell) {
            layers.insert(name, allowed.clone());
        }
    }
    layers
}

#[test]
fn every_crate_depends_only_on_the_workspace_crates_architecture_md_allows() {
    let layers = documented_layers();
    let packages: BTreeMap<String, (String, BTreeSet<String>)> = members()
        .into_iter()
        .map(|m| (package_and_dependencies(&m).0, (m.clone(), package_and_dependencies(&m).1)))
        .collect();
    let workspace_crates: BTreeSet<&String> = packages.keys().collect();
    let mut violations = Vec::new();
    for (name, (member, dependencies)) in &packages {
        // The three cdylib crates share one row, `fmu-*-cdylib`: their own model crate and the runtime.
        let allowed = if name.ends_with("-cdylib") {
            let model = name.trim_end_matches("-cdylib").to_string();
            Some([model, "fmu-runtime".to_string()].into_iter().collect())
        } else {
            match layers.get(name) {
                Some(allowed) => allowed.clone(),
                None => {
                    violations.push(format!("{name} ({member}) has no row in ARCHITECTURE.md's crate table"));
                    continue;
                }
            }
        };
        let Some(allowed) = allowed else { continue };
        for dependency in dependencies.iter().filter(|d| workspace_crates.contains(d)) {
            if !allowed.contains(dependency) {
                violations.push(format!("{name} depends on {dependency}, which ARCHITECTURE.md does not allow"));
            }
        }
    }
    assert!(violations.is_empty(), "{}", violations.join("\n"));
}

#[test]
fn every_crate_opts_into_the_workspace_lints() {
    let missing: Vec<String> = members()
        .into_iter()
        .filter(|m| !read(&workspace_root().join(m).join("Cargo.toml")).contains("[lints]\nworkspace = true"))
        .collect();
    assert!(missing.is_empty(), "no `[lints] workspace = true` in: {missing:?}");
}

/// Every `.rs` file below `dir`.
fn rust_files_below(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else { return out };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            out.extend(rust_files_below(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
    out
}

/// Every `.rs` file under the members' `src/` folders.
fn source_files() -> Vec<(String, PathBuf)> {
    let mut files = Vec::new();
    for member in members() {
        let found = rust_files_below(&workspace_root().join(&member).join("src"));
        files.extend(found.into_iter().map(|p| (member.clone(), p)));
    }
    files.sort();
    files
}

/// The code of a file before its first `#[cfg(test)]`, without comments.
fn code_outside_tests(text: &str) -> Vec<(usize, String)> {
    let end = text.find("#[cfg(test)]").unwrap_or(text.len());
    text[..end]
        .lines()
        .enumerate()
        .map(|(i, line)| (i + 1, line.split("//").next().unwrap_or("").to_string()))
        .collect()
}

fn is_unsafe_code(line: &str) -> bool {
    ["unsafe {", "unsafe fn", "unsafe impl", "unsafe extern"].iter().any(|pattern| line.contains(pattern))
}

#[test]
fn unsafe_code_lives_only_on_the_fmi_boundary() {
    let boundary = ["fmu-runtime", "fmu-runtime/ffi", "fmu-import"];
    let mut violations = Vec::new();
    for (member, path) in source_files() {
        if boundary.contains(&member.as_str()) {
            continue;
        }
        for (line_number, line) in code_outside_tests(&read(&path)) {
            if is_unsafe_code(&line) {
                violations.push(format!("{}:{line_number}: {}", path.display(), line.trim()));
            }
        }
    }
    assert!(violations.is_empty(), "unsafe outside fmu-runtime and fmu-import:\n{}", violations.join("\n"));
}

#[test]
fn every_unsafe_block_on_the_boundary_says_why_it_is_sound() {
    let mut violations = Vec::new();
    for (member, path) in source_files().into_iter().filter(|(m, _)| m == "fmu-runtime" || m == "fmu-import") {
        let text = read(&path);
        let lines: Vec<&str> = text.lines().collect();
        for (index, line) in lines.iter().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            if !code.contains("unsafe {") {
                continue;
            }
            // The reason stands on the line itself or in the comment lines just above it.
            let from = index.saturating_sub(6);
            let explained = lines[from..=index].iter().any(|l| l.contains("SAFETY:"));
            if !explained {
                violations.push(format!("{member}: {}:{}: {}", path.display(), index + 1, line.trim()));
            }
        }
    }
    assert!(violations.is_empty(), "unsafe blocks without a `// SAFETY:` reason:\n{}", violations.join("\n"));
}

#[test]
fn every_module_starts_with_a_line_saying_what_it_is_for() {
    let missing: Vec<String> = source_files()
        .into_iter()
        .filter(|(_, path)| !read(path).trim_start().starts_with("//!"))
        .map(|(_, path)| path.display().to_string())
        .collect();
    assert!(missing.is_empty(), "modules without a `//!` header:\n{}", missing.join("\n"));
}

#[test]
fn the_model_crates_never_print() {
    // An FMU runs inside someone else's process: it reports through the master's logger only.
    let models = ["fmu-runtime", "fmu-plant", "fmu-wind", "fmu-controller", "fmu-structure", "lti"];
    let mut violations = Vec::new();
    for (member, path) in source_files() {
        if !models.iter().any(|m| member == *m || member.starts_with(&format!("{m}/"))) {
            continue;
        }
        for (line_number, line) in code_outside_tests(&read(&path)) {
            if ["println!", "eprintln!", "print!(", "eprint!(", "dbg!("].iter().any(|p| line.contains(p)) {
                violations.push(format!("{}:{line_number}: {}", path.display(), line.trim()));
            }
        }
    }
    assert!(violations.is_empty(), "printing in model code:\n{}", violations.join("\n"));
}

/// The sibling modules a top-level module of a crate refers to (`crate::name`, or `super::name`
/// from a file directly in `src/`), outside its tests and comments.
fn module_references(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let files = rust_files_below(src);
    let top_level = |path: &Path| -> Option<String> {
        let relative = path.strip_prefix(src).ok()?;
        let first = relative.components().next()?.as_os_str().to_string_lossy().trim_end_matches(".rs").to_string();
        (!["lib", "main", "bin"].contains(&first.as_str())).then_some(first)
    };
    let names: BTreeSet<String> = files.iter().filter_map(|p| top_level(p)).collect();
    let mut references: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for path in &files {
        let Some(module) = top_level(path) else { continue };
        let directly_in_src = path.parent() == Some(src);
        let code: String = code_outside_tests(&read(path)).into_iter().map(|(_, l)| l + "\n").collect();
        let mut found = BTreeSet::new();
        for prefix in ["crate::", "super::"] {
            if prefix == "super::" && !directly_in_src {
                continue;
            }
            for piece in code.split(prefix).skip(1) {
                let name: String = piece.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                if names.contains(&name) && name != module {
                    found.insert(name);
                }
            }
        }
        references.entry(module).or_default().extend(found);
    }
    references
}

#[test]
fn no_two_modules_of_a_crate_depend_on_each_other() {
    let mut cycles = Vec::new();
    for member in members() {
        let src = workspace_root().join(&member).join("src");
        let references = module_references(&src);
        for (module, uses) in &references {
            for other in uses {
                if module < other && references.get(other).is_some_and(|back| back.contains(module)) {
                    cycles.push(format!("{member}: {module} <-> {other}"));
                }
            }
        }
    }
    assert!(cycles.is_empty(), "modules that use each other:\n{}", cycles.join("\n"));
}
