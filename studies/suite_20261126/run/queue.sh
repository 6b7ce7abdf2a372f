#!/bin/bash
# The whole diagnoses of a job file (make_jobs.py cpu CASE ...) one after another, in the run's checkout (run_fits.py
# beside it): queue.sh JOBS fwd|rev LOCKS. Two queues side by side (fwd and rev) keep both cores busy through a
# diagnosis' last, single searches; a case is taken by one queue only (a folder in LOCKS; empty LOCKS after a stop).
# Cases without a base fit or with a finished diagnosis are skipped; a diagnosis resumes from its stored evaluations.
jobs=$1 order=$2 locks=$3
mkdir -p "$locks"
names=$(python3 -c "import json, sys; print(' '.join(j['name'] for j in json.load(open(sys.argv[1]))))" "$jobs")
read -r -a names <<< "$names"
indices=$(seq 0 $((${#names[@]} - 1)))
[ "$order" = rev ] && indices=$(seq $((${#names[@]} - 1)) -1 0)
for i in $indices; do
  case=${names[$i]}
  [ -f "results/concealed/$case/fit/params.json" ] || continue
  [ -f "results/concealed/$case/diagnosis/diagnosis.json" ] && continue
  mkdir "$locks/$case" 2>/dev/null || continue
  echo "$(date) [$order] start $case"
  PYTHONPATH=. python3 run_fits.py --one "$jobs" "$i" > "logs/concealed/$case/queue.txt" 2>&1
  echo "$(date) [$order] $case exit $?"
  rmdir "$locks/$case"
done
