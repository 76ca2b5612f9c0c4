//! The repository's rules, checked on its sources (after rust-analyzer's "repo rules as tests"):
//! crates depend only on what ARCHITECTURE.md allows, `unsafe` stays on the FMI boundary with a
//! reason at every block, every crate opts into the workspace lints, every module says what it
//! is for, the model crates never print, and no modules of a crate depend on each other in a circle.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("tests/ lives in the workspace root").to_path_buf()
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

/// One workspace crate as `cargo metadata` describes it: its folder relative to the workspace
/// root, its package name, and the names of its dependencies by kind.
struct Member {
    folder: String,
    name: String,
    /// Normal and build dependencies: what the crate itself is built from.
    dependencies: BTreeSet<String>,
    /// Dev-dependencies: what only its tests, examples and benchmarks use.
    dev_dependencies: BTreeSet<String>,
}

/// The workspace members, read through `cargo metadata` (never by parsing manifests by hand:
/// cargo resolves `workspace = true`, renames and targets the same way it builds).
fn members_with_dependencies() -> Vec<Member> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    let output = std::process::Command::new(cargo)
        .args(["metadata", "--format-version", "1", "--no-deps", "--offline"])
        .current_dir(workspace_root())
        .output()
        .expect("cargo metadata runs");
    assert!(output.status.success(), "cargo metadata failed: {}", String::from_utf8_lossy(&output.stderr));
    let metadata: serde_json::Value = serde_json::from_slice(&output.stdout).expect("cargo metadata prints JSON");
    let root = workspace_root();
    let mut members: Vec<Member> = metadata["packages"]
        .as_array()
        .expect("a packages list")
        .iter()
        .map(|package| {
            let manifest = PathBuf::from(package["manifest_path"].as_str().expect("a manifest path"));
            let folder = manifest.parent().and_then(|f| f.strip_prefix(&root).ok()).expect("a member below the root");
            let mut member = Member {
                folder: folder.to_string_lossy().replace('\\', "/"),
                name: package["name"].as_str().expect("a package name").to_string(),
                dependencies: BTreeSet::new(),
                dev_dependencies: BTreeSet::new(),
            };
            for dependency in package["dependencies"].as_array().expect("a dependency list") {
                let name = dependency["name"].as_str().expect("a dependency name").to_string();
                match dependency["kind"].as_str() {
                    Some("dev") => member.dev_dependencies.insert(name),
                    _ => member.dependencies.insert(name),
                };
            }
            member
        })
        .collect();
    members.sort_by(|a, b| a.folder.cmp(&b.folder));
    members
}

/// The workspace members' folders.
fn members() -> Vec<String> {
    members_with_dependencies().into_iter().map(|m| m.folder).collect()
}

/// What one row of ARCHITECTURE.md's crate table allows (`None` for "any").
struct Allowed {
    dependencies: Option<BTreeSet<String>>,
    /// What its tests may use besides (dev-dependencies).
    in_tests: BTreeSet<String>,
}

/// The crate table of ARCHITECTURE.md: crate name -> the workspace crates it may depend on,
/// and those its tests may use besides.
fn documented_layers() -> BTreeMap<String, Allowed> {
    let text = read(&workspace_root().join("ARCHITECTURE.md"));
    let mut layers = BTreeMap::new();
    for line in text.lines().filter(|l| l.starts_with("| `")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() < 7 {
            continue;
        }
        let names = |cell: &str| -> BTreeSet<String> {
            cell.split('`').skip(1).step_by(2).map(str::to_string).collect::<BTreeSet<_>>()
        };
        let allowed = Allowed {
            dependencies: if cells[4] == "any" { None } else { Some(names(cells[4])) },
            in_tests: names(cells[5]),
        };
        for name in names(cells[2]) {
            layers.insert(
                name,
                Allowed { dependencies: allowed.dependencies.clone(), in_tests: allowed.in_tests.clone() },
            );
        }
    }
    layers
}

#[test]
fn every_crate_and_its_tests_depend_only_on_the_workspace_crates_architecture_md_allows() {
    let layers = documented_layers();
    let members = members_with_dependencies();
    let workspace_crates: BTreeSet<&String> = members.iter().map(|m| &m.name).collect();
    let mut violations = Vec::new();
    for member in &members {
        let name = &member.name;
        // The cdylib crates share one row, `fmu-*-cdylib`: their own model crate and the runtime.
        let (allowed, in_tests) = if name.ends_with("-cdylib") {
            let model = name.trim_end_matches("-cdylib").to_string();
            (Some([model, "fmu-runtime".to_string()].into_iter().collect::<BTreeSet<_>>()), BTreeSet::new())
        } else {
            match layers.get(name) {
                Some(row) => (row.dependencies.clone(), row.in_tests.clone()),
                None => {
                    violations.push(format!("{name} ({}) has no row in ARCHITECTURE.md's crate table", member.folder));
                    continue;
                }
            }
        };
        let Some(allowed) = allowed else { continue };
        for dependency in member.dependencies.iter().filter(|d| workspace_crates.contains(d)) {
            if !allowed.contains(dependency) {
                violations.push(format!("{name} depends on {dependency}, which ARCHITECTURE.md does not allow"));
            }
        }
        for dependency in member.dev_dependencies.iter().filter(|d| workspace_crates.contains(d)) {
            if !allowed.contains(dependency) && !in_tests.contains(dependency) {
                violations.push(format!(
                    "the tests of {name} use {dependency}, which ARCHITECTURE.md's column \"its tests may also use\" does not list"
                ));
            }
        }
    }
    assert!(violations.is_empty(), "{}", violations.join("\n"));
}

#[test]
fn the_crate_table_catches_a_test_only_dependency_it_does_not_list() {
    // The check above must not pass vacuously: every workspace crate has a row, and the table's
    // test column is read (fmu-wind's tests plot through antenna-plot, and the table says so).
    let layers = documented_layers();
    let members = members_with_dependencies();
    for member in members.iter().filter(|m| !m.name.ends_with("-cdylib")) {
        assert!(layers.contains_key(&member.name), "{} has no row", member.name);
    }
    let wind = members.iter().find(|m| m.name == "fmu-wind").expect("fmu-wind is a member");
    assert!(wind.dev_dependencies.contains("antenna-plot"), "cargo metadata reports dev-dependencies");
    assert!(layers["fmu-wind"].in_tests.contains("antenna-plot"), "the table's test column is read");
    assert!(!layers["fmu-wind"].dependencies.as_ref().expect("a list").contains("antenna-plot"));
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

/// A circle of references through `start` (the modules in order, `start` first), if any: a
/// depth-first search from `start` that looks for a way back to it, of any length.
fn circle_through(start: &str, references: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn search(
        path: &mut Vec<String>,
        visited: &mut BTreeSet<String>,
        start: &str,
        references: &BTreeMap<String, BTreeSet<String>>,
    ) -> bool {
        let current = path.last().expect("the path starts at `start`").clone();
        for next in references.get(&current).into_iter().flatten() {
            if next == start {
                return true;
            }
            if visited.insert(next.clone()) {
                path.push(next.clone());
                if search(path, visited, start, references) {
                    return true;
                }
                path.pop();
            }
        }
        false
    }
    let mut path = vec![start.to_string()];
    let mut visited = BTreeSet::from([start.to_string()]);
    search(&mut path, &mut visited, start, references).then_some(path)
}

/// Every circle of module references in `references`, each reported once (from its smallest
/// module) as "a -> b -> c -> a".
fn module_circles(references: &BTreeMap<String, BTreeSet<String>>) -> Vec<String> {
    let mut reported: BTreeSet<BTreeSet<String>> = BTreeSet::new();
    let mut circles = Vec::new();
    for module in references.keys() {
        if let Some(circle) = circle_through(module, references) {
            let members: BTreeSet<String> = circle.iter().cloned().collect();
            if reported.insert(members) {
                circles.push(format!("{} -> {module}", circle.join(" -> ")));
            }
        }
    }
    circles
}

#[test]
fn no_modules_of_a_crate_depend_on_each_other_through_a_circle_of_any_length() {
    let mut circles = Vec::new();
    for member in members() {
        let references = module_references(&workspace_root().join(&member).join("src"));
        circles.extend(module_circles(&references).into_iter().map(|c| format!("{member}: {c}")));
    }
    assert!(circles.is_empty(), "modules that depend on each other in a circle:\n{}", circles.join("\n"));
}

#[test]
fn the_circle_check_finds_circles_of_two_three_and_four_modules_and_no_false_ones() {
    let graph = |edges: &[(&str, &str)]| -> BTreeMap<String, BTreeSet<String>> {
        let mut references: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (from, to) in edges {
            references.entry(from.to_string()).or_default().insert(to.to_string());
            references.entry(to.to_string()).or_default();
        }
        references
    };
    assert_eq!(module_circles(&graph(&[("a", "b"), ("b", "a")])), ["a -> b -> a"]);
    assert_eq!(module_circles(&graph(&[("checks", "instance"), ("instance", "state"), ("state", "checks")])).len(), 1);
    assert_eq!(
        module_circles(&graph(&[("a", "b"), ("b", "c"), ("c", "d"), ("d", "a"), ("x", "a")])),
        ["a -> b -> c -> d -> a"]
    );
    // A diamond is layered, not circular.
    assert!(module_circles(&graph(&[("a", "b"), ("a", "c"), ("b", "d"), ("c", "d")])).is_empty());
}
