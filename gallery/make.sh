#!/usr/bin/env bash
# Rebuilds the gallery: blond, brown and black hair, front-lit and back-lit, rendered with
# Kajiya–Kay (fitted), Marschner, Chiang and the measured table of an explicit fiber, each
# compared with a high-sample render of the measured table (the "photograph").
#   gallery/make.sh            # preview quality (128×128, 16 spp; a few minutes on 2 cores)
#   SIZE=512 SPP=64 REF_SPP=1024 RAYS=20000000 gallery/make.sh   # publication quality
set -euo pipefail
cd "$(dirname "$0")/.."
SIZE=${SIZE:-128} SPP=${SPP:-16} REF_SPP=${REF_SPP:-128} RAYS=${RAYS:-2000000}
cargo build --release -q
bin=target/release/fiberlab
out=gallery
page=$out/README.md
{
  echo "# Gallery"
  echo
  echo "Made by \`gallery/make.sh\` (SIZE=$SIZE SPP=$SPP REF_SPP=$REF_SPP RAYS=$RAYS). Each row: the reference"
  echo "(the measured table of an explicit fiber with 2° cuticle scales, rendered at $REF_SPP spp), then"
  echo "Kajiya–Kay fitted to Chiang, Marschner 2003, Chiang 2016 and the measured table at $SPP spp."
  echo "Metrics are against the reference (\`fiberlab compare\`)."
} > "$page"
# name  eumelanin pheomelanin  sigma_a (d'Eon's melanin table, per unit radius)
while read -r name eu ph sigma; do
  table=$out/${name}_fiber
  $bin measure --theta-i=-70,-50,-30,-10,10,30,50,70 --rays "$RAYS" --bins 60,120 \
    --param sigma_a="$sigma" --param scale_angle=2 --out "$table" > /dev/null
  for light in front back; do
    if [ "$light" = front ]; then sun="[4.0, 1.3, -4.3]"; else sun="[-4.0, 1.5, 4.3]"; fi
    scene=$out/$name-$light.toml
    sed -e "s/width = 512/width = $SIZE/; s/height = 512/height = $SIZE/" \
        -e "s/eumelanin = 0.8, pheomelanin = 0.4/eumelanin = $eu, pheomelanin = $ph/" \
        -e "s/direction = \[1.0, 1.3, -0.5\]/direction = $sun/" scenes/hair_chiang.toml > "$scene"
    dir=$out/$name-$light
    {
      echo
      echo "## $name hair, $light-lit"
      echo
      echo "![$name $light]($name-$light/grid.png)"
      echo
      echo "Crops — highlights: ![highlights]($name-$light/crop_highlights.png)"
      echo "silhouette: ![silhouette]($name-$light/crop_silhouette.png)"
      echo
      echo '```'
      # Crops (fractions of the image for the default camera): the highlights on the crown
      # (R and the shifted, coloured TRT) and the silhouette where back light is transmitted.
      crops=(--crop "highlights=$((SIZE*30/100)),$((SIZE*10/100)),$((SIZE*70/100)),$((SIZE*35/100))"
             --crop "silhouette=$((SIZE*14/100)),$((SIZE*35/100)),$((SIZE*34/100)),$((SIZE*75/100))")
      $bin evaluate --scene "$scene" --table "$table.csv" --models kajiya-kay,marschner,chiang,measured \
        --spp "$SPP" --reference-spp "$REF_SPP" --out "$dir" "${crops[@]}" 2>"$dir.log" | grep -v "^wrote"
      echo '```'
    } >> "$page"
    rm -f "$dir"/*.exr
  done
done <<'TABLE'
blond 0.15 0.1 0.0815,0.1446,0.3105
brown 0.8 0.4 0.410,0.718,1.516
black 3.0 0.0 1.257,2.091,4.11
TABLE
rm -f $out/*_fiber.csv $out/*_fiber.exr $out/*.toml
echo "wrote $page"
