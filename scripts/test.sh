#!/usr/bin/env bash
# The whole test suite, from a fresh Debian machine: installs what the tests need, then
# checks formatting and lints and runs every test (unit, integration, end-to-end CLI,
# benchmarks in test mode, doc tests).
set -euo pipefail
cd "$(dirname "$0")/.."

need_apt=()
why=()
if ! command -v cc >/dev/null 2>&1; then
    need_apt+=(gcc libc6-dev)
    why+=("a C compiler for the Blosc decoder")
fi
if ! command -v python3 >/dev/null 2>&1; then
    need_apt+=(python3 python3-venv)
    why+=("Python 3 for the layout check and the Python package's tests")
elif ! python3 -c 'import ensurepip' >/dev/null 2>&1; then
    need_apt+=(python3-venv)
    why+=("Python's venv for the Python package's tests")
fi
# The GPU tests need a Vulkan device and fail (never skip) without one; on a machine
# without a GPU that is Mesa's lavapipe, a Vulkan driver running on the CPU.
if ! ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1 &&
    ! { PATH="$PATH:/sbin:/usr/sbin" ldconfig -p 2>/dev/null | grep -q libvulkan_lvp; }; then
    need_apt+=(mesa-vulkan-drivers libvulkan1)
    why+=("Mesa's lavapipe (Vulkan on the CPU) for the GPU tests")
fi
# The viewer's window test runs `haze view` on a virtual X display.
if ! command -v Xvfb >/dev/null 2>&1; then
    need_apt+=(xvfb)
    why+=("Xvfb, a virtual X display for the viewer window's test")
fi
if ((${#need_apt[@]})); then
    reasons=$(IFS=';' && echo "${why[*]}")
    echo "test.sh: installing ${need_apt[*]} (${reasons//;/; })" >&2
    sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    $sudo apt-get update -qq
    $sudo apt-get install -y -qq "${need_apt[@]}"
fi
if ! command -v cargo >/dev/null 2>&1; then
    echo "test.sh: cargo not found: install a Rust toolchain (1.88 or newer) first" >&2
    exit 1
fi

cargo fmt --all -- --check
# The layout's invariants (ARCHITECTURE.md): a thin binary, no import circle between
# rooms, no shader text edited by string replacement, no renderer function over 120 lines.
python3 scripts/check_layout.py
cargo clippy --workspace --all-targets --locked -- -D warnings
# The API docs, private items included (the crates are the project's rooms, read by the
# people who change them): every intra-doc link must resolve. Links to private items
# resolve in these docs, so rustdoc's lint against them is off.
RUSTDOCFLAGS="-D warnings -A rustdoc::private_intra_doc_links" \
    cargo doc --workspace --no-deps --document-private-items --locked -q

log=$(mktemp)
trap 'rm -f "$log"' EXIT
cargo test --workspace --doc --locked 2>&1 | tee "$log"
cargo test --workspace --all-targets --locked 2>&1 | tee -a "$log"

# The Python package (python/): its wheel built by maturin from the build above (the same
# dev profile and target folder, so only the native module is linked again), installed in
# a virtual environment of its own, then its tests, which also run the `haze` binary.
venv=target/py-venv
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
"$venv/bin/python" -m pip install -q --disable-pip-version-check \
    'maturin>=1.9,<2' numpy pytest OpenEXR 'dask[distributed]>=2024.1'
rm -rf target/wheels
(cd python && "../$venv/bin/maturin" build --profile dev --locked --out ../target/wheels 2>&1 | tail -n 3)
"$venv/bin/python" -m pip install -q --disable-pip-version-check --force-reinstall --no-deps target/wheels/haze-*.whl
HAZE_BIN="$PWD/target/debug/haze" "$venv/bin/python" -m pytest -q -p no:cacheprovider python/tests 2>&1 | tee -a "$log"

# The Blender add-on (blender/haze_bake), headless with Blender as a Python module (bpy
# from PyPI, for CPython 3.11): it bakes a small Mantaflow domain, then runs the add-on's
# operators on it.
"$venv/bin/python" -m pip install -q --disable-pip-version-check 'bpy==5.0.1'
"$venv/bin/python" blender/tests/test_addon.py 2>&1 | grep -E '^(ok|FAILED|Error)|passed' | tee -a "$log"

# One closing line for the whole suite, summed over every test binary and pytest's run.
awk '/^test result:/ { for (i = 1; i <= NF; i++) { if ($(i+1) ~ /^passed/) p += $i; if ($(i+1) ~ /^failed/) f += $i } }
     /^[0-9]+ (passed|failed).* in [0-9.]+s/ { for (i = 1; i <= NF; i++) { if ($(i+1) ~ /^passed/) p += $i; if ($(i+1) ~ /^failed/) f += $i } }
     END { printf "%d passed, %d failed\n", p, f }' "$log"
