#!/usr/bin/env bash
# The committed results (experiments/: ~80 MB of evaluation JSON, policies and figures) make the
# working tree larger than what one call to the lent GPU machine carries (64 MiB with the carried
# wheels). For the length of a lease, take experiments/' files out of git's index (they stay on
# disk, ignored through .git/info/exclude) but keep its scripts (experiments/*.sh), which the
# campaign runs; afterwards put the index back. Commit nothing in between.
#   bash experiments/gpu_tree.sh slim      # before the device calls
#   bash experiments/gpu_tree.sh restore   # after them (also after a crash in between)
# Prints the size of what would travel.
set -euo pipefail
cd "$(git rev-parse --show-toplevel)"
exclude=.git/info/exclude
marks=('/experiments/*' '!/experiments/*.sh')
case ${1:-} in
slim)
  git ls-files experiments | grep -v '^experiments/[^/]*\.sh$' > .git/gpu_tree_slim.txt
  git rm -q --cached --pathspec-from-file=.git/gpu_tree_slim.txt
  printf '%s\n' "${marks[@]}" >> "$exclude" ;;
restore)
  [ -f "$exclude" ] && { grep -vxF -e "${marks[0]}" -e "${marks[1]}" "$exclude" > "$exclude.tmp" || true; mv "$exclude.tmp" "$exclude"; }
  git reset -q -- experiments
  rm -f .git/gpu_tree_slim.txt ;;
*) echo "usage: $0 slim|restore" >&2; exit 2 ;;
esac
git ls-files -z | xargs -0 du -cb 2>/dev/null | tail -n 1
