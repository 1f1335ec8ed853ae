#!/usr/bin/env bash
# The runtime's modules import each other without cycles: every `crate::…` path in a module's
# code (doc comments and unit tests excluded) is an edge to the deepest module it names, and so is
# a path through a child module (`child::item`); `tsort` reports a loop if there is one.
# Usage: .ci/module-cycles.sh [--print]   (--print lists the edges and a topological order)
set -euo pipefail
cd "$(dirname "$0")/../runtime/src"

module_of() { # file path → module path
  local m="${1%.rs}"
  m="${m%/mod}"
  [ "$m" = lib ] && m=crate
  echo "${m//\//::}"
}

mapfile -t files < <(find . -name '*.rs' -printf '%P\n' | sort)
declare -A known
for f in "${files[@]}"; do known[$(module_of "$f")]=1; done

edges=$(
  for f in "${files[@]}"; do
    from=$(module_of "$f")
    # Code lines only, up to the unit tests (a test module may use anything).
    sed -n '/^#\[cfg(test)\]/q;p' "$f" | grep -v '^\s*//' | grep -o 'crate::[a-z_0-9:]*' |
      sed 's/^crate:://; s/::$//' | sort -u | while read -r path; do
        to=""
        IFS=':' read -ra parts <<< "${path//::/:}"
        prefix=""
        for p in "${parts[@]}"; do
          prefix="${prefix:+$prefix::}$p"
          [ -n "${known[$prefix]:-}" ] && to="$prefix"
        done
        [ -n "$to" ] && [ "$to" != "$from" ] && echo "$from $to"
      done
    # Paths relative to this module (`child::item`) reach its child modules.
    for m in "${!known[@]}"; do
      case "$m" in
        "$from"::*) child="${m#"$from"::}" ;;
        *) [ "$from" = crate ] && child="$m" || continue ;;
      esac
      case "$child" in *::*) continue ;; esac
      if sed -n '/^#\[cfg(test)\]/q;p' "$f" | grep -v '^\s*//' | grep -v '^\s*\(pub \)\?mod ' |
        grep -qE "(^|[^a-z_:])$child::"; then
        echo "$from $m"
      fi
    done
    # Every module also stands alone, so that leaves show up in the order.
    echo "$from $from"
  done | sort -u
)

if [ "${1:-}" = "--print" ]; then
  echo "$edges" | awk '$1 != $2 { print $1 " -> " $2 }'
  echo "--- dependencies first:"
fi
if ! order=$(echo "$edges" | awk '{ print $2, $1 }' | tsort 2>&1) || echo "$order" | grep -q loop; then
  echo "import cycle between the runtime's modules:" >&2
  echo "$order" | grep '^tsort' >&2
  exit 1
fi
[ "${1:-}" = "--print" ] && echo "$order" | tr '\n' ' ' && echo
echo "runtime module graph: $(echo "$edges" | awk '$1 != $2' | wc -l) edges between $(echo "$order" | wc -l) modules, no cycle"
