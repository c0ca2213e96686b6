#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
#
# One entry point for a fresh Debian/Ubuntu machine:
#   tools/dev.sh demo    install what is missing, build the tool and the modules (not the
#                        tests), run the demo scenes
#   tools/dev.sh test    install what is missing, build, run every test but those labelled long
#                        (and tsan)
#   tools/dev.sh tsan    build and run the thread test under ThreadSanitizer (build-tsan)
#   tools/dev.sh deps    only install what is missing (apt-get as root, through sudo otherwise;
#                        without sudo it prints the apt-get line)
#   tools/dev.sh build   only configure and build
#   tools/dev.sh sanitize  build with ASan + UBSan in ./build-asan, run the tests labelled
#                        "sanitize" (unit, conformance, tool and fuzz-regression tests)
#
# Environment: DEFSIM_BUILD_DIR (default ./build), DEFSIM_SANITIZE_BUILD_DIR (default
# ./build-asan), DEFSIM_TSAN_BUILD_DIR (default ./build-tsan), DEFSIM_JOBS (default nproc),
# DEFSIM_CMAKE_ARGS (extra cmake arguments).
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${DEFSIM_BUILD_DIR:-$root/build}
jobs=${DEFSIM_JOBS:-$(nproc)}
# libglfw3-dev: the viewer (defsim view); xvfb, xauth and Mesa's software GL (libgl1-mesa-dri:
# llvmpipe, libglx-mesa0, libgl1) for its tests, which open their windows under xvfb-run.
packages="cmake ninja-build gcc g++ make pkg-config binutils libsundials-dev libsuitesparse-dev
  libcmocka-dev libosmesa6-dev libcjson-dev libpng-dev python3 python3-venv python3-pip doxygen
  libglfw3-dev xvfb xauth libgl1 libglx-mesa0 libgl1-mesa-dri"

deps() {
    local missing=""
    for p in $packages; do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing="$missing $p"
    done
    [ -z "$missing" ] && return 0
    # As root (a container) apt-get itself; otherwise through sudo where there is one.
    local as_root=""
    if [ "$(id -u)" != 0 ]; then
        if ! command -v sudo >/dev/null 2>&1; then
            echo "Missing packages. Run as root, or install them with:" >&2
            echo "  apt-get install -y$missing" >&2
            exit 1
        fi
        as_root="sudo"
    fi
    echo "== installing:$missing"
    $as_root apt-get update -qq
    $as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
        $missing
}

# A virtual environment with what the Python binding's tests need (numpy, cffi, pytest, and the
# sweep extras of pyproject.toml: dask[distributed], pandas, pyarrow, matplotlib, tqdm), and
# meshio for the io extra, the examples and test_vtu_readers (frames read by another reader), and
# scipy for the identification example (example_python_identify_cantilever, docs/gradients.md).
# Without network access the Python tests are left out (CMake says so) and the rest runs.
pyenv() {
    local venv=$build/pyenv
    local imports="numpy, cffi, pytest, distributed, pandas, pyarrow, matplotlib, tqdm, meshio, scipy"
    if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c "import $imports" 2>/dev/null; then
        mkdir -p "$build"
        [ -x "$venv/bin/python" ] || python3 -m venv "$venv" || true
        "$venv/bin/python" -m pip install -q --disable-pip-version-check numpy cffi pytest \
            "dask[distributed]" pandas pyarrow matplotlib tqdm meshio scipy || echo "== pip failed"
        # Without the sweep extras the binding's own tests still run (CMake says what it skipped).
        "$venv/bin/python" -c "import numpy, cffi, pytest" 2>/dev/null ||
            { echo "== no Python test environment"; return 0; }
    fi
    python_arg="-DDEFSIM_PYTHON=$venv/bin/python"
}

# configure_and_build [TARGET...]: every target, or only those named (the demo: the tool and
# the backend modules, not the tests).
configure_and_build() {
    cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release ${python_arg:-} \
        ${DEFSIM_CMAKE_ARGS:-}
    local targets=()
    for t in "$@"; do targets+=(--target "$t"); done
    cmake --build "$build" -j "$jobs" "${targets[@]}"
}

# The thread test alone in a ThreadSanitizer build (docs/threads.md): the library without
# OpenMP (libgomp is not instrumented) and without the optional modules; about 25 s of CPU to
# build and 2 s to run. The other tests are not run there.
tsan() {
    local tb=${DEFSIM_TSAN_BUILD_DIR:-$root/build-tsan}
    cmake -S "$root" -B "$tb" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDEFSIM_TSAN=ON \
        -DDEFSIM_WITH_CHOLMOD=OFF -DDEFSIM_WITH_SUNDIALS=OFF -DDEFSIM_WITH_OSMESA=OFF \
        -DDEFSIM_BUILD_TOOLS=OFF
    cmake --build "$tb" -j "$jobs" --target test_threads
    ctest --test-dir "$tb" -R '^test_threads$' --output-on-failure
}

# The sanitizer stage of CI (issue 17, docs/fuzzing.md): a second build with
# -DDEFSIM_SANITIZE=ON (ASan, UBSan, float-cast-overflow; every report aborts) without the
# renderer, and the tests labelled "sanitize" in it (tests/CMakeLists.txt says which and why).
sanitize() {
    local sbuild=${DEFSIM_SANITIZE_BUILD_DIR:-$root/build-asan}
    cmake -S "$root" -B "$sbuild" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDEFSIM_SANITIZE=ON \
        -DDEFSIM_WITH_OSMESA=OFF ${DEFSIM_CMAKE_ARGS:-}
    cmake --build "$sbuild" -j "$jobs"
    ASAN_OPTIONS=detect_leaks=1:check_initialization_order=1 UBSAN_OPTIONS=print_stacktrace=1 \
        ctest --test-dir "$sbuild" -L sanitize --output-on-failure -j "$jobs" --timeout 900
}

python_arg=""
# What the demo builds: the tool and the backend modules it may load (tests/CMakeLists.txt's
# test_dev_sh checks that this compiles no test).
demo_targets="defsim-cli defsim_modules"
case "${1:-}" in
deps) deps ;;
build) deps; configure_and_build ;;
test)
    deps
    pyenv
    configure_and_build
    # Tests labelled "long" (the adversarial suite's long matrices) run on demand only:
    # ctest --test-dir build -L long.
    ctest --test-dir "$build" --output-on-failure -j "$jobs" --timeout 900 -LE long
    tsan
    ;;
tsan) deps; tsan ;;
sanitize)
    deps
    sanitize
    ;;
demo)
    deps
    configure_and_build $demo_targets
    # The cantilever: a clamped beam of tets sagging under gravity. Per-frame energy and tip
    # position on the terminal and in energy.csv; VTK frames, PNGs and a contact sheet.
    "$build/bin/defsim" run "$root/tests/scenes/cantilever.json" --render --progress lines \
        --out "$build/cantilever"
    # Contact: a soft block lands among a ground plane, a box and a sphere (newton_cholmod,
    # barrier contact with friction); the colliders are drawn in the PNGs.
    "$build/bin/defsim" run "$root/tests/scenes/ground_box_sphere.json" --render \
        --progress lines --out "$build/ground_box_sphere"
    ;;
*)
    sed -n '3,18p' "${BASH_SOURCE[0]}"
    exit 2
    ;;
esac
