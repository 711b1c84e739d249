#!/usr/bin/env bash
# The GPU benchmark as one prepared command, for a lent GPU machine that has Python, NumPy and
# numba-cuda but no Pinocchio and no network (a session has 15 minutes of device time, all calls
# together, and the machine takes 2-3 of them to start).
#
#   bash benchmarks/gpu_session.sh prepare bench-out/gpu     # here, where robodyn is installed
#   bash benchmarks/gpu_session.sh run bench-out/gpu [ARGS]  # there: the one command (carry bench-out/gpu)
#
# prepare: bench_gpu.py --prepare DIR (the models' arrays), then MJX's wheels for CPython 3.12 on
#   x86-64 Linux into DIR/wheels (mujoco and mujoco-mjx 3.17 with the packages they import: 37 MB;
#   JAX is on the machine already). Without network the wheels are left out: MJX's columns then say so.
# run: installs DIR/wheels into a temporary folder (no index, no dependencies), runs
#   bench_gpu.py --run DIR [ARGS] under a 300 s limit, and copies DIR/gpu.json (written after every
#   section, so a run cut short keeps what it measured) and the log into $OUT (the device tool's
#   folder that comes back), or DIR when $OUT is unset. Exits with bench_gpu's status.
set -uo pipefail
cd "$(dirname "$0")/.."
if [ $# -lt 2 ] || { [ "$1" != prepare ] && [ "$1" != run ]; }; then
  echo "usage: bash benchmarks/gpu_session.sh prepare|run DIR [bench_gpu.py --run options]" >&2
  exit 2
fi
mode=$1
dir=$2
shift 2
python=${PYTHON:-python3}
if [ "$mode" = prepare ]; then
  "$python" benchmarks/bench_gpu.py --prepare "$dir" || exit $?
  if "$python" -m pip download --quiet --only-binary=:all: --no-deps --python-version 3.12 \
    --platform manylinux_2_28_x86_64 --platform manylinux2014_x86_64 --platform any \
    --dest "$dir/wheels" mujoco==3.17.0 mujoco-mjx==3.17.0 glfw pyopengl websockets trimesh etils absl-py; then
    echo "wrote $dir/wheels: $(ls "$dir/wheels" | wc -l) wheels for MJX ($(du -sh "$dir/wheels" | cut -f1))"
  else
    echo "MJX's wheels could not be downloaded: the GPU run will leave MJX out" >&2
  fi
  exit 0
fi
out=${OUT:-$dir}
site=$(mktemp -d)
if ls "$dir"/wheels/*.whl >/dev/null 2>&1; then
  "$python" -m pip install --quiet --no-index --no-deps --target "$site" "$dir"/wheels/*.whl \
    || echo "MJX's wheels did not install here: MJX is left out" >&2
fi
PYTHONPATH="src:$site" timeout 300 "$python" benchmarks/bench_gpu.py --run "$dir" "$@" 2>&1 | tee "$out/bench_gpu.log"
status=${PIPESTATUS[0]}
if [ -f "$dir/gpu.json" ] && [ "$out" != "$dir" ]; then
  cp "$dir/gpu.json" "$out/"
fi
echo "bench_gpu exited with $status; $out/gpu.json and $out/bench_gpu.log"
exit "$status"
