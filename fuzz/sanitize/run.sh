#!/usr/bin/env bash
# Runs the C programs examples/c/load_and_shade.c (through the library) and examples/c/read_sphb.c
# (no library, the spec's structs) under AddressSanitizer + UndefinedBehaviorSanitizer over the
# .sphb fuzz seeds, the load corpus (if a fuzz run made one; as is and checksum-repaired), the
# golden fixtures and COUNT
# (default 400) files mutated from them by mutate.py. A file may load (exit 0) or be rejected
# (exit 1, one-line error); any sanitizer report, crash or other exit status is a finding.
# Usage: fuzz/sanitize/run.sh [COUNT]   (from anywhere; needs cc with libasan/libubsan, python3)
set -euo pipefail
cd "$(dirname "$0")/../.."
COUNT=${1:-400}
TARGET=${CARGO_TARGET_DIR:-target}
OUT=$TARGET/sanitize
rm -rf "$OUT" && mkdir -p "$OUT"

cargo build --release -p spherebake-capi   # target/release/libspherebake.a
SAN=(-g -O1 -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=all)
cc -std=c99 "${SAN[@]}" -Iinclude examples/c/load_and_shade.c "$TARGET/release/libspherebake.a" \
  -lm -lpthread -ldl -o "$OUT/load_and_shade"
cc -std=c99 "${SAN[@]}" -Iinclude examples/c/read_sphb.c -lm -o "$OUT/read_sphb"

BASES=(fixtures/golden/*.sphb fuzz/seeds/*.sphb)
python3 fuzz/sanitize/mutate.py "$COUNT" "$OUT/mutated" "${BASES[@]}"
FILES=("${BASES[@]}" "$OUT"/mutated/*.sphb)
if [ -d fuzz/corpus/load ]; then
  # The corpus as is and with its checksums repaired (the load target reads both ways).
  python3 fuzz/sanitize/mutate.py repair "$OUT/repaired" fuzz/corpus/load/*
  FILES+=(fuzz/corpus/load/* "$OUT"/repaired/*.sphb)
fi

export ASAN_OPTIONS=detect_leaks=1:exitcode=90
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1:exitcode=91
reports=0
for prog in load_and_shade read_sphb; do
  loaded=0 rejected=0
  : >"$OUT/rules-$prog"
  for f in "${FILES[@]}"; do
    set +e
    "$OUT/$prog" "$f" >/dev/null 2>"$OUT/stderr"
    rc=$?
    set -e
    if [ "$rc" -gt 1 ] || grep -q "Sanitizer\|runtime error" "$OUT/stderr"; then
      reports=$((reports + 1))
      echo "REPORT $prog $f (exit $rc):"
      head -30 "$OUT/stderr"
    elif [ "$rc" -eq 0 ]; then
      loaded=$((loaded + 1))
    else
      rejected=$((rejected + 1))
      grep -o "rule [0-9]*" "$OUT/stderr" | head -1 >>"$OUT/rules-$prog" || true
    fi
  done
  echo "$prog: ${#FILES[@]} files, $loaded loaded, $rejected rejected;" \
    "distinct rules: $(sort -u "$OUT/rules-$prog" | wc -l) ($(sort -u "$OUT/rules-$prog" | cut -c6- | tr '\n' ' '))"
done
echo "sanitizer reports: $reports"
[ "$reports" -eq 0 ]
