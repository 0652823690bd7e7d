# Sourced by the scripts beside it (not run): their common arguments
#   BUILD_DIR [COUNT] [DURATION_S] [SCENARIO] [CONFIG]
# and a work folder removed on exit. Call: bench_args NAME COUNT_DEFAULT DURATION_DEFAULT "$@"
# Sets build, count, duration, scenario (default config/sim_gracefo.yaml, the ideal preset), config
# (default config/gracefo_ideal.yaml), cli (the boresight program), here (the project) and work.
bench_args() {
  local name=$1 count_default=$2 duration_default=$3
  shift 3
  build=${1:?usage: $name.sh BUILD_DIR [COUNT] [DURATION_S] [SCENARIO] [CONFIG]}
  count=${2:-$count_default}
  duration=${3:-$duration_default}
  here=$(cd "$(dirname "${BASH_SOURCE[0]}")/../../.." && pwd)
  scenario=${4:-$here/config/sim_gracefo.yaml}
  config=${5:-$here/config/gracefo_ideal.yaml}
  cli=$build/tools/boresight
  work=$(mktemp -d "${TMPDIR:-/tmp}/boresight-$name.XXXXXX")
  trap 'rm -rf "$work"' EXIT
}
