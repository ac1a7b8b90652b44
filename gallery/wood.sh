#!/usr/bin/env bash
# The surfaces row of the gallery (README and the book): scenes/wood.toml (figured maple, the wood model with the
# procedural fiber map of `fiberlab texture wood`) and scenes/tigers_eye.toml (a cabochon, the
# tigers-eye preset), each under two light directions, to docs/gallery/wood/*.png:
#   wood_left / wood_right        distant light from −x / +x (along the grain): the curl
#                                 stripes move along the board
#   tigers_eye_left / _right      sun from −x / +x (across the fibers): the band glides
#   gallery/wood.sh                      # the committed images (256²; 64 spp, the stone 4096)
#   SIZE=512 SPP=256 gallery/wood.sh     # larger and cleaner
# The stone gets STONE_SPP (4096) samples: the polished dome reflects the sun onto the dark floor,
# a caustic that a path tracer finds only when a floor sample's bounce happens to hit the glint,
# and then with a large weight (depth 1 alone has no such dots; depth 2 has them). At 64 spp the
# floor of tigers_eye_left showed about 20 isolated dots more than twice as bright as the floor
# around them; at 4096 spp none (a few bright pixels remain on the stone's rim). No clamp is used.
set -euo pipefail
cd "$(dirname "$0")/.."
SIZE=${SIZE:-256} SPP=${SPP:-64} STONE_SPP=${STONE_SPP:-4096}
cargo build --release -q -p fiberlab-cli
bin=target/release/fiberlab
out=docs/gallery/wood
mkdir -p "$out"
$bin texture wood --out scenes/textures/maple > /dev/null
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
scenes=$(pwd)/scenes
while IFS='|' read -r name scene from to; do
  spp=$SPP
  [ "$scene" = tigers_eye ] && spp=$STONE_SPP
  # Relative paths of the scene (plank.obj, textures/…) are made absolute for the copy.
  sed -e "s/width = 256/width = $SIZE/; s/height = 256/height = $SIZE/; s/spp = 64/spp = $spp/" \
      -e "s|\"textures/|\"$scenes/textures/|g; s|\"plank.obj\"|\"$scenes/plank.obj\"|" \
      -e "s/^direction = $from\$/direction = $to/" "scenes/$scene.toml" > "$tmp/$name.toml"
  grep -qF "direction = $to" "$tmp/$name.toml" || {
    echo "gallery/wood.sh: scenes/$scene.toml changed; the light line 'direction = $from' was not found" >&2
    exit 1
  }
  t0=$(date +%s)
  $bin render "$tmp/$name.toml" --out "$tmp/$name" --quiet 2> "$tmp/$name.log"
  cp "$tmp/$name.png" "$out/$name.png"
  echo "$name: $spp spp, $(( $(date +%s) - t0 )) s"
done <<TABLE
wood_left|wood|\[0.9, 1.0, -0.35\]|[-0.9, 1.0, -0.35]
wood_right|wood|\[0.9, 1.0, -0.35\]|[0.9, 1.0, -0.35]
tigers_eye_left|tigers_eye|\[-0.6, 1.0, 0.2\]|[-0.6, 1.0, 0.2]
tigers_eye_right|tigers_eye|\[-0.6, 1.0, 0.2\]|[0.5, 1.0, 0.2]
TABLE
echo "wrote $out/{wood,tigers_eye}_{left,right}.png (${SIZE}², $SPP spp; the stone $STONE_SPP)"
