#!/usr/bin/env bash
# Runs the libFuzzer target of BUILD_DIR on every reader for a bounded time and fails if any crashes.
# Usage: test/fuzz/run_fuzzers.sh BUILD_DIR [SECONDS_PER_READER=30] [READER...]
#   (default: every reader; BORESIGHT_FUZZ_SEED: libFuzzer seed, default 1)
# BUILD_DIR must have been configured with clang and -DBORESIGHT_BUILD_FUZZ=ON, e.g.
#   CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DBORESIGHT_BUILD_FUZZ=ON -DBORESIGHT_BUILD_BENCH=OFF
#   ninja -C build-fuzz boresight_fuzzers
# Seed corpora are made at run time in a temporary folder from the real samples when they are present
# (../shared/data/real next to the project, or $BORESIGHT_REAL_DATA); nothing is written to the repo.
# The LCM log reader's seeds: a small log the fuzz executable writes itself (BORESIGHT_FUZZ_MAKE_SEED),
# and, when a `boresight` program is found ($BORESIGHT_CLI, BUILD_DIR/tools, build/tools), a log written
# by `boresight convert` from the real SCA1A/ACC1A samples.
# The method C measurement reader (ground_yaml) is seeded with small sample lists behind the fuzzer's own
# valid prefix and, when a `boresight` program is found, small files from `boresight simulate-ground`
# (and the same with the samples as one flow list).
set -euo pipefail

build=${1:?usage: run_fuzzers.sh BUILD_DIR [SECONDS_PER_READER] [READER...]}
secs=${2:-30}
shift 2 2>/dev/null || shift $#
here=$(cd "$(dirname "$0")" && pwd)
real=${BORESIGHT_REAL_DATA:-$here/../../../shared/data/real}
fuzzdir=$build/test/fuzz
exe=$fuzzdir/fuzz_level1
[[ -x $exe ]] || { echo "no $exe (configure with clang and -DBORESIGHT_BUILD_FUZZ=ON)" >&2; exit 2; }

work=$(mktemp -d "${TMPDIR:-/tmp}/boresight-fuzz.XXXXXX")
trap 'rm -rf "$work"' EXIT

# reader -> product name patterns of the real files that seed it
declare -A seeds=(
  [header]="*" [summary]="*" [generic]="KBR1B MAG1B GNV1A GPS1A GPS1B MAS1B TNK1B USO1B ILG1A"
  [sca1a]="SCA1A" [flagged]="ACC1A ACT1A AHK1A AHK1B" [acc1a]="ACC1A ACT1A" [sca1b]="SCA1B" [acc1b]="ACC1B ACT1B"
  [gnv]="GNV1B GNI1B" [qsa]="QSA1B QKS1B" [imu]="IMU1A IMU1B" [thr]="THR1A THR1B" [ihk]="IHK1A IHK1B"
  [hrt]="HRT1A HRT1B" [tim]="TIM1B" [clk]="CLK1A CLK1B"
  [stream_sca1a]="SCA1A" [stream_acc1a]="ACC1A ACT1A" [lcmlog]="" [ground_yaml]="" [lcmnode]=""
)

# mode byte: bit0 stop-on-error, bits1-2 kind (0 whole file, 1 ASCII header + body, 2 binary header + body)
seed_file() {  # seed_file OUT MODE_BYTE_OCTAL FILE [skip_header]
  local out=$1 mode=$2 src=$3
  { printf "\\$mode"; cat "$src"; } > "$out"
}

make_corpus() {
  local -
  set -f  # the patterns below are for find, not for the shell
  local reader=$1 dir=$work/corpus_$reader
  mkdir -p "$dir"
  printf '\000' > "$dir/empty"
  if [[ $reader == lcmlog ]]; then
    make_lcm_seeds "$dir"
    return 0
  fi
  if [[ $reader == ground_yaml ]]; then
    make_ground_seeds "$dir"
    return 0
  fi
  if [[ $reader == lcmnode ]]; then  # the node's own seed: a minute of valid messages of three heads
    BORESIGHT_FUZZ_MAKE_SEED="$dir/own" "$fuzzdir/fuzz_node" >/dev/null 2>&1 || true
    return 0
  fi
  [[ -d $real ]] || return 0
  local n=0 pat f
  for pat in ${seeds[$reader]}; do
    while IFS= read -r -d '' f; do
      n=$((n + 1))
      seed_file "$dir/whole_$n" 000 "$f"
      if [[ $reader == stream_* ]]; then
        # the streaming readers read files: the body behind the synthesised header, cut to fit max_len
        # (head ends the pipe early: awk's SIGPIPE is expected, hence || true under pipefail)
        { printf '\002'; awk 'body{print} /# End of YAML header|END OF HEADER/{body=1}' "$f" | head -c 60000 || true; } > "$dir/body_$n"
        head -c 60000 "$f" > "$dir/whole_$n.tmp" && { printf '\000'; cat "$dir/whole_$n.tmp"; } > "$dir/whole_$n" && rm -f "$dir/whole_$n.tmp"
      elif [[ $reader != header && $reader != summary && $reader != generic ]]; then
        # records only, behind the target's own synthesised header (kind 1)
        { printf '\002'; awk 'body{print} /# End of YAML header|END OF HEADER/{body=1}' "$f"; } > "$dir/body_$n"
      fi
    done < <(find "$real" -type f \( -name "${pat}_*" -o -name "${pat}" \) -print0 2>/dev/null | sort -z | head -z -n 60)
  done
  # Binary records for the binary readers (kind 2), converted from the real ASCII with python3 when present.
  if command -v python3 >/dev/null && [[ $reader == sca1b || $reader == acc1b || $reader == gnv ]]; then
    python3 - "$reader" "$real" "$dir" <<'PY'
import struct, sys, glob, os
reader, real, out = sys.argv[1:4]
pats = {"sca1b": ["SCA1B"], "acc1b": ["ACC1B", "ACT1B"], "gnv": ["GNV1B", "GNI1B"]}[reader]
k = 0
for pat in pats:
    for path in sorted(glob.glob(os.path.join(real, "**", pat + "_*"), recursive=True)):
        if path.endswith(".rpt"):
            continue
        body, data = False, b""
        for line in open(path, errors="replace"):
            if body:
                t = line.split()
                try:
                    if reader == "sca1b":
                        data += struct.pack(">icb5dB", int(t[0]), t[1].encode(), int(t[2]), *map(float, t[3:8]), int(t[8], 2))
                    elif reader == "acc1b":
                        data += struct.pack(">ic9dB", int(t[0]), t[1].encode(), *map(float, t[2:11]), int(t[11], 2))
                    else:
                        data += struct.pack(">icc12dB", int(t[0]), t[1].encode(), t[2].encode(), *map(float, t[3:15]), int(t[15], 2))
                except (ValueError, IndexError, struct.error):
                    pass
            if "End of YAML header" in line or line.startswith("END OF HEADER"):
                body = True
        k += 1
        with open(os.path.join(out, "binary_%d" % k), "wb") as f:
            f.write(b"\x04" + data[: 40 * 103])
PY
  fi
}

# LCM log seeds (mode byte 0: the log's bytes as they are).
make_lcm_seeds() {
  local dir=$1 cli=""
  if BORESIGHT_FUZZ_READER=lcmlog BORESIGHT_FUZZ_MAKE_SEED="$work/own.lcm" "$exe" >/dev/null 2>&1; then
    { printf '\000'; cat "$work/own.lcm"; } > "$dir/own"
  fi
  for c in "${BORESIGHT_CLI:-}" "$build/tools/boresight" "$here/../../build/tools/boresight"; do
    [[ -n $c && -x $c ]] && { cli=$c; break; }
  done
  [[ -n $cli && -d $real ]] || return 0
  local sca acc k=0
  sca=$(find "$real" -type f -name 'SCA1A_*' 2>/dev/null | sort | head -n 2 || true)
  acc=$(find "$real" -type f -name 'ACC1A_*' 2>/dev/null | sort | head -n 2 || true)
  for s in $sca; do
    for a in $acc; do
      k=$((k + 1))
      if "$cli" convert "$s" "$a" --out "$work/real_$k.lcm" >/dev/null 2>&1; then
        { printf '\000'; head -c 60000 "$work/real_$k.lcm"; } > "$dir/real_$k"
      fi
    done
  done
}

# Measurement-file seeds (mode byte 0: the whole file; 002 / 004: the samples behind the fuzzer's prefix
# that ends with "accel_mps2:" / "accel_mps2: [").
find_cli() {
  local c
  for c in "${BORESIGHT_CLI:-}" "$build/tools/boresight" "$here/../../build/tools/boresight"; do
    [[ -n $c && -x $c ]] && { echo "$c"; return 0; }
  done
  return 0
}
make_ground_seeds() {
  local dir=$1 cli setup k=0
  printf '\002\n      - [0.01, -0.02, 9.80665]\n      - [0.011, -0.019, 9.8067]  # c\n' > "$dir/block"
  printf '\004[0.01, -0.02, 9.80665],\n   [0.011, -0.019,\n    9.8067]]\n' > "$dir/flow"
  cli=$(find_cli)
  [[ -n $cli ]] || return 0
  for setup in single two-faces tilted; do
    k=$((k + 1))
    if "$cli" simulate-ground --seed "$k" --setup "$setup" --targets 5 --accel-samples 8 --out "$work/g_$k.yaml" >/dev/null 2>&1; then
      { printf '\000'; cat "$work/g_$k.yaml"; } > "$dir/sim_$k"
      # the same samples as one flow list [[...], ...]
      { printf '\000'; awk '/^    accel_mps2:/{print "    accel_mps2: ["; s=1; next}
           s && /^      - \[/{sub(/^      - /, "      "); print $0 ","; next}
           {if (s) {print "    ]"; s=0}; print} END{if (s) print "    ]"}' "$work/g_$k.yaml"; } > "$dir/sim_flow_$k"
    fi
  done
}

readers=("$@")
[[ ${#readers[@]} -gt 0 ]] || readers=(header sca1a flagged acc1a sca1b acc1b gnv qsa imu thr ihk hrt tim clk generic summary stream_sca1a stream_acc1a lcmlog ground_yaml lcmnode)
status=0
summary=()
for reader in "${readers[@]}"; do
  [[ -n ${seeds[$reader]+x} ]] || { echo "unknown reader '$reader'" >&2; exit 2; }
  name=fuzz_$reader
  rexe=$exe
  if [[ $reader == lcmnode ]]; then  # the node's handlers: their own executable (fuzz_node)
    rexe=$fuzzdir/fuzz_node
    [[ -x $rexe ]] || { summary+=("$name skipped: $rexe not built (needs the node library)"); continue; }
  fi
  make_corpus "$reader"
  log=$work/$name.log
  mkdir -p "$work/artifacts_$reader"
  echo "== $name: ${secs}s, seeds: $(ls "$work/corpus_$reader" | wc -l)"
  if BORESIGHT_FUZZ_READER=$reader "$rexe" -seed="${BORESIGHT_FUZZ_SEED:-1}" -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 -max_len=65536 -print_final_stats=1 \
      -artifact_prefix="$work/artifacts_$reader/" "$work/corpus_$reader" >"$log" 2>&1; then
    execs=$(grep -Eo 'stat::number_of_executed_units: *[0-9]+' "$log" | grep -Eo '[0-9]+$' || echo '?')
    summary+=("$name ok: $execs executions in ${secs}s")
  else
    status=1
    summary+=("$name CRASHED")
    echo "---- $name failed; last lines of its log:"
    tail -n 40 "$log"
    for a in "$work/artifacts_$reader"/*; do
      [[ -f $a ]] || continue
      mkdir -p "$build/fuzz-artifacts"
      cp "$a" "$build/fuzz-artifacts/${reader}_$(basename "$a")"
      echo "reproducer kept: $build/fuzz-artifacts/${reader}_$(basename "$a")"
    done
  fi
done
printf '%s\n' "${summary[@]}"
[[ ${#summary[@]} -gt 0 ]] || { echo "no reader was fuzzed" >&2; exit 2; }
exit $status
