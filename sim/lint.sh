#!/usr/bin/env bash
# Lint gate: verilator --lint-only -Wall per Verilog module, ghdl -a --std=08 per VHDL file.
# Non-zero exit on any warning or error. Arguments: optional list of files (default: all RTL).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
py="${PYTHON:-$here/../.venv/bin/python}"
exec "$py" "$here/lint.py" "$@"
