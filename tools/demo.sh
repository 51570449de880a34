#!/usr/bin/env bash
# The main job on the default scenario (lab_2r), headless. Expects the workspace sourced.
#   1. the simulator: robots drive a scripted route in lock-step (figures: results/sim_demo.json)
#   2. MAPPO training on the embedded executor: from new weights, the paper's way (results/demo/train/),
#      and the shipped generalist fine-tuned, train's default (results/demo/finetune/)
#   3. evaluation of both learned policies beside the baselines (results/demo/evaluate_*.json + Gantt PNGs)
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
scenario=${SCENARIO:-$here/scenarios/lab_2r.xml}
out=${OUT:-$here/results/demo}
mkdir -p "$out"

echo "== 1/3 simulator: scripted route, headless, lock-step"
# roslaunch's own start and shutdown lines (colour codes stripped first) are left out; sim_demo is
# a required node, so its normal end reads "REQUIRED process has died" (a failure leaves no figures,
# checked below).
roslaunch marl_mrta sim_demo.launch output:="$out/sim_demo.json" 2>&1 \
  | sed -u -e 's/\x1b\[[0-9;]*m//g' -e 's/\x1b\]2;[^\x07]*\x07//g' \
  | grep -v -E '^\s*$|^(started|process|logging|setting|Checking|Done checking|NODES|SUMMARY|PARAMETERS| \* |  /|ROS_MASTER|ROS_IP|auto-starting|core service|\[master\]|========|\.\.\. logging|Press Ctrl-C|log file:|Initiating shutdown|shutting down processing monitor|\.\.\. shutting down|done$|    (sim_demo|simulator) \()|REQUIRED process \[sim_demo-[0-9]+\] has died|killing on exit' || true
test -s "$out/sim_demo.json" || { echo "demo: the simulator demo wrote no figures" >&2; exit 1; }

echo "== 2/3 MAPPO training (embedded executor): new weights, preset tuned; then the generalist fine-tuned"
# Each demo trains afresh; runs of your own (scripts/train --out ...) are resumable instead.
rm -rf "$out/train" "$out/finetune"
rosrun marl_mrta train --scenario "$scenario" --preset tuned --seed 0 --out "$out/train"
# train's default (the finetune preset), bounded by steps rather than its minute of wall time so
# that every demo gives the same actor whatever the machine's load.
rosrun marl_mrta train --scenario "$scenario" --seed 0 --set total_env_steps=4000 --out "$out/finetune"

echo "== 3/3 evaluation: random, GA, auction, exact, then the learned policies (under the mask each was trained with)"
rosrun marl_mrta evaluate --method random,ga,auction,exact --scenario "$scenario" --episodes 20 --seed 0 \
  --quiet --out "$out/evaluate_baselines.json"
rosrun marl_mrta evaluate --method policy --policy "$out/train/actor.pt" --scenario "$scenario" \
  --episodes 20 --seed 0 --quiet --out "$out/evaluate_policy.json"
rosrun marl_mrta evaluate --method policy --policy "$out/finetune/actor.pt" --scenario "$scenario" \
  --episodes 20 --seed 0 --quiet --out "$out/evaluate_finetuned.json"
echo "demo: results in $out"
