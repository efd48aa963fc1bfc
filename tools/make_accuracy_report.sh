#!/usr/bin/env bash
# Regenerates docs/accuracy.md and docs/accuracy/<scene>/ (report, table and charts):
# `basalt study` on shipped scenes, on lavapipe and the CPU reference. Run it on a quiet
# machine of the CI class (2 cores). Environment:
#   BUDGET   seconds per scene (default 240)
#   BUILD    build directory (default ./build; basalt is built there first)
#   PBRT     path to a pbrt-v4 binary: adds the equal-error comparison with pbrt-v4 at 16 spp
#            (its image and wall time) to the Cornell box report
#   REPLOT=1 no new measurements: redraw the charts and reports from BUILD/accuracy/*/study.json
# Usage: tools/make_accuracy_report.sh [SCENE...]   (default: cornell-box coated-rough bump)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD:-$root/build}
budget=${BUDGET:-240}
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(cornell-box coated-rough bump)
cmake --build "$build" --target basalt -j"$(nproc)" >/dev/null
for scene in "${scenes[@]}"; do
  work=$build/accuracy/$scene
  out=$root/docs/accuracy/$scene
  extra=()
  if [ -n "${REPLOT:-}" ]; then
    /usr/bin/python3 "$root/tools/study_report.py" "$work/study.json"
  elif [ -n "${PBRT:-}" ] && [ "$scene" = cornell-box ]; then
    # pbrt-v4's own 16-spp render and its wall time, for the equal-error comparison.
    mkdir -p "$work"
    start=$(date +%s.%N)
    (cd "$root/scenes" && "$PBRT" --quiet --nthreads "$(nproc)" --spp 16 \
        --outfile "$work/pbrt-v4-16spp.exr" "$scene.pbrt")
    end=$(date +%s.%N)
    extra=(--compare "$work/pbrt-v4-16spp.exr" --compare-time "$(echo "$end - $start" | bc)"
           --compare-name "pbrt-v4 (16 spp, $(nproc) threads)")
  fi
  if [ -z "${REPLOT:-}" ]; then
    echo "basalt study $scene (budget $budget s)" >&2
    "$build/basalt" study "$root/scenes/$scene.pbrt" --budget "$budget" --spp-max 64 \
        --out "$work" "${extra[@]}"
  fi
  rm -rf "$out"
  mkdir -p "$out"
  cp "$work"/report.md "$work"/study.json "$work"/study.csv "$work"/chart-*.png "$out"/
  # Paths relative to the repository, not to this machine's checkout.
  sed -i "s|$root/||g; s|$build/|build/|g" "$out"/report.md "$out"/study.json "$out"/study.csv
done
# docs/accuracy.md: an introduction, then each scene's report with its links rebased.
/usr/bin/python3 - "$root" "${scenes[@]}" <<'PY'
import re, sys, os
root, scenes = sys.argv[1], sys.argv[2:]
parts = ["""# What accuracy costs in time

Every quality knob of basalt measured as error against time, on lavapipe and on the CPU
reference, by `basalt study` (README, "Command line"). Regenerate this page and
`docs/accuracy/` with one command, on a quiet 2-core machine of the CI class:

    tools/make_accuracy_report.sh            # PBRT=/path/to/pbrt adds the pbrt-v4 comparison

Each scene's section is its `report.md`, whose first lines give the machine and the basalt
commit measured; `docs/accuracy/<scene>/`
also holds the full table (`study.json`, `study.csv`). Error is relMSE (pbrt-v4's MRSE) and
1 - SSIM against a high-spp reference rendered by basalt with the default knobs; the knobs'
images and the reference come from the same renderer, so a biased setting shows as a floor.
Points a scene's budget did not reach are listed as skipped in its table.

"""]
for s in scenes:
    text = open(os.path.join(root, "docs", "accuracy", s, "report.md"), encoding="utf-8").read()
    text = re.sub(r"\]\((?!http)([^)]+)\)", lambda m: "](accuracy/%s/%s)" % (s, m.group(1)), text)
    text = re.sub(r"^(#+)", lambda m: m.group(1) + "#", text, flags=re.M)
    parts.append(text.rstrip() + "\n\n")
open(os.path.join(root, "docs", "accuracy.md"), "w", encoding="utf-8").write("".join(parts))
PY
echo "wrote docs/accuracy.md" >&2
