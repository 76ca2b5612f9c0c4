#!/usr/bin/env bash
# Runs every test of the project on a fresh machine: checks formatting and lints, builds and
# packages the FMUs, checks that the generated model descriptions are fresh, runs the Rust tests
# (which load the packaged .fmu files through the C ABI) and the Python tests with fmpy in a
# private virtual environment. The build tasks run through the `cargo xtask` alias
# (.cargo/config.toml).
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v cargo >/dev/null 2>&1; then
    echo "cargo not found: install Rust with rustup (https://rustup.rs) first" >&2
    exit 1
fi

echo "== formatting (cargo fmt --check) and lints (clippy, warnings are errors)"
cargo fmt --all --check
cargo clippy --release --workspace --all-targets --quiet -- -D warnings

echo "== generated files are fresh"
cargo xtask codegen --check

echo "== build and package the FMUs into target/fmu/, and again from a copy at another path: byte-identical"
cargo xtask package --reproducibility-check

echo "== Rust tests"
cargo test --release --workspace --quiet

echo "== Python tests with fmpy"
if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
fi
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r tests/python/requirements.txt
.venv/bin/python -m pip install --quiet --disable-pip-version-check --no-deps -e tools/fmpy_master
.venv/bin/python -m pytest -q tests/python

echo "== all tests passed"
