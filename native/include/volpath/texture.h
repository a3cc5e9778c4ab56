// Textures: a BSDF parameter that varies over a surface, looked up at the surface point's
// texture coordinates (u, v). As in Mitsuba, v = 0 is an image's first (top) row, and an
// 8-bit image stays 8-bit in memory: its sRGB texels are decoded per lookup.
#pragma once

#include <cstdint>
#include <variant>
#include <vector>

#include "math.h"

namespace volpath {

// An affine map of texture coordinates (Mitsuba's to_uv): (u', v') = m (u, v, 1).
struct UVTransform {
    Real m[2][3] = {{1, 0, 0}, {0, 1, 0}};
    Vec2 apply(Vec2 uv) const {
        return {m[0][0] * uv.x + m[0][1] * uv.y + m[0][2], m[1][0] * uv.x + m[1][1] * uv.y + m[1][2]};
    }
};

// An image with one or three channels: 8-bit texels (sRGB-encoded unless raw) or floats
// (linear), bilinearly filtered or nearest, wrapped per axis beyond [0, 1].
struct BitmapTexture {
    enum class Wrap : uint8_t { Repeat, Mirror, Clamp };
    int width = 0, height = 0, channels = 3;
    std::vector<uint8_t> bytes;  // row-major, channels interleaved; or
    std::vector<float> floats;   // the same as floats (one of the two is empty)
    bool srgb = true;            // whether 8-bit texels encode sRGB
    bool bilinear = true;
    Wrap wrap = Wrap::Repeat;
    UVTransform to_uv;
    Spectrum texel(int x, int y) const;  // linear; grey for one channel
};

// Mitsuba's checkerboard: color0 where the fractional parts of u and v are both above or
// both below 1/2, else color1.
struct CheckerboardTexture {
    Spectrum color0{0.4}, color1{0.2};
    UVTransform to_uv;
};

using Texture = std::variant<BitmapTexture, CheckerboardTexture>;

Spectrum eval_texture(const Texture &texture, Vec2 uv);
// A step in uv for finite differences of the texture: half a texel of a bitmap.
Real texture_step(const Texture &texture);
size_t texture_bytes(const Texture &texture);
// The mean luminance of the texture's values over [0, 1]^2 (a bitmap's texels).
Real mean_luminance(const Texture &texture);

// 8-bit sRGB to linear.
Real srgb_to_linear(uint8_t v);

}  // namespace volpath
