#!/usr/bin/env bash
# Renders every material of a catalogue (default examples/catalogue.json) into docs/gallery/NAME.png
# and writes docs/gallery/README.md, a markdown table of the images, for the README gallery. The
# catalogue's materials with a rough surface (the seed white in gloss, satin and matte) also get their
# in-plane lobes plotted into docs/gallery/finishes-lobes.png.
#
#   tools/dev/gallery.sh [BRDFTOOL] [CATALOGUE] [OUT_DIR]
#
# BRDFTOOL defaults to the newest build/*/bin/brdftool (or $BRDFTOOL). Previews, not tables: each
# material is solved on the CPU at "draft" accuracy (a temporary copy of the catalogue with the
# accuracy overridden; tables for production keep the catalogue's own) and rendered at 256 x 256 under
# a light from the upper left and a dim sky. Needs jq. About a minute for the 8 example materials.
set -euo pipefail

root=$(cd "$(dirname "$0")/../.." && pwd)
tool=${1:-${BRDFTOOL:-}}
if [[ -z "$tool" ]]; then
  tool=$(ls -t "$root"/build*/bin/brdftool 2>/dev/null | head -n 1 || true)
fi
catalogue=${2:-$root/examples/catalogue.json}
out=${3:-$root/docs/gallery}
size=${GALLERY_SIZE:-256}
if [[ -z "$tool" || ! -x "$tool" ]]; then
  echo "gallery.sh: no brdftool found; build it or pass its path as the first argument" >&2
  exit 2
fi
command -v jq >/dev/null || { echo "gallery.sh: needs jq (apt-get install jq)" >&2; exit 2; }

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Draft accuracy for every material, whatever the catalogue or its defaults say.
jq '(.defaults // {}) as $d | .defaults = ($d + {accuracy: "draft"})
    | .materials |= map(.accuracy = "draft")' "$catalogue" > "$tmp/catalogue.json"

mkdir -p "$out"
mapfile -t names < <(jq -r '.materials[].name' "$tmp/catalogue.json")
start=$SECONDS
for name in "${names[@]}"; do
  t0=$SECONDS
  BRDF_LOG=error "$tool" render "$tmp/catalogue.json" --material "$name" --device cpu --size "$size" \
    --environment sky -o "$out/$name.png"
  echo "gallery.sh: $name.png ($((SECONDS - t0)) s)"
done
# The rough surfaces: a finish name or {"roughness": ...}, the material's own or the defaults'.
mapfile -t finish_names < <(jq -r '(.defaults.surface // "smooth") as $d | .materials[]
    | select((.surface // $d) as $s | ($s | type) == "object" or $s == "gloss" or $s == "satin" or $s == "matte")
    | .name' "$tmp/catalogue.json")
if (( ${#finish_names[@]} > 0 )); then
  lobe_inputs=()
  for name in "${finish_names[@]}"; do
    jq --arg n "$name" '.defaults as $d | .materials[] | select(.name == $n) | $d + .' "$tmp/catalogue.json" \
      > "$tmp/$name.json"
    lobe_inputs+=("$tmp/$name.json")
  done
  t0=$SECONDS
  BRDF_LOG=error "$tool" lobes "${lobe_inputs[@]}" --device cpu --theta-i 45 --log --decades 3 \
    --title "WHITE PAINT: GLOSS, SATIN, MATTE (LOG10 BRDF, 1/SR)" -o "$out/finishes-lobes.png"
  echo "gallery.sh: finishes-lobes.png ($((SECONDS - t0)) s)"
fi

{
  echo "# Gallery"
  echo
  echo "Preview renderings of the materials of \`$(realpath --relative-to="$root" "$catalogue" 2>/dev/null || echo "$catalogue")\`:"
  echo "a unit sphere under a directional light from the upper left (45 degrees off the view, 2 degree disc)"
  echo "and a dim sky, solved at draft accuracy on the CPU. Regenerate with \`tools/dev/gallery.sh\`."
  echo
  echo "| material | preview | description |"
  echo "|---|---|---|"
  for name in "${names[@]}"; do
    desc=$(jq -r --arg n "$name" '.materials[] | select(.name == $n) | .description // ""' "$tmp/catalogue.json" \
      | sed 's/|/\\|/g')
    echo "| \`$name\` | ![$name]($name.png) | $desc |"
  done
  if (( ${#finish_names[@]} > 0 )); then
    echo
    echo "## Finishes"
    echo
    echo "The seed white paint under a rough air/binder interface (GGX, the named finishes of docs/spec.md):"
    echo "$(printf '`%s` ' "${finish_names[@]}")above, rendered with the first-surface lobe drawn exactly and the"
    echo "body as the tables hold it. Their in-plane lobes at 45 degrees incidence (log scale, three decades):"
    echo
    echo "![in-plane lobes of the finishes](finishes-lobes.png)"
  fi
} > "$out/README.md.tmp"
mv "$out/README.md.tmp" "$out/README.md"
echo "gallery.sh: ${#names[@]} materials in $((SECONDS - start)) s -> $out"
