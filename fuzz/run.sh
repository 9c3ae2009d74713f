#!/usr/bin/env bash
# Fuzz every scene reader for SECONDS each (default 300), one job at a time, niced, then
# print a summary. Usage: fuzz/run.sh [SECONDS] [TARGET...]
#   FUZZ_ARGS="..."  extra libFuzzer flags, e.g. FUZZ_ARGS="-fork=1 -ignore_crashes=1" to
#                    keep going past a crash (crashes still land in artifacts/<target>/).
# New corpus entries go to fuzz/corpus/<target>/ (the seeds in fuzz/seeds/<target>/ are read
# too), crash inputs to fuzz/artifacts/<target>/, logs to fuzz/logs/<target>.log; none of
# these is committed. Needs the nightly toolchain and cargo-fuzz
# (cargo +nightly install cargo-fuzz --locked).
set -u
cd "$(dirname "$0")"
secs=${1:-300}
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(gltf glb obj toml)
mkdir -p logs
nice -n 10 cargo +nightly fuzz build --debug-assertions 2>logs/build.log \
  || { tail -20 logs/build.log; exit 1; }
summary=()
for t in "${targets[@]}"; do
  mkdir -p "corpus/$t" "artifacts/$t"
  before=$(ls "artifacts/$t" | wc -l)
  echo "== $t: ${secs}s" >&2
  dict=dicts/$t.dict
  [ "$t" = glb ] && dict=dicts/gltf.dict
  # shellcheck disable=SC2086
  nice -n 10 cargo +nightly fuzz run --debug-assertions "$t" "corpus/$t" "seeds/$t" -- \
    -max_total_time="$secs" -max_len=65536 -rss_limit_mb=2048 -timeout=10 \
    -jobs=1 -workers=1 -print_final_stats=1 -dict="$dict" ${FUZZ_ARGS:-} >"logs/$t.log" 2>&1
  rc=$?
  # With -jobs=1 libFuzzer runs one worker whose output also lands in fuzz-0.log.
  mv -f fuzz-0.log "logs/$t.job0.log" 2>/dev/null
  execs=$(grep -oE '(Done [0-9]+ runs|stat::number_of_executed_units: *[0-9]+)' "logs/$t.log" \
    | grep -oE '[0-9]+' | tail -1)
  corpus=$(ls "corpus/$t" | wc -l)
  crashes=$(( $(ls "artifacts/$t" | wc -l) - before ))
  summary+=("$(printf '%-5s %6ss  execs %-10s corpus %-5s new crashes %s  (exit %s)' \
    "$t" "$secs" "${execs:-?}" "$corpus" "$crashes" "$rc")")
done
echo "== summary"
printf '%s\n' "${summary[@]}"
