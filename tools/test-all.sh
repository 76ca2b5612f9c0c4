#!/usr/bin/env bash
# Runs every test of the project on a fresh machine: checks formatting and lints, builds and
# packages the FMUs, checks that the generated model descriptions are fresh, runs the Rust tests
# (which load the packaged .fmu files through the C ABI) and the Python tests with fmpy in a
# private virtual environment. The build tasks run through the `cargo xtask` alias
# (.cargo/config.toml).
#
# `--long` adds the long tier: the statistical and end-to-end checks that do not fit in the
# test command's 15 minutes (the Rust tests marked `#[ignore = "long: ..."]`, the Python tests
# marked `long`), and the rebuild of the FMUs from a copy of the sources at another path that
# must give byte-identical archives.
set -euo pipefail
cd "$(dirname "$0")/.."

long=0
for argument in "$@"; do
    case "$argument" in
        --long) long=1 ;;
        *) echo "usage: tools/test-all.sh [--long]" >&2; exit 2 ;;
    esac
done

if ! command -v cargo >/dev/null 2>&1; then
    echo "cargo not found: install Rust with rustup (https://rustup.rs) first" >&2
    exit 1
fi

echo "== formatting (cargo fmt --check) and lints (clippy, warnings are errors)"
cargo fmt --all --check
cargo clippy --release --workspace --all-targets --quiet -- -D warnings

echo "== generated files are fresh"
cargo xtask codegen --check

if [ "$long" = 1 ]; then
    echo "== build and package the FMUs into target/fmu/, and again from a copy at another path: byte-identical"
    cargo xtask package --reproducibility-check
else
    echo "== build and package the FMUs into target/fmu/"
    cargo xtask package
fi

echo "== Rust tests"
if [ "$long" = 1 ]; then
    cargo test --release --workspace --quiet -- --include-ignored
else
    cargo test --release --workspace --quiet
fi

echo "== Python tests with fmpy"
if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
fi
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r tests/python/requirements.txt
.venv/bin/python -m pip install --quiet --disable-pip-version-check --no-deps -e tools/fmpy_master
if [ "$long" = 1 ]; then
    .venv/bin/python -m pytest -q tests/python
else
    .venv/bin/python -m pytest -q -m "not long" tests/python
fi

echo "== all tests passed"
