#!/usr/bin/env bash
# The shared core exports exactly the functions its public headers declare
# with SC_API (the headers the umbrella spherecull.h includes): none
# missing, no internal symbol leaking.
#   exports.sh INCLUDE_DIR LIBSPHERECULL_SO
set -euo pipefail
inc=$1 so=$2
headers=$(sed -n 's|^#include "\(spherecull/sc_[a-z_]*\.h\)"|\1|p' "$inc/spherecull.h")
declared=$(cd "$inc" && sed -n '/^SC_API/{s/(.*//;s/.*[ *]//;p}' $headers | sort -u)
exported=$(nm -D --defined-only "$so" | awk '{print $3}' | sort -u)
[ -n "$declared" ] || { echo "no SC_API declarations found"; exit 1; }
if [ "$declared" != "$exported" ]; then
  echo "declared (<) and exported (>) differ:"
  diff <(echo "$declared") <(echo "$exported") || true
  exit 1
fi
echo "$(wc -l <<<"$exported") functions declared and exported"
