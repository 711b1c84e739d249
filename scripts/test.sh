#!/usr/bin/env bash
# Set up and run robodyn's whole test suite on a fresh machine with Python 3.11:
# headless Chromium for the browser tests (Debian's package, when run as root), a virtual
# environment in .venv with robodyn and its test extra, then the static checks (ruff lint and
# format, mypy, import-linter's layer contracts), the documentation built in strict mode (into a
# temporary folder, outside the checkout), and pytest, whose tests/test_docs.py runs every command
# and snippet of README.md and docs/; then the documentation tests once more on an emulated other
# CPU (see below). Any finding fails the run.
#
# `bash scripts/test.sh --quick` is the subset to run before a commit: the static checks and the
# house, kind, integrator and checker tests that compile nothing with numba, in the environment you
# have (robodyn installed with its test extra, `ruff`, `mypy`, `lint-imports` on the PATH); at most
# 5 minutes on 2 cores. The full run (no flag) is what CI runs. Arguments after --quick go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."

QUICK_TESTS=(
  tests/test_package.py tests/test_house_functions.py tests/test_kind_object.py tests/test_formulas.py
  tests/test_params.py tests/test_integrators.py tests/test_cli_parse.py tests/test_fileio.py
)
if [ "${1:-}" = "--quick" ]; then
  shift
  echo "quick: static checks, then ${#QUICK_TESTS[@]} test files (the full run: bash scripts/test.sh)"
  ruff check src tests benchmarks examples docs/hooks
  ruff format --check src tests benchmarks examples docs/hooks
  mypy src/robodyn
  lint-imports
  python -m pytest -q -m "not slow" "${QUICK_TESTS[@]}" "$@"
  exit 0
fi

if ! command -v chromium >/dev/null 2>&1; then
  if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
    echo "installing Debian's chromium for the browser tests"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
  else
    echo "warning: chromium is not installed; the browser tests will say so (install Debian's chromium)" >&2
  fi
fi

python3 -m venv .venv
.venv/bin/python -m pip install --quiet --upgrade pip
.venv/bin/python -m pip install --quiet ".[test]"
echo "static checks: ruff, ruff format, mypy, import-linter"
.venv/bin/ruff check src tests benchmarks examples docs/hooks
.venv/bin/ruff format --check src tests benchmarks examples docs/hooks
.venv/bin/mypy src/robodyn
.venv/bin/lint-imports
echo "documentation: mkdocs build --strict"
site="$(mktemp -d)"
NO_MKDOCS_2_WARNING=1 .venv/bin/mkdocs build --strict --quiet --site-dir "$site"
rm -rf "$site"
.venv/bin/python -m pytest -q "$@"

# No documented output may depend on the machine. Run the documentation's commands once more as
# another CPU would: numba's generic target (no FMA, no wide vectors), numpy without its AVX-512
# kernels (the features numpy.show_runtime() finds here; none on a machine without AVX-512, and
# numpy ignores a feature the machine lacks), and, on x86-64, OpenBLAS on an older core's kernels
# (Haswell, AVX2, where the machine has AVX-512; Sandybridge, AVX, otherwise): different sums in
# the last bits, as on another machine. (OpenBLAS's kernels are what moved the Panda's evaluation
# count from 917 to 913 on an AVX2 machine.) numba keys its cache on the CPU name and features, so a generic
# run never loads host code, but it gets a cache folder of its own anyway: the checkout's stays
# as the host run left it.
emulated="$(.venv/bin/python - <<'PY'
import numpy
try:
    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
except ImportError:  # numpy 1.x
    from numpy.core._multiarray_umath import __cpu_dispatch__, __cpu_features__
found = [f for f in __cpu_dispatch__ if __cpu_features__.get(f) and (f.startswith("AVX512") or f == "X86_V4")]
print(" ".join(found))
PY
)"
blas_core=""
if [ "$(uname -m)" = "x86_64" ]; then
  if [ -n "$emulated" ]; then blas_core=Haswell; else blas_core=Sandybridge; fi
fi
numba_cache="$(mktemp -d)"
echo "documentation on an emulated CPU: NUMBA_CPU_NAME=generic NPY_DISABLE_CPU_FEATURES=\"$emulated\" OPENBLAS_CORETYPE=${blas_core:-(unchanged)}"
env NUMBA_CPU_NAME=generic NPY_DISABLE_CPU_FEATURES="$emulated" ${blas_core:+OPENBLAS_CORETYPE=$blas_core} \
  NUMBA_CACHE_DIR="$numba_cache" .venv/bin/python -m pytest -q tests/test_docs.py
rm -rf "$numba_cache"

