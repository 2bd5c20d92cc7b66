#!/usr/bin/env bash
# Static checks, run by .ci/run: ruff (lint and format) and mypy, with the configuration in
# pyproject.toml ([tool.ruff], [tool.mypy]; docs/DEVELOPING.md says what each covers). Exits
# non-zero on any finding. Uses the test environment (scripts/test.sh installs ruff and mypy with
# the test extra). Usage: scripts/check.sh [--fix]  (--fix: let ruff fix and format what it can)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_env.sh"
ensure_test_venv  # the same install as scripts/test.sh: nothing more after it
cd "$ROOT"
# The strict part of the tree: the format check and mypy's strict mode cover these (keep the
# per-file-ignores glob and the mypy override in pyproject.toml in step with this list).
STRICT=(simx_wire simx_client/servers.py simx_server/commands/handler.py simx_server/loop simx_server/api/registry.py
        simx_server/api/context.py scripts/wire_imports.py
        tests/base tests/loop)
if [ "${1:-}" = --fix ]; then
    "$VENV/bin/ruff" check --fix .
    "$VENV/bin/ruff" format "${STRICT[@]}"
fi
status=0
echo "simx: ruff check (lint, the whole tree) ..."
"$VENV/bin/ruff" check . || status=1
echo "simx: ruff format --check (${STRICT[*]}) ..."
"$VENV/bin/ruff" format --check "${STRICT[@]}" || status=1
echo "simx: mypy (${STRICT[*]}) ..."
"$VENV/bin/mypy" "${STRICT[@]}" || status=1
[ "$status" = 0 ] && echo "simx: static checks passed." || echo "simx: static checks FAILED (see above)." >&2
exit "$status"
