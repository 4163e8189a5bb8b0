#!/usr/bin/env bash
# The ManiSkill3 environment (.venv-maniskill): mani-skill 3.0.1 + sapien 3.0.3 and this package, on numpy 1.26.
# ManiSkill's motion-planning experts (mplib 0.1.1) crash with numpy 2 and need scipy < 1.16, so the environment
# holds numpy 1.26.4 / scipy 1.15.3 / pyarrow 21 (overriding the package's numpy >= 2, which only the shared .venv needs: our
# recorder runs on 1.26 too) and otherwise the locked versions of uv.lock's core (torch as in uv.lock, so uv's
# cache serves the wheel the default environment downloaded). SAPIEN renders on the CPU through Vulkan: it needs
# Mesa >= 23's lavapipe (bookworm's 22.3.6 lacks descriptorBindingPartiallyBound), installed from
# bookworm-backports (mesa-vulkan-drivers 25.0.7) when the system's is older. The default environment's setup
# (Debian packages, Python 3.12, uv) runs first.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export UV_PYTHON_DOWNLOADS=never
# No bytecode compilation at install (unlike .venv's): its tests run in one process, which compiles only the
# modules it imports (torch, ManiSkill, this package), where compiling all ~7 GB of site-packages took minutes.
say() { echo "setup_maniskill: $*" >&2; }
started=$SECONDS

# Vulkan on the CPU: lavapipe from Mesa >= 23
mesa=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || true)
if [ -z "$mesa" ] || dpkg --compare-versions "$mesa" lt 23; then
    SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
    if [ -r /etc/os-release ] && grep -q 'VERSION_CODENAME=bookworm' /etc/os-release \
        && ! grep -rqs 'bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then
        echo 'deb http://deb.debian.org/debian bookworm-backports main' \
            | $SUDO tee /etc/apt/sources.list.d/bookworm-backports.list >/dev/null
    fi
    say "installing Mesa's Vulkan CPU driver (lavapipe >= 23, bookworm-backports; about 30 s) ..."
    $SUDO apt-get update -qq >/dev/null
    release=()
    if grep -rqs 'bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then release=(-t bookworm-backports); fi
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${release[@]}" \
        mesa-vulkan-drivers libvulkan1 >/dev/null
fi

PY=python
if command -v pyenv >/dev/null 2>&1; then PY="$(pyenv which python)"; fi
UV=("$PY" -m uv)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# pyarrow 21 and zarr 3.0: the last releases that run on numpy 1.x (the lock's pyarrow 26 and zarr 3.4 need numpy 2)
printf 'numpy==1.26.4\nscipy==1.15.3\npyarrow==21.0.0\nzarr==3.0.10\n' >"$tmp/overrides.txt"
# the core's locked versions as constraints, but those overridden (and opencv-python: ManiSkill's to choose)
"${UV[@]}" export --frozen --quiet --no-dev --no-hashes --no-emit-project --no-header \
    | grep -v -E '^ *#|^(numpy|scipy|pyarrow|zarr|opencv-python)==' >"$tmp/constraints.txt"
torch=$(grep -A1 '^name = "torch"$' uv.lock | sed -n 's/^version = "\(.*\)"$/\1/p')
if [ ! -x .venv-maniskill/bin/python ]; then "${UV[@]}" venv --quiet --python "$PY" .venv-maniskill; fi
say "installing mani-skill 3.0.1, sapien 3.0.3, torch $torch and openral-data into .venv-maniskill" \
    "(about 1 min from uv's cache, ~7 GB) ..."
"${UV[@]}" pip install --quiet --python .venv-maniskill/bin/python -c "$tmp/constraints.txt" \
    --override "$tmp/overrides.txt" -e . "mani-skill==3.0.1" "sapien==3.0.3" "torch==$torch" \
    "pytest>=8" "pytest-timeout>=2.3"
say "ready in $((SECONDS - started)) s: .venv-maniskill/bin/openral-data"
