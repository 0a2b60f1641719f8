#!/usr/bin/env bash
# Builds the documentation with warnings as errors: build_docs.sh PYTHON DOCS_SOURCE OUT_DIR.
# PYTHONPATH (the built module, for autodoc) and JAMFLOW_BIN (the CLI reference) come from ctest.
# Exit status 77 (ctest: skipped) only when Sphinx, myst-parser or furo is missing;
# scripts/setup.sh installs them, so in CI the build always runs.
set -euo pipefail
python="$1" source="$2" out="$3"
if ! "$python" -c 'import sphinx, myst_parser, furo' 2>/dev/null; then
  echo "SKIPPED: Sphinx, myst-parser or furo is missing for $python" \
       "(apt-get install -y python3-sphinx python3-myst-parser furo; scripts/setup.sh installs them)"
  exit 77
fi
rm -rf "$out/html" "$out/doctrees"
# -E -a: every page read and written afresh, so no warning hides in a cached page.
exec "$python" -m sphinx -W --keep-going -E -a -q -b html -d "$out/doctrees" "$source" "$out/html"
