#!/usr/bin/env bash
# Run a command inside the workspace environment (see tools/env.sh).
set -euo pipefail
# shellcheck disable=SC1091
. "$(dirname "${BASH_SOURCE[0]}")/env.sh"
exec "$@"
