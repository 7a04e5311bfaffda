#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Every tracked source file carries the SPDX licence line of LICENSE (MIT): add it where it is
# missing, or check that none lacks it.
#
#   scripts/license.sh           # insert the line (after a #! line) into files without it
#   scripts/license.sh --check   # list files without it and exit 1 if there is any (CI)
#
# Sources: C/C++ (.c .h .hpp .cpp) and GLSL (.glsl, whose #version the shader loader adds) get
# "// SPDX-License-Identifier: MIT", CMake, Python and shell files and .ci/run "# ...", the
# linker version script "/* ... */". Data (JSON, glTF, binaries, images) and docs carry none.
set -euo pipefail

usage() {
  sed -n '3,11p' "$0" | sed 's/^# \{0,1\}//'
}

check=0
for arg in "$@"; do
  case "$arg" in
    --check) check=1 ;;
    -h | --help) usage; exit 0 ;;
    *) echo "license.sh: unknown argument '$arg'" >&2; usage >&2; exit 2 ;;
  esac
done

repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo_root"

tag="SPDX-License-Identifier: MIT"
comment_for() {
  case "$1" in
    *.c | *.h | *.hpp | *.cpp | *.glsl) echo "// $tag" ;;
    *.map) echo "/* $tag */" ;;
    *CMakeLists.txt | *.cmake | *.cmake.in | *.pc.in | *.py | *.sh | .ci/run) echo "# $tag" ;;
    *) return 1 ;;
  esac
}

missing=()
while IFS= read -r -d '' file; do
  line="$(comment_for "$file")" || continue
  # The tag within the first three lines (after a #! line and a comment opener).
  [[ $(head -n 3 -- "$file") == *"$tag"* ]] && continue
  if ((check)); then
    missing+=("$file")
    continue
  fi
  tmp="$file.license.$$"
  if [[ $(head -c 2 -- "$file") == "#!" ]]; then
    { head -n 1 -- "$file"; echo "$line"; tail -n +2 -- "$file"; } >"$tmp"
  else
    { echo "$line"; cat -- "$file"; } >"$tmp"
  fi
  chmod --reference="$file" "$tmp"
  mv -- "$tmp" "$file"
  echo "license.sh: added to $file"
done < <(git ls-files -z)

if ((check)); then
  if ((${#missing[@]})); then
    printf '%s\n' "${missing[@]}"
    echo "license.sh: ${#missing[@]} files lack '$tag' (run scripts/license.sh)" >&2
    exit 1
  fi
  echo "license.sh: every source file carries '$tag'"
fi
