# Copyright 2026 observer_ros contributors
# Licensed under the Apache License, Version 2.0.
#
# Sourced by demo.sh and test.sh: creates .venv with a Python 3.10-3.13 and installs
# requirements.txt plus this package (editable). Re-running is cheap: it reinstalls only
# when requirements.txt or setup.py change.
#
# Sourced into an interactive shell it leaves that shell's options as they were: the set-up
# runs with set -euo pipefail in a subshell, and only ROOT, VENV and the exports below reach
# the caller (a failed set-up returns 1). The scripts that source it set their own options.
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${OBSERVER_ROS_VENV:-$ROOT/.venv}"

# Not under "if": there bash would ignore set -e inside the subshell too.
(
set -euo pipefail

pick_python() {
  local candidate version
  for candidate in "${PYTHON:-}" python3 python3.13 python3.12 python3.11 python3.10; do
    [ -n "$candidate" ] || continue
    command -v "$candidate" >/dev/null 2>&1 || continue
    version=$("$candidate" -c 'import sys; print("%d%02d" % sys.version_info[:2])')
    if [ "$version" -ge 310 ] && [ "$version" -le 313 ]; then
      echo "$candidate"
      return 0
    fi
  done
  echo "observer_ros: need Python 3.10-3.13 (the ROS 2 Jazzy wheels exist for those)" >&2
  return 1
}

if [ ! -x "$VENV/bin/python" ]; then
  PY=$(pick_python)
  if ! "$PY" -m venv "$VENV" 2>/dev/null; then
    # Debian and Ubuntu ship venv separately.
    if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
      pyver=$("$PY" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
      apt-get update -qq && apt-get install -y -qq "python${pyver}-venv" || \
        apt-get install -y -qq python3-venv
      rm -rf "$VENV"
      "$PY" -m venv "$VENV"
    else
      echo "observer_ros: '$PY -m venv' failed; install python3-venv" >&2
      exit 1
    fi
  fi
fi

stamp="$VENV/.observer_ros_installed"
want=$(cat "$ROOT/requirements.txt" "$ROOT/setup.py" | sha256sum | cut -d' ' -f1)
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
  "$VENV/bin/python" -m pip install -q --upgrade pip
  "$VENV/bin/python" -m pip install -q -r "$ROOT/requirements.txt"
  "$VENV/bin/python" -m pip install -q -e "$ROOT"
  echo "$want" > "$stamp"
fi
# The report tests render the HTML reports in headless Chromium (Debian's package): install
# it where this runs as root with apt-get and it is missing (CI's fresh machines).
if ! command -v chromium >/dev/null 2>&1 && command -v apt-get >/dev/null 2>&1 \
    && [ "$(id -u)" = 0 ] && [ -z "${OBSERVER_ROS_NO_BROWSER:-}" ]; then
  echo "observer_ros: installing chromium for the report tests" >&2
  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium \
    >/dev/null) || echo "observer_ros: could not install chromium" >&2
fi
)
_observer_ros_status=$?
if [ "$_observer_ros_status" != 0 ]; then
  unset _observer_ros_status
  echo "observer_ros: the set-up of $VENV failed" >&2
  return 1 2>/dev/null || exit 1
fi
unset _observer_ros_status
export PATH="$VENV/bin:$PATH"
# Keep ROS traffic on this machine.
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
export MPLBACKEND=Agg
