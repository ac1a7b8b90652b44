#!/usr/bin/env bash
# The fur row of the gallery (README and the book): scenes/fur.toml rendered three ways with one cortex absorption
# σ_a = (0.25, 0.45, 0.9) per unit radius (the colour of the fibre without a medulla):
#   medulla     yan-fur, kappa 0.7, sigma_m_s 1.5 (the scene as committed)
#   no_medulla  yan-fur, kappa 0 (a plain dielectric cylinder: R, TT, TRT only)
#   chiang      Chiang 2016 with sigma_a = the same σ_a, roughness chosen for the same lobe
#               widths: beta_m 0.2 ⇒ √v₀ = 0.178 rad ≈ 10°, beta_n 0.3 ⇒ logistic s = 0.117,
#               standard deviation sπ/√3 ≈ 12° (crates/scatter/src/hair/roughness.rs), alpha 3°.
#   gallery/fur.sh                      # the committed images (256², 64 spp)
#   SIZE=512 SPP=256 gallery/fur.sh     # larger and cleaner
set -euo pipefail
cd "$(dirname "$0")/.."
SIZE=${SIZE:-256} SPP=${SPP:-64}
cargo build --release -q -p fiberlab-cli
bin=target/release/fiberlab
out=gallery/fur
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
yan='model = "yan-fur"'
chiang='model = "chiang"'
medulla='params = { sigma_c_a = [0.25, 0.45, 0.9], kappa = 0.7, sigma_m_s = 1.5, beta_m = 10.0, beta_n = 12.0, alpha = 3.0 }'
while IFS='|' read -r name model params; do
  sed -e "s/width = 384/width = $SIZE/; s/height = 384/height = $SIZE/; s/spp = 32/spp = $SPP/" \
      -e "s/^$yan\$/$model/" -e "s/^params = { sigma_c_a = .*\$/$params/" scenes/fur.toml > "$tmp/$name.toml"
  grep -q "^$model\$" "$tmp/$name.toml" && grep -qF "$params" "$tmp/$name.toml" || {
    echo "gallery/fur.sh: scenes/fur.toml changed; the material lines were not found" >&2
    exit 1
  }
  t0=$(date +%s)
  $bin render "$tmp/$name.toml" --out "$tmp/$name" 2> "$tmp/$name.log"
  cp "$tmp/$name.png" "$out/$name.png"
  echo "$name: $(( $(date +%s) - t0 )) s ($(grep -o 'scene [0-9.]* s, render [0-9.]* s' "$tmp/$name.log"))"
done <<TABLE
medulla|$yan|$medulla
no_medulla|$yan|params = { sigma_c_a = [0.25, 0.45, 0.9], kappa = 0.0, sigma_m_s = 1.5, beta_m = 10.0, beta_n = 12.0, alpha = 3.0 }
chiang|$chiang|params = { sigma_a = [0.25, 0.45, 0.9], beta_m = 0.2, beta_n = 0.3, alpha = 3.0 }
TABLE
echo "wrote $out/{medulla,no_medulla,chiang}.png (${SIZE}², $SPP spp)"
