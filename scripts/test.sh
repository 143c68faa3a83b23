#!/usr/bin/env bash
# Copyright 2026 observer_ros contributors
# Licensed under the Apache License, Version 2.0.
#
# Set up the environment (first run) and run the whole test suite. Extra arguments go to
# pytest. ROS traffic stays on this machine, in a domain of its own (see test/conftest.py).
set -euo pipefail
source "$(dirname "$0")/setup_env.sh"
cd "$ROOT"
# Two workers (pytest-xdist), each in a DDS domain of its own; OBSERVER_ROS_TEST_WORKERS=0
# runs in one process.
exec python -m pytest -n "${OBSERVER_ROS_TEST_WORKERS:-2}" "$@"
