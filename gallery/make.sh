#!/usr/bin/env bash
# Rebuilds the gallery: blond, brown and black hair, front-lit and back-lit, rendered with
# Kajiya–Kay (fitted), Marschner, Chiang and the measured table of an explicit fiber, each
# compared with a high-sample render of the measured table (the "photograph"), with the
# residual Monte Carlo noise of every render beside each metric (`fiberlab evaluate --help`).
#   SPP_blond_front=1536 SPP_brown_front=768 SPP_brown_back=768 SPP_black_back=4096 gallery/make.sh   # the committed gallery (26 min on 2 cores)
#   SIZE=96 SPP=48 REF_SPP=448 gallery/make.sh        # a quick look (minutes): differences near the noise
#   ROWS="blond-front brown-front" SPP=… gallery/make.sh   # only these rows; the others are kept
# Each row writes gallery/ROW/section.md (its settings, output and time); README.md is the
# header and every row's section, so a row re-rendered alone keeps the others. SPP_<hair>_<light>
# gives one row its own models' spp (light hair needs more: the aim is every model's excess
# RMSE at least 3× its noise floor, which evaluate prints).
# Every hair gets the scene's absorption (`evaluate` maps it; docs/theory/hair.md, "One
# absorption for every hair model"), and the explicit fiber is measured with the same σ_a.
set -euo pipefail
cd "$(dirname "$0")/.."
SIZE=${SIZE:-96} SPP=${SPP:-384} REF_SPP=${REF_SPP:-3584} RAYS=${RAYS:-1000000} ROWS=${ROWS:-}
cargo build --release -q -p fiberlab-cli
bin=target/release/fiberlab
out=gallery
page=$out/README.md
wanted() { [ -z "$ROWS" ] || [[ " $ROWS " == *" $1 "* ]]; }
# name  eumelanin pheomelanin; σ_a per unit radius from d'Eon 2011's pigment table, as the models get it
while read -r name eu ph; do
  wanted "$name-front" || wanted "$name-back" || continue
  sigma=$(awk -v e="$eu" -v p="$ph" 'BEGIN { printf "%.6g,%.6g,%.6g", 0.419*e+0.187*p, 0.697*e+0.4*p, 1.37*e+1.05*p }')
  table=$out/${name}_fiber
  # Incidences up to ±85°: beyond the measured range the `measured` model reuses the nearest
  # slice, which underestimates the steeply rising reflection at grazing light (blond, green: the
  # camera-side furnace at θ_o = 69° is 0.61 from −70…70, 0.71 from these, Chiang's 0.71).
  $bin measure --theta-i=-85,-78,-70,-60,-50,-30,-10,10,30,50,60,70,78,85 --rays "$RAYS" --bins 60,120 \
    --param sigma_a="$sigma" --param scale_angle=2 --out "$table" > /dev/null
  for light in front back; do
    wanted "$name-$light" || continue
    if [ "$light" = front ]; then sun="[4.0, 1.3, -4.3]"; else sun="[-4.0, 1.5, 4.3]"; fi
    row_spp_var="SPP_${name}_${light}"
    row_spp=${!row_spp_var:-$SPP}
    scene=$out/$name-$light.toml
    sed -e "s/width = 512/width = $SIZE/; s/height = 512/height = $SIZE/" \
        -e "s/eumelanin = 0.8, pheomelanin = 0.4/eumelanin = $eu, pheomelanin = $ph/" \
        -e "s/direction = \[1.0, 1.3, -0.5\]/direction = $sun/" scenes/hair_chiang.toml > "$scene"
    dir=$out/$name-$light
    mkdir -p "$dir"
    t0=$(date +%s)
    section=$dir/section.md.partial  # renamed when the row is done: a failed row keeps the old one
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
        --spp "$row_spp" --reference-spp "$REF_SPP" --out "$dir" "${crops[@]}" 2>"$dir.log" | grep -v "^wrote"
      echo '```'
      echo
      echo "*${SIZE}², models $row_spp spp, reference $REF_SPP spp, table $RAYS rays per incidence; $(( $(date +%s) - t0 )) s on $(nproc) cores.*"
    } > "$section"
    mv "$section" "$dir/section.md"
    rm -f "$dir"/*.exr
  done
done <<'TABLE'
blond 0.15 0.1
brown 0.8 0.4
black 3.0 0.0
TABLE
rm -f $out/*_fiber.csv $out/*_fiber.exr $out/*.toml
{
  echo "# Gallery"
  echo
  echo "Made by \`gallery/make.sh\`; each row says its size, samples and time. Each row: the reference"
  echo "(the measured table of an explicit fiber with 2° cuticle scales, rendered at many samples),"
  echo "then Kajiya–Kay fitted to Chiang, Marschner 2003, Chiang 2016 and the measured table at fewer."
  echo "Every model gets the scene's hair: one σ_a per unit radius, mapped to"
  echo "each model's parametrization and printed below (\`docs/theory/hair.md\`, \"One absorption for every"
  echo "hair model\"); Kajiya–Kay is fitted to its luminance under an energy bound, coloured by what"
  echo "the hair scatters toward the viewer's side, then scaled per channel until its hair is as bright"
  echo "as Chiang's in the same scene, within the bound (\`docs/book/src/measuring/evaluate.md\`; its line"
  echo "below says by how much and how close it came). \`hair R/G/B\`: per channel, the model's mean over"
  echo "the pixels the hair covers over the reference's (1/1/1: same brightness and colour)."
  echo
  echo "Metrics are against the reference (\`fiberlab compare\`), on linear values except SSIM and FLIP."
  echo "Each render is the mean of two halves of its samples with different seeds; its noise is"
  echo "RMSE(half 1, half 2)/2 (\`image noise\`). Beside each metric, in parentheses, its **noise floor**:"
  echo "what the model's and the reference's noise alone give (RMSE: √(noise_model² + noise_reference²);"
  echo "relMSE: the same per pixel). \`excess\` = √(rmse² − floor²) is the part of the RMSE the model, not"
  echo "the noise, explains, and \`= N× noise\` after it is excess over floor: a model's difference from the"
  echo "reference is resolved where that is at least 3. The \`measured\` row is the reference's own model"
  echo "at the models' budget: its excess should be ≈ 0, and its SSIM and FLIP show what the noise alone"
  echo "does to those two metrics."
  for row in blond-front blond-back brown-front brown-back black-front black-back; do
    cat "$out/$row/section.md"
  done
} > "$page"
echo "wrote $page"
