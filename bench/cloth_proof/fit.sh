#!/usr/bin/env bash
# Fits the microcylinder cloth model `sadeghi-2013` (Sadeghi et al. 2013) to surface tables of
# the explicit woven patch (`fiberlab measure --surface --cloth`, issue 20 part 3) and reports
# the residual with `compare-model` (per-bin RMS, relative L2 against the table's own Monte
# Carlo noise, the worst bins, and the plane-of-incidence / cross-plane slices as a figure).
#
# The fit's objective is on the table's bins: the model is averaged over each bin (midpoint
# rule, SUB×SUB nodes in the table's cosθ dω measure), weighted by the table's standard errors;
# the colours (volume albedos) are fitted per channel. The preset fixes the weave geometry
# (coverages and tangent offsets are not parameters of the model's registry entry); the thread
# parameters of both families are free.
#
# The patch's tables are traced from the camera (their theta_i is the viewer), hence
# --viewer-first: sadeghi-2013 is not reciprocal.
#
# Usage: bench/cloth_proof/fit.sh TABLE.csv...     (default: bench/cloth_proof/{plain,twill}.csv)
# Environment:
#   PRESET  sadeghi-2013 preset fixing the weave geometry  (default linen-plain)
#   SUB     midpoint nodes per bin and axis                (default 3)
#   ITERS   Nelder–Mead iterations                         (default 400)
#   OUT     output directory                               (default bench/cloth_proof/fit)
# Writes OUT/NAME_fit.toml (the fitted parameters, usable with --params-file), OUT/NAME_fit.txt,
# OUT/NAME_residual.txt and .json, OUT/NAME_slices.png and OUT/NAME_fit_residuals.png.
set -euo pipefail
cd "$(dirname "$0")/../.."
PRESET=${PRESET:-linen-plain}
SUB=${SUB:-3}
ITERS=${ITERS:-400}
OUT=${OUT:-bench/cloth_proof/fit}
mkdir -p "$OUT"
if [ $# -eq 0 ]; then set -- bench/cloth_proof/plain.csv bench/cloth_proof/twill.csv; fi
cargo build --release -q -p fiberlab-cli
F=target/release/fiberlab
FREE=(--init gamma_s_1=12 --init gamma_s_2=12 --init gamma_v_1=24 --init gamma_v_2=24
      --init k_d_1=0.3 --init k_d_2=0.3 --init albedo_1=0.3 --init albedo_2=0.3)
for table in "$@"; do
  name=$(basename "$table" .csv)
  /usr/bin/time -f "$name: fit %e s wall" "$F" fit --model sadeghi-2013 --table "$table" --fix preset="$PRESET" \
    "${FREE[@]}" --subsamples "$SUB" --viewer-first --iterations "$ITERS" -q --out "$OUT/${name}_fit" | tee "$OUT/${name}_fit.txt"
  "$F" compare-model --model sadeghi-2013 --params-file "$OUT/${name}_fit.toml" --table "$table" \
    --subsamples "$SUB" --viewer-first --out "$OUT/$name" | tee "$OUT/${name}_residual.txt"
  "$F" compare-model --model sadeghi-2013 --params-file "$OUT/${name}_fit.toml" --table "$table" \
    --subsamples "$SUB" --viewer-first --json >"$OUT/${name}_residual.json"
  # The preset itself, unfitted, for reference.
  "$F" compare-model --model sadeghi-2013 --param preset="$PRESET" --table "$table" --subsamples "$SUB" --viewer-first \
    | grep 'relative L2' | sed "s/^/$name, preset $PRESET unfitted:/"
done
# The fitted model on a flat quad under the camera and lights of the explicit patch's render
# (scenes/cloth_patch.toml): scenes/cloth_fitted_NAME.toml, docs/gallery/cloth/fitted_NAME.png.
if [ "${RENDER:-1}" = 1 ]; then
  for table in "$@"; do
    name=$(basename "$table" .csv)
    scene=scenes/cloth_fitted_$name.toml
    {
      echo "# sadeghi-2013 fitted to the explicit $name patch's table (bench/cloth_proof/fit.sh writes this file),"
      echo "# on a flat quad with the camera and lights of scenes/cloth_patch.toml (mm, z up)."
      echo "#   fiberlab render $scene --out docs/gallery/cloth/fitted_$name"
      cat <<'SCENE'

[camera]
eye = [1.92, -0.48, 3.2]
target = [1.92, 1.92, 0.0]
up = [0.0, 0.0, 1.0]
fov = 40.0
width = 240
height = 240

[render]
spp = 16
max_depth = 12
seed = 0
exposure = 0.0

[[mesh]]
file = "cloth_quad.obj"
material = "fitted"

[[light]]
type = "environment"
radiance = [0.05, 0.05, 0.06]

[[light]]
type = "sun"
direction = [-0.5, -0.3, 0.81]
angular_radius_deg = 2.0
irradiance = [3.0, 2.9, 2.7]

[materials.fitted]
model = "sadeghi-2013"

[materials.fitted.params]
SCENE
      sed -n '/^\[params\]/,$p' "$OUT/${name}_fit.toml" | tail -n +2
    } >"$scene"
    "$F" render "$scene" --out "docs/gallery/cloth/fitted_$name" --quiet
  done
fi
