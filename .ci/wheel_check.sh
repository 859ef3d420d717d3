#!/usr/bin/env bash
# CI: the toolkit as a user installs it.  Builds the wheel from the tracked files, installs it into
# a new virtualenv (no system site-packages, no source tree on the path) and runs the CLI from a
# directory outside the checkout: help, the shipped models, a tiny render and an evaluation of the
# shipped default model.  Only package data is there to find configs, shaders and checkpoints.
set -euo pipefail
cd "$(dirname "$0")/.."
unset PYTHONPATH  # the installed package only
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# Build from a copy of the tracked files so no build/ directory in the checkout leaks stale files.
mkdir "$work/src"
git ls-files -z | tar --null -T - -c | tar -x -C "$work/src"
.venv/bin/python -m pip wheel -q --no-deps "$work/src" -w "$work/dist"  # the venv scripts/setup.sh made
wheel=$(ls "$work"/dist/mnss_kit-*.whl)
built=$SECONDS

python3 -m venv "$work/venv"
# torch is pinned: the CPU build of 2.13.0 is what this toolkit is tested with.  --no-compile: byte-
# compiling torch's files would take most of the install time; imports compile what they use.
"$work/venv/bin/pip" install -q --no-compile --disable-pip-version-check "torch==2.13.0" "$wheel"
installed=$SECONDS

mkdir "$work/run" && cd "$work/run"
kit="$work/venv/bin/mnss-kit"
location=$("$work/venv/bin/python" -c "import mnss_kit; print(mnss_kit.__file__)")
case "$location" in
    "$work/venv/"*) ;;
    *) echo "wheel check: mnss_kit imported from $location, not from the new virtualenv" >&2; exit 1 ;;
esac
"$kit" --help >/dev/null
"$kit" models
"$kit" render tiny_test --set frames=2 --out data --no-progress
"$kit" eval mnss_x2 --data data --max-frames 2 --json eval.json --no-progress
"$work/venv/bin/python" - <<'PY'
import json, math
methods = json.load(open("eval.json"))["methods"]
assert {"model", "bicubic", "taau"} <= set(methods), sorted(methods)
assert all(math.isfinite(m["psnr"]) for m in methods.values()), methods
print("wheel check passed: " + ", ".join(f"{k} {m['psnr']:.2f} dB" for k, m in methods.items()))
PY
echo "wheel check: built in ${built} s, installed in $((installed - built)) s, ran in $((SECONDS - installed)) s"
