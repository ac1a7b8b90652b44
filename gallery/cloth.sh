#!/usr/bin/env bash
# The cloth row of the gallery (README and the book): scenes/cloth.toml (a cloth draped over a sphere, the mesh of
# `fiberlab mesh cloth`) with every preset of irawan-2012 (6, the weave tiled uv_scale = 40
# times across the cloth) and of sadeghi-2013 (6, no UV dependence), under two sun
# directions, assembled by `fiberlab montage` into docs/gallery/cloth/presets_light{1,2}.png:
#   light1   sun from [-0.8, 1.0, 0.5] (front left, as the scene is committed)
#   light2   sun from [0.9, 0.5, -0.7] (behind right, low: grazing and back-scattered light)
# The satin tiles are labelled charmeuse / charmeuse-back (polyester-satin-charmeuse[-back]).
#   gallery/cloth.sh                      # the committed images (160² each, 32 spp)
#   SIZE=320 SPP=256 gallery/cloth.sh     # larger and cleaner
set -euo pipefail
cd "$(dirname "$0")/.."
SIZE=${SIZE:-160} SPP=${SPP:-32}
cargo build --release -q -p fiberlab-cli
bin=target/release/fiberlab
out=docs/gallery/cloth
mkdir -p "$out"
$bin mesh cloth --out scenes/cloth.obj > /dev/null
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
scenes=$(pwd)/scenes
irawan="cotton-denim silk-shantung silk-charmeuse cotton-twill wool-gabardine polyester-lining"
sadeghi="linen-plain silk-crepe-de-chine polyester-satin-charmeuse polyester-satin-charmeuse-back silk-shot velvet"
start=$(date +%s)
for light in 1 2; do
  case $light in
    1) direction='[-0.8, 1.0, 0.5]' ;;
    2) direction='[0.9, 0.5, -0.7]' ;;
  esac
  tiles=()
  for entry in $(for p in $irawan; do echo "irawan-2012:$p"; done; for p in $sadeghi; do echo "sadeghi-2013:$p"; done); do
    model=${entry%%:*} preset=${entry#*:}
    name="${model}_${preset}_light$light"
    # The committed scene with the size, samples, fabric and light replaced; sadeghi-2013 has
    # no position, so its copy drops uv_scale.
    sed -e "s/width = 256/width = $SIZE/; s/height = 256/height = $SIZE/; s/spp = 64/spp = $SPP/" \
        -e "s|\"cloth.obj\"|\"$scenes/cloth.obj\"|" \
        -e "s/^model = \"irawan-2012\"\$/model = \"$model\"/" \
        -e "s/^params = { preset = \"cotton-denim\" }\$/params = { preset = \"$preset\" }/" \
        -e "s/^direction = \[-0.8, 1.0, 0.5\]\$/direction = $direction/" scenes/cloth.toml > "$tmp/$name.toml"
    if [ "$model" = sadeghi-2013 ]; then sed -i '/^uv_scale = /d' "$tmp/$name.toml"; fi
    grep -qF "preset = \"$preset\"" "$tmp/$name.toml" && grep -qF "direction = $direction" "$tmp/$name.toml" || {
      echo "gallery/cloth.sh: scenes/cloth.toml changed; the material or light lines were not found" >&2
      exit 1
    }
    $bin render "$tmp/$name.toml" --out "$tmp/$name" --quiet 2> "$tmp/$name.log"
    # The longest names do not fit over a 160-pixel tile: the satin labels drop "polyester-".
    tiles+=("$tmp/$name.png=${preset#polyester-satin-}")
  done
  $bin montage --columns 6 --out "$out/presets_light$light.png" \
    --title "irawan-2012 (top), sadeghi-2013 (bottom); sun from $direction; ${SIZE}², $SPP spp" "${tiles[@]}"
done
echo "wrote $out/presets_light{1,2}.png in $(( $(date +%s) - start )) s"
