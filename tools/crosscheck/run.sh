#!/usr/bin/env bash
# Cross-check glimpse's path tracer against Mitsuba 3: installs Mitsuba (PyPI `mitsuba`, its
# scalar_rgb variant, pinned to 3.9.1, the version the bounds were measured with) into
# target/mitsuba-venv on first use, builds glimpse in release, then runs
# crosscheck.py with the arguments given (see `run.sh --help`).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
venv="$root/target/mitsuba-venv"
if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c "import mitsuba, numpy; assert mitsuba.__version__ == '3.9.1'" 2>/dev/null; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet "mitsuba==3.9.1" numpy
fi
# GLIMPSE=path uses that binary (CI: the one `cargo test` built) instead of a release build.
if [ -z "${GLIMPSE:-}" ]; then
    cargo build --release --quiet --bin glimpse --manifest-path "$root/Cargo.toml"
    GLIMPSE="$root/target/release/glimpse"
fi
exec "$venv/bin/python" "$root/tools/crosscheck/crosscheck.py" --glimpse "$GLIMPSE" "$@"
