#!/usr/bin/env bash
# Set up and run robodyn's whole test suite on a fresh machine with Python 3.11:
# headless Chromium for the browser tests (Debian's package, when run as root), a virtual
# environment in .venv with robodyn and its test extra, then the static checks (ruff lint and
# format, mypy, import-linter's layer contracts), the documentation built in strict mode (into a
# temporary folder, outside the checkout), and pytest, whose tests/test_docs.py runs every command
# and snippet of README.md and docs/. Any finding fails the run.
set -euo pipefail
cd "$(dirname "$0")/.."

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
