#!/usr/bin/env bash
# Copyright 2026 observer_ros contributors
# Licensed under the Apache License, Version 2.0.
#
# The golden and reference tests where the last bits move (doc/testing.md, "Goldens on other
# machines"): under several OpenBLAS kernels, then in a second venv with the oldest numpy and
# scipy that requirements.txt allows. Prints one row per run: the set, numpy, scipy, the
# kernel, the counts and the wall time; exits non-zero when any run failed.
#
#   scripts/check_numerics.sh [--kernels "Haswell Sandybridge Prescott"] [--no-oldest]
#
# The second venv is OBSERVER_ROS_OLDEST_VENV (default .venv-oldest), made on first use.
# Extra arguments after -- go to pytest.
source "$(dirname "$0")/setup_env.sh"
cd "$ROOT"
kernels="Haswell Sandybridge Prescott"
oldest=1
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --kernels) kernels="$2"; shift 2 ;;
    --no-oldest) oldest=0; shift ;;
    --) shift; extra=("$@"); break ;;
    *) echo "check_numerics: unknown option $1 (--kernels LIST, --no-oldest, -- PYTEST ARGS)" >&2
       exit 2 ;;
  esac
done
TESTS=(test/test_golden_outputs.py test/test_sources_reference.py
       test/test_core_chen_conditioning.py test/test_core_seeds.py test/test_design_cli.py
       test/test_observer_controller.py)
rows=()
status=0

run_set() {  # NAME PYTHON KERNEL
  local name="$1" python="$2" kernel="$3" versions log start wall summary
  versions=$("$python" -c 'import numpy, scipy; print(numpy.__version__, scipy.__version__)')
  log=$(mktemp)
  start=$(date +%s%N)
  if [ "$kernel" = default ]; then
    env -u OPENBLAS_CORETYPE "$python" -m pytest -n 2 -q -p no:warnings "${TESTS[@]}" \
      "${extra[@]}" >"$log" 2>&1 || status=1
  else
    OPENBLAS_CORETYPE="$kernel" "$python" -m pytest -n 2 -q -p no:warnings "${TESTS[@]}" \
      "${extra[@]}" >"$log" 2>&1 || status=1
  fi
  wall=$(( ($(date +%s%N) - start) / 1000000000 ))
  summary=$(grep -E '(passed|failed|error)' "$log" | tail -n 1)
  grep -E '^FAILED' "$log" || true
  rows+=("$(printf '%-8s %-7s %-7s %-12s %6d s  %s' "$name" ${versions} "$kernel" "$wall" \
    "$summary")")
  rm -f "$log"
}

for kernel in default $kernels; do
  run_set newest "$VENV/bin/python" "$kernel"
done

if [ "$oldest" = 1 ]; then
  OLD="${OBSERVER_ROS_OLDEST_VENV:-$ROOT/.venv-oldest}"
  constraints=$(mktemp)
  # numpy>=X and scipy>=Y in requirements.txt become numpy==X.* and scipy==Y.*
  sed -nE 's/^(numpy|scipy)>=([0-9.]+).*/\1==\2.*/p' requirements.txt >"$constraints"
  if [ ! -x "$OLD/bin/python" ] || ! "$OLD/bin/python" -m pip install -q --dry-run \
      -r requirements.txt -c "$constraints" >/dev/null 2>&1; then
    rm -rf "$OLD"
    "$(command -v python3)" -m venv "$OLD"
    "$OLD/bin/python" -m pip install -q --upgrade pip
    "$OLD/bin/python" -m pip install -q -r requirements.txt -c "$constraints"
  fi
  "$OLD/bin/python" -m pip install -q --no-deps -e "$ROOT"
  rm -f "$constraints"
  for kernel in default $kernels; do
    PATH="$OLD/bin:$PATH" run_set oldest "$OLD/bin/python" "$kernel"
  done
fi

echo
printf '%-8s %-7s %-7s %-12s %8s  %s\n' set numpy scipy kernel wall result
printf '%s\n' "${rows[@]}"
exit "$status"
