#!/usr/bin/env bash
# Copyright 2026 observer_ros contributors
# Licensed under the Apache License, Version 2.0.
#
# Set up the environment (first run) and build the documentation site (doc/, Sphinx with
# Markdown pages) to doc/_build/html, with warnings as errors as the test suite builds it.
# Extra arguments go to sphinx-build (for example -b linkcheck to fetch the external links).
set -euo pipefail
source "$(dirname "$0")/setup_env.sh"
cd "$ROOT"
exec python -m sphinx -W --keep-going -b html doc doc/_build/html "$@"
