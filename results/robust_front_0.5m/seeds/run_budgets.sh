#!/usr/bin/env bash
# The 0.5 m robust-front searches, one budget after another, each answer then checked on NEC-2 and the
# field set (../check_answer.py); resumable: run this again after a stop and every budget picks up its
# history.jsonl, every check its finished outputs. It runs in the checkout that holds it:
#   bash results/robust_front_0.5m/seeds/run_budgets.sh [BUDGET ...]        (default: 600 900 200)
# or in a worktree of the commit being searched (so edits to the checkout cannot reach a running search),
# writing into the checkout's folder:
#   PYTHONPATH=/tmp/wt PYTHON=/work/main/.venv/bin/python OUT=/work/main/results/robust_front_0.5m \
#     bash /tmp/wt/results/robust_front_0.5m/seeds/run_budgets.sh
set -euo pipefail
cd "$(dirname "$0")/../../.."  # the checkout (or worktree): the seeds are named by these relative paths, as in every run so far
PYTHON="${PYTHON:-.venv/bin/python}"
OUT="${OUT:-results/robust_front_0.5m}"
budgets=("$@")
[ ${#budgets[@]} -eq 0 ] && budgets=(600 900 200)
for a in "${budgets[@]}"; do
  seeds=(results/robust_front_0.5m/seeds/budget-"$a"-{1,2,3,4,5,6}.json)
  "$PYTHON" -m groundplane optimise --pareto "$a" --shape teeth-xy --scenarios soil --max-loss 0.005 \
    --budget 120 --explore 6 --build-tolerance 0.001 --max-budget 240 --mesh 0.5 --freqs 55:97:3 \
    --confirm-top 2 --answer-mesh 0.35 --ladder 0 --reference sawtooth-20-16 \
    --beside results/pareto/pareto.csv -o "$OUT" --seed "${seeds[@]}"
  # the answer on NEC-2 and on the field set (check_answer.py: the steps still missing)
  "$PYTHON" results/robust_front_0.5m/check_answer.py "$a" --folder "$OUT" || echo "run_budgets: budget $a's checks did not finish"
done
