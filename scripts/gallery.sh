#!/usr/bin/env bash
# Regenerates every picture of docs/GALLERY.md (and the two view.html
# screenshots of docs/) with the commands the gallery lists.
#   HOOKEAN=target/release/hookean scripts/gallery.sh
# Needs headless Chromium (Debian's `chromium`) for the screenshots.
set -euo pipefail
cd "$(dirname "$0")/.."
hookean=${HOOKEAN:-target/release/hookean}
out=$(mktemp -d)
g=docs/gallery

for scene in drape cloth-sphere cloth-table cloth-fold cloth-slope flag curtain jelly rope tutorial1 tutorial2 tutorial3; do
  "$hookean" run "scenes/$scene.toml" --out "$out/$scene" --quiet
  cp "$out/$scene/final.png" "$g/final-$scene.png"
done
mv "$g/final-drape.png" docs/drape.png # the README's picture
"$hookean" filter-analysis scenes/drape.toml --plot "$out/filter" > /dev/null
cp "$out"/filter/fig4-*.png "$out"/filter/fig5-*.png "$out/filter/fig6.svg" "$g/"
for problem in tutorial1 tutorial2 tutorial3 wave; do
  "$hookean" workprecision --problem "$problem" --out "$out/wp-$problem.csv" --plot "$g/workprecision-$problem.svg" --force > /dev/null
done
"$hookean" stability --plot "$g/stability.svg" --force > /dev/null
"$hookean" bench data --cloth 64 --out "$out/bench" --quiet > /dev/null
cp "$out/bench/residual-cloth16-A.svg" "$out/bench/residual-cloth64.svg" "$g/"
cp "$out/bench/profile.svg" "$g/profile-bench.svg"

# view.html of the reference drape, first and last frame.
chrome() {
  chromium --headless=new --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader \
    --disable-background-networking --disable-component-update --disable-sync --no-first-run \
    --hide-scrollbars --window-size=1000,640 --virtual-time-budget=10000 \
    --user-data-dir="$(mktemp -d)" "$@" 2> /dev/null
}
page="file://$(cd "$out/drape" && pwd)/view.html"
chrome --screenshot=docs/view-drape-first.png "$page#frame=0"
chrome --screenshot=docs/view-drape-last.png "$page#frame=last"
# view.html of the contact scenes: the table at the end, the fold at 0.5 s.
chrome --screenshot="$g/view-cloth-table.png" "file://$(cd "$out/cloth-table" && pwd)/view.html#frame=last"
chrome --screenshot="$g/view-cloth-fold.png" "file://$(cd "$out/cloth-fold" && pwd)/view.html#frame=5"
# The curtain gathered in pleats at 1.9 s, before its rings let go.
chrome --screenshot="$g/view-curtain.png" "file://$(cd "$out/curtain" && pwd)/view.html#frame=19"
ls -l "$out/drape/view.html"
rm -rf "$out"
