#!/usr/bin/env bash
# Formats every C and C++ file of the repository with .clang-format (clang-format-14, the one
# Debian 12 ships: another version formats some constructs differently).
# Usage: bash tools/format.sh           rewrite the files in place
#        bash tools/format.sh --check   change nothing; fail listing what differs (tools/test.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v clang-format-14 >/dev/null; then
  echo "format.sh: clang-format-14 is missing (sudo apt-get install clang-format-14, or bash tools/setup.sh --test)" >&2
  exit 2
fi
# The files git tracks (a fresh clone) or, outside a git checkout, the source folders.
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  mapfile -t files < <(git ls-files '*.h' '*.c' '*.cpp')
else
  mapfile -t files < <(find apps include src tests tools fuzz cmake -name '*.h' -o -name '*.c' -o -name '*.cpp')
fi
if [ "${1:-}" = "--check" ]; then
  printf '%s\0' "${files[@]}" | xargs -0 -n 50 clang-format-14 --dry-run --Werror
  echo "format.sh: ${#files[@]} files match .clang-format"
else
  printf '%s\0' "${files[@]}" | xargs -0 -n 50 clang-format-14 -i
  echo "format.sh: formatted ${#files[@]} files"
fi
