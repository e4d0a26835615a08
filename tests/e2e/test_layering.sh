#!/usr/bin/env bash
# The layering docs/architecture.md promises holds in the code that was built: no file-level
# cycles, libraries used one way, no include cycles (tests/e2e/layering.py).
set -euo pipefail
command -v nm >/dev/null || { echo "SKIP: nm (binutils) not installed"; exit 77; }
python3 "$OPALINE_SOURCE_DIR/tests/e2e/layering.py" "$OPALINE_SOURCE_DIR" "$OPALINE_BIN_DIR/.."
