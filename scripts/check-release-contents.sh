#!/usr/bin/env bash
# The release build ships the product only: no test support, no benchmark harness.
#
#   bash scripts/check-release-contents.sh [CARGO_ARGS…]
#
# CARGO_ARGS go to `cargo tree` and `cargo build` (e.g. `--features test-support`, which must fail:
# that is how the check is shown to catch test support in a build).
#
# Builds what `cargo build --release` builds (the library and the `texatlas` binary, without
# dev-dependencies; LTO off, see below) and fails when
# 1. the `test-support` feature of texatlas is on in the normal dependency graph;
# 2. the release library (rlib) or binary defines a symbol of the test support modules
#    (`mesh::fixtures`, `atlas::parameterize::test_meshes`, `atlas::pack::test_charts`) or of a
#    `bench` module. The library is checked, not only the binary, because the linker drops unused
#    functions from the binary, so test support compiled into the library would not show there;
# 3. the binary's `--help` lists a `bench` subcommand (the harness is `cargo bench`, see
#    benches/).
# A positive control (`atlas::generate` must be found in both) makes sure the symbol search
# itself works: a renamed mangling scheme or an unreadable file fails instead of passing.
# Symbols are matched in their mangled (legacy) form, so no demangler is needed.
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$repo"
fail=0
bad() {
  echo "check-release-contents: $*" >&2
  fail=1
}

# `-i texatlas` lists the features of texatlas itself and what enables them (normal edges only:
# the dev-dependency that turns test-support on for tests and benches is not followed).
features=$(cargo tree -e normal,features -i texatlas "$@")
if ! grep -q 'texatlas feature "default"' <<<"$features"; then
  bad "cargo tree did not list the features of texatlas:"
  echo "$features" >&2
elif grep -q 'texatlas feature "test-support"' <<<"$features"; then
  bad 'the normal (shipped) dependency graph enables texatlas feature "test-support":'
  echo "$features" >&2
fi

# The artifact paths of this very build (not whatever a later `cargo bench` left in target/).
# Built without the release profile's LTO (and with the default codegen units): with LTO the
# rlib holds only bitcode, where nm finds no symbol at all, and the binary may inline
# `atlas::generate`. LTO changes how the code is generated, not which modules are compiled in.
# In a target directory of its own, so that it neither replaces nor rebuilds the LTO build of
# target/release.
artifacts=$(CARGO_PROFILE_RELEASE_LTO=false CARGO_PROFILE_RELEASE_CODEGEN_UNITS=16 \
  cargo build --release --target-dir "$repo/target/release-contents" --message-format=json \
  --quiet "$@" |
  python3 -c '
import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "texatlas":
        kinds = m["target"]["kind"]
        for f in m["filenames"]:
            if f.endswith(".rlib") or (kinds == ["bin"] and not f.endswith(".dwp")):
                print(f)
')
rlib=$(grep '\.rlib$' <<<"$artifacts" | head -n1 || true)
bin=$(grep -v '\.rlib$' <<<"$artifacts" | head -n1 || true)
[ -f "$rlib" ] || { echo "check-release-contents: no texatlas rlib in the build output" >&2; exit 1; }
[ -x "$bin" ] || { echo "check-release-contents: no texatlas binary in the build output" >&2; exit 1; }

forbidden='8texatlas(4mesh8fixtures|5atlas12parameterize11test_meshes|5atlas4pack11test_charts|5bench)'
control='8texatlas5atlas8generate'
for artifact in "$rlib" "$bin"; do
  symbols=$(nm --defined-only "$artifact" 2>/dev/null || true)
  if ! grep -q "$control" <<<"$symbols"; then
    bad "positive control failed: no atlas::generate symbol in $artifact (is nm working?)"
    continue
  fi
  found=$(grep -Eo "_ZN${forbidden}[0-9A-Za-z_\$.]*" <<<"$symbols" | sort -u || true)
  if [ -n "$found" ]; then
    bad "$artifact defines test support or benchmark symbols:"
    head -n 10 <<<"$found" >&2
  fi
done

if "$bin" --help | grep -Eq '^[[:space:]]+bench([[:space:]]|$)'; then
  bad "$bin --help lists a bench subcommand"
fi

if [ "$fail" -ne 0 ]; then
  exit 1
fi
echo "check-release-contents: ok ($rlib and $bin: no test support, no bench harness)"
