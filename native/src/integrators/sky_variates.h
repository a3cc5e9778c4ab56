// The atmosphere's variance reduction, as strategies the scattering tracers call. Where the
// sun alone lights the scene, the sky map (SkyMap) predicts the light that arrives at a point
// of the air from each direction; a path uses that prediction three ways:
//
//   guiding          directions after scattering in the air drawn partly from the map
//                    (SkyPoint: a mixture with the phase function's lobes);
//   control variates the map's light integrated against the phase function at a scattering
//                    event (scattered_sky_variate) or against the BSDF at a surface's bounce
//                    into the air (surface_sky_integral), less its value in the direction
//                    the path then takes, from which the path brings what truly arrives;
//   roulette         the prediction of what the rest of the walk brings back, kept where
//                    roulette ends the path, or the share of the sample it stands for
//                    (the Path's roulette_after_sky_model and roulette_by_share).
//
// Each is unbiased whatever the map's error, which sets only the variance left.
#pragma once

#include "common.h"
#include "volpath/sky_map.h"

namespace volpath {

// After scattering in guided air, a direction is drawn from the sky map (SkyMap) with this
// probability, else from the phase function; less where the map is also a control variate
// (below): its model then does most of the work that the directions drawn from it would.
constexpr Real kSkyMapShareGuide = 0.5, kSkyMapShareModel = 0.1;
// Russian roulette at every scattering event in the air where the sky map predicts what the
// path brings back: survival kSkyRouletteSurvival, and the map's prediction as a control
// variate (see scatter_in_medium): the walks are cut short, the prediction carries their rest.
constexpr Real kSkyRouletteSurvival = 0.55;
// The same roulette for a surface's bounce that escapes to the sky (Path::roulette_toward_sky).
constexpr Real kSurfaceSkySurvival = 0.3;
// Roulette by the map's predicted share of the sample (Path::roulette_by_share).
constexpr Real kShareKept = 0.1, kShareSurvival = 0.05;
// Mie's share of the map's light scattered at an event has no closed-form integral (its lobe
// is narrow, the map piecewise constant): kMieLobeSamples directions of the lobe estimate it,
// without bias, from the map alone.
constexpr int kMieLobeSamples = 2;
// The map's light a surface's bounce brings back from the air, integrated against the BSDF
// (Path::add_sky_model_integral): estimated from this many stratified BSDF directions.
constexpr int kSurfaceMapSamples = 4;
// Shifts the second coordinate of stratified samples (the golden ratio's fraction: a
// rank-1 lattice with the first).
constexpr Real kLatticeShift = 0.6180339887498949;
// A scattering event in air with a sky map: the map's point, and the phase function's
// lobes as drawn there: Rayleigh or Mie by their channel-averaged shares, so that the
// direction's density is the same in every channel and the path's return carries the
// weight the control variates give their models (the value stays per channel).
struct SkyPoint {
    const SkyMap *map;
    SkyMap::Point at;
    PhaseFunction lobes;
    Real share;  // of directions drawn from the map
    SkyPoint(const SkyMap *map, const Vec3 &p, const PhaseFunction &phase, bool models)
        : map(map), at(map->at(p)), share(models ? kSkyMapShareModel : kSkyMapShareGuide) {
        const auto &air = std::get<RayleighMiePhase>(phase);
        lobes = RayleighMiePhase{Spectrum(average(air.rayleigh_fraction)), air.g};
    }
    // The density of d under the mixture of the map and the lobes.
    Spectrum pdf(const Vec3 &d_in, const Vec3 &d) const {
        return phase_pdf(lobes, dot(d_in, d)) * (1 - share) + Spectrum(share * map->pdf(at, d));
    }
};

// The map's light scattered at an event in the air, as a control variate: its integral over
// directions, less its value in the direction drawn (d_out, density pdf; `arriving`: the
// map's radiance from there), whose path brings the light that truly arrives. Rayleigh's
// share integrates exactly (SkyMap::rayleigh_integral); Mie's by an unbiased estimate from
// the map alone: kMieLobeSamples directions of its lobe (drawn like Henyey-Greenstein's,
// stratified, from one 2D sample u), independent of d_out.
Spectrum scattered_sky_variate(const SkyPoint &sky, const RayleighMiePhase &air, const Vec3 &d_in, const Vec3 &d_out,
                               const Spectrum &arriving, Real pdf, Vec2 u);

// The sky map's light arriving at a surface's point from directions that stay in the air it
// reflects into (none from the others).
struct SurfaceSky {
    const SkyMap *map;
    SkyMap::Point at;
    const ShapeInfo *shape;
    Vec3 n;
    int medium;
    Spectrum arriving(const Vec3 &d) const {
        return medium_after_crossing(*shape, d, n, medium) == medium ? map->radiance(at, d) : Spectrum(0.0);
    }
};

// The sum over kSurfaceMapSamples stratified BSDF directions (from u and u_lobe) of the BSDF
// sample's weight times the map's light arriving from there: kSurfaceMapSamples times an
// estimate of the map's light the bounce reflects.
Spectrum surface_sky_integral(const SurfaceSky &sky, const BSDF &bsdf, const Frame &frame, const Vec3 &wi, Vec2 u,
                              Real u_lobe);

}  // namespace volpath
