// The five volumetric path tracers, each a superset of the previous one. The absorption
// tracer is an estimator of its own (integrators/absorption.cpp); the four that scatter are
// one estimator with features switched on in order (integrators/volpath.cpp), so they share
// every sampler:
//
//   absorption       L = T(camera -> first surface) Le, closed-form transmittance.
//   single           + one real scattering event (medium or surface) lit by next-event
//                      estimation; max_depth is at most 2.
//   multiple         + any number of events, phase/BSDF sampling only (no NEE: delta
//                      lights are invisible), Russian roulette.
//   nee_mis          + NEE at every event, combined with phase/BSDF sampling by the
//                      power heuristic; shadow rays cross index-matched boundaries.
//   null_scattering  + heterogeneous media: delta tracking against a majorant, ratio
//                      tracking on shadow rays (the air: a guided free flight and
//                      tabulated transmittances, see AirSegment; directions after
//                      scattering partly from a map of the sky's light, see SkyMap).
//
// In a sky that nothing but the planet shadows, the air's light also has models with
// known integrals, used as control variates (unbiased whatever the model): along each
// segment the sun's single scattering and the sky map's scattered light (AirSegment::
// light_model), at each scattering event Rayleigh's share of the map's light, and for
// Russian roulette the map's prediction of what the path would bring back. A single
// sample can then fall below zero (about one in 10^4-10^5 at sunrise); render() counts it
// as zero and reports the light that adds.
//
// The camera's rays, until their paths first scatter, are split on the grid media they
// cross (homogeneous media and the air only where the camera stands in them): one branch
// crosses the medium without a tentative collision, weighted by that probability, and one
// or (in grids) four are forced to collide in it, which together replace free flight's
// draw between the two (Branch, in volpath.cpp).
//
// The tracers with NEE also estimate point and directional lights in homogeneous media
// from distances drawn for those lights on every segment (equiangular sampling; the
// segment's transmittance), combined with free flight's NEE by MIS (SegmentVertex).
//
// All of them handle chromatic (RGB) coefficients the same way: each path picks one
// colour channel to sample distances with, and every pdf is averaged over the channels
// (one-sample spectral MIS), kept as the rescaled path pdfs r_u (unidirectional) and
// r_l (light) of pbrt-v4. max_depth counts path segments as Mitsuba does: 1 = emitters
// seen directly, 2 = single scattering, -1 = unlimited; index-matched crossings are free.
#pragma once

#include "scene.h"

namespace volpath {

enum class Tracer { Absorption = 0, Single, Multiple, NeeMis, NullScattering };

struct TracerConfig {
    Tracer tracer = Tracer::NullScattering;
    int max_depth = -1;
    int rr_depth = 5;
    int max_null_collisions = 1000;
    // Point and directional lights' light in homogeneous media also from distances drawn
    // for them (equiangular sampling; the segment's transmittance), combined with free
    // flight's by MIS.
    bool light_distances = true;
};

// Radiance arriving along `ray`, which starts in `medium` (-1: vacuum).
Spectrum radiance(const Scene &scene, Ray ray, int medium, Sampler &sampler, const TracerConfig &config);

// Throws std::invalid_argument if the tracer cannot render the scene's media.
void check_tracer_supports(const Scene &scene, Tracer tracer);

}  // namespace volpath
