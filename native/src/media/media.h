// What the media's sources share (media.cpp dispatches over the variant; grid.cpp and
// atmosphere.cpp hold what is particular to those media).
#pragma once

#include "volpath/medium.h"

namespace volpath {

// Composite Simpson's rule: the weight of sample k of 0..steps (steps even), times h / 3.
inline Real simpson_weight(int k, int steps) { return (k == 0 || k == steps) ? 1.0 : (k % 2 ? 4.0 : 2.0); }

// The air's table of optical depths to the top (AtmosphereMedium::tau_to_top).
void build_tau_table(AtmosphereMedium &m);
// The air's majorant over [a, b]: the coefficients at the piece's lowest altitude.
// Altitude along a line is convex in t, so its minimum over [a, b] is at the closest
// approach to the centre clamped to [a, b] and its maximum at an end.
Spectrum air_majorant(const AtmosphereMedium &m, const Ray &ray, Real a, Real b);
// The majorant and minorant grid of a density grid at res^3 cells.
MajorantGrid build_majorants(const VoxelGrid &g, int res);

}  // namespace volpath
