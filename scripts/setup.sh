#!/usr/bin/env bash
# Idempotent set-up of a fresh machine: system packages (when run as root), a virtualenv in .venv,
# and the toolkit with its test dependencies.  Fast when everything is already there.
set -euo pipefail
cd "$(dirname "$0")/.."

apt_packages=(chromium glslang-tools junit4 libandroid-json-java libegl1 libegl-mesa0 libgl1-mesa-dri
              libjogl2-java libjogl2-jni libgluegen2-rt-java libgluegen2-jni  # JOGL: GLES from Java on Mesa; chromium: the report page test
              sweethome3d-furniture)  # CC0 models and textures of the rooms scenes (docs/assets.md)
missing=()
for p in "${apt_packages[@]}"; do
    dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
command -v javac >/dev/null 2>&1 || missing+=(openjdk-17-jdk-headless)  # the Android core's unit tests
if ((${#missing[@]})); then
    if [ "$(id -u)" = 0 ]; then
        echo "setup: installing ${missing[*]}" >&2
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
    else
        echo "setup: please install with apt: ${missing[*]} (shader validation, Java tests and EGL need them)" >&2
    fi
fi

if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
fi
stamp=.venv/.mnss-kit-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
    # torch is pinned: the CPU build of 2.13.0 is what this toolkit is tested with.
    .venv/bin/pip install -q --disable-pip-version-check "torch==2.13.0" -e ".[test]"
    touch "$stamp"
fi
