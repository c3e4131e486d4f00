#!/usr/bin/env bash
# Benchmark raytrace on this machine: the workshop's table for every
# acceleration structure, scaling with mesh size, a peer (embreex or open3d,
# if installed) and soft-shadow error against time.  Markdown on stdout.
#
#   bash bench.sh [--quick] [--json FILE] [--plot FILE] [--sections LIST]
#
# Needs only raytrace installed as the README says (pip install .); the
# optional extras add the peer row ('.[peers]') and the plot ('.[plot]').
set -euo pipefail
cd "$(dirname "$0")"
exec python bench/bench.py "$@"
