#!/usr/bin/env bash
# Wheels larger than one transfer to a GPU machine (64 MiB a call: warp-lang's is ~149 MB) travel in parts.
#   here:   experiments/wheel_parts.sh split .whl [MiB]   # each big wheel -> .whl/parts/NAME.partNN + NAME.sha256
#   there:  experiments/wheel_parts.sh join .whl          # reassembles every NAME from its parts, checks its hash
# Carry the parts over back-to-back calls (ignored files stay on a warm machine between calls), then join.
set -euo pipefail
cmd=${1:?split|join}; dir=$(cd "${2:?wheel folder}" && pwd); mib=${3:-60}
parts="$dir/parts"
case "$cmd" in
  split)
    mkdir -p "$parts"
    for whl in "$dir"/*.whl; do
      [ -e "$whl" ] || continue
      size=$(stat -c %s "$whl")
      [ "$size" -gt $((mib * 1024 * 1024)) ] || continue
      name=$(basename "$whl")
      rm -f "$parts/$name".part*
      (cd "$dir" && sha256sum "$name") > "$parts/$name.sha256"
      split -b "${mib}M" -d -a 2 "$whl" "$parts/$name.part"
      rm "$whl"
      echo "split $name into $(ls "$parts/$name".part* | wc -l) parts of at most $mib MiB"
    done ;;
  join)
    for sum in "$parts"/*.sha256; do
      [ -e "$sum" ] || continue
      name=$(basename "$sum" .sha256)
      cat "$parts/$name".part* > "$dir/$name.tmp"
      mv "$dir/$name.tmp" "$dir/$name"
      if ! (cd "$dir" && sha256sum --quiet -c "$parts/$name.sha256"); then
        rm -f "$dir/$name"; echo "error: $name: the reassembled parts do not match its sha256" >&2; exit 2
      fi
      echo "joined $name"
    done ;;
  *) echo "error: unknown command $cmd (split|join)" >&2; exit 2 ;;
esac
