// A map of the sun's light scattered in the air, for choosing the direction a path takes
// after scattering in it.
//
// Seen from a point low in the air, most of the light scattered toward it comes from a
// thin band along the horizon and from the aureole around the sun: a small part of the
// sphere, which phase sampling (Rayleigh's lobe is nearly uniform) seldom picks: the
// direction, not the distances, is where multiple scattering's noise comes from.
//
// For one sun, the map tabulates the radiance arriving at a point from each direction
// (the sun's single scattering along it, AirSegment's model, and the sunlit ground) at
// a set of altitudes and local sun elevations (a point 300 km away sees the sun 2.7
// degrees higher). Directions are (azimuth from the sun, cosine to the zenith), the cosine
// warped to crowd cells next to the horizon. The integrator draws directions from a mixture
// of the phase function and the map (kSkyMapShareGuide/Model in the integrator).
#pragma once

#include <memory>
#include <vector>

#include "medium.h"
#include "warp.h"

namespace volpath {

struct SkyMap {
    static constexpr int kAltitudes = 16, kElevations = 9, kZenith = 48, kAzimuth = 48;
    // Directions at a level: x = (azimuth from the sun + pi) / 2 pi and y = the warped zenith
    // cosine, over the unit square; cells of kAzimuth x kZenith, rows of equal y.
    struct Level {
        std::vector<Spectrum> radiance;  // per cell
        Distribution2D directions;       // in proportion to the radiance (channel average)
        // The radiance's integral over the sphere, and of the radiance times w w^T in the
        // level's frame (toward the sun's azimuth, across it, up): xx, yy, zz, xy, xz, yz.
        Spectrum total{0.0}, moment[6];
    };
    // What serves a point: its local frame, and the two altitude levels around it with
    // linear weights (the levels' own horizons shape their cells).
    struct Point {
        Vec3 up, toward_sun, across;
        const Level *level[2];
        Real horizon[2], weight[2];
    };
    Vec3 center, to_sun;
    Spectrum irradiance, ground_albedo;  // the sun's and the ground's the levels were made with
    Real planet_radius = 0, height = 0;
    Real elevation_lo = 0, elevation_step = 0;  // radians; levels at elevation_lo + k * elevation_step
    Real radius[kAltitudes] = {};               // of the altitude levels
    Real horizon[kAltitudes] = {};              // zenith cosine of the horizon at each altitude level
    // Altitude fastest. A level holds directions in its local frame (up, toward the sun's
    // azimuth, across), so it depends on its sun elevation, not on the sun's direction:
    // maps for suns that differ in direction alone share their levels.
    std::shared_ptr<const std::vector<Level>> levels;
    bool models_light = false;  // good enough to be a control variate

    Point at(const Vec3 &p) const;
    // Solid-angle density of sample() returning d.
    Real pdf(const Point &at, const Vec3 &d) const;
    // A direction in proportion to the blended map's radiance; u_level picks the level.
    Vec3 sample(const Point &at, Vec2 u, Real u_level, Real &pdf) const;
    // The map's radiance arriving from direction d, and the integral over directions w of
    // p_R(dot(d_in, w)) radiance(w) with Rayleigh's phase function p_R: exact for the
    // piecewise-constant map (p_R is quadratic in w), so the map can be a control variate
    // for the light scattered at a point (see the integrator).
    Spectrum radiance(const Point &at, const Vec3 &d) const;
    Spectrum rayleigh_integral(const Point &at, const Vec3 &d_in) const;
};

// The map for `sun` over `air`, whose ground reflects `ground_albedo`, with local sun
// elevations around the one at `viewpoint` (all of them from outside the air). The levels
// of `previous`, a map over the same air, are taken over when they are the ones this map
// needs (an animated sun that stays within a window of elevations): the levels are built
// for a sun along +z, so they are the same bits whichever map built them first.
std::shared_ptr<const SkyMap> build_sky_map(const AtmosphereMedium &air, const SunGuide &sun,
                                            const Spectrum &ground_albedo, const Vec3 &viewpoint,
                                            const SkyMap *previous = nullptr);

}  // namespace volpath
