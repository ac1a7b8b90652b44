#!/usr/bin/env bash
# The huang-2022 row of the gallery (the book's huang-2022 chapter): scenes/hair_huang.toml (20,000
# wavy strands on a head, sky and a low sun from behind the left) with the hair material replaced,
# assembled by `fiberlab montage` into docs/gallery/huang/huang_vs_chiang.png:
#   columns   huang-2022 circular (aspect 1) | huang-2022 elliptical (aspect 0.6, orientations
#             averaged) | chiang (beta_m = beta_n = the GGX alpha: not an equivalence, the same
#             number in its own roughness)
#   rows      smooth (alpha 0.1) | rough (alpha 0.4)
# Every tile has the same light, melanin (eumelanin 0.4, pheomelanin 0.15) and tilt (2°).
#   gallery/huang.sh                   # the committed image (200² tiles, 48 spp)
#   SIZE=320 SPP=256 gallery/huang.sh  # larger and cleaner
set -euo pipefail
cd "$(dirname "$0")/.."
SIZE=${SIZE:-200} SPP=${SPP:-48}
# FIBERLAB: a fiberlab binary to use as it is (default: build target/release/fiberlab).
if [ -n "${FIBERLAB:-}" ]; then bin=$FIBERLAB; else cargo build --release -q --bin fiberlab; bin=target/release/fiberlab; fi
out=docs/gallery/huang
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
melanin='eumelanin = 0.4, pheomelanin = 0.15'
start=$(date +%s)
tiles=()
for rough in 0.1 0.4; do
  for kind in circle ellipse chiang; do
    case $kind in
      circle)  material="model = \"huang-2022\"\nparams = { roughness = $rough, aspect = 1.0, alpha = 2.0, $melanin }"
               label="huang α=$rough circular" ;;
      ellipse) material="model = \"huang-2022\"\nparams = { roughness = $rough, aspect = 0.6, orientation = \"average\", alpha = 2.0, $melanin }"
               label="huang α=$rough aspect 0.6" ;;
      chiang)  material="model = \"chiang\"\nparams = { beta_m = $rough, beta_n = $rough, alpha = 2.0, $melanin }"
               label="chiang β=$rough" ;;
    esac
    name="${kind}_$rough"
    # The committed scene with the size, samples and hair material replaced.
    awk -v size="$SIZE" -v spp="$SPP" -v material="$material" '
      /^width = /  { print "width = " size; next }
      /^height = / { print "height = " size; next }
      /^spp = /    { print "spp = " spp; next }
      /^\[materials.hair\]/ { print; gsub(/\\n/, "\n", material); print material; skip = 2; next }
      skip > 0     { skip--; next }
      { print }' scenes/hair_huang.toml > "$tmp/$name.toml"
    grep -qF "spp = $SPP" "$tmp/$name.toml" && grep -qF "width = $SIZE" "$tmp/$name.toml" || {
      echo "gallery/huang.sh: scenes/hair_huang.toml changed; the lines to replace were not found" >&2
      exit 1
    }
    $bin render "$tmp/$name.toml" --out "$tmp/$name" --quiet 2> "$tmp/$name.log"
    tiles+=("$tmp/$name.png=$label")
  done
done
$bin montage --columns 3 --out "$out/huang_vs_chiang.png" \
  --title "same light and melanin; top α=0.1, bottom α=0.4; ${SIZE}², $SPP spp" "${tiles[@]}"
echo "wrote $out/huang_vs_chiang.png in $(( $(date +%s) - start )) s"
