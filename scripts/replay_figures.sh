#!/usr/bin/env bash
# Regenerate the viewer guide's replay screenshots and the control guide's portraits (docs/figures/).
#
#   scripts/replay_figures.sh [WORKDIR]      # default WORKDIR: a fresh temporary folder
#
# Each replay is simulated, written as a self-contained page by `robodyn view --html`, and
# photographed by headless Chromium (software WebGL) at a stated simulation time (#t=... in the
# URL); the portraits are `robodyn portrait`'s own PNGs. Needs `chromium` on PATH (Debian's
# package) and robodyn with its viewer extra. Takes a few minutes (the swing-ups run 8 and 11 s).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
figures="$root/docs/figures"
work="${1:-$(mktemp -d)}"
mkdir -p "$work"
cd "$work"

shoot() {  # shoot PAGE.html TIME OUT.png: the page at simulation time TIME, 1400 x 1100 pixels
  chromium --headless --no-sandbox --disable-gpu --enable-unsafe-swiftshader --use-angle=swiftshader \
    --hide-scrollbars --window-size=1400,1100 --virtual-time-budget=3000 \
    --screenshot="$3" "file://$work/$1#t=$2" 2>/dev/null
  echo "wrote $3 ($1 at t = $2 s)"
}

linkage="$root/examples/textbook/linkage"
robodyn run "$linkage/linkage.toml" --out linkage-run --no-view > /dev/null
robodyn view "$linkage/linkage.urdf" linkage-run/linkage.npz --trace bar_bc --label A=joint_a --label B=joint_b \
  --label C=collar --angle θ=joint_a --html linkage-spring.html > /dev/null
robodyn view "$linkage/linkage.urdf" linkage-run/linkage.npz --html linkage-drift.html > /dev/null
robodyn simulate cart_pole --q0 0,3.14159 --controller swing_up --duration 8 --out swing.npz > /dev/null
robodyn view cart_pole swing.npz --html swing.html > /dev/null
robodyn simulate pendubot --q0=-1.5708,0 --controller swing_up --duration 11 --dt 0.002 --out pendubot-swing.npz > /dev/null
robodyn view pendubot pendubot-swing.npz --html pendubot-swing.html > /dev/null
robodyn simulate panda --duration 2 --out panda.npz > /dev/null 2>&1
robodyn view panda panda.npz --ground --html panda.html > /dev/null
robodyn simulate pendubot --q0 0.5,0 --duration 5 --dt 0.01 --integrator euler --max-energy-growth 100 --out euler.npz > /dev/null
robodyn simulate pendubot --q0 0.5,0 --duration 5 --dt 0.01 --integrator rk4 --out rk4.npz > /dev/null
robodyn view pendubot euler.npz rk4.npz --html compare.html > /dev/null
robodyn simulate pendubot --q0 0.5,0 --duration 5 --out t.npz > /dev/null
robodyn view pendubot t.npz --html t.html > /dev/null

shoot linkage-spring.html 1.77 "$figures/replay_linkage_spring.png"
shoot linkage-drift.html 1.5 "$figures/replay_linkage_drift.png"
shoot swing.html 0.8 "$figures/replay_swing_up_cart_pole.png"
shoot pendubot-swing.html 1.5 "$figures/replay_swing_up_pendubot.png"
shoot panda.html 1.5 "$figures/replay_panda_stops.png"
shoot compare.html 3 "$figures/replay_two_runs.png"
shoot t.html 2.2 "$figures/replay_fit_pendubot.png"

robodyn simulate pendubot --q0 1.6,0.05 --controller lqr --duration 2 --out balance.npz > /dev/null
robodyn portrait pendubot --lqr --trajectory balance.npz --basin 21 --out portrait-pendubot > /dev/null
robodyn portrait cart_pole --trajectory swing.npz --out portrait-cart-pole > /dev/null
cp portrait-pendubot/portrait.png "$figures/portrait_pendubot.png"
cp portrait-cart-pole/portrait.png "$figures/portrait_cart_pole_swing_up.png"
echo "wrote $figures/portrait_pendubot.png and $figures/portrait_cart_pole_swing_up.png"
