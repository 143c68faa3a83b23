#!/usr/bin/env bash
# Copyright 2026 observer_ros contributors
# Licensed under the Apache License, Version 2.0.
#
# Set up the environment (first run) and run the benchmark suite; writes BENCHMARKS.md and
# benchmarks/figures/. Arguments go to benchmarks/run.py (--smoke, --only N, --output DIR).
set -euo pipefail
source "$(dirname "$0")/setup_env.sh"
cd "$ROOT"
exec python -m benchmarks.run "$@"
