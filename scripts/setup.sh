#!/usr/bin/env bash
# Install everything openral-data needs on a fresh machine: Python 3.12 (pyenv, via .python-version), uv,
# the locked environment in .venv, and the Debian packages for headless rendering (and libusb for the RealSense
# SDK, pyrealsense2) when missing.
#
# `bash scripts/setup.sh --core` installs only the core (MuJoCo scenes, the writers, convert, stats, view: no
# torch, no simulator suite, no dev tools; about 2 GB instead of 8) and the rendering packages, for scripts/demo.sh.
# It adds to an existing .venv without removing anything (a full environment stays full).
set -euo pipefail
cd "$(dirname "$0")/.."
core=0
if [ "${1:-}" = "--core" ]; then core=1; fi
export UV_PYTHON_DOWNLOADS=never
# Compile site-packages to bytecode at install time: with PYTHONDONTWRITEBYTECODE set (as on CI machines) every
# test subprocess would otherwise recompile lerobot/robosuite/torch sources on import.
export UV_COMPILE_BYTECODE=1

# Each step says what it does and about how long it takes (on a fresh machine; seconds once installed), then how
# long it took: a first install downloads several GB and must not look hung.
say() { echo "setup: $*" >&2; }
started=$SECONDS
step() {  # step "what" "about how long" command...: say it, run it, say how long it took
    local what=$1 eta=$2 t0=$SECONDS
    shift 2
    say "$what ($eta) ..."
    "$@"
    say "  done in $((SECONDS - t0)) s"
}

APT_PACKAGES=(libegl1 libegl-mesa0 libgl1-mesa-dri libopengl0 libosmesa6)
if ((!core)); then APT_PACKAGES+=(chromium libusb-1.0-0); fi
missing=()
for pkg in "${APT_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
apt_install() {
    SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
    $SUDO apt-get update -qq >/dev/null
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}
if ((${#missing[@]})); then
    step "installing Debian packages (headless rendering, browser, libusb): ${missing[*]}" "about 1-3 min" apt_install
else
    say "Debian packages (headless rendering, browser, libusb): present"
fi

PY=python
if command -v pyenv >/dev/null 2>&1; then PY="$(pyenv which python)"; fi
if ! "$PY" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 12))'; then
    echo "setup: Python 3.12 is required (found $("$PY" --version 2>&1)); install it with pyenv" >&2
    exit 1
fi
say "Python: $("$PY" --version 2>&1) ($PY)"
if ! command -v uv >/dev/null 2>&1 || ! uv --version >/dev/null 2>&1; then
    step "installing uv with pip" "about 10 s" "$PY" -m pip install --quiet --disable-pip-version-check uv
fi
UV=("$PY" -m uv)
# Optional extras the default environment (and CI) installs; each is one [project.optional-dependencies] entry.
# Extras that conflict with these (e.g. a separate simulator environment) are set up by their own script.
EXTRAS=(lerobot robosuite metaworld aloha pusht feetech dynamixel so_arm openarm ray browse mcap_profiles minari)
extra_args=()
for extra in "${EXTRAS[@]}"; do extra_args+=(--extra "$extra"); done
if ((core)); then
    step "syncing .venv with uv.lock: the package's core (MuJoCo, no torch), keeping what is already there" \
        "about 1-2 min and ~2 GB the first time; seconds when up to date" \
        "${UV[@]}" sync --frozen --quiet --python "$PY" --no-dev --inexact
    say "ready in $((SECONDS - started)) s: .venv/bin/openral-data (the core; bash scripts/setup.sh adds the rest)"
    exit 0
fi
step "syncing .venv with uv.lock: the package, the dev tools and the extras ${EXTRAS[*]}" \
    "about 3-6 min and ~8 GB with torch the first time; seconds when up to date" \
    "${UV[@]}" sync --frozen --quiet --python "$PY" "${extra_args[@]}"

# Older lerobot releases, as writers of the layouts they wrote (tests/support/old_lerobot.py): 0.3.3 writes
# LeRobot v2.1, 0.4.4 the early v3.0 layout (task text in tasks.parquet's pandas index). Their code only, without
# dependencies: they run on this environment's torch/datasets/PyAV, each from its own folder on PYTHONPATH.
OLD_LEROBOT=("0.3.3:lerobot==0.3.3" "0.4.4:lerobot==0.4.4 accelerate==1.15.0")
old_lerobot() {  # old_lerobot TARGET REQUIREMENT...
    local target=$1
    shift
    rm -rf "$target"
    "${UV[@]}" pip install --quiet --no-deps --python "$PY" --target "$target" "$@"
    touch "$target/.installed"
}
for entry in "${OLD_LEROBOT[@]}"; do
    version="${entry%%:*}"; target=".old-lerobot/$version"
    if [ ! -f "$target/.installed" ]; then
        # shellcheck disable=SC2086  # the requirement list is split on purpose
        step "lerobot $version's code into $target (a test writer of old layouts)" "about 10 s" \
            old_lerobot "$target" ${entry#*:}
    fi
done
say "ready in $((SECONDS - started)) s: .venv/bin/openral-data"
