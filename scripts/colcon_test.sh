#!/usr/bin/env bash
# Copyright 2026 observer_ros contributors
# Licensed under the Apache License, Version 2.0.
#
# Run the whole test suite the way a ROS 2 workspace does: copy this repository into
# WORKSPACE/src (default: a new temporary directory), `colcon build`, `colcon test`, then
# `colcon test-result --verbose`. Exit status 0 only when every test passed. Extra arguments
# after WORKSPACE go to pytest (`scripts/colcon_test.sh /tmp/ws -k signals`).
#
# With a sourced ROS 2 install (ROS_DISTRO set) it uses that install's colcon. Otherwise it
# uses the pip set-up's (.venv, see setup_env.sh) but leaves .venv/bin off PATH, so the tests
# find the console scripts where ament_python installs them (install/observer_ros/lib/
# observer_ros), as on a Jazzy install.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
WORKSPACE="${1:-$(mktemp -d -t observer_ros_ws.XXXXXX)}"
shift || true

if [ -n "${ROS_DISTRO:-}" ] && command -v colcon >/dev/null 2>&1; then
  COLCON=colcon
else
  source "$ROOT/scripts/setup_env.sh"
  COLCON="$VENV/bin/colcon"
  PATH="$(printf '%s' "$PATH" | tr ':' '\n' | grep -vx "$VENV/bin" | paste -sd: -)"
  export PATH
fi
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"

mkdir -p "$WORKSPACE/src/observer_ros"
# The working tree as it is (uncommitted changes included), without local build products.
tar -C "$ROOT" --exclude=./.venv --exclude=./.git --exclude=./build --exclude=./install \
  --exclude=./log --exclude=./output --exclude='__pycache__' --exclude='*.egg-info' \
  --exclude=.pytest_cache --exclude=.hypothesis -cf - . | tar -C "$WORKSPACE/src/observer_ros" -xf -

cd "$WORKSPACE"
echo "observer_ros: colcon workspace $WORKSPACE"
"$COLCON" build --event-handlers console_direct-
extra=()
if [ "$#" -gt 0 ]; then
  extra=(--pytest-args "$@")
fi
status=0
"$COLCON" test --event-handlers console_direct+ --return-code-on-test-failure \
  ${extra[@]+"${extra[@]}"} || status=$?
"$COLCON" test-result --verbose || status=$?
exit "$status"
