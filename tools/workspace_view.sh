#!/usr/bin/env bash
# Makes WS/src/marl_mrta a view of the checkout: a directory of symlinks to its top-level
# entries. A single symlink to the checkout would put the workspace inside its own source
# space (the workspace lives in the checkout), and rosrun's `find -L` would loop through it.
set -euo pipefail
pkg_dir=$1
view=$2/src/marl_mrta
[ -L "$view" ] && rm "$view"
mkdir -p "$view"
shopt -s dotglob nullglob
for entry in "$pkg_dir"/*; do
  name=$(basename "$entry")
  case "$name" in .ws|.git|.venv) continue ;; esac
  [ "$(readlink "$view/$name" 2>/dev/null)" = "$entry" ] || ln -sfn "$entry" "$view/$name"
done
for link in "$view"/*; do  # entries removed from the checkout
  [ -e "$link" ] || rm -f "$link"
done
# Tests find the TurtleBot3 reference files at ../shared beside the package; keep that true here.
if [ -d "$pkg_dir/../shared" ]; then
  ln -sfn "$(cd "$pkg_dir/.." && pwd)/shared" "$2/src/shared"
fi
