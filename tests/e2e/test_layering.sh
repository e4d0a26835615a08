#!/usr/bin/env bash
# The layering docs/architecture.md promises holds in the code that was built and its sources:
# no file-level cycles, libraries used one way, no include cycles, headers shared across
# top-level folders only through include/, bench/ on the public API only, the subsurface code
# kept off the integrator, no Python import cycles (tests/e2e/layering.py).
set -euo pipefail
command -v nm >/dev/null || { echo "SKIP: nm (binutils) not installed"; exit 77; }
python3 "$OPALINE_SOURCE_DIR/tests/e2e/layering.py" "$OPALINE_SOURCE_DIR" "$OPALINE_BIN_DIR/.."
