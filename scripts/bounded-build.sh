# Sourced by scripts/fuzz.sh and scripts/sanitizers.sh: a build that README command (2) bounds so
# that the run stays within CI's 30 minutes.
#   bounded_build SECONDS WHAT COMMAND...
# Runs COMMAND; when SECONDS > 0 and it has not finished by then, says so naming WHAT and exits 3
# (what is built so far stays for the next run). SECONDS 0: no bound.
bounded_build() {
  local seconds=$1 what=$2 code=0
  shift 2
  if (( seconds <= 0 )); then
    "$@"
    return
  fi
  timeout "$seconds" "$@" || code=$?
  if (( code == 124 )); then
    echo "$what not finished within $seconds s: it does not run"
    exit 3
  fi
  return "$code"
}
