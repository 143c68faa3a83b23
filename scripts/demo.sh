#!/usr/bin/env bash
# Copyright 2026 observer_ros contributors
# Licensed under the Apache License, Version 2.0.
#
# Set up the environment (first run) and run the main job.
source "$(dirname "$0")/setup_env.sh"
cd "$ROOT"
design_observer config/seed001_third_order.yaml "$@"
