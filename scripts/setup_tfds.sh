#!/usr/bin/env bash
# The TensorFlow Datasets environment (.venv-tfds): tensorflow-cpu + tensorflow-datasets, only to check that
# `export --to rlds` writes what `tfds.builder_from_directory` loads (tests/convert/test_export_tfds.py runs its
# reader, tests/support/tfds_load.py, in it). TensorFlow is not a dependency of openral-data (1.6 GB, and TFDS
# cannot read TFRecord shards without it), so it gets an environment of its own beside .venv; nothing of
# openral-data is installed into it. Seconds when already installed.
set -euo pipefail
cd "$(dirname "$0")/.."
export UV_PYTHON_DOWNLOADS=never
PY=python
if command -v pyenv >/dev/null 2>&1; then PY="$(pyenv which python)"; fi
UV=("$PY" -m uv)
command -v uv >/dev/null 2>&1 && uv --version >/dev/null 2>&1 && UV=(uv)
PACKAGES=(tensorflow-cpu==2.21.0 tensorflow-datasets==4.9.10 importlib_resources)
if [ -f .venv-tfds/.installed ] && [ "$(cat .venv-tfds/.installed)" = "${PACKAGES[*]}" ]; then
    echo "setup_tfds: .venv-tfds: present (${PACKAGES[*]})" >&2
    exit 0
fi
t0=$SECONDS
echo "setup_tfds: installing ${PACKAGES[*]} into .venv-tfds (about 1-2 min and 1.6 GB the first time) ..." >&2
rm -rf .venv-tfds
"${UV[@]}" venv --quiet --python "$PY" .venv-tfds
"${UV[@]}" pip install --quiet --python .venv-tfds/bin/python "${PACKAGES[@]}"
echo "${PACKAGES[*]}" > .venv-tfds/.installed
echo "setup_tfds: done in $((SECONDS - t0)) s" >&2
