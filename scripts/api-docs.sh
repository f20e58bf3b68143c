#!/usr/bin/env bash
# HTML reference of the public headers with Doxygen (Debian's doxygen,
# installed here if missing), into build/api-docs/html (never committed).
# The headers' comments are plain C comments written for a reader of the
# header; an input filter hands them to Doxygen as documentation comments,
# so the HTML says exactly what the headers say.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v doxygen >/dev/null; then
  sudo=; [ "$(id -u)" -ne 0 ] && sudo=sudo
  echo "api-docs: installing doxygen" >&2
  $sudo apt-get update -qq >/dev/null
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends doxygen >/dev/null
fi
out=build/api-docs
mkdir -p "$out"
version=$(sed -n 's/^#define SPHERECULL_VERSION_STRING "\(.*\)"/\1/p' include/spherecull/sc_version.h)
cat >"$out/Doxyfile" <<DOX
PROJECT_NAME           = spherecull
PROJECT_NUMBER         = $version
PROJECT_BRIEF          = "Circumsphere prefilter, 8-wide BVH, exact ray tracing"
OUTPUT_DIRECTORY       = $out
INPUT                  = include README.md
RECURSIVE              = YES
FILE_PATTERNS          = *.h
USE_MDFILE_AS_MAINPAGE = README.md
INPUT_FILTER           = "sed -e 's|^\\([ ]*\\)/\\* |\\1/** |'"
FILTER_SOURCE_FILES    = NO
EXTRACT_ALL            = YES
EXTRACT_STATIC         = YES
OPTIMIZE_OUTPUT_FOR_C  = YES
MACRO_EXPANSION        = YES
PREDEFINED             = SC_API= "SC_ALIGNAS(n)=" "SC_STATIC_ASSERT(c,m)="
GENERATE_LATEX         = NO
HAVE_DOT               = NO
QUIET                  = YES
WARN_IF_UNDOCUMENTED   = NO
DOX
doxygen "$out/Doxyfile"
echo "api-docs: $out/html/index.html"
