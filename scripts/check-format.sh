#!/usr/bin/env bash
# Checks that every C++ file is as clang-format writes it with the repository's .clang-format;
# --fix rewrites them instead. Build trees (build*/) are left out.
set -euo pipefail
cd "$(dirname "$0")/.."
mapfile -t files < <(find . -path './build*' -prune -o -path './.git' -prune -o \( -name '*.cc' -o -name '*.h' \) -print | sort)
if [[ "${1:-}" == --fix ]]; then
  clang-format -i "${files[@]}"
  echo "check-format: formatted ${#files[@]} files"
  exit 0
fi
clang-format --dry-run -Werror "${files[@]}"
echo "check-format: ${#files[@]} files as .clang-format writes them"
