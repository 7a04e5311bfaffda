#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Format the C/C++ sources with the pinned clang-format (Debian 12's clang-format-14), or check
# that they are formatted.
#
#   scripts/format.sh           # rewrite every tracked .h/.hpp/.c/.cpp in place
#   scripts/format.sh --check   # list unformatted files and exit 1 if there is any (CI)
#
# The version is pinned because clang-format's output changes between major versions: a tree
# formatted with another one would fail the check. Installs clang-format-14 when missing.
set -euo pipefail

usage() {
  sed -n '3,10p' "$0" | sed 's/^# \{0,1\}//'
}

check=0
for arg in "$@"; do
  case "$arg" in
    --check) check=1 ;;
    -h | --help) usage; exit 0 ;;
    *) echo "format.sh: unknown argument '$arg'" >&2; usage >&2; exit 2 ;;
  esac
done

repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo_root"

pinned_major=14
clang_format=clang-format-$pinned_major
if ! command -v "$clang_format" >/dev/null 2>&1; then
  if [[ $(id -u) -eq 0 ]]; then sudo_cmd=(); else sudo_cmd=(sudo); fi
  echo "format.sh: installing $clang_format"
  "${sudo_cmd[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q "$clang_format" >/dev/null
fi
version="$("$clang_format" --version)"
if [[ ! $version =~ version\ $pinned_major\. ]]; then
  echo "format.sh: $clang_format reports '$version', expected major version $pinned_major" >&2
  exit 1
fi

# Tracked sources only: build trees, mirrors and generated files are never formatted.
mapfile -t files < <(git ls-files -- '*.h' '*.hpp' '*.c' '*.cpp')
if ((check)); then
  unformatted=()
  for f in "${files[@]}"; do
    "$clang_format" --style=file --dry-run -Werror "$f" >/dev/null 2>&1 || unformatted+=("$f")
  done
  if ((${#unformatted[@]})); then
    echo "format.sh: ${#unformatted[@]} of ${#files[@]} files are not formatted ($version):" >&2
    printf '  %s\n' "${unformatted[@]}" >&2
    echo "format.sh: run scripts/format.sh (or cmake --build <dir> --target format) and commit" >&2
    exit 1
  fi
  echo "format.sh: all ${#files[@]} files formatted ($version)"
else
  "$clang_format" --style=file -i "${files[@]}"
  echo "format.sh: formatted ${#files[@]} files ($version)"
fi
