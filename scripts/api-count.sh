#!/usr/bin/env bash
# Counts the public API of the runtime crate `lobefit-tables` from its rustdoc HTML
# (stable rustdoc; every public item reachable from the crate root has its own page).
# Usage: bash scripts/api-count.sh [cargo doc feature flags...]
#   bash scripts/api-count.sh                      # default features (what a renderer sees)
#   bash scripts/api-count.sh --features writer    # plus the writer-only items
# Prints: free functions, constants, statics (the embedded tables), types (structs, enums, traits),
# methods (inherent methods and associated consts of the types, plus trait methods).
set -euo pipefail
cd "$(dirname "$0")/.."
target=${CARGO_TARGET_DIR:-target}
rm -rf "$target/doc/lobefit_tables"
cargo doc -q -p lobefit-tables --no-deps "$@"
doc="$target/doc/lobefit_tables"

# Item pages, skipping rustdoc's redirect stubs.
pages() { find "$doc" -name "$1" -print0 | xargs -0 -r grep -L 'http-equiv="refresh"' | sort; }
count() { pages "$1" | grep -c . || true; }

fns=$(count 'fn.*.html')
consts=$(count 'constant.*.html')
statics=$(count 'static.*.html')
types=$(( $(count 'struct.*.html') + $(count 'enum.*.html') + $(count 'trait.*.html') ))

# Methods of structs/enums: the anchors in the inherent "Implementations" section only
# (trait implementations such as Debug or Display are not the crate's API). Trait pages:
# the methods the trait declares (required and provided), before its implementors.
methods=0
for f in $(pages 'struct.*.html') $(pages 'enum.*.html'); do
  n=$(perl -0777 -ne '
    my ($s) = /id="implementations-list"(.*?)(?:id="trait-implementations"|id="synthetic-implementations"|id="blanket-implementations"|$)/s;
    my $c = () = ($s // "") =~ /id="(?:method|associatedconstant)\.\w+"/g; print $c' "$f")
  methods=$((methods + n))
done
for f in $(pages 'trait.*.html'); do
  n=$(perl -0777 -ne '
    my ($s) = /^(.*?)(?:id="implementors"|id="foreign-impls"|$)/s;
    my $c = () = $s =~ /id="(?:tymethod|method)\.\w+"/g; print $c' "$f")
  methods=$((methods + n))
done

printf 'free functions %d\nconstants %d\nstatics %d\ntypes %d\nmethods %d\n' "$fns" "$consts" "$statics" "$types" "$methods"
