#!/usr/bin/env bash
# The cluster scripts' own checks (issue 43), without a cluster: every bad invocation of
# submit-slurm and parallel-ssh is one "error:" line and exit 2 before anything is submitted
# (an option without its value once ended them with bash's "unbound variable", exit 1; -n of
# 20 digits reached sbatch). A stub sbatch on PATH records what a good invocation submits:
# the array, the resubmitted shards of N, the dependency; a refusing sbatch is exit 1 naming
# the job it refused.
#
#   tests/cluster/script_arguments_test.sh SCRIPTS_CLUSTER_DIR BIN_DIR
set -euo pipefail
[[ $# -eq 2 ]] || { echo "usage: $0 SCRIPTS_CLUSTER_DIR BIN_DIR" >&2; exit 2; }
cluster=$(cd "$1" && pwd)
bin=$(cd "$2" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }

mkdir -p "$tmp/stub"
cat > "$tmp/stub/sbatch" <<'STUB'
#!/usr/bin/env bash
echo "$*" >> "$SBATCH_LOG"
[[ -z ${SBATCH_REFUSE:-} ]] || { echo "sbatch: error: Batch job submission failed" >&2; exit 1; }
n=$(wc -l < "$SBATCH_LOG")
echo "$((1000 + n));cluster"
STUB
chmod +x "$tmp/stub/sbatch"
export PATH="$tmp/stub:$PATH" SBATCH_LOG="$tmp/sbatch.log"

# expect_usage_error SCRIPT ARGS...: exit 2, exactly one line on stderr, an error: line.
expect_usage_error() {
  local script=$1 status=0
  shift
  : > "$SBATCH_LOG"
  "$cluster/$script" "$@" > "$tmp/out" 2> "$tmp/err" || status=$?
  local lines
  lines=$(wc -l < "$tmp/err")
  if [[ $status -ne 2 || $lines -ne 1 ]] || ! grep -q "^error: $script: " "$tmp/err"; then
    fail "$script $*: exit $status, stderr: $(cat "$tmp/err")"
  fi
  [[ ! -s $SBATCH_LOG ]] || fail "$script $*: submitted despite the error"
}

out="$tmp/out-dir"
for opt in -n --resubmit --after --bin --logs --sbatch; do
  expect_usage_error submit-slurm "$opt"
done
expect_usage_error submit-slurm -n 4
expect_usage_error submit-slurm -- stereo-batch in -o "$out"
expect_usage_error submit-slurm -n 0 -- stereo-batch in -o "$out"
expect_usage_error submit-slurm -n 99999999999999999999 -- stereo-batch in -o "$out"
expect_usage_error submit-slurm -n 1000001 -- stereo-batch in -o "$out"
expect_usage_error submit-slurm -n 4 --resubmit 4 -- stereo-batch in -o "$out"
expect_usage_error submit-slurm -n 4 --resubmit 1-9 -- stereo-batch in -o "$out"
expect_usage_error submit-slurm -n 4 --resubmit "1;rm" -- stereo-batch in -o "$out"
expect_usage_error submit-slurm -n 4 --after abc -- stereo-batch in -o "$out"
expect_usage_error submit-slurm -n 4 --bin "$tmp/none" -- stereo-batch in -o "$out"
expect_usage_error submit-slurm -n 4 --bin "$bin" -- no-such-tool in -o "$out"
expect_usage_error submit-slurm -n 4 --bin "$bin" -- stereo-batch in
expect_usage_error submit-slurm -n 4 --bin "$bin" -- stereo-batch in -o "$out" --shard 1/2
expect_usage_error submit-slurm -n 4 --bin "$bin" -- stereo-batch in -o "$out" -j 4
expect_usage_error submit-slurm -n 4 --frobnicate -- stereo-batch in -o "$out"

for opt in -n --hosts --jobs-per-host --bin; do
  expect_usage_error parallel-ssh "$opt"
done
echo ":" > "$tmp/hosts"
expect_usage_error parallel-ssh -n 4 -- stereo-batch in -o "$out"
expect_usage_error parallel-ssh -n 4 --hosts "$tmp/none" -- stereo-batch in -o "$out"
expect_usage_error parallel-ssh -n 99999999999999999999 --hosts "$tmp/hosts" -- stereo-batch in -o "$out"
expect_usage_error parallel-ssh -n 4 --hosts "$tmp/hosts" --jobs-per-host 0 -- stereo-batch in -o "$out"
expect_usage_error parallel-ssh -n 4 --hosts "$tmp/hosts" --jobs-per-host x -- stereo-batch in -o "$out"

# A good submission: the array of N, then the merge after it.
: > "$SBATCH_LOG"
ids=$("$cluster/submit-slurm" -n 4 --bin "$bin" --after 77 -- stereo-batch in -o "$out" 2> "$tmp/err") ||
  fail "a good submission failed: $(cat "$tmp/err")"
[[ $ids == "1001 1002" ]] || fail "a good submission printed '$ids', not the two job ids"
grep -q -- "--array=0-3 .*--dependency=afterok:77 .*shard.sbatch stereo-batch in -o $out" "$SBATCH_LOG" ||
  fail "the array job was not submitted as expected: $(head -1 "$SBATCH_LOG")"
grep -q -- "--dependency=afterok:1001 .*merge.sbatch $out" "$SBATCH_LOG" ||
  fail "the merge job does not wait for the array: $(tail -1 "$SBATCH_LOG")"

# Resubmitted shards keep N.
: > "$SBATCH_LOG"
"$cluster/submit-slurm" -n 4 --bin "$bin" --resubmit 0,2-3 -- stereo-batch in -o "$out" > /dev/null 2>&1 ||
  fail "a resubmission failed"
grep -q -- "--array=0,2-3 .*LUNARNAV_SHARDS=4" "$SBATCH_LOG" || fail "resubmitted shards lost N: $(head -1 "$SBATCH_LOG")"

# sbatch refusing: exit 1, its own message and one error line naming the job.
: > "$SBATCH_LOG"
status=0
SBATCH_REFUSE=1 "$cluster/submit-slurm" -n 4 --bin "$bin" -- stereo-batch in -o "$out" > /dev/null 2> "$tmp/err" || status=$?
[[ $status -eq 1 ]] && grep -q "^error: submit-slurm: sbatch refused the array job" "$tmp/err" ||
  fail "a refusing sbatch: exit $status, stderr: $(cat "$tmp/err")"

if [[ $failures -gt 0 ]]; then
  echo "script_arguments_test: $failures failure(s)" >&2
  exit 1
fi
echo "script_arguments_test: passed"
