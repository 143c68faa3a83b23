#!/usr/bin/env bash
# Copyright 2026 observer_ros contributors
# Licensed under the Apache License, Version 2.0.
#
# Set up the environment (first run) and run the main job: the closed-loop demo. The seed 001
# third-order plant, its reduced-order observer and state feedback run as ROS 2 nodes in
# lockstep for 3 s of simulated time; the error table is printed and output/closed_loop.png
# written. Extra arguments go to closed_loop (for example another --params-file).
set -euo pipefail
source "$(dirname "$0")/setup_env.sh"
cd "$ROOT"
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$((RANDOM % 100 + 1))}"
design_observer config/seed001_third_order.yaml
echo
closed_loop --report output --ros-args --params-file config/seed001_third_order.yaml \
  -p plant.lockstep:=true -p plant.samples:=300 "$@"
