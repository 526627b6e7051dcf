#!/usr/bin/env bash
# The reduced reproduction end to end (docs/REPRODUCTION.md): examples/paper/claims_reduced.toml is run,
# summarised with its fits, drawn by tools/plot.py, and judged by tools/claims.py, which must
# find the claims of the paper that hold at this size: a parabola with positive curvature for
# protocol A at Bo = 1e2 and none (a constant Delta y) at Bo = 0, an exponential decay of the
# |Delta y| histogram beyond 2 R at Bo = 0, straight lines for protocol C with flat initial and final densities, the
# final density predicted from the initial one and dnu/nu_i below its limit, and judge the
# identity b' = b/(1+b), a' = a/(1+b). Several minutes on one core.
source "$(dirname "$0")/common.sh"

"$exe" run "$repo/examples/paper/claims_reduced.toml" -o "$dir/claims.h5" -q
"$exe" summary "$dir/claims.h5" > "$dir/summary.txt"
grep -q "Delta y(y_e) = " "$dir/summary.txt" || fail "summary prints no avalanche-profile fit"
grep -qE "histogram.*: .* \(chi2/dof gaussian .*; t of the quadratic term .*, of the cubic .*, of the quartic " \
  "$dir/summary.txt" || fail "summary prints no histogram shape with its terms' t"
/usr/bin/python3 "$repo/tools/plot.py" "$dir/claims.h5" -o "$dir/fig" >/dev/null
for f in density_profiles nu_lower_half avalanche_profiles abs_dy_histograms deposition_density \
  event_sizes; do
  [ -s "$dir/fig/$f.png" ] || fail "plot.py did not write $f.png"
done
set +e
/usr/bin/python3 "$repo/tools/claims.py" "$dir/claims.h5" > "$dir/claims.txt"
rc=$?
set -e
cat "$dir/claims.txt"
[ "$rc" -le 1 ] || fail "claims.py found nothing to judge or failed (exit $rc)"
# The claims that hold at this size (docs/REPRODUCTION.md, "The paper's claims"): the parabola
# at Bo = 1e2, its absence (a constant Delta y) at Bo = 0, the exponential decay of the histogram
# beyond 2 R at Bo = 0 and the collapse's straight lines, flat densities, predicted final density and upper limit.
for claim in "Bo = 100, H = 48): Delta y(y_e) is a parabola with positive curvature" \
  "Bo = 0, H = 24): Delta y(y_e) is constant in the bulk, no parabola" \
  "Bo = 0, H = 24): the |Delta y| histogram decays exponentially beyond 2 R" \
  "Bo = 1000, H = 60): Delta y is a straight line in y_e and y_i" \
  "Bo = 1000, H = 60): nu_i(y) is flat in the bulk" \
  "Bo = 1000, H = 60): nu_f(y) is flat in the bulk" \
  "Bo = 1000, H = 60): the final density predicted from the initial one matches" \
  "Bo = 1000, H = 60): dnu/nu_i stays below its limit nu_rcp/nu_i - 1"; do
  grep -F "$claim" "$dir/claims.txt" | grep -q "^PASS" ||
    fail "claim '$claim' does not hold"
done
# The whole histogram at Bo = 0 is judged, with errors from the members' scatter; at this size
# neither shape fits it (the disks that stay put and the roll-off peak between sqrt(3) and 2 R,
# REPRODUCTION.md).
grep -F "Bo = 0, H = 24): |Delta y| histogram is exponential" "$dir/claims.txt" |
  grep -q "errors from the members' scatter" || fail "the Bo = 0 histogram was not judged"
# The collapse identity is judged with the jackknife of the difference (at this size b' and
# b/(1+b) differ by about two of its errors, REPRODUCTION.md).
[ "$(grep -c "(jackknife of the difference)" "$dir/claims.txt")" -eq 2 ] ||
  fail "the collapse identity was not judged"
