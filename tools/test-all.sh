#!/usr/bin/env bash
# Runs every test of the project on a fresh machine: checks formatting and lints, builds and
# packages the FMUs, checks that the generated model descriptions are fresh, runs the Rust tests
# (which load the packaged .fmu files through the C ABI) and the Python tests with fmpy in a
# private virtual environment. The build tasks run through the `cargo xtask` alias
# (.cargo/config.toml).
#
# `--long` adds the long tier: the statistical and end-to-end checks that do not fit in the
# test command's 15 minutes (the Rust tests marked `#[ignore = "long: ..."]`, the Python tests
# marked `long`), the rebuild of the FMUs from a copy of the sources at another path that
# must give byte-identical archives, and the FMUs' win64 binaries run under wine beside their
# linux64 ones. The last needs Debian's rustc-web, rust-web-src, gcc-mingw-w64-x86-64 and
# wine64, which `--long` installs with apt-get when it runs as root and they are missing.
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

# Steps that wait on the network or leave a core idle run beside others: the Python environment
# is installed while the FMUs build, and clippy (a build of its own, about 5 minutes from a
# fresh clone) and the fmpy tests, which keep one core busy, run while the Rust tests run.
# Their output is kept in target/test-all/ and shown when they end; any failing fails the
# command.
logs=target/test-all
mkdir -p "$logs"

echo "== formatting (cargo fmt --check)"
cargo fmt --all --check

echo "== the Python environment (.venv), installed in the background"
(
    if [ ! -x .venv/bin/python ]; then
        python3 -m venv .venv
    fi
    .venv/bin/python -m pip install --quiet --disable-pip-version-check -r tests/python/requirements.txt
    .venv/bin/python -m pip install --quiet --disable-pip-version-check --no-deps -e tools/fmpy_master
) >"$logs/venv.log" 2>&1 &
venv=$!

echo "== generated files are fresh"
cargo xtask codegen --check

if [ "$long" = 1 ]; then
    if ! command -v x86_64-w64-mingw32-gcc >/dev/null 2>&1 || [ ! -x /usr/lib/wine/wine64 ] \
        || [ ! -d /usr/lib/rustlib/src/rust/library/std ]; then
        if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
            echo "== the win64 tools (Debian: rustc-web, rust-web-src, gcc-mingw-w64-x86-64, wine64)"
            apt-get install -y -q --no-install-recommends rustc-web rust-web-src gcc-mingw-w64-x86-64 wine64 >/dev/null
        else
            echo "--long needs rustc-web, rust-web-src, gcc-mingw-w64-x86-64 and wine64 (apt install as root)" >&2
            exit 1
        fi
    fi
    echo "== build and package the FMUs into target/fmu/, and again from a copy at another path: byte-identical;"
    echo "   and with win64 binaries beside the linux64 ones into target/fmu-linux64-win64/"
    cargo xtask package --reproducibility-check --win64
else
    echo "== build and package the FMUs into target/fmu/"
    cargo xtask package
fi

# The Rust test binaries are built first; then they run while the fmpy tests (one core, the Rust
# master started from the binary just built through ANTENNA_BIN, so they never wait for cargo's
# lock) and clippy (its own target folder) run beside them, so that no core idles while one
# test binary runs alone. The examples are not built here (clippy checks them with
# --all-targets) and no crate has doc examples, so no doc tests are collected.
rust_targets=(--workspace --lib --bins --tests)
echo "== Rust tests: build"
cargo test --release "${rust_targets[@]}" --no-run --quiet

if ! wait "$venv"; then
    cat "$logs/venv.log" >&2
    echo "the Python environment could not be installed" >&2
    exit 1
fi

echo "== lints (clippy, warnings are errors) and the Python tests with fmpy, beside the Rust tests"
CARGO_TARGET_DIR=target/clippy cargo clippy --release --workspace --all-targets --quiet -- -D warnings \
    >"$logs/clippy.log" 2>&1 &
clippy=$!
pytest_marks=(-m "not long")
if [ "$long" = 1 ]; then
    pytest_marks=()
fi
ANTENNA_BIN="$PWD/target/release/antenna" .venv/bin/python -m pytest -q "${pytest_marks[@]}" tests/python \
    >"$logs/pytest.log" 2>&1 &
python=$!

echo "== Rust tests: run"
rust_status=0
if [ "$long" = 1 ]; then
    cargo test --release "${rust_targets[@]}" --quiet -- --include-ignored || rust_status=$?
else
    cargo test --release "${rust_targets[@]}" --quiet || rust_status=$?
fi

python_status=0
wait "$python" || python_status=$?
echo "== Python tests with fmpy"
cat "$logs/pytest.log"
clippy_status=0
wait "$clippy" || clippy_status=$?
if [ "$clippy_status" != 0 ]; then
    cat "$logs/clippy.log" >&2
    echo "clippy found problems (above)" >&2
fi
if [ "$rust_status" != 0 ] || [ "$python_status" != 0 ] || [ "$clippy_status" != 0 ]; then
    exit 1
fi

echo "== all tests passed"
